"""Units that used to slip through (issue 17 p.1), on the emulator's BMS-like exports in three climates.

- cfm and L/s mixed up on boxes that never come near their limits: caught by the minimum-airflow
  plateau (a VAV box rests at m_min; in the wrong unit the plateau sits 2.1 times off);
- outdoor air in °C declared as °F in a cold month (-10 °C reads -23 °C, a possible Chicago January):
  flagged because the zones are declared in °C and °C fits the outdoor air as well;
- °F declared as °C in midwinter: the midwinter envelope (no January above 15 °C poleward of 40°).
The exports as written (correct units) give no unit problem and no unit warning.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from hvacfmu.building import building_from_dict, load_building
from hvacfmu.data import check
from hvacfmu.data.plausibility import check_outdoor, outdoor_envelope
from hvacfmu.data.units import from_si, to_si
from hvacfmu.errors import HvacfmuWarning

#: (climate, first day): cold and mild in January, hot in July. The cold January is the fast tier's case (the
#: hardest for the outdoor-air check: -10 °C reads -23 °C); mild and hot run in the full suite (2 exports each).
CASES = [
    ("cold", "2026-01-05"),
    pytest.param("mild", "2026-01-05", marks=pytest.mark.slow),
    pytest.param("hot", "2025-07-07", marks=pytest.mark.slow),
]


def export(climate, start, units):
    from hvacfmu.emulator import cached_dataset

    return cached_dataset(weeks=2, seed=0, climate=climate, start=start, units=units, hvac="reheat", export_step=900)


def checked(path, bdict, units=None):
    d = dict(bdict)
    d["units"] = {**(bdict.get("units") or {}), **(units or {})}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return check(path, building_from_dict(d))


def unit_notes(report):
    return [p for p in report.problems + report.warnings if "declared " in p or "look like" in p]


@pytest.mark.parametrize("climate, start", CASES)
def test_exports_as_declared_give_no_unit_complaint(climate, start):
    for units in ("us", "si"):
        p = export(climate, start, units)
        report = checked(p.measurements, load_building(p.building).to_dict())
        assert unit_notes(report) == [], (units, unit_notes(report))


def _boxes_kept_low(p, tmp_path, to_unit=None):
    """The export with every airflow sample above 70 % of the box's m_max removed (boxes far from their limits),
    optionally rewritten from cfm into ``to_unit``; returns (csv path, building dict)."""
    b = load_building(p.building)
    f = pd.read_parquet(p.measurements)
    for v in b.vavs:
        col = b.column_for(f"m_{v.name}")
        x = np.array(f[col], dtype=float)
        x[x > from_si(0.7 * v.m_max, "cfm")] = np.nan
        f[col] = x if to_unit is None else from_si(to_si(x, "cfm"), to_unit)
    path = tmp_path / "low.csv"
    f.to_csv(path, index=False)
    return path, b.to_dict()


@pytest.mark.parametrize("climate, start", CASES)
def test_cfm_and_litres_mixed_up_far_from_the_box_limits(tmp_path, climate, start):
    p = export(climate, start, "us")
    path, bdict = _boxes_kept_low(p, tmp_path)
    assert unit_notes(checked(path, bdict)) == []  # as declared (cfm): fine
    report = checked(path, bdict, {"m_*": "L/s"})  # cfm declared as L/s: 2.1 times too much
    boxes = [v.name for v in load_building(p.building).vavs]
    for box in boxes:
        (msg,) = [x for x in report.problems if f"'m_{box}'" in x]
        assert "the data look like cfm" in msg and "never rests at its minimum airflow" in msg, msg
    path, bdict = _boxes_kept_low(p, tmp_path, to_unit="L/s")  # L/s declared as cfm: 2.1 times too little
    report = checked(path, bdict, {"m_*": "cfm"})
    assert not report.ok
    for box in boxes:
        (msg,) = [x for x in report.problems if f"'m_{box}'" in x]
        assert "the data look like L/s" in msg, msg


@pytest.mark.parametrize("climate, start", CASES)
def test_outdoor_celsius_declared_as_fahrenheit_is_flagged_in_every_season(climate, start):
    p = export(climate, start, "si")
    report = checked(p.measurements, load_building(p.building).to_dict(), {"T_out": "degF"})
    notes = [x for x in report.problems + report.warnings if "'T_out'" in x]
    assert len(notes) == 1, notes
    assert "look like degC" in notes[0] or "read as degC its monthly means" in notes[0], notes[0]


def test_outdoor_fahrenheit_declared_as_celsius_in_a_cold_january_is_flagged():
    p = export("cold", "2026-01-05", "us")  # T_out about 14 °F: 14 "°C" fits neither a Chicago January nor the zones
    report = checked(p.measurements, load_building(p.building).to_dict(), {"T_out": "degC"})
    (msg,) = [x for x in report.warnings if "'T_out'" in x]
    assert "declared degC while the zone temperatures are declared degF" in msg
    assert "read as degF its monthly means (Jan -9.9 °C)" in msg


@pytest.mark.parametrize(
    "latitude, month, mean, refused",
    [
        (41.9, 1, 30.0, True),  # -1 °C = 30 °F read as °C: no January at Chicago's latitude is that warm
        (41.9, 1, 12.0, False),
        (33.4, 1, 22.0, True),  # Phoenix: January 13 °C; 22 °C is 72 °F read as °C
        (-33.9, 7, 22.0, True),  # Sydney in July: 12 °C
        (-33.9, 1, 22.0, False),  # Sydney in January: summer
        (10.0, 1, 27.0, False),  # tropics: no midwinter bound
    ],
)
def test_midwinter_envelope(latitude, month, mean, refused):
    idx = pd.date_range(f"2026-{month:02d}-01", periods=96 * 20, freq="15min", tz="UTC")
    problems: list[str] = []
    check_outdoor(np.full(len(idx), mean), "degC", idx, latitude, "column 'T_out'", problems)
    assert bool(problems) == refused, problems
    if refused:
        assert "look like degF" in problems[0] and outdoor_envelope(latitude, False, True)[1] < mean
