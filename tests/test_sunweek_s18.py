"""A holiday week the sun screen set down only for its rule's floor is not remembered as weather (issue 15).

Session 17's memory keeps a week set down to the weather down in the diagnosis's later rounds. Hold-out quad4
seed 2034 case 7 (``benchmarks/diagnosis_holdout_s18.md``): week 5, a true holiday in ordinary weather, kept 95 %
of its departure once the sun was regressed out (0.199) but fell 0.001 below the week floor 0.20 in round 1, was
remembered, and stayed down while its departure rose to 0.31-0.38: the holiday was missed. Only what the sun
explains (less than ``SUN_KEEP`` of the departure kept) is remembered now.
"""

import pytest


@pytest.mark.slow
def test_quad4_2034_case7_holiday_week_kept_by_the_sun_is_found():
    """Generated once into $HVACFMU_CACHE (16 weeks, about 40 s) and diagnosed (about 6 CPU-s)."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.emulator import cached_dataset

    effects = [
        "internal_gain_schedule:kind=holiday,weeks=5+12,factor=0.28",
        "thermal_mass:zone=NE,capacitance=2.24e+08,ua=1491",
    ]
    paths = cached_dataset(weeks=16, seed=4, effects=effects, layout="quad4")
    with pytest.warns(Warning):  # the emulated building works on public holidays: no calendar applied
        ds = prepare(paths.measurements, paths.building, step=900.0)
    rep = diagnose(ds, progress=False)
    hits = [
        f for f in rep.findings if f["cause"] == "internal_gain_schedule" and f["location"].get("variant") == "holiday"
    ]
    assert len(hits) == 1, rep.summary()
    dates = hits[0]["location"]["dates"]
    assert [f"2025-10-{d:02d}" for d in range(6, 11)] == [d for d in dates if d.startswith("2025-10")], dates
    assert [f"2025-11-{d:02d}" for d in range(24, 29)] == [d for d in dates if d.startswith("2025-11")], dates
