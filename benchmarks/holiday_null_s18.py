"""Probe (session 18, ``holiday_s18.md``): every training week scored as a holiday, in every round of a diagnosis.

For each round the diagnosis runs (``selection._score_round``), each training week's weekdays are scored as a
holiday candidate on the round's model (``score_candidate``, the scale gate's inputs): ΔBIC, the fitted scale by
zone, the zones' amplitude weights. On cases without a holiday this is the scale gate's null distribution (what any
week would read if the screen proposed it); on holiday cases it gives the true weeks' scales in every round.

Run (quad4, 4 clean, 4 pairs, 15 min)::

    python3 benchmarks/holiday_null_s18.py --seed 2031 --cases 20 --only 0,1 --out null.jsonl
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from bench_diagnosis_battery import make_cases, run_case  # noqa: E402

from hvacfmu.diagnosis import candidates as cand  # noqa: E402
from hvacfmu.diagnosis import selection  # noqa: E402
from hvacfmu.models.causes.internal_gain_schedule import dst_shift_of  # noqa: E402
from hvacfmu.models.extended import InternalGainSchedule  # noqa: E402


def week_scores(sig, W, terms, cur, opts) -> dict:
    resid = cur.resid
    cur_rss = [ls.rss for ls in cur.zone_ls]
    factors = [selection.ess_factor(selection.lag1(resid[:, z])) for z in range(sig.nz)]
    U_cur = selection.effective_inputs(sig, terms)
    cache = {"U_eff": U_cur, "feats": [selection.term_features(sig, tt, U_cur) for tt in terms]}
    rows = np.asarray(W.rows)
    idx = sig.index[rows]
    wk = np.asarray(sig.week)[rows]
    wd = idx.day_of_week < 5
    out = {}
    for w in sorted(set(wk[wd & (wk >= 0)])):
        dates = sorted({d.isoformat() for d in idx[wd & (wk == w)].date})
        if len(dates) < 3:
            continue
        term = InternalGainSchedule(
            variant="holiday",
            zone_names=sig.zones,
            coef=tuple(0.0 for _ in sig.zones),
            dates=tuple(dates),
            ref_weekday=6,
            shift=dst_shift_of(terms),
        )
        c = cand.Candidate(InternalGainSchedule.cause, {"variant": "holiday", "dates": dates}, [term], 1)
        selection.score_candidate(sig, W, terms, cur_rss, factors, c, opts, cache)
        ev = c.evidence
        out[int(w)] = {
            "delta_bic": c.test["delta_bic"],
            "scale_mean": ev.get("scale_mean"),
            "scale_by_zone": ev.get("scale_by_zone"),
            "scale_weight_by_zone": ev.get("scale_weight_by_zone"),
        }
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=2031)
    ap.add_argument("--cases", type=int, default=20)
    ap.add_argument("--only", required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    only = {int(x) for x in a.only.split(",")}
    cases = [c for c in make_cases(a.cases, a.seed, ["quad4"], 4, 4, 900.0) if c["id"] in only]
    orig = selection._score_round
    rounds: list = []

    def score_round(sig, W, terms, cur, opts, plan=None):
        out = orig(sig, W, terms, cur, opts, plan)
        rounds.append(
            {
                "terms": [f"{t.cause}:{t.location()}" for t in terms],
                "weeks": week_scores(sig, W, terms, cur, opts),
                "weather_weeks": sorted((opts.get("_holiday_weather") or {}).get("weeks", {})),
            }
        )
        return out

    selection._score_round = score_round
    for c in cases:
        rounds.clear()
        r = run_case(c, 16)
        with open(a.out, "a") as f:
            rec = {
                "id": c["id"],
                "seed": a.seed,
                "effects": c["effects"],
                "found": r["found"],
                "unsupported": r["unsupported"],
                "rounds": list(rounds),
            }
            f.write(json.dumps(rec, default=str) + "\n")
        print(c["id"], r["found"], r["unsupported"], flush=True)


if __name__ == "__main__":
    main()
