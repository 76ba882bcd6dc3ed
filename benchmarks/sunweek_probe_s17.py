"""Probe (session 17, ``diagnosis_sunweek_s17.md``): every holiday screen call of a case, with the terms in the
model, the weeks picked and set down to the weather, and each training week's mean γ (pooled, then by zone) on the
one-step residual (``raw``) and with each zone's regression on its facades' irradiance anomaly taken out (``sun``).

Run (quad4, 4 clean, 4 pairs, 15 min; 20 cases for seed 2031, 32 otherwise)::

    python3 benchmarks/sunweek_probe_s17.py 2031 8 probe.jsonl
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np
import pandas as pd

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from bench_diagnosis_battery import make_cases, run_case  # noqa: E402

from hvacfmu.models.causes import internal_gain_schedule as igs  # noqa: E402


def _week_means(sig, resid, rows, shift):
    deps = igs.day_departures(sig, resid, rows=rows, shift=shift)
    by_week: dict = {}
    for d in deps:
        wk = int(sig.week[sig.index.searchsorted(pd.Timestamp(d["date"]).tz_localize(sig.index.tz))])
        by_week.setdefault(wk, []).append(d)
    out = {}
    for wk, ds in by_week.items():
        if len(ds) < 3:
            continue
        zs = [[d["gamma_by_zone"][j] for d in ds if d["gamma_by_zone"][j] is not None] for j in range(len(sig.zones))]
        out[wk] = [round(float(np.mean([d["gamma"] for d in ds])), 3)] + [
            round(float(np.mean(z)), 3) if z else None for z in zs
        ]
    return out


def main():
    seed, out = int(sys.argv[1]), sys.argv[3]
    only = {int(x) for x in sys.argv[2].split(",")}
    cases = [c for c in make_cases(20 if seed == 2031 else 32, seed, ["quad4"], 4, 4, 900.0) if c["id"] in only]
    orig_screen = igs.InternalGainSchedule.screen.__func__
    orig_hc = igs.holiday_candidate
    state: dict = {}

    def screen(cls, sig, terms, W, resid, options):
        state["terms"] = [f"{t.cause}:{t.location()}" for t in terms]
        return orig_screen(cls, sig, terms, W, resid, options)

    def hc(sig, W, options, shift=0):
        c = orig_hc(sig, W, options, shift)
        ra = options["_resid_all"]
        sun = igs.sun_partialled(sig, ra, W.rows)
        ev = c.evidence or {}
        state["calls"].append(
            {
                "terms": state.get("terms"),
                "status": c.status,
                "zones": list(sig.zones),
                "weeks": [(w["week"], w["gamma"], w.get("gamma_sun")) for w in ev.get("weeks", [])],
                "zone_weeks": [(w["week"], w["zones"], w.get("gamma_sun")) for w in ev.get("zone_weeks", [])],
                "weather": ev.get("weather_explained"),
                "raw": _week_means(sig, ra, W.rows, shift),
                "sun": _week_means(sig, sun, W.rows, shift) if sun is not None else None,
            }
        )
        return c

    igs.InternalGainSchedule.screen = classmethod(screen)
    igs.holiday_candidate = hc
    for c in cases:
        state.clear()
        state["calls"] = []
        r = run_case(c, 16)
        with open(out, "a") as f:
            rec = {"id": c["id"], "seed": seed, "found": r["found"], "unsupported": r["unsupported"], **state}
            f.write(json.dumps(rec, default=str) + "\n")
        print(c["id"], r["found"], r["unsupported"], flush=True)


if __name__ == "__main__":
    main()
