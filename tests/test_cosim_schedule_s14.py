"""Co-simulation on data with an operating schedule (issue 13 p.3, issue 18 p.1; session 14).

On ``--schedule night-off`` data the air handler is off at night and at weekends: every box near 0 airflow and
the logged ``T_supply`` reading an idle duct (about room air). ``cosim`` used to clip every command to
``[m_min, m_max]``: a night ran the boxes at ``m_min`` with room-temperature "supply air", and replay did not
replay the data. Now a run follows the building's schedule by default (off boxes at 0, no reheat; the
controllers are told), or runs through it with ``system="always-on"`` and the unit's last running supply
temperature.
"""

from __future__ import annotations

import dataclasses
import json
import warnings

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from harness.controllers import ReplayController, RuleController
from harness.cosim import limits_check, run_cosim
from harness.mpc import MPCController, MPCSettings
from harness.schedule import off_steps, running_supply
from hvacfmu.building import building_from_dict
from hvacfmu.errors import HvacfmuWarning
from hvacfmu.models.linear import LinearZoneModel

START = "2025-11-03"  # a Monday, cold climate
SPAN = dict(start="2025-11-04 12:00", stop="2025-11-05 12:00", warmup=86400.0)  # Tue noon .. Wed noon: one night


@pytest.fixture(scope="module")
def night(tmp_path_factory):
    """Two cold weeks of the four-zone row with the night-off schedule, prepared, and the plant FMU."""
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.fmu import export_plant_fmu

    paths = cached_dataset(weeks=2, seed=0, climate="cold", start=START, layout="row4", schedule="night-off")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        data = prepare(paths.measurements, paths.building)
    return data, export_plant_fmu(paths.truth, tmp_path_factory.mktemp("plant") / "PlantNight.fmu"), paths


def _limits(data, vavs):
    by = {b.name: b for b in data.building.vavs}
    return np.array([by[v].m_min for v in vavs]), np.array([by[v].m_max for v in vavs])


def _span_off(data, table, vavs):
    frame = data.frame.loc[table.index[:-1]]
    return off_steps(frame, data.building, vavs)[0].any(axis=1), frame


# ----------------------------------------------------------------------------- the rule, on small tables
def test_off_steps_by_unit_and_noise_and_the_limits_check():
    b = building_from_dict(
        {
            "name": "two units",
            "latitude": 40.0,
            "longitude": -90.0,
            "timezone": "UTC",
            "ahus": [{"name": "A1"}, {"name": "A2"}],
            "zones": [{"name": "Z", "area": 10.0, "volume": 30.0}],
            "vavs": [
                {"name": "a", "zone": "Z", "m_min": 0.2, "m_max": 1.0, "ahu": "A1"},
                {"name": "b", "zone": "Z", "m_min": 0.2, "m_max": 1.0, "ahu": "A1"},
                {"name": "c", "zone": "Z", "m_min": 0.1, "m_max": 0.5, "ahu": "A2"},
            ],
        }
    )
    frame = pd.DataFrame(
        {
            "m_a": [0.0, 0.011, 0.3, 0.0],  # 0.011: above a's 5 % bound (0.01), far below m_min: noise
            "m_b": [0.005, 0.0, 0.0, 0.25],
            "m_c": [0.2, 0.0, 0.002, 0.001],
            "T_supply_A1": [14.0, 20.0, 15.0, 14.5],
            "T_supply_A2": [13.0, 21.0, 22.0, 23.0],
        },
        index=pd.date_range("2025-11-03", periods=4, freq="15min", tz="UTC"),
    )
    off, noise = off_steps(frame, b, ("a", "b", "c"))
    assert off.tolist() == [[True, True, False], [True, True, True], [False, False, True], [False, False, True]]
    assert noise == 1  # row 1 of unit A1
    held, counts = running_supply(frame, b)
    assert held["T_supply_A1"].tolist() == [15.0, 15.0, 15.0, 14.5]  # before the unit first runs: its first value
    assert held["T_supply_A2"].tolist() == [13.0, 13.0, 13.0, 13.0]
    assert counts == {"T_supply_A1": 2, "T_supply_A2": 3}
    M = np.array([[0.0, 0.2, 0.1], [0.5, 1.0, 0.05], [1.2, 0.0, 0.5]])  # 0.05 < m_min of c, 1.2 > m_max of a
    assert limits_check(M, b, ("a", "b", "c")) == {
        "off": 2,
        "in_range": 5,
        "outside": 2,
        "outside_max": pytest.approx(0.2),
    }


def test_rule_controller_turns_off_one_unit_and_holds_its_integrals():
    from harness.controllers import ControlContext

    b = building_from_dict(
        {
            "name": "two units",
            "latitude": 40.0,
            "longitude": -90.0,
            "timezone": "UTC",
            "ahus": [{"name": "A1"}, {"name": "A2"}],
            "zones": [{"name": "Z", "area": 10.0, "volume": 30.0}, {"name": "Y", "area": 10.0, "volume": 30.0}],
            "vavs": [
                {"name": "a", "zone": "Z", "m_min": 0.2, "m_max": 1.0, "ahu": "A1"},
                {"name": "c", "zone": "Y", "m_min": 0.1, "m_max": 0.5, "ahu": "A2"},
            ],
        }
    )
    index = pd.date_range("2025-11-03", periods=3, freq="15min", tz="UTC")
    frame = pd.DataFrame({"T_supply": 14.0, "T_Z": 24.0, "T_Y": 24.0}, index=index)
    off = np.array([[True, False], [True, False], [False, False]])
    ctx = ControlContext(frame, b, ("a", "c"), ("T_Z", "T_Y"), (("Z",), ("Y",)), 900.0, (20.0, 22.0), off=off)
    rule, free = RuleController(), RuleController()
    rule.reset(ctx)
    free.reset(dataclasses.replace(ctx, off=None))
    y, v = np.array([21.5, 21.5]), {"T_supply": 14.0}  # 0.5 K above the set point: the loops unsaturated
    for k in range(2):
        m = rule(k, index[k], y, v)
        assert m[0] == 0.0 and 0.1 <= m[1] <= 0.5
        assert_allclose(m[1], free(k, index[k], y, v)[1], rtol=0, atol=0)  # the running unit as without schedule
    assert rule.cool.integral[0] == 0.0 and free.cool.integral[0] > 0.0  # no wind-up while off
    assert rule(2, index[2], y, v)[0] >= 0.2 and rule.stats()["off_box_steps"] == 2


# ----------------------------------------------------------------------------- the plant FMU
def test_replay_of_night_off_data_reproduces_the_zeros(night):
    data, plant, _ = night
    r = run_cosim(plant, data, ReplayController(), **SPAN)
    vavs = [c[2:] for c in r.table.columns if c.startswith("m_")]
    off, frame = _span_off(data, r.table, vavs)
    M = r.table[[f"m_{v}" for v in vavs]].to_numpy()[:-1]
    assert 20 < off.sum() < len(off) - 20  # the span holds a night and a day
    assert_allclose(M[off], 0.0, rtol=0, atol=0)  # the data's off steps replay as off, not at m_min
    lo, hi = _limits(data, vavs)
    measured = frame[[f"m_{v}" for v in vavs]].ffill().to_numpy()
    assert_allclose(M[~off], np.clip(measured[~off], lo, hi), rtol=0, atol=1e-12)
    s = r.summary
    assert s["schedule"]["system"] == "schedule" and s["schedule"]["off_steps"] == int(off.sum())
    assert s["limits"]["outside"] == 0 and s["limits"]["off"] == int(off.sum()) * len(vavs)
    text = r.format_summary()
    assert "the data's air handler is off in" in text and "off at 0" in text and "50 % of m_min" in text


def test_rule_controller_is_off_at_night(night):
    data, plant, _ = night
    r = run_cosim(plant, data, RuleController(), band=(21.0, 23.0), **SPAN)
    vavs = [c[2:] for c in r.table.columns if c.startswith("m_")]
    off, _ = _span_off(data, r.table, vavs)
    M = r.table[[f"m_{v}" for v in vavs]].to_numpy()[:-1]
    assert_allclose(M[off], 0.0, rtol=0, atol=0)
    lo, hi = _limits(data, vavs)
    assert np.all((M[~off] >= lo - 1e-12) & (M[~off] <= hi + 1e-12))
    Td = r.table[[c for c in r.table.columns if c.startswith("Td_")]].to_numpy()[:-1]
    assert Td.shape[1] and np.all(Td[off] <= 0.0)  # no reheat while off
    assert r.summary["schedule"]["overridden_box_steps"] == 0  # the controller itself was off, not overridden
    assert r.summary["controller_stats"]["off_box_steps"] == int(off.sum()) * len(vavs)


def test_always_on_runs_the_boxes_with_a_running_supply_temperature(night):
    data, plant, _ = night
    r = run_cosim(plant, data, RuleController(), system="always-on", **SPAN)
    vavs = [c[2:] for c in r.table.columns if c.startswith("m_")]
    off, frame = _span_off(data, r.table, vavs)
    M = r.table[[f"m_{v}" for v in vavs]].to_numpy()[:-1]
    lo, hi = _limits(data, vavs)
    assert np.all((M >= lo - 1e-12) & (M <= hi + 1e-12))  # every box runs, off steps included
    T_fed = r.table["T_supply"].to_numpy()[:-1]
    raw = frame["T_supply"].to_numpy()
    k0 = int(np.flatnonzero(off)[0])
    assert k0 > 0 and not off[k0 - 1]
    assert_allclose(T_fed[off & (np.arange(len(off)) < k0 + 8)][:8], T_fed[k0 - 1], rtol=0, atol=0)
    assert np.max(np.abs(raw[off] - T_fed[off])) > 2.0  # not the idle duct's reading (about room air)
    assert_allclose(T_fed[~off], raw[~off], rtol=0, atol=1e-9)
    s = r.summary["schedule"]
    assert s["system"] == "always-on" and s["held_supply"]["T_supply"] == int(off.sum())
    assert "--system always-on" in r.format_summary()


# ----------------------------------------------------------------------------- MPC plans with the schedule
def _linear_model():
    return LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=("A", "B", "C"),
        measured_zones=("A", "B", "C"),
        output_weights=np.eye(3),
        vavs=("V1", "V2", "V3", "V4"),
        input_map=np.array([[1, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=float),
        disturbances=("T_out", "T_supply"),
        A=np.array([[0.90, 0.03, 0.00], [0.03, 0.88, 0.04], [0.00, 0.04, 0.90]]),
        B=-np.diag([0.8, 1.1, 0.9]),
        C=np.array([[0.05, 0.02], [0.05, 0.03], [0.04, 0.02]]),
        gains={"fall": np.full((672, 3), 0.5)},
    )


@pytest.mark.parametrize("solver", [dict(solver="daqp", formulation="qp"), dict(solver="clarabel")])
def test_mpc_plans_and_applies_zero_in_off_steps(solver):
    u_min, u_max = np.array([0.1, 0.05, 0.05]), np.array([1.2, 1.2, 0.9])
    settings = MPCSettings(horizon=6, comfort_penalty=1e3, **solver)  # the dense active-set path and clarabel
    c = MPCController(_linear_model(), u_min, u_max, settings, schedule=True)
    N = c.N
    V = np.column_stack([np.full(N, 18.0), np.full(N, 13.0)])
    Q = np.full((N, 3), 0.6)
    hot = np.array([24.0, 24.0, 24.0])  # above the band: the MPC wants air
    off = np.zeros((N, 3), dtype=bool)
    off[2:] = True  # the unit stops after two steps
    u = c.step(hot, V, Q, off=off)
    assert np.all(u >= u_min - 1e-9)  # on now: inside the limits
    plan = c.plans[-1]
    assert_allclose(plan.U[2:], 0.0, rtol=0, atol=1e-6)  # planned with the schedule
    off[:] = True
    u = c.step(hot, V, Q, off=off)
    assert_allclose(u, 0.0, rtol=0, atol=0)  # off now: 0 applied
    assert_allclose(c.plans[-1].U, 0.0, rtol=0, atol=1e-6)
    assert c.stats()["off_steps"] == 1 and c.stats()["projected_steps"] <= 1  # an off step is no projection
    u = c.step(hot, V, Q)  # the schedule gone: the limits are back
    assert np.all(u >= u_min - 1e-9) and np.any(c.plans[-1].U[2:] > 1e-3)


def test_cosim_command_says_the_schedule_and_takes_system(night, cli, tmp_path):
    data, plant, paths = night
    common = ["cosim", "--plant", plant, "-d", paths.measurements, "-b", paths.building, "-c", "rule", "--warmup", "0"]
    span = ["--start", SPAN["start"], "--stop", "2025-11-04 22:00"]  # the unit stops at 20 h
    r = cli(*common, *span, "--system", "always-on", "--out", tmp_path / "on.csv")
    assert r.returncode == 0, r.stderr
    assert "--system always-on runs the boxes through them" in r.stdout and "box limits" in r.stdout
    summary = json.loads((tmp_path / "on.json").read_text())
    assert summary["schedule"]["system"] == "always-on" and summary["schedule"]["off_steps"] > 0
    assert summary["limits"]["outside"] == 0 and summary["limits"]["off"] == 0
    assert cli(*common, *span, "--system", "never").returncode == 2  # argparse's choices
