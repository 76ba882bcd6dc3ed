#!/bin/bash
# usage: pipe.sh DIR   -- the whole user path on DIR/measurements.parquet + DIR/building.toml, every message kept
export HVACFMU_CACHE="${HVACFMU_CACHE:-$PWD/cache}" OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
D=$1; shift
cd "${WORKDIR:-.}"
run() { local name=$1; shift; echo "### $name: hvacfmu $*" > $D/$name.log; /usr/bin/time -f "WALL %e s CPU %U+%S s RC %x" nice -n 10 python3 -m hvacfmu "$@" >> $D/$name.log 2>&1; echo "rc=$?" >> $D/$name.log; }
M=$D/measurements.parquet; B=$D/building.toml
run check check $M -b $B
for k in lumped zones physics; do run fit_$k fit $M -b $B --model $k -o $D/$k.json; done
run evaluate evaluate $M -b $B --model $D/lumped.json --model $D/zones.json --model $D/physics.json --json $D/eval.json --plots $D/plots
run diagnose diagnose $M -b $B --json $D/diag.json -o $D/extended.json
run export_py export $D/zones.json -o $D/zones.fmu -b $B
run export_native export $D/physics.json -o $D/physics_native.fmu -b $B --native
run export_native_zones export $D/zones.json -o $D/zones_native.fmu -b $B --native
run cosim_replay cosim --fmu $D/zones.fmu -d $M -b $B --model $D/zones.json
run cosim_mpc cosim --fmu $D/physics_native.fmu -d $M -b $B --model $D/zones.json --controller mpc
echo done > $D/DONE
