"""What a holiday week looks like zone by zone and in the weather (session 17, ``diagnosis_holiday_s17.md``).

For each case (cached emulator data, as ``bench_diagnosis_battery.py`` makes them) the diagnosis runs with its
default options while every call of the holiday screen is recorded with the day-by-day departures (pooled γ and
γ by zone, training weeks only, what the screen sees) and the weeks it picked; the weekday means of the outdoor
temperature and of the global irradiance by week are read from the data, and the screen's picks set down to
the weather (``weather_explained``) are kept. One JSON line per case goes to
``--out``; ``--results`` also appends the battery's record of the same run. The zone-agreement ratios of the
write-up were computed offline from these records.

Run::

    python3 benchmarks/holiday_zones_s17.py --layouts quad4 --cases 32 --clean 4 --pairs 4 --step-min 15 \
        --only 20 --out zones.jsonl --results b.jsonl
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np
import pandas as pd

sys.path.insert(0, os.path.dirname(__file__))

from bench_diagnosis_battery import make_cases, run_case  # noqa: E402


def _week_of(sig, date: str) -> int:
    return int(sig.week[sig.index.searchsorted(pd.Timestamp(date).tz_localize(sig.index.tz))])


def record_case(case: dict, weeks: int) -> tuple:
    """Diagnose one case with the holiday screen's calls recorded; returns ``(record, battery record)``."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis.truth import _holiday_dates
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.models.causes import internal_gain_schedule as igs

    paths = cached_dataset(weeks=weeks, seed=case["seed"], effects=case["effects"], layout=case["layout"])
    truth = json.loads(paths.truth.read_text())
    true_days = set()
    for e in truth.get("effects", []):
        if e.get("name") == "internal_gain_schedule" and e.get("kind", "holiday") == "holiday":
            true_days |= set(_holiday_dates(truth, e))
    calls = []
    orig = igs.holiday_candidate
    info = {}

    def recording(sig, W, options, shift=0):
        c = orig(sig, W, options, shift)
        ev = c.evidence or {}
        deps = igs.day_departures(sig, options["_resid_all"], rows=W.rows, shift=shift)
        if "weather" not in info:
            fr = ds.frame.reindex(sig.index)
            wd = sig.index.day_of_week.to_numpy() < 5
            wk = np.asarray(sig.week)
            info["zones"] = list(sig.zones)
            info["weather"] = {
                int(w): {
                    "T_out": float(np.nanmean(fr["T_out"].to_numpy()[wd & (wk == w)])),
                    "ghi": float(np.nanmean(fr["ghi"].to_numpy()[wd & (wk == w)])) if "ghi" in fr else None,
                }
                for w in np.unique(wk[wk >= 0])
            }
        calls.append(
            {
                "days": [
                    {
                        "date": d["date"],
                        "week": _week_of(sig, d["date"]),
                        "gamma": d["gamma"],
                        "t": d["t"],
                        "gamma_by_zone": d["gamma_by_zone"],
                    }
                    for d in deps
                ],
                "true_weeks": sorted({_week_of(sig, d) for d in true_days}),
                "picked_weeks": sorted(
                    {w["week"] for w in ev.get("weeks", [])} | {w["week"] for w in ev.get("zone_weeks", [])}
                ),
                "zone_weeks": [w["week"] for w in ev.get("zone_weeks", [])],
                "weather_weeks": [w["week"] for w in (ev.get("weather_explained") or {}).get("weeks", [])],
                "weather_week_means": (ev.get("weather_explained") or {}).get("weeks", []),
                "status": c.status,
            }
        )
        return c

    ds = prepare(paths.measurements, paths.building, step=case["step"])
    igs.holiday_candidate = recording
    try:
        rec = run_case(case, weeks)
    finally:
        igs.holiday_candidate = orig
    return {
        "case": case,
        "calls": calls,
        **info,
        "true_days": sorted(true_days),
        "found": rec["found"],
        "unsupported": rec["unsupported"],
    }, rec


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", type=int, default=48)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--weeks", type=int, default=16)
    ap.add_argument("--layouts", default=None)
    ap.add_argument("--clean", type=int, default=None)
    ap.add_argument("--pairs", type=int, default=None)
    ap.add_argument("--step-min", type=float, default=None)
    ap.add_argument("--only", type=str, default=None)
    ap.add_argument("--out", default="holiday-zones.jsonl")
    ap.add_argument("--results", default=None)
    args = ap.parse_args()
    layouts = args.layouts.split(",") if args.layouts else None
    step = None if args.step_min is None else 60.0 * args.step_min
    cases = make_cases(args.cases, args.seed, layouts, args.clean, args.pairs, step)
    if args.only:
        keep = {int(x) for x in args.only.split(",")}
        cases = [c for c in cases if c["id"] in keep]
    for c in cases:
        r, rec = record_case(c, args.weeks)
        r["draw"] = args.seed
        with open(args.out, "a") as f:
            f.write(json.dumps(r, default=float) + "\n")
        if args.results:
            with open(args.results, "a") as f:
                f.write(json.dumps(rec, default=float) + "\n")
        print(c["id"], "calls", len(r["calls"]), rec["found"], rec["unsupported"], flush=True)


if __name__ == "__main__":
    main()
