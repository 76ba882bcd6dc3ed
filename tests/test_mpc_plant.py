"""MPC against a plant that is not its model: offset-free estimation, move suppression, back-off, presets.

The plants here are the three-zone Model A of ``test_mpc`` with a known defect (an unmodelled
constant heat, an airflow gain twice the model's), so every expected number follows from the
construction; optimality is checked with the KKT certificate of ``test_mpc``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose
from test_mpc import (
    FEAS_TOL,
    LIN_UMAX,
    LIN_UMIN,
    jacobian,
    kkt_certificate,
    linear_constraints,
    linear_model,
    linear_preview,
)

from harness.mpc import MPCController, MPCSettings, closed_loop, cosim_controller
from harness.mpc.adapter import preset_options
from hvacfmu.errors import HvacfmuError, SolverError


class BiasedPlant:
    """The linear test model with an extra constant drift ``bias`` [K/step] and airflow gain ``gain``x."""

    step = 900.0

    def __init__(self, bias=(0.0, 0.0, 0.0), gain=1.0, model=None):
        self.model = model if model is not None else linear_model()
        self.bias = np.asarray(bias, dtype=float)
        self.gain = float(gain)

    def step_state(self, x, u, v, q):
        extra = (self.gain - 1.0) * (self.model.B @ np.asarray(u, dtype=float))
        return self.model.step_state(x, u, v, q) + extra + self.bias

    def output(self, x):
        return np.asarray(x, dtype=float)


def hot_preview(n):
    """Warm outdoor air and gains: the band's upper edge is active, the limits suffice."""
    V = np.column_stack([np.full(n, 24.0), np.full(n, 13.0)])
    Q = np.full((n, 3), 0.6)
    return V, Q


def test_settings_refuse_bad_plant_options():
    for kw, msg in (
        (dict(move_penalty=-1.0), "move_penalty"),
        (dict(offset_gain=1.5), "offset_gain"),
        (dict(back_off=1.0), "back_off"),  # 2 x 1 K leaves no band of [20, 22]
        (dict(back_off=-0.1), "back_off"),
    ):
        with pytest.raises(SolverError, match=msg):
            MPCSettings(**kw)
    assert MPCSettings(back_off=0.4).band == (20.4, 21.6)


def test_move_penalty_plan_is_kkt_optimal_and_back_off_holds():
    """With ``w Σ ||Δu||²`` (the first difference to the previous move) and a back-off, the plan is the
    certified optimum of that problem, and the predicted outputs keep the narrowed band."""
    N, w, b = 4, 3.0, 0.3
    x0 = np.array([22.2, 21.0, 21.7])
    V, Q = linear_preview(N, seed=4)
    s = MPCSettings(horizon=N, formulation="qp", comfort_penalty=None, move_penalty=w, back_off=b)
    c = MPCController(linear_model(), LIN_UMIN, LIN_UMAX, s)
    u_prev = np.array([0.6, 0.3, 0.2])
    c._last = (u_prev, V[0], Q[0])  # as if this move had been applied at the previous step
    plan = c.plan(x0, V, Q)
    assert plan.found and np.max(np.abs(plan.eps)) <= FEAS_TOL
    Y = plan.Y[1:]
    assert np.max(Y) <= 22.0 - b + FEAS_TOL and np.min(Y) >= 20.0 + b - FEAS_TOL
    narrowed = linear_constraints(x0, V, Q, N)

    def cons(z):  # the band narrowed by the back-off: shift the two band rows of test_mpc's constraints
        out = narrowed(z)
        out[: 2 * N * 3] -= b
        return out

    def grad(z):
        U = z.reshape(N, 3)
        D = np.diff(np.vstack([u_prev, U]), axis=0)
        g = 2 * U + 2 * w * D
        g[:-1] -= 2 * w * D[1:]
        return g.ravel()

    infeas, stat, _ = kkt_certificate(plan.U.ravel(), grad, cons, lambda z: jacobian(cons, z))
    assert infeas <= FEAS_TOL and stat <= 1e-5, (infeas, stat)
    # the reported objective includes the move cost
    moves = np.sum(np.diff(np.vstack([u_prev, plan.U]), axis=0) ** 2)
    assert_allclose(plan.obj, np.sum(plan.U**2) + w * moves, rtol=1e-6, atol=0)
    # and a different previous move changes the plan (the linear term is updated between solves)
    c._last = (np.array([1.1, 1.1, 0.8]), V[0], Q[0])
    assert np.max(np.abs(c.plan(x0, V, Q).U[0] - plan.U[0])) > 1e-3


def test_offset_free_estimate_removes_a_constant_model_bias():
    """An unmodelled constant heat of 0.15 K/step in zone A: the plain MPC settles above the band,
    the offset-free MPC estimates the drift exactly and holds the band."""
    n, bias = 120, np.array([0.15, 0.0, 0.0])
    V, Q = hot_preview(n + 6)
    x0 = np.full(3, 21.5)
    runs = {}
    for g in (0.0, 0.5):
        c = MPCController(linear_model(), LIN_UMIN, LIN_UMAX, MPCSettings(horizon=6, offset_gain=g))
        runs[g] = (closed_loop(c, BiasedPlant(bias), x0, V, Q, n), c)
    plain, _ = runs[0.0]
    free, c = runs[0.5]
    tail = slice(n // 2, None)
    assert np.max(plain.y[1:][tail, 0]) > 22.0 + 0.1  # the bias shows up as a steady violation
    assert np.max(free.y[1:][tail, 0]) <= 22.0 + 1e-6  # removed in steady state
    assert_allclose(c.offset, bias, rtol=0, atol=1e-6)  # [K/step] the drift the estimator found
    assert np.min(free.u[tail, 0]) > np.max(plain.u[tail, 0])  # it cools more where the model was wrong


def test_offset_gain_changes_nothing_when_the_model_is_the_plant():
    n = 48
    V, Q = linear_preview(n + 6, seed=2)
    x0 = np.array([21.0, 21.5, 21.2])
    u = []
    for g in (0.0, 0.6):
        c = MPCController(linear_model(), LIN_UMIN, LIN_UMAX, MPCSettings(horizon=6, offset_gain=g))
        u.append(closed_loop(c, BiasedPlant(), x0, V, Q, n).u)
        assert np.max(np.abs(c.offset)) <= 1e-12
    assert_allclose(u[0], u[1], rtol=0, atol=1e-9)


def fast_model():
    """The test model with 15-minute zone time constants of Model A fitted on closed-loop data (a = 0.45)."""
    m = linear_model()
    return dataclasses.replace(m, A=np.diag([0.45, 0.45, 0.45]))


def test_move_penalty_damps_the_swing_of_a_plant_with_twice_the_airflow_gain():
    """Offset-free MPC on a fast model whose plant cools twice as much per kg/s: the unpenalised
    plan and the drift estimate chase each other and the airflow swings between the limits from
    step to step (as Model A on the emulator's plant); move suppression removes the swing."""
    n = 96
    V, _ = hot_preview(n + 6)
    Q = 11.2 + 0.5 * np.sin(np.arange(n + 6) / 8.0)[:, None] * np.ones(3)  # [K/step] mid airflows hold 22 °C
    x0 = np.full(3, 22.5)
    out = {}
    for w in (0.0, 20.0):
        s = MPCSettings(horizon=6, move_penalty=w, offset_gain=0.6)
        c = MPCController(fast_model(), LIN_UMIN, LIN_UMAX, s)
        r = closed_loop(c, BiasedPlant(gain=2.0, model=fast_model()), x0, V, Q, n)
        out[w] = (float(np.sum(np.abs(np.diff(r.u, axis=0)))), r.violation_Kh)  # [kg/s], [K·h]
    assert out[0.0][0] > 40.0 and out[20.0][0] < 0.2 * out[0.0][0], out
    assert out[20.0][1] < 0.5 * out[0.0][1], out


def test_presets_and_explicit_options():
    assert preset_options("paper", 12, True) == {}
    p3 = preset_options("plant", 3, False)
    assert p3 == {"offset_gain": 0.6, "move_penalty": 20.0, "back_off": 0.4, "gain_adapt": 0.05}
    p12 = preset_options("plant", 12, True)
    assert p12["blocks"] == "auto" and p12["slack"] == "per_step" and p12["linearisation"] == "newton"
    p48 = preset_options("plant", 48, True)  # reduced model: one frozen iteration per step
    assert "linearisation" not in p48 and p48["max_iter"] == 1
    with pytest.raises(HvacfmuError, match="unknown MPC preset"):
        preset_options("fast", 12, False)
    ctrl = cosim_controller(linear_model(), None, horizon=12, back_off=0.1)
    assert ctrl.settings.back_off == 0.1 and ctrl.settings.move_penalty == 20.0
    assert ctrl.settings.block_lengths == (1, 1, 2, 4, 4)
    paper = cosim_controller(linear_model(), None, horizon=12, preset="paper")
    assert (paper.settings.offset_gain, paper.settings.move_penalty, paper.settings.back_off) == (0.0, 0.0, 0.0)


def test_input_weights_plan_is_kkt_optimal():
    """Per-input cost weights (reheat inputs get their own): the plan is the certified optimum of Σ w_i u_i²."""
    N, w = 3, np.array([1.0, 0.2, 5.0])
    x0 = np.array([22.4, 21.0, 21.8])
    V, Q = linear_preview(N, seed=4)
    s = MPCSettings(horizon=N, formulation="qp", comfort_penalty=None)
    plan = MPCController(linear_model(), LIN_UMIN, LIN_UMAX, s, input_weights=w).plan(x0, V, Q)
    assert plan.found and np.max(np.abs(plan.eps)) <= FEAS_TOL
    cons = linear_constraints(x0, V, Q, N)
    infeas, stat, _ = kkt_certificate(
        plan.U.ravel(), lambda z: 2 * np.tile(w, N) * z, cons, lambda z: jacobian(cons, z)
    )
    assert infeas <= FEAS_TOL and stat <= 1e-5, (infeas, stat)
    assert_allclose(plan.obj, np.sum(w * plan.U**2), rtol=1e-7, atol=0)
    with pytest.raises(SolverError, match="input weights"):
        MPCController(linear_model(), LIN_UMIN, LIN_UMAX, s, input_weights=[1.0, 0.0, 1.0]).plan(x0, V, Q)


@dataclasses.dataclass(frozen=True)
class HeatCoolZone:
    """One zone with a = 0.45 per 15 min (Model A on closed-loop data): airflow ``m`` [kg/s] cools, reheat ``h``
    [kW] heats; ``gain`` scales both effects (the plant of a model whose heat gain is 1/gain of the building's)."""

    gain: float = 1.0
    b: tuple = (-0.3, 0.06)  # [K/step per kg/s], [K/step per kW]
    step: float = 900.0
    outputs: tuple = ("A",)
    inputs: tuple = ("m_A", "h_A")
    disturbances: tuple = ("T_out",)
    n_states: int = 1

    @property
    def gains(self):
        return {"fall": np.zeros((672, 1))}

    def step_state(self, x, u, v, q):
        x, u, v, q = (np.asarray(z, dtype=float) for z in (x, u, v, q))
        return 0.45 * x + self.gain * (u @ np.asarray(self.b))[..., None] + 0.05 * v[..., :1] + q

    def output(self, x):
        return np.asarray(x, dtype=float)


HC_UMIN, HC_UMAX = np.array([0.2, 0.0]), np.array([1.5, 6.0])


def heat_cool_run(plant_gain, **options):
    """Two days of the plant preset (N = 12) on a zone that needs reheat at night and cooling by day; returns
    (result, controller, zone moves > 0.5 K that reverse the previous one)."""
    n = 192
    t = np.arange(n + 12)
    V = (8.0 + 3.0 * np.sin(2 * np.pi * t / 96))[:, None]  # [°C]
    Q = (11.0 + 2.0 * np.sin(2 * np.pi * (t - 20) / 96))[:, None]  # [K/step] internal and solar gains
    s = MPCSettings(horizon=12, **{**preset_options("plant", 12, False), **options})
    c = MPCController(HeatCoolZone(), HC_UMIN, HC_UMAX, s, input_weights=[1.0, 0.05], hard_inputs=[False, True])
    r = closed_loop(c, HeatCoolZone(gain=plant_gain), np.array([21.0]), V, Q, n)
    dy = np.diff(r.y[1:, 0])
    reversals = int(np.sum((dy[1:] * dy[:-1] < 0) & (np.abs(dy[1:]) > 0.5) & (np.abs(dy[:-1]) > 0.5)))
    return r, c, reversals


def test_gain_adaptation_stops_the_limit_cycle_of_a_model_five_times_too_weak():
    """A model whose first-step heat gain is 1/5 of the plant's: with move suppression and the offset estimate
    alone the plan cycles between full reheat at minimum airflow and maximum airflow every step (the zone
    swinging by more than 1 K); the plant preset's input-gain adaptation finds the gain and stops the cycle, with
    fewer K·h at less airflow and reheat."""
    cyc, c0, rev0 = heat_cool_run(5.0, gain_adapt=0.0)
    assert rev0 >= 30 and cyc.violation_Kh > 2.0, (rev0, cyc.violation_Kh)
    du = np.diff(cyc.u, axis=0)  # the cycle: reheat and airflow jump across their ranges, in opposite directions
    assert np.sum((np.abs(du[:, 1]) > 4.0) & (np.abs(du[:, 0]) > 0.8) & (du[:, 0] * du[:, 1] < 0)) >= 15
    fixed, c1, rev1 = heat_cool_run(5.0)  # the plant preset
    assert c1.settings.gain_adapt > 0.0
    assert rev1 == 0, rev1
    du = np.diff(fixed.u, axis=0)
    assert np.sum((np.abs(du[:, 1]) > 4.0) & (np.abs(du[:, 0]) > 0.8) & (du[:, 0] * du[:, 1] < 0)) == 0
    assert fixed.violation_Kh < 0.5 * cyc.violation_Kh, (fixed.violation_Kh, cyc.violation_Kh)
    assert np.sum(fixed.u[:, 0] ** 2) < np.sum(cyc.u[:, 0] ** 2) and np.sum(fixed.u[:, 1]) < np.sum(cyc.u[:, 1])
    assert 3.0 <= c1.theta[0] <= c1.settings.gain_max and c1.stats()["input_gain_engaged"] == 1
    assert np.all((fixed.u >= HC_UMIN - 1e-9) & (fixed.u <= HC_UMAX + 1e-9))


def test_gain_adaptation_leaves_a_right_or_moderately_weak_model_alone():
    """The model as its plant: θ stays 1 and the plans are those without adaptation. A plant twice as strong
    (what move suppression handles, Model A on the emulator's plant): θ is estimated near 2, below the engage
    threshold, and the moves are again exactly those without adaptation."""
    for plant_gain, lo, hi in ((1.0, 1.0, 1.0), (2.0, 1.5, 2.9)):
        r_on, c_on, _ = heat_cool_run(plant_gain)
        r_off, _, _ = heat_cool_run(plant_gain, gain_adapt=0.0)
        assert lo <= c_on.theta[0] <= hi, (plant_gain, c_on.theta)
        assert c_on.stats()["input_gain_engaged"] == 0
        assert_allclose(r_on.u, r_off.u, rtol=0, atol=1e-12)


def test_gain_settings_are_checked():
    for kw, msg in (
        (dict(gain_adapt=1.0), "gain_adapt"),
        (dict(gain_adapt=-0.1), "gain_adapt"),
        (dict(gain_max=0.5), "gain_max"),
        (dict(gain_engage=9.0), "gain_engage"),
    ):
        with pytest.raises(SolverError, match=msg):
            MPCSettings(**kw)
    assert preset_options("plant", 12, True)["gain_adapt"] == 0.05
