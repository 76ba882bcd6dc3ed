"""Probe (session 18, ``holiday_s18.md``): the holiday screen's week means (pooled; by zone) in every screen call of
one emulated quad4 case given by its seed and effects, on the one-step residual (``raw``) and with each zone's
regression on its facades' irradiance anomaly taken out (``sun``). Run on a holiday case's twin without the holiday
(same seed, the other effects), it shows what the week reads without the holiday::

    python3 benchmarks/holiday_twin_s18.py 28 '[]' twin28.json
    python3 benchmarks/holiday_twin_s18.py 41 '["thermal_mass:zone=SE,capacitance=2.25e+08,ua=1341"]' twin41.json
"""

from __future__ import annotations

import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import sunweek_probe_s17 as sp  # noqa: E402
from bench_diagnosis_battery import run_case  # noqa: E402

from hvacfmu.models.causes import internal_gain_schedule as igs  # noqa: E402


def main():
    seed, effects, out = int(sys.argv[1]), json.loads(sys.argv[2]), sys.argv[3]
    state: dict = {"calls": []}
    orig = igs.holiday_candidate

    def hc(sig, W, options, shift=0):
        c = orig(sig, W, options, shift)
        ra = options["_resid_all"]
        sun = igs.sun_partialled(sig, ra, W.rows)
        state["calls"].append(
            {
                "status": c.status,
                "raw": sp._week_means(sig, ra, W.rows, shift),
                "sun": sp._week_means(sig, sun, W.rows, shift) if sun is not None else None,
            }
        )
        return c

    igs.holiday_candidate = hc
    r = run_case({"id": -1, "layout": "quad4", "step": 900.0, "seed": seed, "effects": effects}, 16)
    with open(out, "w") as f:
        json.dump({"seed": seed, "effects": effects, "found": r["found"], "unsupported": r["unsupported"], **state}, f)
    print(r["found"], r["unsupported"])


if __name__ == "__main__":
    main()
