"""Benchmark: full diagnosis of the default 51-week emulated dataset (target < 60 s on 2 cores).

Prints the median wall time of ``diagnose`` (base Model A fit included) over a few
repeats, and what it found. Run: ``python3 benchmarks/bench_diagnosis.py [--repeats N]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--weeks", type=int, default=51)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(weeks=args.weeks, seed=args.seed)
    t0 = time.perf_counter()
    ds = prepare(paths.measurements, paths.building)
    t_prep = time.perf_counter() - t0
    times, cpu = [], []
    report = None
    for _ in range(args.repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        report = diagnose(ds, progress=False)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    print(f"dataset: {args.weeks} weeks, seed {args.seed} (prepare {t_prep:.1f} s)")
    print(
        f"diagnose: median {statistics.median(times):.1f} s over {len(times)} runs "
        f"(min {min(times):.1f} s, max {max(times):.1f} s); target < 60 s"
    )
    print(
        f"diagnose CPU time of this process: median {statistics.median(cpu):.1f} s (all threads; independent of "
        f"the other users of the machine; load average now {os.getloadavg()[0]:.1f})"
    )
    print(report.summary())
    ho = report.heldout
    if ho.get("zones"):
        print(
            f"held-out mean 24-h RMS: base {ho['mean_base']:.3f} K -> extended {ho['mean_extended']:.3f} K "
            f"({ho['gain_percent_mean']:+.1f} %)"
        )


if __name__ == "__main__":
    main()
