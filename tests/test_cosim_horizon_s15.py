"""The MPC's default horizon and its forecast of an idle supply temperature (session 15; issue 18 p.7, issue 13).

- ``hvacfmu cosim --controller mpc`` planned over 3 steps (45 min at 15-min data, the paper's) while ``hvacfmu demo``
  ran 12 (3 h); the default is now a duration, 3 h in steps of the data (``harness.controllers.default_horizon``),
  wherever a horizon is not given (CLI, ``harness.cosim``, ``make_controller``, ``cosim_controller``).
- With ``--system schedule``, a model that carries an idle supply rule (``diagnose``'s extended model, airflow
  form: ``T_supply`` acts at zero airflow too) forecast the raw idle duct reading in the off steps, while its FMUs
  (and its fit) replace it by the rule's value: the forecast now applies the same rule.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from harness.controllers import DEFAULT_HORIZON_H, ControlContext, default_horizon
from harness.cosim import CosimResult, make_controller
from harness.mpc import cosim_controller
from hvacfmu.data.idle import idle_supply_rule, unit_off_bounds
from hvacfmu.models.extended import ExtendedModel
from hvacfmu.models.linear import LinearZoneModel
from hvacfmu.timeutil import n_time_of_week


def _model(step):
    """Two zones, three boxes, airflow form (``T_supply`` a linear disturbance), at ``step`` [s]."""
    return LinearZoneModel(
        kind="zones",
        step=float(step),
        outputs=("A", "B"),
        measured_zones=("A", "B"),
        output_weights=np.eye(2),
        vavs=("V1", "V2", "V3"),
        input_map=np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
        disturbances=("T_out", "T_supply"),
        A=np.array([[0.9, 0.02], [0.03, 0.88]]),
        B=-np.diag([0.9, 1.2]),
        C=np.array([[0.05, 0.03], [0.06, 0.04]]),
        gains={"fall": np.full((n_time_of_week(step), 2), 0.9)},
    )


def _context(model, building, n, off=None, seed=0):
    step = model.step
    idx = pd.date_range("2025-10-06", periods=n, freq=pd.Timedelta(seconds=step), tz="America/Los_Angeles")
    rng = np.random.default_rng(seed)
    frame = pd.DataFrame(
        {
            "T_A": 21.0,
            "T_B": 21.0,
            "m_V1": 0.1,
            "m_V2": 0.1,
            "m_V3": 0.05,
            "T_out": 8.0 + 4 * np.sin(np.arange(n) / 15),
            "T_supply": 13.0 + rng.normal(0, 0.1, n),
        },
        index=idx,
    )
    if off is not None:  # the idle duct reads about room air; the data's boxes read 0
        frame.loc[off.all(axis=1), "T_supply"] = 18.0 + rng.normal(0, 0.3, int(off.all(axis=1).sum()))
        for j, b in enumerate(("V1", "V2", "V3")):
            frame.loc[off[:, j], f"m_{b}"] = 0.0
    return ControlContext(
        frame=frame,
        building=building,
        vavs=("V1", "V2", "V3"),
        outputs=("T_A", "T_B"),
        output_zones=(("A",), ("B",)),
        step=float(step),
        band=(20.0, 22.0),
        season="fall",
        model=model,
        off=off,
    )


@pytest.mark.parametrize("step, steps", [(900.0, 12), (300.0, 36)])
def test_default_horizon_is_three_hours_in_steps_of_the_data(small_building, step, steps):
    """No horizon given: 3 h at the data's step, in every entry point; an explicit horizon is kept."""
    assert DEFAULT_HORIZON_H == 3.0 and default_horizon(step) == steps
    model = _model(step)
    for ctrl in (cosim_controller(model, small_building), make_controller("mpc", model, small_building, {})):
        assert ctrl.settings.horizon == steps and ctrl.horizon_default
        assert ctrl.settings.block_lengths != (1,) * steps  # the plant preset of a long horizon (move blocking)
        ctrl.reset(_context(model, small_building, 8))
        assert ctrl.mpc.N == steps
        ctrl(0, None, np.array([21.0, 21.0]), {})
        st = ctrl.stats()
        assert (st["horizon"], st["horizon_h"], st["horizon_default"]) == (steps, 3.0, True)
    pinned = make_controller("mpc", model, small_building, {"horizon": 3})
    assert pinned.settings.horizon == 3 and not pinned.horizon_default
    pinned.reset(_context(model, small_building, 8))
    assert pinned.mpc.N == 3
    # the summary says it in steps and hours
    summary = {
        "fmu": "Zones.fmu", "controller": "mpc", "start": "a", "end": "b", "steps_requested": 1, "step": step,
        "steps_completed": 1, "covered": True, "energy_proxy": 0.0, "total_airflow_kg": 0.0, "mean_airflow": 0.0,
        "comfort_violation_Kh": 0.0, "band": [20.0, 22.0], "step_time_median": 0.0, "step_time_max": 0.0,
        "controller_time_median": 0.0, "fmu_time_median": 0.0, "controller_stats": st,
    }  # fmt: skip
    text = CosimResult(table=pd.DataFrame(), summary=summary).format_summary()
    assert f"horizon         {steps} steps (3 h) (the default: 3 h at the data's step" in text


def test_cli_help_states_the_default(cli):
    out = cli("cosim", "--help").stdout
    assert "default 3 h in steps of the data: 12 at 15-min steps, 36 at 5-min" in " ".join(out.split())


@pytest.mark.parametrize("mode", ["zone", "last"])
def test_idle_supply_forecast_equals_the_plant_input_in_off_steps(small_building, mode):
    """An extended model with an idle rule, run against itself as its FMU runs (``simulate_boxes``' rule, with the
    plant's own zone temperatures): in every off step the MPC's forecast of ``T_supply`` for that step is the
    plant's input, not the idle duct reading."""
    n, N = 40, 6
    off = np.zeros((n, 3), bool)
    off[10:22] = True  # the unit off for 3 h
    off[30:34] = True
    base = _model(900.0)
    rule = idle_supply_rule(small_building, ("T_supply", "m_V1", "m_V2", "m_V3", "T_A", "T_B"),
                            unit_off_bounds(small_building), mode)  # fmt: skip
    model = ExtendedModel(base=base, terms=(), meta={"idle_supply": {"mode": mode, "rule": rule}})
    plant_rule = model.idle_step()
    ctx = _context(model.base, small_building, n, off=off)
    ctrl = cosim_controller(model, small_building, horizon=N)
    ctrl.reset(ctx)
    seen = []
    step = ctrl.mpc.step
    ctrl.mpc.step = lambda y, V, Q, o=None: (seen.append(np.array(V, dtype=float)), step(y, V, Q, o))[1]
    V_raw = ctx.frame[list(model.disturbances)].to_numpy(float)
    Q = np.full(2, 0.9)
    x, last, checked = np.array([21.0, 21.5]), None, 0
    for k in range(n):
        m = ctrl(k, None, model.output(x), {})
        m = np.where(off[k], 0.0, m)  # the harness's schedule
        v, last = plant_rule.apply(V_raw[k], m, model.output(x), last)  # the plant's input (the FMU's rule)
        assert_allclose(seen[k][0], v, rtol=0, atol=1e-12)
        if off[k].all():
            checked += 1
            assert abs(v[1] - V_raw[k, 1]) > 0.5  # the rule replaced the idle reading
        x = model.step_state(x, m @ base.input_map.T, v, Q)
    assert checked == 16
    # over the horizon: the off rows of a forecast made before the unit goes off are held too
    before = seen[8]  # rows 8..13: 10..13 off
    assert np.all(np.abs(before[2:, 1] - V_raw[10:14, 1]) > 0.5)
