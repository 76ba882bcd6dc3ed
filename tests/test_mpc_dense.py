"""The dense active-set path of the MPC (harness.mpc.dense, ``MPCSettings.solver``).

Every check compares DAQP's plans with clarabel's on the same problem (the sparse
interior-point path, the reference of the rest of the MPC tests) or against the
constraints themselves; nothing depends on timings.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from test_mpc import LIN_UMAX, LIN_UMIN, certify_linear_plan, linear_model, linear_preview

from harness.mpc import MPCController, MPCSettings
from harness.mpc.dense import DenseQP
from harness.mpc.synthetic import random_rc_network, steady_state_at, synthetic_week
from hvacfmu.errors import SolverError

pytest.importorskip("daqp")

#: states that leave the band reachable, need input-limit slack (too hot) and band slack (too cold)
STATES = (
    np.array([22.4, 21.0, 21.8]),
    np.array([21.9, 21.5, 22.3]),
    np.array([23.5, 23.0, 23.2]),
    np.array([19.0, 19.5, 20.2]),
    np.array([22.4, 21.0, 21.8]),
)


def plans(solver, N=6, steps=STATES, hard_inputs=None, **kw):
    """Plans of one controller over a sequence of states (the dense path warm-starts from the previous
    one), each with its cost on the model's own trajectory (``MPCController.merit``)."""
    settings = MPCSettings(horizon=N, formulation="qp", solver=solver, **kw)
    c = MPCController(linear_model(), LIN_UMIN, LIN_UMAX, settings, hard_inputs=hard_inputs)
    out = []
    for k, x0 in enumerate(steps):
        V, Q = linear_preview(N, seed=k)
        p = c.plan(x0, V, Q)
        p.merit = c.merit(p.U, p.X) if p.found else np.nan
        out.append(p)
        if p.found:
            c._last = (p.U[0], V[0], Q[0])  # the previous move, for the move penalty
    return out, c


CASES = {
    "paper": {},
    "per-step slack, blocks": {"slack": "per_step", "blocks": (1, 2, 3)},
    "move penalty, auto blocks": {"move_penalty": 20.0, "blocks": "auto", "back_off": 0.4},
    "no airflow floor": {"u_floor": None},
    "large slack penalty": {"rho": 1e3, "comfort_penalty": 1e5},
}


@pytest.mark.parametrize("case", list(CASES))
def test_dense_active_set_is_optimal_like_clarabel(case):
    """Step after step (warm start): the dense plan's objective is its true cost (feasible, slacks
    minimal) and matches the interior point's optimum within its 1e-8 gap.

    Plans are compared by objective, not move by move: the interior point pins a move only to about
    the square root of its gap (~1e-4 kg/s); the active set is exact.
    """
    kw = CASES[case]
    dense, c = plans("daqp", **kw)
    ref, c_ref = plans("clarabel", **kw)
    assert c._problem.dense is not None and c_ref._problem.dense is None
    assert c._problem.n_solver_fallbacks == 0
    used_eps = used_s = False
    for p, r in zip(dense, ref):
        assert p.found and r.found
        assert_allclose(p.merit, p.obj, rtol=1e-6, atol=1e-9)  # feasible (to 1e-9): its objective is its cost
        assert_allclose(p.obj, r.obj, rtol=1e-6, atol=1e-9)
        assert p.obj <= r.merit * (1 + 1e-6)  # never worse than the interior point's plan
        assert_allclose(p.U[0], r.U[0], rtol=0, atol=5e-4)
        used_eps |= bool(np.max(p.eps) > 1e-3)
        lo, hi = c.settings.band
        used_s |= bool(np.max(p.Y[1:]) > hi + 1e-3 or np.min(p.Y[1:]) < lo - 1e-3)
    assert used_eps and (used_s or kw.get("u_floor", 0.0) is None), "the states must exercise the slacks"


def test_dense_hard_band_matches_clarabel_and_fails_like_it():
    """A hard band is one two-sided row; an unreachable one is infeasible for both solvers, and the
    dense failure is counted as a fallback to clarabel."""
    x0 = STATES[0]
    dense, c = plans("daqp", steps=(x0,), comfort_penalty=None)
    ref, _ = plans("clarabel", steps=(x0,), comfort_penalty=None)
    assert dense[0].found and c._problem.n_solver_fallbacks == 0
    certify_linear_plan(dense[0], x0, *linear_preview(6, seed=0), penalty="l1")  # KKT of the hard-band problem
    assert_allclose(dense[0].obj, ref[0].obj, rtol=2e-7)
    cold, c2 = plans("daqp", steps=(x0, np.full(3, 10.0)), comfort_penalty=None)
    assert cold[0].found and not cold[1].found
    assert c2._problem.n_solver_fallbacks == 1 and "Infeasible" in cold[1].status
    assert "daqp exitflag" in cold[1].status


def test_failed_dense_solve_falls_back_to_clarabel(monkeypatch):
    """A dense failure is solved again by clarabel, counted in stats()['solver_fallbacks']."""
    dense, c = plans("daqp", steps=STATES[:1])
    monkeypatch.setattr(DenseQP, "solve", lambda self, y0: (False, "daqp exitflag -4", None, np.nan, 0.0))
    V, Q = linear_preview(6, seed=0)
    plan = c.plan(STATES[0], V, Q)
    assert plan.found and plan.status.startswith("daqp exitflag -4; clarabel: Solved")
    assert c.stats()["solver_fallbacks"] == 1
    assert_allclose(plan.obj, dense[0].obj, rtol=2e-7)


def test_auto_picks_dense_for_condensed_qp_only():
    """``solver="auto"``: daqp for the condensed QP (linear and bilinear models); clarabel for the SOCP
    and for the reduced prediction of long horizons."""
    _, c = plans("auto", steps=STATES[:1])
    assert c._problem.dense is not None
    _, c_socp = plans("clarabel", steps=STATES[:1])
    assert c_socp._problem.dense is None
    c_socp = MPCController(linear_model(), LIN_UMIN, LIN_UMAX, MPCSettings(horizon=3, formulation="socp"))
    V, Q = linear_preview(3)
    assert c_socp.plan(STATES[0], V, Q).found and c_socp._problem.dense is None
    m = random_rc_network(n_zones=2, n_boxes=3, n_states=10, seed=3)
    V, Q = synthetic_week(m, 30, seed=2)
    x0 = steady_state_at(m, V[0], Q[0], 21.0)
    cb = MPCController(m, m.m_min, m.m_max, MPCSettings(horizon=3, formulation="qp"))
    assert cb.plan(x0, V[:3], Q[:3]).found and cb._problem.dense is not None
    cr = MPCController(m, m.m_min, m.m_max, MPCSettings(horizon=30, formulation="qp", prediction="reduced"))
    assert cr.plan(x0, V, Q).found and cr.reduced and not hasattr(cr._problem, "dense")


def test_dense_on_bilinear_model_matches_clarabel():
    """``solver="daqp"`` on a bilinear model rebuilds its workspace for every new linearisation and
    gives the interior point's sequential-QP plan."""
    m = random_rc_network(n_zones=2, n_boxes=3, n_states=10, seed=3)
    V, Q = synthetic_week(m, 4, seed=1)
    x0 = steady_state_at(m, V[0], Q[0], 22.5)
    out = []
    for solver in ("daqp", "clarabel"):
        s = MPCSettings(horizon=4, formulation="qp", linearisation="newton", tol=1e-7, solver=solver)
        c = MPCController(m, m.m_min, m.m_max, s)
        out.append(c.plan(x0, V, Q))
        assert (c._problem.dense is not None) == (solver == "daqp")
    assert out[0].found and out[0].converged and out[1].found
    assert_allclose(out[0].U[0], out[1].U[0], rtol=0, atol=1e-4)
    assert_allclose(out[0].merit, out[1].merit, rtol=1e-6)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"solver": "osqp"}, "solver must be one of"),
        ({"solver": "daqp", "formulation": "socp"}, "needs formulation='qp'"),
    ],
)
def test_bad_solver_settings(kwargs, message):
    with pytest.raises(SolverError, match=message):
        MPCSettings(**kwargs)


def test_projection_counts_real_limit_excess_not_rounding():
    """An active-set plan sits on a limit to ~1e-14 kg/s: clipped, but only a real excess is counted."""
    c = MPCController(linear_model(), LIN_UMIN, LIN_UMAX, MPCSettings(horizon=3, formulation="qp"))
    assert_allclose(c._project(LIN_UMAX + 4e-14), LIN_UMAX, rtol=0, atol=0)
    assert c.stats()["projected_steps"] == 0
    assert_allclose(c._project(LIN_UMAX + np.array([0.0, 2e-6, 0.0])), LIN_UMAX, rtol=0, atol=0)
    assert c.stats()["projected_steps"] == 1 and c.stats()["projected_max"] == pytest.approx(2e-6)


@pytest.mark.parametrize("N", [1, 12, 200])  # 200 x 3 states is past LIFTED_MAX: the recursion
def test_lifted_linear_trajectory_equals_the_recursion(N):
    """The linear predictor's one-product trajectory and simulation equal the step-by-step model, with
    an offset-free drift too."""
    from harness.mpc.predict import AffinePredictor, make_predictor

    m = linear_model()
    pred = make_predictor(m)
    V, Q = linear_preview(N, seed=3)
    U = np.random.default_rng(0).uniform(LIN_UMIN, LIN_UMAX, (N, 3))
    x0 = np.array([21.0, 22.5, 19.5])
    for offset in (None, np.array([0.05, -0.02, 0.1])):
        pred.offset = offset
        W = pred.drift(V, Q)
        assert_allclose(pred.free_trajectory(x0, W), AffinePredictor.free_trajectory(pred, x0, W), rtol=0, atol=1e-11)
        X = AffinePredictor.simulate(pred, x0, U, V, Q)  # step() by step()
        assert_allclose(pred.simulate(x0, U, V, Q), X, rtol=0, atol=1e-11)
    pred.offset = None
    assert_allclose(pred.simulate(x0, U, V, Q), m.simulate(x0, U, V, Q)[0], rtol=0, atol=1e-11)


def test_one_blas_thread_limits_and_restores_the_pool():
    """Model B's algebra runs BLAS on one thread (same plans, no thread synchronisation); the pool is restored."""
    threadpoolctl = pytest.importorskip("threadpoolctl")
    from harness.mpc.controller import one_blas_thread

    def blas_threads():
        return [p["num_threads"] for p in threadpoolctl.threadpool_info() if p["user_api"] == "blas"]

    with threadpoolctl.threadpool_limits(2, user_api="blas"):  # the suite runs on one thread (tests/conftest.py)
        before = blas_threads()
        assert set(before) == {2}
        with one_blas_thread():
            assert set(blas_threads()) <= {1}
        assert blas_threads() == before


@pytest.mark.parametrize("slack", ["shared", "per_step"])
def test_hard_inputs_keep_their_limits_on_both_paths(slack):
    """An input declared hard (the harness's reheat) has no slack: its plan stays in [u_min, u_max] where the
    softened plan left them, DAQP and clarabel agree on the optimum, and the other inputs keep their slack."""
    kw = {"slack": slack, "blocks": (1, 2, 3)}
    soft, _ = plans("daqp", **kw)
    over = np.max([np.max(p.U - LIN_UMAX, axis=0) for p in soft], axis=0)
    i = int(np.argmax(over))
    assert over[i] > 1e-3, "an input must leave its limit in the softened plans for the test to mean anything"
    hard = np.arange(len(LIN_UMAX)) == i
    dense, c = plans("daqp", hard_inputs=hard, **kw)
    ref, _ = plans("clarabel", hard_inputs=hard, **kw)
    n_soft = len(LIN_UMAX) - 1
    assert c._problem.ne == (c._problem.nb * n_soft if slack == "per_step" else n_soft)  # no slack for the hard input
    assert c._problem.dense.soft_U.size == c._problem.nb * (len(LIN_UMAX) - 1)  # no limit rows for the hard input
    assert c._problem.n_solver_fallbacks == 0
    used_eps = False
    for p, r in zip(dense, ref):
        assert p.found and r.found
        for q in (p, r):
            assert np.all(q.U[:, i] <= LIN_UMAX[i] + 1e-6) and np.all(q.U[:, i] >= LIN_UMIN[i] - 1e-6)
            assert np.all(np.asarray(q.eps)[..., i] == 0.0)
        assert_allclose(p.merit, p.obj, rtol=1e-6, atol=1e-9)
        assert_allclose(p.obj, r.obj, rtol=1e-6, atol=1e-9)
        used_eps |= bool(np.max(p.eps) > 1e-3)
    assert used_eps, "the other inputs keep their softened limits"
