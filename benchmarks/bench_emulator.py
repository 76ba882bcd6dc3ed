"""Benchmark: generate the emulator's default dataset (51 weeks of 1-minute data, Parquet).

Times ``hvacfmu.emulator.generate`` three times (wall clock and CPU time of
this process) and prints the medians, plus a breakdown of one run.

    python3 benchmarks/bench_emulator.py [--weeks 51] [--runs 3]
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
    args = parser.parse_args(argv)

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
    print(f"generate (incl. Parquet): median {statistics.median(walls):.2f} s wall, "
          f"{statistics.median(cpus):.2f} s CPU over {args.runs} runs (target < 20 s)")
    print(f"  of which closed-loop simulation (one run): {t_sim:.2f} s wall")


if __name__ == "__main__":
    main()
