"""Benchmark: generate the emulator's default dataset (51 weeks of 1-minute data, Parquet).

Times ``hvacfmu.emulator.generate`` three times (wall clock and CPU time of
this process) and prints the medians, plus a breakdown of one run; then one
``--variant-weeks`` dataset per layout / climate / HVAC mode (states, CPU time
per simulated week) and a small fleet.

    python3 benchmarks/bench_emulator.py [--weeks 51] [--runs 3] [--variant-weeks 4] [--fleet 3]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import pandas as pd

from hvacfmu.emulator import generate, make_truth, simulate


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--weeks", type=int, default=51)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--variant-weeks", type=int, default=4, help="weeks of each layout/mode variant (0: skip)")
    parser.add_argument("--fleet", type=int, default=3, help="buildings of the fleet run (0: skip)")
    args = parser.parse_args(argv)
    if args.runs > 0:
        _default(args)
    if args.variant_weeks > 0:
        _variants(args.variant_weeks, args.seed)
    if args.fleet > 0:
        _fleet(args.fleet, args.variant_weeks or 2, args.seed)


VARIANTS = [
    {"layout": "sdh"},
    {"layout": "row4", "construction": "light", "climate": "hot", "start": "2026-06-01"},
    {"layout": "core9", "construction": "heavy", "climate": "cold", "start": "2026-01-05"},
    {
        "layout": "core9",
        "climate": "cold",
        "start": "2026-01-05",
        "hvac": "reheat",
        "units": "us",
        "clock": "naive-local",
        "export_step": 900,
        "faults": ["outages", "sparse_box", "stuck_sensor"],
    },
]


def _variants(weeks, seed):
    import json

    with tempfile.TemporaryDirectory() as tmp:
        for i, kw in enumerate(VARIANTS):
            t0, c0 = time.perf_counter(), time.process_time()
            paths = generate(Path(tmp) / f"v{i}", weeks=weeks, seed=seed, **kw)
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            truth = json.loads(paths.truth.read_text())
            label = ", ".join(f"{k}={v}" for k, v in kw.items() if k in ("layout", "construction", "climate", "hvac"))
            print(
                f"variant {label}: {len(truth['zones'])} zones, {len(truth['vavs'])} boxes, "
                f"{truth['baseline']['structure']['n_states']} states; {weeks} weeks in {wall:.2f} s wall, "
                f"{cpu / (weeks + 1):.2f} s CPU per simulated week (incl. one week spin-up)"
            )


def _fleet(n, weeks, seed):
    from hvacfmu.emulator import generate_fleet

    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        generate_fleet(n, Path(tmp) / "fleet", seed=seed, weeks=weeks, progress=False)
        wall = time.perf_counter() - t0
    print(f"fleet: {n} buildings x {weeks} weeks in {wall:.1f} s wall ({60.0 * n / wall:.1f} buildings/min)")


def _default(args):
    walls, cpus = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.runs):
            t0, c0 = time.perf_counter(), time.process_time()
            paths = generate(Path(tmp) / f"run{i}", weeks=args.weeks, seed=args.seed)
            walls.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
        rows = len(pd.read_parquet(paths.measurements, columns=["T_NW"]))
    t0 = time.perf_counter()
    sim = simulate(make_truth(args.weeks, args.seed))
    t_sim = time.perf_counter() - t0
    print(f"emulator: {args.weeks} weeks, {rows} rows, {sim['core'].n_thermal} thermal states")
    print(
        f"generate (incl. Parquet): median {statistics.median(walls):.2f} s wall, "
        f"{statistics.median(cpus):.2f} s CPU over {args.runs} runs (target < 20 s)"
    )
    print(f"  of which closed-loop simulation (one run): {t_sim:.2f} s wall")


if __name__ == "__main__":
    main()
