"""A note listing public holidays says how many it leaves out (session 17: "5 public holiday(s)" listed 3)."""

from __future__ import annotations

import copy

from conftest import SMALL_BUILDING
from test_data import make_measurements, write

from hvacfmu.building import building_from_dict
from hvacfmu.data import check


def test_too_few_days_note_counts_the_holidays_it_does_not_list(tmp_path):
    spec = copy.deepcopy(SMALL_BUILDING)
    spec.update(timezone="Asia/Shanghai", latitude=31.2, longitude=121.5)  # National Day week: 5 weekday holidays
    building = building_from_dict(spec)
    frame = make_measurements(building, start="2024-09-29 00:00", periods=9 * 96, freq="15min")
    notes = [n for n in str(check(write(frame, tmp_path / "oct.csv"), building)).splitlines() if "public holiday" in n]
    assert len(notes) == 1, notes
    assert "5 public holiday(s) of CN" in notes[0]
    assert "2024-10-03 National Day and 2 more); too few training workdays" in notes[0]
