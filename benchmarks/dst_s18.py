"""The daylight-saving screen on the cases that test it: injected shifts, false shifts, clean floors (issue 15).

Session 18 added to ``dst_candidate`` the weather test (``dst_step_given_weather``): the weekday
morning's jump at the change must stay once each day's outdoor temperature and irradiance are held.
For each case this runs the default diagnosis (data from ``cached_dataset``, cached in ``$HVACFMU_CACHE``),
records every call of the daylight-saving screen (a wrapper around ``dst_candidate``; the diagnosis
itself is unchanged) and prints one line: the first screen's status, its morning lag, the evening R²
at the legal hour, the weather test (raw jump, jump with the weather held, t), whether a ``dst_shift``
was found and the causes found / false against the emulator's truth.

Run: ``python3 benchmarks/dst_s18.py [--only NAME,...] [--out FILE]`` (about 10 min on the shared 2-core
machine with the datasets cached; write-up ``benchmarks/dst_s18.md``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

DST = "internal_gain_schedule:kind=dst"
DELAY_SW = "actuation_delay:zone=SW,minutes=30"
#: name, layout, seed, step [s] (None: the dataset's own), effects
CASES = (
    # false shifts of main: hold-out quad4 2031 case 14, quad4 2026 case 23
    ("q2031-14", "quad4", 28, 900.0, (DELAY_SW,)),
    ("q2026-23", "quad4", 2, 900.0, ("thermal_mass:zone=NE,capacitance=2.04e+08,ua=1311",)),
    # injected shifts: the default floor (README), the layouts of bench_dst_layouts.py, quad4 (new)
    ("sdh-0", "sdh", 0, None, (DST,)),
    ("sdh-1", "sdh", 1, None, (DST,)),
    ("sdh-2", "sdh", 2, None, (DST,)),
    ("sdh-4", "sdh", 4, None, (DST,)),
    ("sdh-5", "sdh", 5, None, (DST,)),
    ("sdh-1+reheat", "sdh", 1, None, (DST, "reheat:power=4000")),
    ("row4-901", "row4", 31, 900.0, (DST,)),
    ("core9-902", "core9", 32, 900.0, (DST,)),
    ("row4-903", "row4", 33, 300.0, (DST,)),
    ("quad4-28", "quad4", 28, 900.0, (DST,)),
    ("quad4-28+delay", "quad4", 28, 900.0, (DST, DELAY_SW)),
    # clean default floor
    ("sdh-0-clean", "sdh", 0, None, ()),
    ("sdh-1-clean", "sdh", 1, None, ()),
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
        calls.append({"status": c.status, "retest": bool(options.get("_dst_retest")), "evidence": c.evidence})
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
    first = calls[0] if calls else {"status": "not called", "evidence": {}}
    ev = first["evidence"]
    return {
        "name": name,
        "effects": list(effects),
        "first_screen": first["status"],
        "lag_h": ev.get("lag_h"),
        "evening_r2_legal": (ev.get("evening") or {}).get("r2_at_legal_lag"),
        "step_given_weather": ev.get("step_given_weather"),
        "dst_found": any(f["location"].get("variant") == "dst_shift" for f in rep.findings),
        "found": [e["name"] for e in cmp["found"]],
        "false": [{"cause": f["cause"], "location": f["location"]} for f in cmp["unsupported"]],
        "screens": len(calls),
        "diagnose_cpu_s": cpu,
    }


def line(r: dict) -> str:
    s = r["step_given_weather"] or {}
    w = (
        f"jump {s['jump']:+.2f}, with weather {s['jump_given_weather']:+.2f} (t {s['t']:.1f})"
        if s.get("t") is not None
        else "weather test not reached"
    )
    lag = "" if r["lag_h"] is None else f"lag {r['lag_h']:+.2f} h"
    eve = "" if r["evening_r2_legal"] is None else f", evening R² {r['evening_r2_legal']:.2f}"
    false = [f"{f['cause']}:{f['location'].get('variant', f['location'].get('zone', ''))}" for f in r["false"]]
    return (
        f"{r['name']:15s} first screen {r['first_screen']:15s} {lag}{eve}; {w}; dst_shift found {r['dst_found']}; "
        f"found {r['found']} false {false}"
    )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", help="comma-separated case names")
    ap.add_argument("--out", default="dst-s18.jsonl", help="JSON-lines file of the results")
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
