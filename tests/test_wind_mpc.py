"""A ``wind_infiltration`` term (``coef · wind · (T_out − T_zone)``) in the matrix form, the native FMU and MPC
(issue 15 p.6, issue 18 p.4).

- ``ExtendedModel.equations()`` holds the term as products with a disturbance (``Bxv``/``Bvv``) and reproduces
  ``step_state`` to 1e-12 K on random data;
- the native FMU (input ``wind`` [m/s]) follows the Python model;
- the MPC predictor's ``A_k = A + Σ v_j Bxv_j`` follows the wind forecast: its prediction equals the model's
  simulation over the horizon (linear and bilinear extended models, frozen, newton and reduced forms), and
  the controller runs closed loop on the model;
- ``terms_on_base`` keeps the wind term in the control model and ``cosim --controller mpc --model extended.json``
  runs with it on the emulator's plant FMU.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import warnings

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from hvacfmu.errors import HvacfmuWarning
from hvacfmu.models.causes import WindInfiltration
from hvacfmu.models.equations import check_equations
from hvacfmu.models.extended import ExtendedModel, SolarGain, SupplyAirBilinear, ThermalMass, ZoneCoupling
from hvacfmu.models.linear import LinearZoneModel

STEP = 900.0  # [s]


def _base():
    return LinearZoneModel(
        kind="zones",
        step=STEP,
        outputs=("A", "B", "C"),
        measured_zones=("A", "B", "C"),
        output_weights=np.eye(3),
        vavs=("V1", "V2", "V3"),
        input_map=np.eye(3),
        disturbances=("T_out", "T_supply", "I_S"),
        A=np.array([[0.9, 0.02, 0.0], [0.03, 0.88, 0.02], [0.0, 0.02, 0.91]]),
        B=np.diag([-0.2, -0.3, -0.25]),
        C=np.array([[0.02, 0.03, 0.0], [0.02, 0.03, 1e-3], [0.02, 0.03, 0.0]]),
        gains={"fall": np.full((672, 3), 0.1)},
    )


#: a linear extended model (wind in two zones, a coupling, solar) and a bilinear one (with supply air and slow mass)
MODELS = {
    "linear": (
        WindInfiltration(zone="A", coef=0.004),
        WindInfiltration(zone="C", coef=0.002),
        ZoneCoupling(zone_a="A", zone_b="C", coef_ab=0.01, coef_ba=0.015),
        SolarGain(zone="B", facade="S", coef=1e-3),
    ),
    "bilinear": (
        WindInfiltration(zone="A", coef=0.004),
        ThermalMass(zone="B", alpha=0.02, beta=0.05),
        SupplyAirBilinear(zone="C", coef=0.02),
    ),
}


def _model(which):
    return ExtendedModel(base=_base(), terms=MODELS[which])


def _signals(model, n, seed=0):
    """Random disturbances (n, nv) in their ranges (wind 0..12 m/s), airflows (n, nu), gains (n, nq)."""
    rng = np.random.default_rng(seed)
    cols = []
    for d in model.disturbances:
        if d == "wind":
            cols.append(rng.uniform(0.0, 12.0, n))
        elif d == "T_out":
            cols.append(rng.uniform(-5.0, 25.0, n))
        elif d.startswith("T_"):
            cols.append(rng.uniform(12.0, 16.0, n))
        else:
            cols.append(rng.uniform(0.0, 500.0, n))
    return rng.uniform(0.05, 0.5, (n, len(model.inputs))), np.column_stack(cols), 0.2 * rng.random((n, 3))


def _simulate(model, x0, U, V, Q):
    X = np.empty((len(U) + 1, np.size(x0)))
    X[0] = x0
    for k in range(len(U)):
        X[k + 1] = model.step_state(X[k], U[k], V[k], Q[k])
    return X


# ----------------------------------------------------------------------------- equations
@pytest.mark.parametrize("which", sorted(MODELS))
def test_equations_of_a_wind_model_reproduce_its_step_exactly(which):
    model = _model(which)
    eq = model.equations()
    assert eq.disturbance_products and eq.disturbances[-1] == "wind"
    w, i_out = eq.disturbances.index("wind"), eq.disturbances.index("T_out")
    assert eq.Bxv[w][0, 0] == -0.004 and eq.Bvv[w][0, i_out] == 0.004  # coef · wind · (T_out − T_A)
    assert not any(np.any(M) for j, M in enumerate(eq.Bxv) if j != w)
    rng = np.random.default_rng(3)
    n = 200
    x = 20 + 3 * rng.normal(size=(n, model.n_states))
    u, v, q = _signals(model, n, seed=4)
    assert_allclose(eq.step_state(x, u, v, q), model.step_state(x, u, v, q), rtol=0, atol=1e-12)  # [K]
    assert check_equations(model, eq, atol=1e-12) <= 1e-12
    # the wind term matters in these data: without it the step differs by far more than the tolerance
    plain = ExtendedModel(base=_base(), terms=tuple(t for t in MODELS[which] if t.cause != "wind_infiltration"))
    diff = model.step_state(x, u, v, q)[:, 0] - plain.step_state(x, u, v[:, :-1], q)[:, 0]
    assert np.max(np.abs(diff)) > 0.1
    # the diagnosis's control model keeps the term now (no "left out" path for it)
    assert WindInfiltration.matrix_form


def test_load_check_sees_a_wind_term_through_its_matrix_form():
    """The response check counts ``Bxv``/``Bvv`` (20 m/s of wind) and the state matrix at that wind stays stable."""
    from hvacfmu.models.loadcheck import model_problems, response_k

    model = _model("linear")
    assert model_problems(model) == []
    eq = model.equations()
    without = ExtendedModel(base=_base(), terms=MODELS["linear"][2:])
    assert response_k(eq)[0] > response_k(without.equations())[0]  # zone A's wind term adds to its drive


# ----------------------------------------------------------------------------- native FMU
@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs the system C compiler gcc")
def test_native_fmu_of_a_wind_model_matches_the_python_model(tmp_path):
    """Two weeks through ``fmpy.simulate_fmu`` with a measured wind: the native FMU equals the Python model."""
    from fmpy import simulate_fmu

    from hvacfmu.fmu import validate
    from hvacfmu.fmu_native import export_native_fmu
    from hvacfmu.fmu_slave import state_from_outputs

    model = _model("bilinear")
    path = export_native_fmu(model, tmp_path / "wind.fmu")
    assert validate(path, native=True) == []
    from fmpy import read_model_description

    (wind,) = [v for v in read_model_description(str(path)).modelVariables if v.name == "wind"]
    assert (wind.causality, wind.unit, float(wind.min), float(wind.max)) == ("input", "m/s", 0.0, 60.0)
    n = 2 * 672
    rng = np.random.default_rng(5)
    t = np.arange(n) * STEP
    day = 2 * np.pi * t / 86400.0
    cols = {
        "m_V1": 0.25 + 0.1 * np.sin(day),
        "m_V2": 0.2 + 0.1 * np.sin(day + 1),
        "m_V3": 0.3 + 0.1 * np.sin(day + 2),
        "T_out": 8 + 6 * np.sin(day),
        "T_supply": 14 + np.sin(2 * np.pi * t / 3e5),
        "I_S": np.clip(400 * np.sin(day), 0, None),
        "wind": np.clip(5 + 3 * np.sin(2 * np.pi * t / 2e5) + rng.normal(0, 1, n), 0, None),
    }
    sig = np.zeros(n, dtype=[("time", float)] + [(c, float) for c in cols])
    sig["time"] = t
    for c, x in cols.items():
        sig[c] = x
    res = simulate_fmu(
        str(path),
        start_time=0.0,
        stop_time=(n - 1) * STEP,
        output_interval=STEP,
        input=sig,
        start_values={"T_A_start": 21.0, "T_B_start": 21.0, "T_C_start": 21.0, "season": 1, "start_time_of_week": 0.0},
        output=["T_A", "T_B", "T_C"],
    )
    Y = np.column_stack([res[f"T_{z}"] for z in model.outputs])
    idx = pd.date_range("2025-01-06", periods=n, freq="900s", tz="UTC")  # a Monday 00:00
    u, v = model.signals(pd.DataFrame(cols, index=idx))
    q = model.gains_at(idx, "fall")
    _, Yref = model.simulate(state_from_outputs(model, np.full(3, 21.0), u[0], v[0], q[0]), u, v, q)
    assert_allclose(Y, Yref[: len(Y)], rtol=0, atol=1e-9)  # [K]
    plain = ExtendedModel(base=_base(), terms=MODELS["bilinear"][1:])
    _, Yplain = plain.simulate(state_from_outputs(plain, np.full(3, 21.0), u[0], v[0, :-1], q[0]), u, v[:, :-1], q)
    assert np.max(np.abs(Yplain - Yref)) > 0.5  # the wind term moves zone A: the comparison is not trivial


# ----------------------------------------------------------------------------- MPC
@pytest.mark.parametrize("which", sorted(MODELS))
def test_mpc_prediction_of_a_wind_model_equals_its_simulation_over_the_horizon(which):
    """``y0 + G U`` (the condensed prediction the QP optimises) against the model's own step, wind varying."""
    from harness.mpc.predict import make_predictor

    model = _model(which)
    pred = make_predictor(model)
    assert pred.time_varying and pred.linear == (which == "linear")
    N = 12
    U, V, Q = _signals(model, N, seed=7)
    x0 = 21 + np.random.default_rng(8).normal(size=pred.nx)
    X = _simulate(model, x0, U, V, Q)
    Y = (X[1:] @ pred.C.T).ravel()
    assert_allclose(pred.simulate(x0, U, V, Q), X, rtol=0, atol=1e-11)  # [K]
    lengths = np.ones(N, dtype=int)
    if pred.linear:
        y0, G = pred.affine_prediction(x0, V, Q, lengths)
        assert_allclose(y0 + G @ U.ravel(), Y, rtol=0, atol=1e-11)
        # the sensitivity follows the forecast: another wind gives another G
        V2 = V.copy()
        V2[:, -1] = 0.0
        assert np.max(np.abs(pred.affine_prediction(x0, V2, Q, lengths)[1] - G)) > 1e-4
        return
    y0, G = pred.affine_prediction(x0, V, Q, lengths, Xbar=X, mode="frozen")  # frozen at the true trajectory
    assert_allclose(y0 + G @ U.ravel(), Y, rtol=0, atol=1e-11)
    y0, G = pred.affine_prediction(x0, V, Q, lengths, Ubar=U, mode="newton")
    assert_allclose(y0 + G @ U.ravel(), Y, rtol=0, atol=1e-11)
    dU = 1e-5 * np.random.default_rng(9).normal(size=U.shape)  # newton's G is the derivative
    Xd = pred.simulate(x0, U + dU, V, Q)
    assert_allclose((Xd[1:] @ pred.C.T).ravel() - Y, G @ dU.ravel(), rtol=0, atol=1e-9)
    # the reduced form carries the wind's state feedback (theta) in the frozen mode too
    _, _, theta = pred.reduced_prediction(x0, V, Q, Xbar=X, mode="frozen")
    assert theta is not None and np.max(np.abs(theta)) > 0.0


@pytest.mark.parametrize("which", sorted(MODELS))
def test_mpc_with_a_wind_model_runs_closed_loop_on_the_model(which):
    """A day against the model as its own plant: no failure, moves inside the limits, every plan's predicted
    trajectory equal to the model's simulation of its moves under the forecast wind."""
    from harness.mpc import MPCController, MPCSettings, closed_loop

    model = _model(which)
    n, N = 96, 6
    U, V, Q = _signals(model, n + N, seed=11)
    V[:, model.disturbances.index("T_out")] = 5.0 + 3.0 * np.sin(np.arange(n + N) * 2 * np.pi / 96)
    ctrl = MPCController(model, np.full(3, 0.05), np.full(3, 0.8), MPCSettings(horizon=N, T_min=20.0, T_max=22.0))
    x0 = np.full(model.n_states, 21.0)
    res = closed_loop(ctrl, model, x0, V, Q, n)
    assert res.summary()["failures"] == 0
    assert np.all(res.u >= 0.05 - 1e-9) and np.all(res.u <= 0.8 + 1e-9)
    for k in (0, 40, 95):
        plan = ctrl.plans[k]
        assert_allclose(plan.X, _simulate(model, plan.X[0], plan.U, V[k : k + N], Q[k : k + N]), rtol=0, atol=1e-10)


def test_mpc_reduced_prediction_runs_with_a_wind_model():
    """The bilinear model at a long horizon (the reduced problem): wind's time-varying A enters as theta."""
    from harness.mpc import MPCController, MPCSettings, closed_loop

    model = _model("bilinear")
    n, N = 8, 30
    U, V, Q = _signals(model, n + N, seed=12)
    ctrl = MPCController(
        model, np.full(3, 0.05), np.full(3, 0.8), MPCSettings(horizon=N, T_min=20.0, T_max=22.0, prediction="reduced")
    )
    assert ctrl.reduced
    res = closed_loop(ctrl, model, np.full(model.n_states, 21.0), V, Q, n)
    assert res.summary()["failures"] == 0 and ctrl._problem.has_theta


def test_mpc_probes_a_wind_model_with_calendar_terms_exactly():
    """A holiday term leaves no time-invariant ``equations()``; MPC probes the step instead, and the probe finds the
    wind's products (``Bxv``/``Bvv``) too, so such a model is controlled with the wind term, not refused."""
    from harness.mpc.predict import make_predictor, model_equations
    from hvacfmu.errors import ModelError
    from hvacfmu.models.extended import InternalGainSchedule

    terms = MODELS["bilinear"] + (
        InternalGainSchedule(variant="holiday", zone_names=("A", "B", "C"), coef=(1.0,) * 3, dates=("2025-10-29",)),
    )
    model = ExtendedModel(base=_base(), terms=terms)
    with pytest.raises(ModelError):
        model.equations()
    eq = model_equations(model)
    assert eq.disturbance_products
    assert check_equations(model, eq, atol=1e-12) <= 1e-12
    pred = make_predictor(model)
    N = 8
    U, V, Q = _signals(model, N, seed=13)
    x0 = np.full(pred.nx, 21.0)
    assert_allclose(pred.simulate(x0, U, V, Q), _simulate(model, x0, U, V, Q), rtol=0, atol=1e-11)  # [K]


# ----------------------------------------------------------------------------- control model and cosim
@pytest.mark.slow  # about 60 s on the shared 2-core machine: the fit on 8 weeks, the plant FMU, a 12-h run
def test_control_model_keeps_the_wind_term_and_cosim_mpc_runs_it(tmp_path):
    """``terms_on_base`` refits the wind term (no warning, no ``left_out``) and ``hvacfmu cosim --controller mpc
    --model extended.json`` runs it against the emulator's plant FMU (with ``wind_infiltration`` injected)."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis.control import terms_on_base
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.fmu import export_plant_fmu
    from hvacfmu.models.datadriven import fit_zones

    p = cached_dataset(weeks=8, seed=0, effects=["wind_infiltration:zone=NW"], start="2025-11-03", wind="m/s")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        ds = prepare(p.measurements, p.building)
        base = fit_zones(ds, open_loop=False, plausibility=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HvacfmuWarning)  # no "leaves out" warning
        ctl = terms_on_base(ds, base, [WindInfiltration(zone="NW")], heat="airflow")
    assert "left_out" not in ctl.meta
    (term,) = ctl.terms
    assert term.cause == "wind_infiltration" and term.coef > 0.0
    assert ctl.equations().disturbance_products
    # a term without a matrix form (held_setpoint is one, tests/test_held_setpoint.py): left out, said
    import dataclasses
    from typing import ClassVar

    @dataclasses.dataclass(frozen=True)
    class NoForm(WindInfiltration):
        matrix_form: ClassVar[bool] = False

    with pytest.warns(HvacfmuWarning, match="leaves out wind_infiltration in NW"):
        left = terms_on_base(ds, base, [NoForm(zone="NW")], heat="airflow")
    assert left.terms == () and left.meta["left_out"][0]["zone"] == "NW"
    mp = ctl.save(tmp_path / "extended.json")
    plant = export_plant_fmu(p.truth, tmp_path / "Plant.fmu")
    out = tmp_path / "run.csv"
    cmd = [
        sys.executable,
        "-m",
        "hvacfmu.cli",
        "-q",
        "cosim",
        "--plant",
        str(plant),
        "--data",
        str(p.measurements),
        "--building",
        str(p.building),
        "--controller",
        "mpc",
        "--model",
        str(mp),
        "--start",
        "2025-12-10T00:00",
        "--stop",
        "2025-12-10T12:00",
        "--warmup",
        "0",
        "--horizon",
        "6",
        "--out",
        str(out),
    ]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    summary = json.loads(out.with_suffix(".json").read_text())
    assert summary["controller"] == "mpc" and summary["steps_completed"] == 48
    assert summary["controller_stats"]["failures"] == 0
