"""Benchmark: ``hvacfmu demo`` end to end, with the per-stage breakdown.

Runs the demo ``--repeat`` times into temporary folders (the emulated dataset is
cached after the first generation, as for a user running the demo twice; pass
``--cold`` to time a first run with an empty cache) and prints the median of
each stage and of the total. Target: under 3 minutes on the 2-core machine.

    python3 benchmarks/bench_demo.py [--repeat 3] [--cold]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import statistics
import tempfile
import time
import warnings


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--weeks", type=int, default=51)
    p.add_argument("--cold", action="store_true", help="use an empty dataset cache for every run")
    args = p.parse_args(argv)
    warnings.simplefilter("ignore")
    from hvacfmu.cli.demo import run_demo

    stage_times, totals = {}, []
    for i in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            if args.cold:
                os.environ["HVACFMU_CACHE"] = os.path.join(tmp, "cache")
            t0 = time.perf_counter()
            with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
                result = run_demo(os.path.join(tmp, "demo"), weeks=args.weeks, progress=False)
            total = time.perf_counter() - t0
        totals.append(total)
        for s in result.stages:
            stage_times.setdefault(s.name, []).append(s.seconds)
        failed = f"  FAILED: {', '.join(result.failed)}" if result.failed else ""
        print(f"run {i + 1}: {total:.1f} s{failed}")
    print(
        f"\nhvacfmu demo ({args.weeks} weeks{', cold cache' if args.cold else ''}), "
        f"median of {args.repeat} on {os.cpu_count()} cores:"
    )
    for name, ts in stage_times.items():
        print(f"  {name:<10} {statistics.median(ts):7.1f} s")
    med = statistics.median(totals)
    print(f"  {'total':<10} {med:7.1f} s   (target < 180 s: {'met' if med < 180 else 'NOT met'})")


if __name__ == "__main__":
    main()
