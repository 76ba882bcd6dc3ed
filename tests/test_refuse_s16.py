"""Bad inputs the session-15 red team left silent or poorly reported (benchmarks/redteam_s16.py).

Each test is one corrupted export and the message the user now sees (README "What gets refused");
each failed on main before its change.
"""

from __future__ import annotations

import copy

import numpy as np
import pandas as pd
import pytest
from test_properties import BUILDING, base_frame, write

from hvacfmu.building import building_from_dict
from hvacfmu.data import boxmap, check


def _check(frame, tmp_path, name="m.csv"):
    return check(write(frame, tmp_path / name, "offset"), building_from_dict(copy.deepcopy(BUILDING)))


def _one(lines, fragment):
    found = [x for x in lines if fragment in x]
    assert len(found) == 1, (fragment, lines)
    return found[0]


def test_zone_columns_swapped_between_zones_that_are_not_adjacent_are_flagged(winter_dataset):
    """T_NW and T_E exchanged (not adjacent): the model fitted and predicted each zone from the other zone's boxes
    (red team: 0.310 K on the clean data against 0.199 K), and the per-box map saw it only at 2:1. Each column now
    follows the other zone's boxes and facades better than its own, and both ways is what a swap looks like."""
    frame, building = winter_dataset.frame, winter_dataset.building
    assert boxmap.check_zone_swaps(frame, building) == []  # the clean export: no pair
    swapped = frame.assign(T_NW=frame["T_E"], T_E=frame["T_NW"])
    msg = _one(boxmap.check_zone_swaps(swapped, building), "look swapped")
    assert msg.startswith("columns 'T_NW' (T_NW) and 'T_E' (T_E) look swapped")
    assert "follow zone E's drivers (the heat its boxes deliver and the sun on its facades)" in msg
    assert 'map them the other way round in the building\'s [columns] table (T_E = "T_NW", T_NW = "T_E")' in msg
    rotated = frame.assign(T_NW=frame["T_W"], T_W=frame["T_NW"])  # an adjacent pair
    assert "'T_NW' (T_NW) and 'T_W' (T_W) look swapped" in _one(boxmap.check_zone_swaps(rotated, building), "swap")


def test_three_zone_columns_rotated_are_flagged(winter_dataset):
    """Three columns rotated (T_NW holds E, T_E holds S, T_S holds NW): no pair is exchanged, so the pair test
    cannot see it (red team: silent, 0.327 K on the clean data against 0.199 K); the same rule runs around the
    cycle."""
    frame, building = winter_dataset.frame, winter_dataset.building
    rotated = frame.assign(T_NW=frame["T_E"], T_E=frame["T_S"], T_S=frame["T_NW"])
    msg = _one(boxmap.check_zone_swaps(rotated, building), "look rotated")
    assert msg.startswith("columns 'T_E' (T_E), 'T_S' (T_S), 'T_NW' (T_NW) look rotated")
    assert '(T_S = "T_E", T_NW = "T_S", T_E = "T_NW")' in msg


def test_a_box_that_moves_every_zone_does_not_make_a_swap():
    """One column preferring another zone's boxes is not a swap (an EnergyPlus core box on a shared air handler
    explains every zone's changes a little): the other column must prefer the first zone's back."""
    ev = boxmap.ZonePairEvidence(
        gain={"C": {"C": 108.0, "P": 393.0}, "P": {"C": 26.0, "P": 116.0}},  # measured: OfficeMedium, bottom floor
        boxes_only={"C": {"C": 108.0, "P": 393.0}, "P": {"C": 26.0, "P": 116.0}},
        sunlit=frozenset({"P"}),
        rows=2686,
    )
    own, swapped = ev.swap("C", "P")
    assert swapped > own  # the sum alone would flag it
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(boxmap, "zone_pair_evidence", lambda frame, building: ev)
        assert boxmap.check_zone_swaps(None, building_from_dict(copy.deepcopy(BUILDING))) == []


def test_outdoor_sensor_frozen_with_noise_is_masked_and_named(tmp_path):
    """T_out frozen at one value with quantisation noise for days: not an exact repeat, so the stuck-sensor check
    let it through and the models learned a building without weather (red team: three weeks, silent)."""
    f = base_frame(days=20)
    col = f.columns.get_loc("T_out")
    rng = np.random.default_rng(1)
    f.iloc[500:1100, col] = 9.0 + rng.choice([-0.05, 0.0, 0.05], 600)  # 6.25 days from row 501
    report = _check(f, tmp_path)
    assert report.ok and report.exit_code == 3
    msg = _one(report.warnings, "'T_out'")
    assert "a frozen outdoor sensor? the outdoor air barely moves for 3 days or more" in msg
    assert "from row 501 (2025-03-08T05:00:00-08:00) to row 1100 (2025-03-14T11:45:00-07:00)" in msg
    assert "600 sample(s) masked as missing" in msg
    assert report.load_report.masked[("T_out", "frozen sensor")] == 600
    clean = _check(base_frame(days=20), tmp_path, "clean.csv")
    assert not [w for w in clean.warnings if "frozen" in w]


def test_a_units_row_under_the_header_is_one_problem(tmp_path):
    """A units row under the header ('°C', 'kg/s', ...) gave one non-numeric problem per column (75 lines in the red
    team) and an 'empty time' one; it is one problem naming the row."""
    f = base_frame(days=8)
    path = write(f, tmp_path / "m.csv", "offset")
    lines = path.read_text().splitlines()
    units = ["" if c == "time" else "°C" if c.startswith("T") else "kg/s" if c.startswith("m_") else "%"
             for c in lines[0].split(",")]  # fmt: skip
    path.write_text("\n".join([lines[0], ",".join(units), *lines[1:]]) + "\n")
    report = check(path, building_from_dict(copy.deepcopy(BUILDING)))
    assert not report.ok and len(report.problems) == 1, report.problems
    msg = report.problems[0]
    assert msg.startswith("m.csv: row 1 holds text instead of readings in 11 of the 11 value columns")
    assert "'°C' in 'T_A', 'kg/s' in 'm_V1'" in msg and "an empty time" in msg and "delete those rows" in msg


def test_ghi_late_on_its_own_is_named_as_the_ghi_column(tmp_path):
    """ghi an hour late (a pyranometer logger on another clock) was reported as a clock offset whose advice was
    about the timestamps only; the advice now names the ghi column and the shift that fixes it."""
    f = base_frame(days=8)
    assert not [w for w in _check(f, tmp_path, "clean.csv").warnings if "clock:" in w]
    f["ghi"] = f["ghi"].shift(4).fillna(0.0)
    msg = _one(_check(f, tmp_path).warnings, "clock:")
    assert "the data look 2 h late" in msg  # base_frame's ghi peaks 0.7 h after solar noon, + 1 h
    assert "measured on the ghi column alone" in msg and "shift ghi 2 h earlier" in msg
    late = base_frame(days=8)
    late["ghi"] = late["ghi"].shift(16).fillna(0.0)  # 4 h: T_out's cycle tells that only ghi moved
    msg = _one(_check(late, tmp_path, "late.csv").warnings, "clock:")
    assert "only the ghi column is offset" in msg and "shift the ghi column 5 h earlier" in msg


@pytest.mark.slow
def test_check_flags_swapped_zone_columns_in_a_file(tmp_path, winter_paths):
    """The swap test runs where a user meets it: ``check`` on the export, exit 3 with the pair named."""
    frame = pd.read_parquet(winter_paths.measurements)
    swapped = frame.assign(T_S=frame["T_NE"], T_NE=frame["T_S"])
    swapped.to_parquet(tmp_path / "m.parquet")
    report = check(tmp_path / "m.parquet", winter_paths.building)
    assert report.exit_code == 3
    assert "'T_S' (T_S) and 'T_NE' (T_NE) look swapped" in _one(report.attention, "look swapped")
    rotated = frame.assign(T_NW=frame["T_E"], T_E=frame["T_S"], T_S=frame["T_NW"])
    rotated.to_parquet(tmp_path / "r.parquet")
    report = check(tmp_path / "r.parquet", winter_paths.building)
    assert report.exit_code == 3 and _one(report.attention, "look rotated")
