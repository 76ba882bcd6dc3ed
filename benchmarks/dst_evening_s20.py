"""The daylight-saving screen's evening check, both directions (issue 15, session 20).

A clock moves the whole weekday schedule one way. Session 14's evening check asks only that the evening ramp-down
(13-21 h) align with R² >= 0.2 when moved by the legal hour in the morning's direction; on the two-storey layout
``stack4`` (seed 30: hold-out 2061 clean case 4 and 2060 case 6) the morning moved +1.25 h while the evening aligned
far better moved the other way (R² 0.65 at -1 h against 0.42 at +1 h), and a false ``dst_shift`` was found
(cv t 3.6 and 2.6). Session 20 refuses a shift whose evening aligns better at the opposite legal lag.

For each case this runs the default diagnosis (``cached_dataset``, cached in ``$HVACFMU_CACHE``), records every call
of the screen and prints its first call: status, morning lag, the evening's R² at the legal lag and at the opposite
one, whether a ``dst_shift`` was found, and the causes found / false against the emulator's truth. The cases are
``benchmarks/dst_s18.py``'s (injected shifts on sdh, row4, core9, quad4, the two false shifts of session 17, two
clean floors) and the two stack4 false shifts.

Run with the library on ``PYTHONPATH`` (the branch, or main for the comparison):
``python3 benchmarks/dst_evening_s20.py [--only NAME,...] --out FILE`` (write-up ``benchmarks/layout_stack4_s20.md``).
"""

from __future__ import annotations

import argparse
import json
import time

from dst_s18 import CASES as S18_CASES

CASES = S18_CASES + (
    ("stack4-2061-4", "stack4", 30, 900.0, ()),
    (
        "stack4-2060-6",
        "stack4",
        30,
        900.0,
        ("solar_gain:zone=S2,facade=W,shgc=0.23", "reheat:zone=S1,power=2765,below=14.7"),
    ),
)


def run(name, layout, seed, step, effects) -> dict:
    import hvacfmu.models.causes.internal_gain_schedule as igs
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.diagnosis.truth import compare_with_truth
    from hvacfmu.emulator import cached_dataset

    calls = []
    screen = igs.dst_candidate

    def recorded(sig, W, options, exclude_dates=()):
        c = screen(sig, W, options, exclude_dates=exclude_dates)
        calls.append({"status": c.status, "reason": c.reason, "evidence": c.evidence})
        return c

    igs.dst_candidate = recorded
    try:
        paths = cached_dataset(weeks=16, seed=seed, effects=list(effects), layout=layout)
        ds = prepare(paths.measurements, paths.building, **({"step": step} if step else {}))
        c0 = time.process_time()
        rep = diagnose(ds, progress=False)
        cpu = time.process_time() - c0
    finally:
        igs.dst_candidate = screen
    cmp = compare_with_truth(rep, json.loads(paths.truth.read_text()))
    first = calls[0] if calls else {"status": "not called", "reason": "", "evidence": {}}
    ev = first["evidence"]
    eve = ev.get("evening") or {}
    opposite = eve.get("r2_at_opposite_lag")  # None on main, whose evidence does not record it
    return {
        "name": name,
        "effects": list(effects),
        "first_screen": first["status"],
        "first_reason": first["reason"],
        "lag_h": ev.get("lag_h"),
        "evening": eve,
        "evening_r2_opposite": opposite,
        "dst_found": any(f["location"].get("variant") == "dst_shift" for f in rep.findings),
        "found": [e["name"] for e in cmp["found"]],
        "false": [{"cause": f["cause"], "location": f["location"]} for f in cmp["unsupported"]],
        "screens": len(calls),
        "diagnose_cpu_s": cpu,
    }


def line(r: dict) -> str:
    e = r["evening"] or {}
    eve = (
        f"evening R² {e['r2_at_legal_lag']:.2f} at {e['legal_lag_h']:+.0f} h"
        + (
            f", {r['evening_r2_opposite']:.2f} at {-e['legal_lag_h']:+.0f} h"
            if r["evening_r2_opposite"] is not None
            else ""
        )
        + f" (best {e.get('lag_h', float('nan')):+.2f} h)"
        if e
        else "evening not reached"
    )
    lag = "" if r["lag_h"] is None else f"lag {r['lag_h']:+.2f} h, "
    false = [f"{f['cause']}:{f['location'].get('variant', f['location'].get('zone', ''))}" for f in r["false"]]
    return (
        f"{r['name']:15s} first screen {r['first_screen']:15s} {lag}{eve}; dst_shift found {r['dst_found']}; "
        f"found {r['found']} false {false}"
    )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", help="comma-separated case names")
    ap.add_argument("--out", required=True, help="JSON-lines file of the results")
    args = ap.parse_args(argv)
    only = set(args.only.split(",")) if args.only else None
    with open(args.out, "a") as f:
        for case in CASES:
            if only and case[0] not in only:
                continue
            r = run(*case)
            f.write(json.dumps(r) + "\n")
            f.flush()
            print(line(r), flush=True)


if __name__ == "__main__":
    main()
