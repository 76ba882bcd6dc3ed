"""The holiday screen's week statistic, recorded on battery cases (session 16, ``diagnosis_holiday_s16.md``).

For each case (cached emulator data, as ``bench_diagnosis_battery.py`` makes them) the diagnosis runs with
its default options while every call of the holiday screen (one per round until a holiday term is accepted)
is recorded: the week means of the weekday departure scale γ (training weeks only, what the screen sees)
and, per week, the whole-span robust z the rule of session 5 uses; the summary adds the neighbour z of
:func:`neighbour_week_z` (the median of the weeks within ±3, measured and not adopted). The injected holiday weeks are read
from ``truth.json``. One JSON line per case goes to ``--out``; ``--summary`` prints the table of the
``.md`` from that file.

Run::

    python3 benchmarks/holiday_screen_s16.py --layouts quad4 --cases 32 --clean 4 --pairs 4 --step-min 15 \
        --only 0,1,2,3,5,6,9,15,21,27 --out screen.jsonl
    python3 benchmarks/holiday_screen_s16.py --only 0,1,3,4,6,7,9,10,12,13,19,21,27,33,39,45 --out screen.jsonl
    python3 benchmarks/holiday_screen_s16.py --summary --out screen.jsonl
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


def _week_of_date(sig, date: str) -> int:
    return int(sig.week[sig.index.searchsorted(pd.Timestamp(date).tz_localize(sig.index.tz))])


def record_case(case: dict, weeks: int) -> tuple:
    """Diagnose one case (``bench_diagnosis_battery.run_case``: its battery record) with the holiday screen's
    calls recorded; returns ``(screen record, battery record)``, both JSON-ready."""
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

    def recording(sig, W, options, shift=0):
        c = orig(sig, W, options, shift)
        ev = c.evidence or {}
        wm = {int(k): v for k, v in (ev.get("week_means") or {}).items()}
        calls.append(
            {
                "week_means": wm,
                "z_span": {
                    w: (g - ev["week_mean_median"]) / ev["week_mean_robust_std"]
                    for w, g in wm.items()
                    if "week_mean_median" in ev
                },
                "true_weeks": sorted({_week_of_date(sig, d) for d in true_days}),
                "picked_weeks": sorted(
                    {w["week"] for w in ev.get("weeks", [])} | {w["week"] for w in ev.get("zone_weeks", [])}
                ),
                "picked_dates": (c.location or {}).get("dates", []),
                "status": c.status,
            }
        )
        return c

    igs.holiday_candidate = recording
    try:
        rec = run_case(case, weeks)
    finally:
        igs.holiday_candidate = orig
    return {"case": case, "calls": calls, "found": rec["found"], "unsupported": rec["unsupported"]}, rec


def neighbour_week_z(week_means: dict, half_width: int = 3, floor: float = 0.03) -> dict:
    """Robust z of each week mean against the weeks around it: ``{week: z}`` (measured, not adopted).

    Each week's baseline is the median of the other weeks within ``half_width`` week numbers (held-out weeks
    are absent, not bridged); the scale is 1.4826 × the MAD (at least ``floor``) of the weeks' departures from
    their baselines, centred on their median. A week with no other week in reach gets no z; with fewer than 4
    such weeks none does.
    """
    weeks = sorted(week_means)
    g = np.array([week_means[w] for w in weeks], dtype=float)
    base = np.full(len(weeks), np.nan)
    for i, w in enumerate(weeks):
        nb = [g[j] for j, v in enumerate(weeks) if v != w and abs(v - w) <= half_width]
        if nb:
            base[i] = float(np.median(nb))
    r = g - base
    ok = np.isfinite(r)
    if ok.sum() < 4:
        return {}
    med = float(np.median(r[ok]))
    scale = max(float(1.4826 * np.median(np.abs(r[ok] - med))), floor)
    return {w: float((r[i] - med) / scale) for i, w in enumerate(weeks) if ok[i]}


def summary(paths: list, g_min: float = 0.2, z_min: float = 4.0) -> None:
    """Per case and round: each week ``week[*]: γ / z over the span / z against its neighbours`` (``*``: an
    injected holiday week), then the weeks each rule flags over all rounds: γ ≥ ``g_min`` and z ≥ ``z_min`` over
    the span (session 5), against the neighbours, either, and ``graded`` (session 16: z over the span ≥
    ``week_z_needed(γ)``)."""
    rows = [json.loads(x) for p in paths for x in open(p)]
    from hvacfmu.models.causes.internal_gain_schedule import week_z_needed

    # true weeks flagged, of, spurious; "graded": the rule of session 16 (week_z_needed, over the span)
    tally = {"span": [0, 0, 0], "neighbours": [0, 0, 0], "either": [0, 0, 0], "graded": [0, 0, 0]}
    for r in rows:
        c = r["case"]
        tag = f"{c['layout']} s{r.get('draw', c.get('draw', ''))} case {c['id']:2d}"
        flags = {k: set() for k in tally}
        true_all = set()
        for i, call in enumerate(r["calls"]):
            wm = {int(k): v for k, v in call["week_means"].items()}
            zs = {int(k): v for k, v in call["z_span"].items()}
            zn = neighbour_week_z(wm)
            tw = set(call["true_weeks"]) & set(wm)
            true_all |= tw
            parts = []
            for w in sorted(wm):
                mark = "*" if w in tw else ""
                parts.append(f"{w}{mark}:{wm[w]:+.2f}/{zs.get(w, np.nan):.1f}/{zn.get(w, np.nan):.1f}")
                big = wm[w] >= g_min
                a, b = big and zs.get(w, -np.inf) >= z_min, big and zn.get(w, -np.inf) >= z_min
                d = zs.get(w, -np.inf) >= week_z_needed(wm[w], 2 * g_min, z_min)
                for k, on in (("span", a), ("neighbours", b), ("either", a or b), ("graded", d)):
                    if on:
                        flags[k].add(w)
            print(f"{tag} round {i + 1}: {' '.join(parts)}")
        line = []
        for k, f in flags.items():
            tally[k][0] += len(f & true_all)
            tally[k][1] += len(true_all)
            tally[k][2] += len(f - true_all)
            line.append(f"{k}: true {sorted(f & true_all)} of {sorted(true_all)}, spurious {sorted(f - true_all)}")
        print(f"{tag} flags over all rounds: " + "; ".join(line))
    for k, (t, n, f) in tally.items():
        print(f"rule '{k}': {t} of {n} true holiday weeks flagged, {f} spurious weeks flagged")


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
    ap.add_argument(
        "--out", default="holiday-screen.jsonl", help="JSON-lines file (with --summary: a comma-separated list)"
    )
    ap.add_argument("--results", default=None, help="also append the battery records (bench_diagnosis_battery.py's)")
    ap.add_argument("--summary", action="store_true")
    args = ap.parse_args()
    if args.summary:
        summary(args.out.split(","))
        return
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
        print(c["id"], "calls", len(r["calls"]), flush=True)


if __name__ == "__main__":
    main()
