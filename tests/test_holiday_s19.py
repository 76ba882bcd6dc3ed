"""A zone whose days cannot tell a holiday from none no longer sinks it (session 19, benchmarks/holiday_s19.md).

Hold-out quad4 seed 2034 case 15 (holiday weeks 7 + 10, gains x0.30; ``diagnosis_holdout_s18.md``) was missed: week 7
is proposed by its likelihood (ΔBIC 49-52) but its amplitude-weighted scale is 0.27-0.28 < 0.33. Zone SE is fitted
at 0.006, not at the bound, and reads +0.01 over the days at a standard error of 0.20 (t 0.05): under cooling
control its airflow took most of the lost gains (occupied-hours cooling 6.5 -> 3.8 kW), and its day-to-day departure
swings both ways. NW/NE/SW read 0.27-0.38 at standard errors 0.02-0.09. A zone whose mean departure over the days lies
within two standard errors of both 0 and the gate carries no evidence on the gate's question and is left out.
"""

from __future__ import annotations

import numpy as np
import pytest

from hvacfmu.diagnosis.selection import HOLIDAY_UNINFORMATIVE_SE, _holiday_scale_with

ZONES = ("NW", "NE", "SE", "SW")


def _scale(g, w):
    return {"scale_mean": float(np.dot(g, w) / sum(w))}


def test_a_zone_whose_days_cannot_reach_the_gate_either_way_leaves_the_scale():
    # case 15's week 7 (hold-out quad4 2034, round 1 of the week by likelihood): SE fitted at 0.006, not at the bound
    g = [0.392, 0.424, 0.006, 0.302]
    w = [0.01284, 0.01494, 0.01409, 0.01440]
    dep = {
        "NW": (0.349, 13.4, 0.026),
        "NE": (0.375, 18.5, 0.020),
        "SE": (0.010, 0.05, 0.199),
        "SW": (0.273, 3.13, 0.087),
    }
    ev = _scale(g, w)
    assert ev["scale_mean"] < 0.33
    _holiday_scale_with(ev, g, w, ZONES, dep, min_scale=0.33)
    assert ev["scale_zones_uninformative"] == ["SE"] and ev["scale_zones_at_bound"] == ["SE"]
    keep = [0, 1, 3]
    assert ev["scale_mean"] == pytest.approx(np.dot(np.take(g, keep), np.take(w, keep)) / np.take(w, keep).sum())
    assert ev["scale_mean"] >= 0.33 > ev["scale_mean_all_zones"]


def test_a_zone_whose_days_do_decide_stays_in_the_scale():
    # quad4 2031 case 6's spurious dark week 13 (no holiday): NW at the bound reads -0.065 +- 0.036 (it decides: no
    # holiday in NW), SW +0.096 +- 0.076 (its 2-se interval stops at 0.25 < 0.33): nothing leaves, the week fails
    g = [0.0, 0.191, 0.581, 0.102]
    w = [0.0176, 0.0218, 0.0267, 0.0140]
    dep = {
        "NW": (-0.065, -1.79, 0.0365),
        "NE": (0.166, 3.35, 0.0496),
        "SE": (0.477, 8.25, 0.0578),
        "SW": (0.096, 1.27, 0.0756),
    }
    ev = _scale(g, w)
    _holiday_scale_with(ev, g, w, ZONES, dep, min_scale=0.33)
    assert "scale_zones_uninformative" not in ev and "scale_zones_at_bound" not in ev
    assert ev["scale_mean"] == pytest.approx(0.263, abs=0.002) and ev["scale_mean"] < 0.33

    # a zone as vague as case 15's SE but reading well above the gate is left out too (no evidence either way):
    # the rule does not only raise the mean
    g2, w2 = [0.35, 0.35, 0.9, 0.35], [1.0, 1.0, 1.0, 1.0]
    dep2 = {"NW": (0.3, 10.0, 0.03), "NE": (0.3, 10.0, 0.03), "SE": (0.15, 0.6, 0.25), "SW": (0.3, 10.0, 0.03)}
    ev2 = _scale(g2, w2)
    _holiday_scale_with(ev2, g2, w2, ZONES, dep2, min_scale=0.33)
    assert ev2["scale_zones_uninformative"] == ["SE"] and ev2["scale_mean"] == pytest.approx(0.35)

    # the interval is HOLIDAY_UNINFORMATIVE_SE standard errors: just short of 0 stays in
    se = 0.1
    gam = HOLIDAY_UNINFORMATIVE_SE * se + 0.001  # 0 is outside its interval
    ev3 = _scale([gam] * 4, [1.0] * 4)
    _holiday_scale_with(ev3, [gam] * 4, [1.0] * 4, ZONES, {z: (gam, gam / se, se) for z in ZONES}, min_scale=0.33)
    assert "scale_zones_uninformative" not in ev3


def test_without_the_gate_or_a_standard_error_nothing_new_leaves():
    g, w = [0.392, 0.424, 0.006, 0.302], [1.0, 1.0, 1.0, 1.0]
    ev = _scale(g, w)
    # session 18's call (no min_scale) and session 18's records (mean, t) without a standard error
    _holiday_scale_with(ev, g, w, ZONES, {"SE": (0.010, 0.05, 0.199)})
    _holiday_scale_with(ev, g, w, ZONES, {"SE": (0.010, 0.05)}, min_scale=0.33)
    assert "scale_zones_uninformative" not in ev and "scale_zones_at_bound" not in ev


@pytest.mark.slow
def test_quad4_holdout_2034_case_15_holiday_is_found():
    """The emulator's quad4 case (16 weeks, generated once into $HVACFMU_CACHE, about 40 s) and its diagnosis
    (about 6 CPU-s): week 7's holiday is found, zone SE left out of its scale as uninformative (main: missed, the
    scale 0.27-0.28 < 0.33)."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.emulator import cached_dataset

    effects = ["internal_gain_schedule:kind=holiday,weeks=7+10,factor=0.30"]
    paths = cached_dataset(weeks=16, seed=36, effects=effects, layout="quad4")
    with pytest.warns(Warning):  # the emulated building works on public holidays: no calendar applied
        ds = prepare(paths.measurements, paths.building, step=900.0)
    rep = diagnose(ds, progress=False)
    hits = [
        f for f in rep.findings if f["cause"] == "internal_gain_schedule" and f["location"].get("variant") == "holiday"
    ]
    assert len(hits) == 1, rep.summary()
    assert hits[0]["location"]["dates"] == [f"2025-10-{d}" for d in range(20, 25)]
    ev = hits[0]["evidence"]
    assert ev["scale_zones_uninformative"] == ["SE"] and ev["scale_mean_all_zones"] < 0.33 <= ev["scale_mean"], ev
    # every finding is in the truth (the four facades' sun are the building's baseline)
    assert {f["cause"] for f in rep.findings} <= {"internal_gain_schedule", "solar_gain"}


def test_pooled_zone_departures_serve_the_week_ranking_and_the_one_sided_departure():
    from hvacfmu.diagnosis.selection import _holiday_week_gain
    from hvacfmu.models.causes.internal_gain_schedule import one_sided_departure, pooled_zone_departures

    days = [
        {"date": "2025-12-01", "gamma_by_zone": [0.2, None, -0.5], "weight_by_zone": [1.0, 2.0, 2.0]},
        {"date": "2025-12-02", "gamma_by_zone": [0.6, 0.3, -0.1], "weight_by_zone": [3.0, 0.0, 2.0]},
        {"date": "2025-12-03", "gamma_by_zone": [0.9, 0.9, 0.9], "weight_by_zone": [1.0, 1.0, 1.0]},
    ]
    dates = ["2025-12-01", "2025-12-02"]
    g, w = pooled_zone_departures(days, dates)
    # zone 0: (0.2*1 + 0.6*3) / 4; zone 1: no weighted day (None, weight 0) -> 0 at weight 0; zone 2: -0.3
    assert g == pytest.approx([0.5, 0.0, -0.3]) and w == pytest.approx([4.0, 0.0, 4.0])
    assert pooled_zone_departures(days, ["2025-11-03"]) is None
    assert one_sided_departure(days, dates) == pytest.approx(0.5 * 4.0 / 8.0)
    resid = np.array([[1.0, 0.0, 2.0], [-1.0, 0.0, -2.0]])  # variances 1, 0, 4
    assert _holiday_week_gain(days, dates, resid) == pytest.approx(0.5**2 * 4.0 / 1.0)
    assert _holiday_week_gain(days, ["2025-11-03"], resid) == 0.0
