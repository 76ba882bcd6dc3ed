"""Run the MPC and diagnosis test files many times and print every failure (issue 17 p.6: determinism).

Each round is one ``pytest`` process (``-n 0 -p no:randomly``, fresh interpreter, so nothing is
cached between rounds) over the given files; a round's failures are printed with their test ids,
and the closing line counts rounds and failures per test. Exit status 1 when any round failed.

Usage::

    python3 benchmarks/loop_tests.py [--rounds 20] [--files tests/test_mpc.py tests/test_diagnosis.py]
        [-k EXPR] [--threads N]

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


def run_round(files, k=None, threads=None) -> tuple[list[str], int, float]:
    """One pytest run; returns (failed test ids, passed count, wall time [s])."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    if threads:
        for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
            env[var] = str(threads)
    cmd = [sys.executable, "-m", "pytest", "-q", "-n", "0", "-rf", "-p", "no:cacheprovider", *files]
    if k:
        cmd += ["-k", k]
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
    ap.add_argument("-k", help="pytest -k expression")
    ap.add_argument("--threads", type=int, help="BLAS/OpenMP threads for the runs")
    args = ap.parse_args(argv)
    counts = collections.Counter()
    bad_rounds = 0
    for r in range(1, args.rounds + 1):
        failed, passed, wall = run_round(args.files, args.k, args.threads)
        bad_rounds += bool(failed)
        counts.update(failed)
        print(
            f"round {r:2d}/{args.rounds}: {passed} passed, {len(failed)} failed ({wall:.0f} s)"
            + "".join(f"\n    FAILED {f}" for f in failed),
            flush=True,
        )
    print(f"{args.rounds} rounds of {' '.join(args.files)}: {bad_rounds} with failures")
    for test, n in counts.most_common():
        print(f"  {n:2d}x {test}")
    return 1 if bad_rounds else 0


if __name__ == "__main__":
    sys.exit(main())
