"""Benchmark: lifecycle of the pythonfmu FMUs (memory over instantiate/simulate/free cycles, exit status of processes).

1. **Cycles in one process.** For each FMU: ``--cycles`` times instantiate, set up,
   initialise, ``--steps`` steps of 900 s, terminate, free (FMPy ``FMU2Slave``).
   Prints the resident memory after 3 warm-up cycles and at the end, raw and after
   ``malloc_trim(0)`` (glibc keeps freed heap pages; the trimmed figure is what
   is still allocated), and the time per cycle. Target: < 20 MB growth in all.
2. **Separate processes.** ``--processes`` times per FMU a fresh Python process
   that runs ``fmpy.simulate_fmu`` for a day and exits; counts exit codes (an
   abort at exit, e.g. glibc's "corrupted double-linked list", is a negative
   code = signal). Target: all 0.
3. **Refused steps** (``--refusing``, default 20). In one process, ``--refusing`` cycles of
   instantiate, a step the FMU refuses (half its step size: pythonfmu answers fmi2Fatal),
   terminate and free anyway, as a non-conforming host does (the harness, libcosim): memory
   and survival. Then ``--refusing`` separate ``fmpy simulate`` processes with a refused
   step size: all must exit 1 (the error), none crash (a negative code) or exit 0.

Usage: ``python3 benchmarks/bench_fmu_lifecycle.py [--cycles 200] [--processes 100] [--refusing 20]
[--kinds lumped zones physics plant]``
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import logging
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

KINDS = ("lumped", "zones", "physics", "extended", "plant")


def rss_mb(trim: bool) -> float:
    """Resident set size [MB]; with ``trim`` after glibc's malloc_trim(0)."""
    if trim:
        try:
            ctypes.CDLL("libc.so.6").malloc_trim(0)
        except OSError:  # not glibc
            pass
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def build_fmus(kinds, folder: Path) -> dict:
    """kind -> FMU path (the test suite's hand-written models; the plant from a cached 8-week dataset)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from test_fmu import extended_model, lumped_model, physics_model, zones_model

    from hvacfmu.emulator import cached_dataset, sdh_building
    from hvacfmu.fmu import export_fmu, export_plant_fmu

    b = sdh_building(nominal=True)
    makers = {"lumped": lumped_model, "zones": zones_model, "physics": physics_model, "extended": extended_model}
    out = {}
    for kind in kinds:
        if kind == "plant":
            out[kind] = export_plant_fmu(cached_dataset(weeks=8, seed=0).truth, folder / "plant.fmu")
        else:
            out[kind] = export_fmu(makers[kind](b).save(folder / f"{kind}.json"), folder / f"{kind}.fmu")
    return out


def cycles(path, n: int, steps: int) -> dict:
    """Instantiate/simulate/free ``n`` times in this process; memory and time figures."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(path))
    outs = [v.valueReference for v in md.modelVariables if v.causality == "output"]
    unz = extract(str(path))

    def one(i):
        s = FMU2Slave(
            guid=md.guid, unzipDirectory=unz, modelIdentifier=md.coSimulation.modelIdentifier, instanceName=f"cycle{i}"
        )
        s.instantiate()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        for k in range(steps):
            s.doStep(k * 900.0, 900.0)
            s.getReal(outs)
        s.terminate()
        s.freeInstance()

    for i in range(3):
        one(i)
    gc.collect()
    raw0, trim0 = rss_mb(False), rss_mb(True)
    t = time.perf_counter()
    for i in range(n):
        one(i)
    dt = time.perf_counter() - t
    gc.collect()
    return {"raw": rss_mb(False) - raw0, "trimmed": rss_mb(True) - trim0, "s_per_cycle": dt / n}


def refused_cycles(path, n: int) -> dict:
    """``n`` instantiate / refused step / terminate / free cycles in this process; memory figures."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    logging.getLogger("hvacfmu.fmu").addHandler(logging.NullHandler())  # the refusals are expected here
    md = read_model_description(str(path))
    step = float(md.defaultExperiment.stepSize)
    unz = extract(str(path))
    refused = 0

    def one(i):
        nonlocal refused
        s = FMU2Slave(
            guid=md.guid, unzipDirectory=unz, modelIdentifier=md.coSimulation.modelIdentifier, instanceName=f"r{i}"
        )
        s.instantiate()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        s.doStep(0.0, step)
        try:
            s.doStep(step, step / 2)
        except Exception as exc:  # noqa: BLE001 - FMICallException, expected
            refused += "fatal" in str(exc)
        s.terminate()
        s.freeInstance()

    for i in range(3):
        one(i)
    gc.collect()
    trim0 = rss_mb(True)
    for i in range(n):
        one(i)
    gc.collect()
    return {"trimmed": rss_mb(True) - trim0, "refused": refused - 3}


def refusing_processes(path, n: int, jobs: int) -> dict:
    """Exit codes of ``n`` ``fmpy simulate`` processes with a step size the FMU refuses (expected: all 1)."""
    from fmpy import read_model_description

    step = float(read_model_description(str(path)).defaultExperiment.stepSize)
    cmd = ["fmpy", "simulate", str(path), "--output-interval", repr(step / 2), "--stop-time", repr(4 * step)]

    def run(_):
        return subprocess.run(cmd, capture_output=True, text=True, timeout=600)

    with ThreadPoolExecutor(jobs) as pool:
        runs = list(pool.map(run, range(n)))
    codes = [r.returncode for r in runs]
    named = sum("step refused" in r.stderr and "status 4 (fatal)" in r.stderr for r in runs)
    return {"exit1": codes.count(1), "named": named, "codes": sorted(set(codes))}


PROCESS_SCRIPT = (
    "import sys\n"
    "from fmpy import simulate_fmu\n"
    "r = simulate_fmu(sys.argv[1], stop_time=86400.0, output_interval=900.0)\n"
    "assert len(r) == 97, len(r)\n"
)


def processes(path, n: int, jobs: int) -> dict:
    """Exit codes of ``n`` fresh processes that each simulate the FMU for a day."""

    def run(_):
        return subprocess.run(
            [sys.executable, "-c", PROCESS_SCRIPT, str(path)], capture_output=True, text=True, timeout=600
        )

    with ThreadPoolExecutor(jobs) as pool:
        runs = list(pool.map(run, range(n)))
    bad = [r for r in runs if r.returncode != 0]
    return {
        "ok": n - len(bad),
        "codes": sorted({r.returncode for r in bad}),
        "first_error": (bad[0].stderr.strip().splitlines() or ["?"])[-1] if bad else "",
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=200)
    ap.add_argument("--steps", type=int, default=24, help="steps per cycle (default 24 = 6 h)")
    ap.add_argument("--processes", type=int, default=100)
    ap.add_argument("--refusing", type=int, default=20, help="refused-step cycles and processes per FMU")
    ap.add_argument("--jobs", type=int, default=2, help="processes at a time (default 2)")
    ap.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        fmus = build_fmus(args.kinds, Path(tmp))
        if args.cycles:
            print(f"{args.cycles} instantiate/simulate({args.steps} steps)/free cycles per FMU, one process")
            print(f"{'FMU':10s} {'RSS growth raw [MB]':>20s} {'after malloc_trim [MB]':>23s} {'s/cycle':>8s}")
            total_raw = total_trim = 0.0
            for kind, path in fmus.items():
                r = cycles(path, args.cycles, args.steps)
                total_raw += r["raw"]
                total_trim += r["trimmed"]
                print(f"{kind:10s} {r['raw']:20.1f} {r['trimmed']:23.1f} {r['s_per_cycle']:8.3f}", flush=True)
            print(f"{'all':10s} {total_raw:20.1f} {total_trim:23.1f}")
        if args.processes:
            print(f"\n{args.processes} separate processes per FMU (fmpy.simulate_fmu, one day), {args.jobs} at a time")
            for kind, path in fmus.items():
                r = processes(path, args.processes, args.jobs)
                extra = f"  exit codes {r['codes']}: {r['first_error']}" if r["codes"] else ""
                print(f"{kind:10s} {r['ok']:4d} / {args.processes} exited 0{extra}", flush=True)
        if args.refusing:
            _print_refusing(fmus, args.refusing, args.jobs)


def _print_refusing(fmus, n, jobs):
    print(f"\nrefused steps: {n} instantiate/refused step/terminate/free cycles in one process, then")
    print(f"{n} separate `fmpy simulate` processes with a refused step size, {jobs} at a time")
    print(f"{'FMU':10s} {'refused':>8s} {'growth [MB]':>12s} {'exit 1':>7s} {'reason named':>13s} exit codes")
    for kind, path in fmus.items():
        c = refused_cycles(path, n)
        p = refusing_processes(path, n, jobs)
        print(
            f"{kind:10s} {c['refused']:8d} {c['trimmed']:12.1f} {p['exit1']:7d} {p['named']:13d} {p['codes']}",
            flush=True,
        )


if __name__ == "__main__":
    main()
