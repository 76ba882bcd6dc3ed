"""The diagnosis holds an idle air handler's supply temperature (issues #13/#15, session 13).

Model A's airflow form takes ``T_supply`` linearly; while every box of a unit has zero airflow the logged supply
temperature is an idle duct node. ``diagnose`` holds it at the unit's last running value (when a unit is off in
more than 5 % of the training steps) and the extended model carries the rule to apply it to raw data.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from hvacfmu.building import building_from_dict
from hvacfmu.data import prepare
from hvacfmu.data.idle import box_off_bounds, hold_idle_supply, idle_supply_rule
from hvacfmu.diagnosis import diagnose
from hvacfmu.diagnosis.pipeline import _hold_idle_supply
from hvacfmu.emulator import generate
from hvacfmu.models.extended import ExtendedModel
from hvacfmu.models.heat import OFF_FLOW

START = "2025-11-03"


def _two_units():
    return building_from_dict(
        {
            "name": "two",
            "latitude": 37.9,
            "longitude": -122.3,
            "timezone": "America/Los_Angeles",
            "zones": [{"name": "A", "area": 100.0, "volume": 300.0}, {"name": "B", "area": 100.0, "volume": 300.0}],
            "ahus": [{"name": "U1"}, {"name": "U2"}],
            "vavs": [
                {"name": "a", "zone": "A", "ahu": "U1", "m_min": 0.1, "m_max": 1.0},
                {"name": "b", "zone": "B", "ahu": "U2", "m_min": 0.1, "m_max": 1.0},
            ],
        }
    )


def _frame():
    idx = pd.date_range("2025-01-06", periods=6, freq="15min", tz="UTC")
    return pd.DataFrame(
        {
            "m_a": [0.5, 0.004, 0.0, 0.4, 0.0, 0.3],  # row 1: sensor noise of a shut box (bound 5 % of m_min)
            "m_b": [0.0, 0.2, np.nan, 0.0, 0.0, 0.1],
            "T_supply_U1": [13.0, 20.0, 21.0, 14.0, 19.0, 15.0],
            "T_supply_U2": [22.0, 12.0, 23.0, 24.0, 25.0, 12.5],
            "T_supply": [13.0, 12.0, 21.0, 14.0, 19.0, 14.0],
            "T_A": [20.0, 20.5, 21.0, 21.5, 22.0, 22.5],
            "T_B": [18.0, 18.0, 18.0, 18.0, 19.0, np.nan],
        },
        index=idx,
    )


def test_idle_supply_last_running_value_per_unit():
    b = _two_units()
    frame = _frame()
    bounds = box_off_bounds(b, 0.05, OFF_FLOW)
    assert bounds == {"m_a": pytest.approx(0.005), "m_b": pytest.approx(0.005)}
    rule = idle_supply_rule(b, frame.columns, bounds, "last")
    assert rule == {
        "T_supply": {"flows": bounds},
        "T_supply_U1": {"flows": {"m_a": bounds["m_a"]}},
        "T_supply_U2": {"flows": {"m_b": bounds["m_b"]}},
    }
    out, counts = hold_idle_supply(frame, rule)
    # U1 off in rows 1, 2, 4: last running value 13 (row 0), then 14 (row 3)
    assert out["T_supply_U1"].tolist() == [13.0, 13.0, 13.0, 14.0, 14.0, 15.0]
    # U2 off in rows 0, 3, 4 (row 2: airflow missing, left as measured and no source); row 0: first running value
    assert out["T_supply_U2"].tolist() == [12.0, 12.0, 23.0, 12.0, 12.0, 12.5]
    # T_supply idle only when every box is off (row 4)
    assert out["T_supply"].tolist() == [13.0, 12.0, 21.0, 14.0, 14.0, 14.0]
    assert counts == {"T_supply": 1, "T_supply_U1": 3, "T_supply_U2": 3}
    assert frame["T_supply_U1"].iloc[1] == 20.0  # the input is not modified


def test_idle_supply_zone_air():
    b = _two_units()
    frame = _frame()
    rule = idle_supply_rule(b, frame.columns, box_off_bounds(b, 0.05, OFF_FLOW), "zone")
    assert rule["T_supply"]["zones"] == {"T_A": 1.0, "T_B": 1.0} and rule["T_supply_U2"]["zones"] == {"T_B": 1.0}
    out, _ = hold_idle_supply(frame, rule)
    assert out["T_supply_U1"].tolist() == [13.0, 20.5, 21.0, 14.0, 22.0, 15.0]
    assert out["T_supply_U2"].tolist() == [18.0, 12.0, 23.0, 18.0, 19.0, 12.5]
    assert out["T_supply"].tolist() == [13.0, 12.0, 21.0, 14.0, 20.5, 14.0]  # row 4: mean of T_A and T_B


def test_idle_discharge_air_of_a_shut_box():
    b = _two_units()
    frame = _frame().assign(Td_a=[30.0, 25.0, 24.0, 31.0, 23.0, 29.0])
    rule = idle_supply_rule(b, frame.columns, box_off_bounds(b, 0.05, OFF_FLOW), "zone")
    assert rule["Td_a"] == {"flows": {"m_a": pytest.approx(0.005)}, "zones": {"T_A": 1.0}}
    out, counts = hold_idle_supply(frame, rule)
    assert out["Td_a"].tolist() == [30.0, 20.5, 21.0, 31.0, 22.0, 29.0]  # box a shut in rows 1, 2, 4
    assert counts["Td_a"] == 3


@pytest.fixture(scope="module")
def night_off(tmp_path_factory):
    paths = generate(tmp_path_factory.mktemp("idle") / "d", weeks=3, seed=0, climate="cold", start=START,
                     schedule="night-off")  # fmt: skip
    return prepare(paths.measurements, paths.building)


def test_always_on_data_unchanged(tmp_path):
    paths = generate(tmp_path / "on", weeks=2, seed=0, climate="cold", start=START)
    ds = prepare(paths.measurements, paths.building)
    notes = []
    same, idle = _hold_idle_supply(ds, True, notes)
    assert same is ds and idle == {} and notes == []


def test_diagnosis_base_reads_held_supply(night_off):
    ds = night_off
    raw = ds.frame
    m = raw[[f"m_{v}" for v in ds.building.vav_names]].to_numpy(float)
    bound = np.array([0.5 * v.m_min for v in ds.building.vavs])  # the unit-off rule (unit_off_bounds)
    off = np.all(m <= bound, axis=1)
    assert 0.2 < off.mean() < 0.8  # the emulator's shut boxes read noise, not 0
    t = raw["T_supply"].to_numpy(float)
    w = {}
    for v in ds.building.vavs:
        w[f"T_{v.zone}"] = w.get(f"T_{v.zone}", 0.0) + v.m_max
    expect = raw[list(w)].to_numpy(float) @ np.array(list(w.values())) / sum(w.values())
    off_z = off & np.isfinite(expect)  # (elsewhere: the last running value)
    assert off_z.sum() > 0.9 * off.sum()
    assert np.max(np.abs(t[off_z] - expect[off_z])) > 1.0  # the idle duct is not (yet) the zone air

    report = diagnose(ds, progress=False)
    idle = report.model.meta["idle_supply"]
    assert list(idle["rule"]) == ["T_supply"]
    assert idle["mode"] == "zone"
    assert list(idle["rule"]["T_supply"]["flows"]) == [f"m_{v}" for v in ds.building.vav_names]
    assert any("idle supply temperature is replaced" in n and "T_supply in" in n for n in report.notes)
    # the saved model applies the same substitution to the raw measurements
    _, v = report.model.signals(raw)
    j = report.model.disturbances.index("T_supply")
    np.testing.assert_allclose(v[off_z, j], expect[off_z], rtol=0, atol=1e-9)
    np.testing.assert_allclose(v[~off, j], t[~off], rtol=0, atol=1e-12)
    # ... also after a JSON round trip (the model file evaluate and export read)
    again = ExtendedModel.from_dict(json.loads(json.dumps(report.model.to_dict())))
    np.testing.assert_array_equal(again.signals(raw)[1], v)
