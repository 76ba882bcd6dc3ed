"""Bad inputs found by the session-15 red team (benchmarks/redteam_s15.py) that gave a silent wrong result.

Each test is one corrupted export a real BMS writes and the message the user now sees
(README "What gets refused" names the same message); each failed before its fix.
"""

from __future__ import annotations

import copy
import warnings

import numpy as np
from test_properties import BUILDING, base_frame, write

from hvacfmu.building import building_from_dict
from hvacfmu.data import check
from hvacfmu.errors import HvacfmuWarning
from hvacfmu.models import datadriven, openloop
from tests.test_datadriven import simulate_frame, six_zone_building_dict, write_dataset
from tests.test_delivered_heat import delivered_truth


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


def test_scattered_missing_cells_do_not_cost_the_open_loop_refinement(tmp_path):
    """A BMS export with NULL in a few random cells (a missed poll here and there): Model A's 24-h refinement kept
    only days with every zone temperature measured, so 1 % of scattered blanks in one zone left too few training
    days, the refinement was dropped without a word and the red team's six-zone model scored 0.261 K instead of
    0.199 K. Its training windows now follow the evaluation's coverage rules (inputs filled across gaps up to 2 h,
    outputs measured in 75 % of the steps), and an input gap is filled, not read as 0."""
    bdict = six_zone_building_dict()
    building = building_from_dict(bdict)
    frame = simulate_frame(delivered_truth(building), building, weeks=4, seed=5)
    rng = np.random.default_rng(0)
    for col in (f"T_{building.zone_names[0]}", f"m_{building.vav_names[0]}", "T_out"):
        frame.iloc[rng.choice(len(frame), len(frame) // 100, replace=False), frame.columns.get_loc(col)] = np.nan
    ds = write_dataset(tmp_path, frame, bdict)
    prep = datadriven._Prepared(ds, datadriven._options({"heat": "delivered"}))
    whole_days = int(np.sum(prep.train[::96]))
    assert openloop.training_windows(prep, 96).size >= whole_days - 4  # not ~40 % of them as before
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        model = datadriven.fit_zones(ds, heat="delivered")
    info = model.meta["open_loop"]
    assert info["used"] and info["windows"] >= 7, info
    u, v = openloop._filled_signals(model, prep)
    gap = np.flatnonzero(~np.isfinite(prep.frame["T_out"].to_numpy()))[5]
    k = list(model.disturbances).index("T_out")
    lo, hi = sorted((v[gap - 1, k], v[gap + 1, k]))
    assert lo - 1e-9 <= v[gap, k] <= hi + 1e-9  # filled from its neighbours, not read as 0 °C


def test_a_clock_that_never_changes_is_named_with_the_zone_to_declare(tmp_path):
    """A BMS server on standard time all year (or on UTC) writes the autumn's repeated hour once: the file was refused
    ("appears once only") with a fix that asked for UTC offsets, not for the declaration that reads it right."""
    f = base_frame(start="2025-11-01 00:00", days=8)
    std = f.index.tz_convert("Etc/GMT+8").tz_localize(None)  # Pacific standard time all year
    path = tmp_path / "m.csv"
    out = f.copy()
    out.index = [t.isoformat() for t in std]
    out.index.name = "time"
    out.to_csv(path)
    report = check(path, building_from_dict(copy.deepcopy(BUILDING)))
    msg = _one(report.problems, "the repeated hour appears once only")
    assert 'declare its zone: data_timezone = "UTC" or, for standard time all year, data_timezone = "Etc/GMT+8"' in msg
    report = check(path, building_from_dict(copy.deepcopy(BUILDING)), timezone="Etc/GMT+8")
    assert report.ok, report.problems
