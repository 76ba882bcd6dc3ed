"""Bad inputs found by the session-15 red team (benchmarks/redteam_s15.py) that gave a silent wrong result.

Each test is one corrupted export a real BMS writes and the message the user now sees
(README "What gets refused" names the same message); each failed before its fix.
"""

from __future__ import annotations

import copy

from test_properties import BUILDING, base_frame, write

from hvacfmu.building import building_from_dict
from hvacfmu.data import check


def _check(frame, tmp_path, name="m.csv"):
    return check(write(frame, tmp_path / name, "offset"), building_from_dict(copy.deepcopy(BUILDING)))


def _one(lines, fragment):
    found = [x for x in lines if fragment in x]
    assert len(found) == 1, (fragment, lines)
    return found[0]


def test_a_zone_sensor_writing_its_default_for_hours_is_caught(tmp_path):
    """A zone sensor offline for 12 h writes 0 °C (32 °F) on every poll: the 12-h running median moves with the run,
    so it went through unmasked and the model learned a room at 0 °C (red team: 24-h RMS 0.199 -> 0.271 K, and
    check said nothing). Compared with the zone air before and after the run, it is a dropout."""
    f = base_frame(days=60)
    f.iloc[1000:1049, f.columns.get_loc("T_A")] = 0.0  # 12 h 15 min at 15 min: 49 of 5760 samples
    report = _check(f, tmp_path)
    assert report.ok
    msg = _one(report.warnings, "'T_A'")
    assert "49 value(s) (0.85 % of its samples) more than 12 K away from the median of the surrounding 12 h" in msg
    assert "from the zone air before and after that run" in msg
    assert "masked as missing: 0 at row 1001 (2025-03-13T11:00:00-07:00)" in msg
    assert report.dataset.frame["T_A"].isna().sum() >= 48  # the run's steps are missing, not a room at 0 °C
    f.iloc[1000:1200, f.columns.get_loc("T_A")] = 0.0  # two days and more: refused (> 1 % of the samples)
    report = _check(f, tmp_path)
    assert not report.ok and "more than the 1 % that are masked" in _one(report.problems, "'T_A'")
