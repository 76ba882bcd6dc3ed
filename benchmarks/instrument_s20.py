"""Session 20 (issue 15): one battery case diagnosed in this process, its whole report saved, and two such reports
compared number by number (``benchmarks/instrument_s20.md``).

``run``: the case (``--seed``/``--cases`` draw of ``bench_diagnosis_battery.py``, or ``--checked FILE`` for the
detectability-checked battery's version of an effect case) is diagnosed with ``--option`` settings, optionally under
cProfile (``--profile OUT``, the top functions by cumulative and by own time printed); the report's
``to_dict()`` (every finding and candidate with its evidence) goes to ``--out`` as JSON with the CPU seconds.

``compare A B``: every number of two such reports (the same structure) within ``--rtol`` relative (absolute for
values under 1e-12), strings and lists equal; timing fields are ignored. Prints the largest relative difference
and each mismatch. Used to check that the held instrument's factorisation changes no result.

    python3 benchmarks/instrument_s20.py run --only 8 --out main8.json [--profile p.out]
    python3 benchmarks/instrument_s20.py compare main8.json branch8.json
"""

from __future__ import annotations

import argparse
import cProfile
import json
import math
import os
import pstats
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))

IGNORED = {"diagnose_wall_s", "diagnose_cpu_s", "generate_wall_s", "commit", "cpu_s", "wall_s", "elapsed_s"}


def _case(args) -> dict:
    import bench_diagnosis_battery as bb

    if args.checked:
        with open(args.checked) as f:
            for line in f:
                r = json.loads(line)
                if r["case"]["id"] == args.only:
                    return r["checked"]
    layouts = args.layouts.split(",") if args.layouts else None
    step = None if args.step_min is None else 60.0 * args.step_min
    for c in bb.make_cases(args.cases, args.seed, layouts, args.clean, args.pairs, step):
        if c["id"] == args.only:
            return c
    raise SystemExit(f"no case {args.only}")


def run(args) -> None:
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.emulator import cached_dataset

    case = _case(args)
    options = {k: json.loads(v) for k, v in (o.split("=", 1) for o in args.option)}
    paths = cached_dataset(weeks=16, seed=case["seed"], effects=case["effects"], layout=case["layout"])
    ds = prepare(paths.measurements, paths.building, step=case["step"])
    prof = cProfile.Profile() if args.profile else None
    w0, c0 = time.perf_counter(), time.process_time()
    if prof:
        prof.enable()
    rep = diagnose(ds, progress=False, **options)
    if prof:
        prof.disable()
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    out = {"case": case, "options": options, "wall_s": wall, "cpu_s": cpu, "report": rep.to_dict()}
    with open(args.out, "w") as f:
        json.dump(out, f, default=float)
    print(
        f"case {case['id']} {case['layout']} {case['step'] / 60:.0f} min: diagnose {cpu:.1f} CPU-s, {wall:.1f} s wall"
    )
    if prof:
        prof.dump_stats(args.profile)
        st = pstats.Stats(prof)
        st.sort_stats("cumulative").print_stats(40)
        st.sort_stats("tottime").print_stats(25)


def _walk(a, b, path, out):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k in IGNORED:
                continue
            if k not in a or k not in b:
                out["mismatch"].append(f"{path}/{k}: only in {'A' if k in a else 'B'}")
                continue
            _walk(a[k], b[k], f"{path}/{k}", out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out["mismatch"].append(f"{path}: lengths {len(a)} != {len(b)}")
            return
        for i, (x, y) in enumerate(zip(a, b)):
            _walk(x, y, f"{path}[{i}]", out)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        out["numbers"] += 1
        if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
            return
        if a == b:
            return
        scale = max(abs(a), abs(b))
        rel = abs(a - b) / scale if scale > 1e-12 else 0.0
        if rel > out["max_rel"]:
            out["max_rel"], out["max_at"] = rel, f"{path}: {a!r} vs {b!r}"
        if rel > out["rtol"]:
            out["mismatch"].append(f"{path}: {a!r} vs {b!r} (rel {rel:.2e})")
    elif a != b:
        out["mismatch"].append(f"{path}: {a!r} != {b!r}")


def compare(args) -> int:
    with open(args.a) as f:
        A = json.load(f)
    with open(args.b) as f:
        B = json.load(f)
    out = {"mismatch": [], "numbers": 0, "max_rel": 0.0, "max_at": "", "rtol": args.rtol}
    _walk(A, B, "", out)
    print(f"{out['numbers']} numbers compared; largest relative difference {out['max_rel']:.2e} ({out['max_at']})")
    print(f"CPU {A.get('cpu_s', float('nan')):.1f} s (A) -> {B.get('cpu_s', float('nan')):.1f} s (B)")
    for m in out["mismatch"][:50]:
        print("MISMATCH", m)
    print("identical within", args.rtol if not out["mismatch"] else f"NO: {len(out['mismatch'])} mismatches")
    return 1 if out["mismatch"] else 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--only", type=int, required=True, help="case id")
    r.add_argument("--seed", type=int, default=2026)
    r.add_argument("--cases", type=int, default=48)
    r.add_argument("--layouts", default=None, help="as bench_diagnosis_battery.py (with --clean, --pairs, --step-min)")
    r.add_argument("--clean", type=int, default=None)
    r.add_argument("--pairs", type=int, default=None)
    r.add_argument("--step-min", type=float, default=None)
    r.add_argument("--checked", default=None, help="the checked battery's case file (effect cases)")
    r.add_argument("--option", action="append", default=[], help="diagnose option key=JSON")
    r.add_argument("--profile", default=None)
    r.add_argument("--out", required=True)
    c = sub.add_parser("compare")
    c.add_argument("a")
    c.add_argument("b")
    c.add_argument("--rtol", type=float, default=1e-9)
    args = ap.parse_args()
    if args.cmd == "run":
        run(args)
        return 0
    return compare(args)


if __name__ == "__main__":
    raise SystemExit(main())
