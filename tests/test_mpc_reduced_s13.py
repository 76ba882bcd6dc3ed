"""The MPC's input-gain adaptation on the reduced prediction of long horizons (bilinear models, N > 24).

The plants are a one-zone bilinear model (airflow cools through ``m (T_supply - T_zone)``, reheat heats) with a
known gain defect, as the linear heat-cool zone of ``test_mpc_plant``; the reduced problem is also checked against
the condensed one at full order with the same gain correction.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose
from test_mpc import bilinear_case

from harness.mpc import MPCController, MPCSettings, closed_loop
from harness.mpc.adapter import preset_options
from harness.mpc.synthetic import random_rc_network


@dataclasses.dataclass(frozen=True)
class BilinearHeatCoolZone:
    """One zone with a = 0.45 per 15 min: airflow ``m`` [kg/s] cools through ``kb m (T_supply - T_zone)``
    (0.3 K/step per kg/s at an 8 K difference), reheat ``h`` [kW] heats; ``gain`` scales both effects (the plant of
    a model whose heat gain is 1/gain of the building's)."""

    gain: float = 1.0
    kb: float = 0.0375  # [K/step per kg/s and K]
    kh: float = 0.06  # [K/step per kW]
    step: float = 900.0
    outputs: tuple = ("A",)
    inputs: tuple = ("m_A", "h_A")
    disturbances: tuple = ("T_out", "T_supply")
    n_states: int = 1

    @property
    def gains(self):
        return {"fall": np.zeros((672, 1))}

    def step_state(self, x, u, v, q):
        x, u, v, q = (np.asarray(z, dtype=float) for z in (x, u, v, q))
        heat = self.kb * u[..., 0] * (v[..., 1] - x[..., 0]) + self.kh * u[..., 1]
        return 0.45 * x + self.gain * heat[..., None] + 0.05 * v[..., :1] + q

    def output(self, x):
        return np.asarray(x, dtype=float)


UMIN, UMAX = np.array([0.2, 0.0]), np.array([1.5, 6.0])


def long_horizon_run(plant_gain, N=48, n=192, **options):
    """``n`` steps (default two days) of the plant preset at N = 48 (the reduced prediction, one convex iteration a step) on a zone that
    needs reheat at night and cooling by day; returns (result, controller, zone moves > 0.5 K that reverse the
    previous one)."""
    t = np.arange(n + N)
    V = np.column_stack([8.0 + 3.0 * np.sin(2 * np.pi * t / 96), np.full(t.size, 13.0)])  # [°C] T_out, T_supply
    Q = (11.0 + 2.0 * np.sin(2 * np.pi * (t - 20) / 96))[:, None]  # [K/step] internal and solar gains
    s = MPCSettings(horizon=N, **{**preset_options("plant", N, True), **options})
    c = MPCController(BilinearHeatCoolZone(), UMIN, UMAX, s, input_weights=[1.0, 0.05], hard_inputs=[False, True])
    assert c.reduced  # "auto": the reduced prediction beyond 24 steps
    r = closed_loop(c, BilinearHeatCoolZone(gain=plant_gain), np.array([21.0]), V, Q, n)
    dy = np.diff(r.y[1:, 0])
    reversals = int(np.sum((dy[1:] * dy[:-1] < 0) & (np.abs(dy[1:]) > 0.5) & (np.abs(dy[:-1]) > 0.5)))
    return r, c, reversals


def test_gain_adaptation_stops_the_limit_cycle_on_the_reduced_prediction():
    """A model with 1/5 of the plant's gain at N = 48: without adaptation the plan cycles (the zone reversing
    moves of more than 0.5 K); the plant preset's adaptation estimates θ on the reduced prediction too and stops
    the cycle, with fewer K·h at less airflow and reheat (before: θ stayed 1 and the moves were those without)."""
    cyc, _, rev0 = long_horizon_run(5.0, gain_adapt=0.0)
    assert rev0 >= 20 and cyc.violation_Kh > 1.5, (rev0, cyc.violation_Kh)
    fixed, c1, rev1 = long_horizon_run(5.0)
    assert c1.settings.gain_adapt > 0.0
    assert rev1 == 0, rev1
    assert fixed.violation_Kh < 0.5 * cyc.violation_Kh, (fixed.violation_Kh, cyc.violation_Kh)
    assert np.sum(fixed.u[:, 0] ** 2) < np.sum(cyc.u[:, 0] ** 2) and np.sum(fixed.u[:, 1]) < np.sum(cyc.u[:, 1])
    assert 3.0 <= c1.theta[0] <= c1.settings.gain_max and c1.stats()["input_gain_engaged"] == 1
    assert np.all((fixed.u >= UMIN - 1e-9) & (fixed.u <= UMAX + 1e-9))


def test_gain_adaptation_on_the_reduced_prediction_leaves_a_right_or_moderately_weak_model_alone():
    """At N = 48, one day: the model as its plant keeps θ = 1 (to rounding: the one-step errors are ~1e-16, not
    exactly 0, on some BLAS builds); a plant twice as strong is estimated near 2, under the engage threshold; both
    give exactly the moves without adaptation."""
    for plant_gain, lo, hi in ((1.0, 1.0, 1.0 + 1e-9), (2.0, 1.5, 2.9)):
        r_on, c_on, _ = long_horizon_run(plant_gain, n=96)
        r_off, _, _ = long_horizon_run(plant_gain, n=96, gain_adapt=0.0)
        assert lo <= c_on.theta[0] <= hi, (plant_gain, c_on.theta)
        assert c_on.stats()["input_gain_engaged"] == 0
        assert_allclose(r_on.u, r_off.u, rtol=0, atol=1e-12)


@pytest.mark.parametrize("linearisation", ["frozen", "newton"])
def test_reduced_gain_correction_is_the_condensed_one_at_full_order(linearisation):
    """With the same θ engaged and the same previous move, the reduced problem at (numerically) full order plans
    what the condensed one plans, and θ changes that plan (the correction reaches the reduced rows). ``rom_tol``
    1e-14 keeps 29 of 30 states: at 1e-12 (28) the Newton state feedback through the truncated states moves the
    plan by 0.02 kg/s even with θ = 1."""
    m = random_rc_network(n_zones=3, n_boxes=5, n_states=30, seed=1)
    N = 24
    x0, V, Q = bilinear_case(m, N, seed=5)
    u_prev = 0.5 * (m.m_min + m.m_max)
    theta = np.array([3.5, 1.0, 5.0])  # per zone; zone 2 not engaged
    plans = {}
    for name, kw, th in (
        ("condensed", dict(prediction="condensed"), theta),
        ("reduced", dict(prediction="reduced", rom_tol=1e-14), theta),
        ("reduced, θ = 1", dict(prediction="reduced", rom_tol=1e-14), np.ones(3)),
    ):
        s = MPCSettings(
            horizon=N, blocks="auto", linearisation=linearisation, max_iter=1, move_penalty=5.0, gain_adapt=0.05, **kw
        )
        c = MPCController(m, m.m_min, m.m_max, s)
        c.theta, c._engaged = th.copy(), th > 1.0
        c._last = (u_prev, V[0], Q[0])  # as if this move had been applied at the previous step
        plans[name] = c.plan(x0, V, Q)
        assert plans[name].found
    assert_allclose(plans["reduced"].U, plans["condensed"].U, rtol=0, atol=1e-6)
    assert np.max(np.abs(plans["reduced"].U - plans["reduced, θ = 1"].U)) > 1e-3
