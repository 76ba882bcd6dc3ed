"""Run the MPC and diagnosis tests many times and print every failure (issue 17 p.6: determinism).

Each round is one ``pytest`` process (``-n 0``, fresh interpreter, no cache provider, so nothing is
carried between rounds) over the given files with the ``-m`` marker expression (default
``not slow``), then a second process over the ``--also`` node ids, which run whatever their
marker (by default one representative slow diagnosis case on emulator data). A round's failures
are printed with their test ids, and the closing line counts rounds and failures per test.
Exit status 1 when any round failed.

The default is the whole MPC test file (it has no slow tests), the not-slow diagnosis tests and
one slow emulator diagnosis case::

    nice -n 10 python3 benchmarks/loop_tests.py [--rounds 20] [--files tests/test_mpc.py ...]
        [-m "not slow"] [--also NODEID ...] [-k EXPR] [--threads N]

``--threads`` sets ``OMP/OPENBLAS/MKL_NUM_THREADS`` for the runs (the references must not
depend on it: try 1 and 2).
"""

from __future__ import annotations

import argparse
import collections
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_FILES = ("tests/test_mpc.py", "tests/test_diagnosis.py")
DEFAULT_ALSO = ("tests/test_diagnosis.py::test_emulator_effect_is_found[actuation_delay-0]",)


def run_round(files, k=None, threads=None, marker=None) -> tuple[list[str], int, float]:
    """One pytest run; returns (failed test ids, passed count, wall time [s])."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    if threads:
        for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
            env[var] = str(threads)
    cmd = [sys.executable, "-m", "pytest", "-q", "-n", "0", "-rf", "-p", "no:cacheprovider", *files]
    if k:
        cmd += ["-k", k]
    if marker:
        cmd += ["-m", marker]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    out = proc.stdout + proc.stderr
    failed = re.findall(r"^(?:FAILED|ERROR) (\S+)", out, flags=re.M)
    passed = re.search(r"(\d+) passed", out)
    if proc.returncode not in (0, 1) and not failed:  # collection error, crash
        failed = [f"pytest exit {proc.returncode}: {out.strip().splitlines()[-1] if out.strip() else ''}"]
    return failed, int(passed.group(1)) if passed else 0, wall


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=20)
    ap.add_argument("--files", nargs="+", default=list(DEFAULT_FILES))
    ap.add_argument("-m", dest="marker", default="not slow", help="pytest -m expression for --files")
    ap.add_argument(
        "--also", nargs="*", default=list(DEFAULT_ALSO), help="node ids run in a second process whatever their marker"
    )
    ap.add_argument("-k", help="pytest -k expression")
    ap.add_argument("--threads", type=int, help="BLAS/OpenMP threads for the runs")
    args = ap.parse_args(argv)
    counts = collections.Counter()
    bad_rounds = 0
    for r in range(1, args.rounds + 1):
        failed, passed, wall = run_round(args.files, args.k, args.threads, args.marker or None)
        if args.also:
            f2, p2, w2 = run_round(args.also, None, args.threads)
            failed, passed, wall = failed + f2, passed + p2, wall + w2
        bad_rounds += bool(failed)
        counts.update(failed)
        print(
            f"round {r:2d}/{args.rounds}: {passed} passed, {len(failed)} failed ({wall:.0f} s)"
            + "".join(f"\n    FAILED {f}" for f in failed),
            flush=True,
        )
    what = " ".join(args.files) + (f" (-m {args.marker!r})" if args.marker else "") + " " + " ".join(args.also)
    print(f"{args.rounds} rounds of {what.strip()}: {bad_rounds} with failures, {sum(counts.values())} failures")
    for test, n in counts.most_common():
        print(f"  {n:2d}x {test}")
    return 1 if bad_rounds else 0


if __name__ == "__main__":
    sys.exit(main())
