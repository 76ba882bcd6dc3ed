"""Benchmark: Model A identification (lumped and six-zone) on the emulator's default dataset.

Prepares the default 51-week dataset (``hvacfmu.emulator.cached_dataset``, generated
once into ``$HVACFMU_CACHE``), then times ``fit_lumped``, ``fit_zones`` and
``evaluate`` (both models) ``--repeat`` times each and prints the medians.
Target: both identifications together under 20 s on the 2-core machine.

    python3 benchmarks/bench_model_a.py [--repeat 3] [--weeks 51]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

from hvacfmu.data import prepare
from hvacfmu.emulator import cached_dataset
from hvacfmu.errors import HvacfmuWarning
from hvacfmu.evaluation import evaluate
from hvacfmu.models.datadriven import fit_lumped, fit_zones


def _time(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), times, out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--weeks", type=int, default=51)
    args = p.parse_args(argv)
    warnings.simplefilter("ignore", HvacfmuWarning)
    paths = cached_dataset(weeks=args.weeks)
    ds = prepare(paths.measurements, paths.building)
    print(f"dataset: {len(ds.frame)} rows of {ds.step:g} s, {len(ds.weeks)} weeks, solar={ds.has_solar}")
    t_l, all_l, ml = _time(lambda: fit_lumped(ds), args.repeat)
    t_z, all_z, mz = _time(lambda: fit_zones(ds), args.repeat)
    t_e, all_e, res = _time(lambda: evaluate([ml, mz], ds), args.repeat)
    fmt = lambda ts: ", ".join(f"{t:.2f}" for t in ts)  # noqa: E731
    print(f"fit_lumped : median {t_l:6.2f} s  ({fmt(all_l)})")
    print(f"fit_zones  : median {t_z:6.2f} s  ({fmt(all_z)})")
    print(f"both fits  : median {t_l + t_z:6.2f} s  (target < 20 s)")
    print(f"evaluate   : median {t_e:6.2f} s  ({fmt(all_e)}) for both models")
    for name in ("lumped", "zones"):
        print(f"mean 24-h RMS {name}: {res.table(name).loc['all', 'mean']:.3f} K")


if __name__ == "__main__":
    main()
