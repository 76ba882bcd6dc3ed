"""Audit of the bad inputs of issue 17 against README "What gets refused": the rows that had no test of their own.

Each case is one bad input and the message the user sees (the README row names the same message).
Rows tested elsewhere: building-file types and values (test_building.py), data columns, units,
spikes, stuck sensors, steps, coverage, clock (test_data.py, test_clock.py, test_refuse_units.py),
model files (test_properties_models.py), FMU inputs (test_properties_fmu.py), implausible fits
(test_datadriven.py, test_delivered_heat.py), controller limits (test_mpc.py).
"""

from __future__ import annotations

import copy
import subprocess
import sys

import numpy as np
import pytest
from test_properties import BUILDING, base_frame, write

from hvacfmu.building import building_from_dict
from hvacfmu.data import check
from hvacfmu.errors import BuildingError


def test_unknown_box_key_is_refused_naming_the_known_keys():
    d = copy.deepcopy(BUILDING)
    d["vavs"][0]["m_design"] = 0.5  # a misspelt or invented key would otherwise be ignored silently
    with pytest.raises(BuildingError, match=r"vavs\[0\] \(V1\): unknown key\(s\) \['m_design'\] \(known: ahu, m_max"):
        building_from_dict(d)


def test_column_answering_rarely_at_irregular_times_is_flagged_and_refused(tmp_path):
    f = base_frame(days=8)
    rng = np.random.default_rng(1)
    keep = np.zeros(len(f), bool)
    keep[rng.choice(len(f), len(f) // 12, replace=False)] = True  # a box controller missing most trend polls
    f.loc[~keep, "m_V2"] = np.nan
    report = check(write(f, tmp_path / "m.csv", "offset"), building_from_dict(copy.deepcopy(BUILDING)))
    (flag,) = [w for w in report.warnings if "'m_V2'" in w]
    assert "values in only 8.3 % of the rows, at irregular times" in flag and "not interpolated" in flag
    assert not report.ok
    (problem,) = [p for p in report.problems if "'m_V2'" in p]
    assert "a value in only 8.3 % of the model steps, below the 50 %" in problem


def test_cli_refuses_a_model_file_for_other_zones_without_a_traceback(tmp_path, short_paths):
    """The evaluate command meets a model fitted elsewhere: exit 2, both zone lists, no KeyError."""
    import json

    from hvacfmu.models.linear import LinearZoneModel

    other = ("X1", "X2")
    model = LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=other,
        measured_zones=other,
        output_weights=np.eye(2),
        vavs=("B1", "B2"),
        input_map=np.eye(2),
        disturbances=("T_out",),
        A=0.9 * np.eye(2),
        B=-0.1 * np.eye(2),
        C=[[0.02], [0.02]],
        gains={"fall": np.full((672, 2), 0.4)},
    )
    path = tmp_path / "other.json"
    path.write_text(json.dumps(model.to_dict()))
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "hvacfmu.cli",
            "evaluate",
            str(short_paths.measurements),
            "-b",
            str(short_paths.building),
        ]
        + ["-m", str(path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr[-2000:]
    assert "Model zones: ['X1', 'X2']" in r.stderr and "data zones: ['NW'" in r.stderr, r.stderr[-2000:]


def test_data_after_the_last_whole_week_are_said_with_the_clock_change_that_cost_them(tmp_path):
    """4 x 168 h from a Monday across the autumn clock change end an hour short of the 4th week, which no stage uses:
    `check` says how much is left out and why (it said "Weeks: 3" and nothing else; fleet_sweep_s10.md, b004)."""
    f = base_frame(start="2025-10-20 00:00", days=28)  # 2688 steps of 15 min: the clock change on 2 Nov
    report = check(write(f, tmp_path / "m.csv", "offset"), building_from_dict(copy.deepcopy(BUILDING)))
    (line,) = [x for x in str(report).splitlines() if x.startswith("Weeks:")]
    assert line == (
        "Weeks: 3 from 2025-10-20; the last 6 d 23 h of data, from 2025-11-10T00:00:00-08:00, are not a whole week and "
        "are not used (1 h 00 min short of one: the week of 2025-10-27 holds the autumn clock change's extra hour)"
    ), line
    # whole weeks leave nothing to say; across the spring change the data run an hour past the last week's end
    for start, tail in (("2025-04-07", ""), ("2025-03-03", "; the last 1 h 00 min of data, from 2025-03-17")):
        f = base_frame(start=f"{start} 00:00", days=14)
        report = check(write(f, tmp_path / "w.csv", "offset"), building_from_dict(copy.deepcopy(BUILDING)))
        (line,) = [x for x in str(report).splitlines() if x.startswith("Weeks:")]
        assert line.startswith(f"Weeks: 2 from {start}{tail}") and ("not used" in line) == bool(tail), line
