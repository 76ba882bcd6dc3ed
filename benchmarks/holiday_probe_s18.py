"""Probe (session 18, ``holiday_s18.md``): every holiday candidate a diagnosis scores, with its dates, ΔBIC,
status, and its scale by zone and the zones' amplitude weights (the scale gate's inputs), for quad4 battery cases.

Run (quad4, 4 clean, 4 pairs, 15 min; ``--cases`` 20 for seed 2031, 32 for 2026)::

    python3 benchmarks/holiday_probe_s18.py --seed 2031 --cases 20 --only 4,9 --out probe.jsonl
"""

from __future__ import annotations

import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from bench_diagnosis_battery import make_cases, run_case  # noqa: E402

from hvacfmu.diagnosis import selection  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=2031)
    ap.add_argument("--cases", type=int, default=20)
    ap.add_argument("--only", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--option", action="append", default=[], help="KEY=JSON diagnose option")
    a = ap.parse_args()
    opts = {k: json.loads(v) for k, v in (o.split("=", 1) for o in a.option)}
    only = {int(x) for x in a.only.split(",")}
    cases = [c for c in make_cases(a.cases, a.seed, ["quad4"], 4, 4, 900.0) if c["id"] in only]
    orig_gate = selection._gate
    seen: list = []

    def gate(c, o):
        orig_gate(c, o)
        if selection._is_holiday(c.term):
            ev = c.evidence or {}
            seen.append(
                {
                    "dates": list(c.location.get("dates", [])),
                    "status": c.status,
                    "delta_bic": c.test.get("delta_bic"),
                    "scale_mean": ev.get("scale_mean"),
                    "scale_by_zone": ev.get("scale_by_zone"),
                    "scale_weight_by_zone": ev.get("scale_weight_by_zone"),
                    "groups": [{k: v for k, v in g.items() if k != "dates"} for g in ev.get("groups", [])],
                    "week_likelihood": ev.get("week_likelihood"),
                    "scale_mean_all_zones": ev.get("scale_mean_all_zones"),
                    "scale_zone_departure": ev.get("scale_zone_departure"),
                }
            )

    selection._gate = gate
    orig_fb = selection._holiday_week_by_likelihood

    def fb(sig, W, terms, cur_rss, factors, c, o, cache, resid_all):
        orig_fb(sig, W, terms, cur_rss, factors, c, o, cache, resid_all)
        seen.append({"fallback": c.evidence.get("week_likelihood"), "status": c.status})

    selection._holiday_week_by_likelihood = fb
    for c in cases:
        seen.clear()
        r = run_case(c, 16, **opts)
        with open(a.out, "a") as f:
            rec = {
                "id": c["id"],
                "seed": a.seed,
                "effects": c["effects"],
                "found": r["found"],
                "missed": r["missed"],
                "unsupported": r["unsupported"],
                "holiday_candidates": list(seen),
            }
            f.write(json.dumps(rec, default=str) + "\n")
        print(c["id"], r["found"], r["unsupported"], flush=True)


if __name__ == "__main__":
    main()
