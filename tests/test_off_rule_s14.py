"""One rule for "the air handler is off" (session 14): diagnosis, FMUs and the co-simulation's schedule agree.

The emulator's shut boxes read 0–0.01 kg/s of sensor noise, above 5 % of an ``m_min`` under 0.2 kg/s. The rule
(:func:`hvacfmu.data.idle.unit_off_bounds`: every box of the unit at most ``max(1e-6, 50 % of m_min)``) counts a
unit with one noisy shut box as off, in ``diagnose``'s idle supply substitution, in the FMUs' per-step rule
(:class:`hvacfmu.data.idle.IdleStep`) and in ``harness.schedule.unit_off_rows``: the same rows.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from harness.schedule import unit_off_rows
from hvacfmu.building import building_from_dict
from hvacfmu.data import prepare
from hvacfmu.data.idle import BOX_OFF_FRACTION, box_off_bounds, idle_rows, idle_step, unit_off_bounds
from hvacfmu.diagnosis.pipeline import _hold_idle_supply


def _per_step(idle: dict, frame: pd.DataFrame, building) -> np.ndarray:
    """Rows where the FMUs' per-step rule (built from the diagnosis's rule) replaces ``T_supply``."""
    zones = sorted({v.zone for v in building.vavs})
    step = idle_step({"idle_supply": idle}, ("T_out", "T_supply"), building.vav_names, zones)
    m = frame[[f"m_{v}" for v in building.vav_names]].to_numpy(float)
    T = frame[[f"T_{z}" for z in zones]].to_numpy(float)
    v = frame[["T_out", "T_supply"]].to_numpy(float)
    out = np.array([step.apply(v[k], m[k], T[k])[0][1] for k in range(len(frame))])
    return (out != v[:, 1]) & ~(np.isnan(out) & np.isnan(v[:, 1]))


def test_one_noisy_shut_box_leaves_the_unit_off():
    b = building_from_dict(
        {
            "name": "one unit",
            "latitude": 40.0,
            "longitude": -90.0,
            "timezone": "UTC",
            "zones": [{"name": "Z", "area": 10.0, "volume": 30.0}],
            "vavs": [{"name": n, "zone": "Z", "m_min": 0.1, "m_max": 0.5} for n in ("a", "b", "c")],
        }
    )
    frame = pd.DataFrame(
        {
            "m_a": [0.3, 0.0, 0.0, 0.12, 0.0],
            "m_b": [0.2, 0.002, 0.0101, 0.0, 0.049],  # rows 2, 4: a shut box's noise above its 5 % bound
            "m_c": [0.1, 0.0, 0.001, 0.0, 0.0],
            "T_out": 0.0,
            "T_supply": [14.0, 19.0, 19.5, 15.0, 19.8],
            "T_Z": [21.0, 20.0, 20.1, 20.2, 20.3],
        },
        index=pd.date_range("2025-11-03", periods=5, freq="15min", tz="UTC"),
    )
    expect = [False, True, True, False, True]  # row 3: box a at its minimum, the unit runs
    assert unit_off_rows(frame, b)[0]["T_supply"].tolist() == expect
    assert idle_rows(frame, unit_off_bounds(b)).tolist() == expect
    assert _per_step({"mode": "zone", "rule": {"T_supply": {"flows": unit_off_bounds(b), "zones": {"T_Z": 1.0}}}},
                     frame, b).tolist() == expect  # fmt: skip
    # the reheat cause's box-off bound of one box is still 5 % of its minimum
    assert box_off_bounds(b, BOX_OFF_FRACTION, 1e-6)["m_b"] == pytest.approx(0.005)


def test_diagnosis_fmu_and_schedule_agree_on_night_off_data():
    """Night-off emulator data with one shut box reading 0.0101 kg/s (above its 5 % bound) in a third of the
    off rows: diagnosis's substitution, the FMUs' rule and the schedule take the same off rows, noisy ones too."""
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(weeks=2, seed=0, climate="cold", start="2025-11-03", schedule="night-off")
    ds = prepare(paths.measurements, paths.building)
    b = ds.building
    clean = unit_off_rows(ds.frame, b)[0]["T_supply"]
    col = f"m_{b.vav_names[0]}"
    noisy = clean & (np.arange(len(clean)) % 3 == 0)
    frame = ds.frame.copy()
    frame.loc[noisy, col] = 0.0101  # the emulator's shut boxes read up to ~0.01 kg/s
    assert 0.0101 > box_off_bounds(b, BOX_OFF_FRACTION, 1e-6)[col] and noisy.sum() > 100
    ds = dataclasses.replace(ds, frame=frame)
    off = unit_off_rows(frame, b)[0]["T_supply"]
    np.testing.assert_array_equal(off, clean)  # the schedule: the noisy rows stay off
    held, idle = _hold_idle_supply(ds, "zone", [])
    np.testing.assert_array_equal(idle_rows(frame, idle["rule"]["T_supply"]["flows"]), off)
    assert idle["held_steps"]["T_supply"] == int(off.sum())
    new, raw = held.frame["T_supply"].to_numpy(float), frame["T_supply"].to_numpy(float)
    changed = (new != raw) & ~(np.isnan(new) & np.isnan(raw))
    assert changed[noisy].all() and not changed[~off].any()
    fmu = _per_step(idle, frame, b)
    assert fmu[noisy].all() and not fmu[~off].any()
