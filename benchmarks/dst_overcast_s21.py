"""Probe (session 21, issue 15): does a screened ``dst_shift`` hold on overcast days?

A clock the occupancy follows moves its gains on every daylight-saving weekday alike, sunny or overcast. The
sun follows solar time, which jumps one hour on the local clock at the change too: any part of the solar gain
the model misses (through the weekday HVAC schedule, the weekday-minus-weekend difference of the screen does not
cancel it) moves like a clock, but only on days with sun. This probe reruns the diagnosis of each case with
``dst_step_given_weather`` wrapped: besides the screen's own numbers it recomputes the morning's jump at the
change on the overcast half of the weekdays (daily mean irradiance below the median of its season and side)
and on the sunny half. Nothing in the library changes; results are printed and written as JSON lines.

    python3 benchmarks/dst_overcast_s21.py [--only NAME,...] [--results FILE]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

DST = "internal_gain_schedule:kind=dst"
#: name, layout, seed, step [s] (None: the dataset's own), effects, what the truth says
CASES = (
    # the false shift of the fresh battery (fresh_s21.md): quad4 seed 6, clean and with the case-18 north sun
    ("quad4-6-clean", "quad4", 6, 900.0, ()),
    ("fresh-a18", "quad4", 6, 900.0, ("solar_gain:zone=NE,facade=N,shgc=0.42",)),
    # the false shift of the fresh 5-min draw (seed 2102 case 5): row4 seed 30 at 5 min, clean
    ("row4-30-5min-clean", "row4", 30, 300.0, ()),
    # injected shifts of benchmarks/dst_s18.py
    ("sdh-0", "sdh", 0, None, (DST,)),
    ("sdh-1", "sdh", 1, None, (DST,)),
    ("sdh-2", "sdh", 2, None, (DST,)),
    ("sdh-4", "sdh", 4, None, (DST,)),
    ("sdh-5", "sdh", 5, None, (DST,)),
    ("sdh-1+reheat", "sdh", 1, None, (DST, "reheat:power=4000")),
    ("row4-901", "row4", 31, 900.0, (DST,)),
    ("core9-902", "core9", 32, 900.0, (DST,)),
    ("quad4-28", "quad4", 28, 900.0, (DST,)),
)


def _split_rows(sig, rows):
    """``rows`` split into (overcast, sunny): weekend rows in both, each weekday in the half of its season and
    daylight-saving side its daily mean irradiance falls in (below / at or above the median)."""
    import hvacfmu.models.causes.internal_gain_schedule as igs

    irr = igs._day_weather(sig).get("irradiance")
    if irr is None:
        return None
    dates = np.array(sig.index.date)
    wd = sig.index.day_of_week.to_numpy()
    per_day = sig.n_tow // 7
    weekday = (wd < 5) & (sig.tow < 5 * per_day)
    keep_c, keep_s = ~weekday[rows], ~weekday[rows]
    for s in sig.seasons:
        for side in (True, False):
            m = weekday[rows] & (sig.season[rows] == s) & (sig.dst[rows] == side)
            days = np.unique(dates[rows][m])
            if len(days) == 0:
                continue
            mean = {d: float(np.nanmean(irr[dates == d])) for d in days}
            med = float(np.median(list(mean.values())))
            dm = dates[rows]
            for d, v in mean.items():
                (keep_c if v < med else keep_s)[m & (dm == d)] = True
    return rows[keep_c], rows[keep_s]


def run(name, layout, seed, step, effects) -> dict:
    import hvacfmu.models.causes.internal_gain_schedule as igs
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.diagnosis.truth import compare_with_truth
    from hvacfmu.emulator import cached_dataset

    calls = []
    screen, step_fn = igs.dst_candidate, igs.dst_step_given_weather

    def step_split(sig, gains, rows, lag, window=igs.DST_WINDOW_H):
        out = step_fn(sig, gains, rows, lag, window)
        parts = _split_rows(sig, rows)
        if parts is not None:
            for key, r in zip(("overcast", "sunny"), parts):
                o = step_fn(sig, gains, r, lag, window)
                out[key] = {k: o.get(k) for k in ("jump", "jump_given_weather", "se", "t", "days_dst", "days_standard")}
        return out

    def recorded(sig, W, options, exclude_dates=()):
        c = screen(sig, W, options, exclude_dates=exclude_dates)
        calls.append({"status": c.status, "retest": bool(options.get("_dst_retest")), "evidence": c.evidence})
        return c

    igs.dst_candidate, igs.dst_step_given_weather = recorded, step_split
    try:
        paths = cached_dataset(weeks=16, seed=seed, effects=list(effects), layout=layout)
        ds = prepare(paths.measurements, paths.building, **({"step": step} if step else {}))
        c0 = time.process_time()
        rep = diagnose(ds, progress=False)
        cpu = time.process_time() - c0
    finally:
        igs.dst_candidate, igs.dst_step_given_weather = screen, step_fn
    cmp = compare_with_truth(rep, json.loads(paths.truth.read_text()))
    screened = [c for c in calls if not c["retest"] and c["evidence"].get("step_given_weather")]
    ev = screened[0]["evidence"] if screened else (calls[0]["evidence"] if calls else {})
    return {
        "name": name,
        "layout": layout,
        "seed": seed,
        "effects": list(effects),
        "first_screen": calls[0]["status"] if calls else "not called",
        "lag_h": ev.get("lag_h"),
        "evening_r2_legal": (ev.get("evening") or {}).get("r2_at_legal_lag"),
        "step_given_weather": ev.get("step_given_weather"),
        "dst_found": any(f["location"].get("variant") == "dst_shift" for f in rep.findings),
        "false": [{"cause": f["cause"], "location": f["location"]} for f in cmp["unsupported"]],
        "screens": [
            {
                "status": c["status"],
                "retest": c["retest"],
                "morning_lag_h": c["evidence"].get("lag_h"),
                "morning_r2_by_lag": c["evidence"].get("r2_by_lag"),
                "evening": c["evidence"].get("evening"),
                "step_t": (c["evidence"].get("step_given_weather") or {}).get("t"),
            }
            for c in calls
        ],
        "diagnose_cpu_s": cpu,
    }


def line(r: dict) -> str:
    s = r["step_given_weather"] or {}

    def part(k):
        p = s.get(k) or {}
        if p.get("t") is None:
            return f"{k} n/a"
        return f"{k} jump {p['jump']:+.2f} → {p['jump_given_weather']:+.2f} (t {p['t']:.1f}, {p['days_dst']}+{p['days_standard']} d)"

    allj = (
        f"all {s['jump']:+.2f} → {s['jump_given_weather']:+.2f} (t {s['t']:.1f})"
        if s.get("t") is not None
        else "all n/a"
    )
    return (
        f"{r['name']:14s} dst found {r['dst_found']!s:5s} lag {r['lag_h']}; {allj}; {part('overcast')}; {part('sunny')}"
    )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", help="comma-separated case names")
    ap.add_argument("--results", default="dst_overcast_s21.jsonl")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    keep = set(args.only.split(",")) if args.only else None
    for case in CASES:
        if keep and case[0] not in keep:
            continue
        r = run(*case)
        with open(args.results, "a") as f:
            f.write(json.dumps(r, default=float) + "\n")
        print(line(r), flush=True)


if __name__ == "__main__":
    main()
