"""The MPC's default horizon (session 15; issue 18 p.7).

- ``hvacfmu cosim --controller mpc`` planned over 3 steps (45 min at 15-min data, the paper's) while ``hvacfmu demo``
  ran 12 (3 h); the default is now a duration, 3 h in steps of the data (``harness.controllers.default_horizon``),
  wherever a horizon is not given (CLI, ``harness.cosim``, ``make_controller``, ``cosim_controller``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from harness.controllers import DEFAULT_HORIZON_H, ControlContext, default_horizon
from harness.cosim import CosimResult, make_controller
from harness.mpc import cosim_controller
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
