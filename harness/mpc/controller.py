"""Receding-horizon MPC controller and a pure-Python closed loop.

:class:`MPCController` solves the energy-efficient problem of
:mod:`harness.mpc.problem` at every step from the current state:

- Model A (linear): the condensed sensitivity ``G`` and the solver's KKT
  structure are built once; a step only updates the right-hand side.
- Model B (bilinear): sequential convex programming. The state in the
  bilinear terms is frozen at the previous plan shifted by one step and
  re-simulated from the current estimate; each iteration is an exact QP (or
  SOCP) in the airflows with a time-varying input matrix; the new plan is
  simulated with the bilinear model and the loop stops when no planned
  airflow moves by more than ``settings.tol`` [kg/s] or after
  ``settings.max_iter`` iterations. Unmeasured states (walls) come from a
  Kalman filter on the measured zone temperatures.

A failed solve never stops a run: the controller applies the previous plan's
next move, counts the failure and keeps the failed problem for replay.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from pathlib import Path

import numpy as np
import pandas as pd

from hvacfmu.errors import ModelError
from hvacfmu.threads import one_blas_thread

from .predict import KalmanFilter, make_predictor
from .problem import CondensedProblem, MPCSettings, ReducedProblem, save_problem


@dataclasses.dataclass
class Plan:
    """One step's plan.

    Attributes
    ----------
    found : bool
    status : str
    U : array (N, nu) [kg/s] planned airflows
    eps : array (nu,) [kg/s] input-limit slack
    X : array (N+1, nx) state trajectory of the model under U (bilinear: exact simulation)
    Y : array (N+1, ny) [°C] outputs along X
    obj : float   Σ u² + ρ||eps|| (+ comfort penalty)
    iterations : int
    converged : bool  the sequential iteration met ``settings.tol`` (always True for linear models)
    solve_time : float [s]  solver calls only
    step_time : float [s]   whole step (estimation, condensing, solving)
    merit : float  cost on the exact model trajectory (:meth:`MPCController.merit`; bilinear models)
    """

    found: bool
    status: str
    U: np.ndarray
    eps: np.ndarray
    X: np.ndarray
    Y: np.ndarray
    obj: float
    iterations: int
    converged: bool
    solve_time: float
    step_time: float = 0.0
    merit: float = float("nan")


def _block_starts(lengths):
    return np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(int)


def _blocked(U, lengths):
    """Project moves onto the blocking (mean over each block), repeated per step."""
    out = np.empty_like(U)
    for s, n in zip(_block_starts(lengths), lengths):
        out[s : s + n] = U[s : s + n].mean(axis=0)
    return out


class MPCController:
    """Energy-efficient MPC (paper eq. ee_controller) for Model A or Model B.

    Parameters
    ----------
    model : LinearZoneModel, PhysicsModel or any object with ``discrete_matrices()``
    u_min, u_max : array (n_inputs,) [kg/s]
        Input limits in the model's input space (see :func:`input_limits`).
    settings : MPCSettings
    kalman_q_std, kalman_r_std : float [K]
        Process (per step) and measurement noise of the Kalman filter (bilinear models).
    failure_dir : path or None
        Where failed problems are saved as ``failure_<step>.npz``; ``None``
        keeps them in :attr:`failed_problems`.
    input_weights : array (n_inputs,) or None
        Cost weight of each input (default ones, the paper's ``Σ ||u||²``).
    hard_inputs : array of bool (n_inputs,) or None
        Inputs whose limits the optimiser keeps as they are, without the
        slack ``eps`` of the paper's softened limits (default none: every
        input's limits are softened). The harness makes the reheat inputs hard
        (:class:`~harness.mpc.adapter.MPCAdapter`): a coil's capacity is a
        limit no plan can exceed.
    schedule : bool
        The run has an operating schedule (:meth:`step`'s ``off``): the
        problem gets hard caps so that an input off in a block stays at 0
        there (the softened limits' shared slack would let it move). Without
        it ``off`` only bounds the blocks softly and zeroes the applied move.
    """

    name = "mpc"

    def __init__(
        self,
        model,
        u_min,
        u_max,
        settings: MPCSettings | None = None,
        *,
        kalman_q_std=0.05,
        kalman_r_std=0.05,
        failure_dir=None,
        input_weights=None,
        hard_inputs=None,
        schedule=False,
    ):
        self.model = model
        self.schedule = bool(schedule)
        self.settings = settings or MPCSettings()
        self.pred = make_predictor(model)
        self.u_min = np.asarray(u_min, dtype=float).ravel()
        self.u_max = np.asarray(u_max, dtype=float).ravel()
        if self.u_min.size != self.pred.nu or self.u_max.size != self.pred.nu:
            raise ModelError(
                f"input limits have {self.u_min.size}/{self.u_max.size} entries, model has {self.pred.nu} inputs"
            )
        self.weights = np.ones(self.pred.nu) if input_weights is None else np.asarray(input_weights, float).ravel()
        self.hard = np.zeros(self.pred.nu, dtype=bool) if hard_inputs is None else np.asarray(hard_inputs, bool).ravel()
        if self.hard.size != self.pred.nu:
            raise ModelError(f"hard_inputs has {self.hard.size} entries, model has {self.pred.nu} inputs")
        self.lengths = np.asarray(self.settings.block_lengths)
        self.N = int(self.lengths.sum())
        self.bilinear = not self.pred.linear
        pm = self.settings.prediction
        self.reduced = self.bilinear and (pm == "reduced" or (pm == "auto" and self.N > 24))
        self.estimated = self.bilinear or not self.pred.state_is_output  # hidden states: Kalman filter
        self.kf = KalmanFilter(self.pred, self.u_min, kalman_q_std, kalman_r_std) if self.estimated else None
        self.failure_dir = Path(failure_dir) if failure_dir is not None else None
        self._problem = None
        self.reset()

    # ----- state ---------------------------------------------------------
    def reset(self, x0=None):
        """Forget plans, estimates and statistics; optionally set the state estimate."""
        self.k = 0
        self.plans = []
        self.failed_problems = []
        self.n_failures = 0
        self.n_frozen_fallbacks = 0  # solves whose full (newton) linearisation failed and the frozen one was used
        self.n_projected = 0  # steps whose planned move left [u_min, u_max] (softened limits) and was projected
        self.projected_max = 0.0  # [kg/s] largest projected difference of one input
        self.projected_sum = 0.0  # [kg/s · steps] sum of |planned - applied| over inputs and steps
        self._plan = None
        self._off = None  # (N, nu) bool of the current step: inputs off (the building's schedule)
        self.n_off_steps = 0  # steps with an input off at the first move
        self._last = None  # (u, v, q) applied at the previous step
        self._x_last = None  # state estimate of the previous step (Model A: its measured outputs)
        self._pinv_C = None
        self.pred.offset = None  # offset-free MPC: the drift is estimated again from the start
        # input-gain adaptation (settings.gain_adapt): per output gain θ on the effect of changing the moves
        self.theta = np.ones(self.pred.ny)  # the estimated gain (plant over model) of each output
        self._engaged = np.zeros(self.pred.ny, dtype=bool)  # outputs whose prediction θ scales
        self._S_gg = np.zeros(self.pred.ny)  # discounted Σ g² [K²] of the first-step effects of move changes
        self._S_ge = np.zeros(self.pred.ny)  # discounted Σ g e [K²] with the one-step errors
        self._G1 = None  # first-step sensitivity (ny, nu) of the last plan, uncorrected
        self._u_before = None  # the move applied before the previous one
        self._theta_in_problem = None  # θ the linear problem's G was last built with
        self._Y_held = None  # bilinear merit: outputs (N, ny) with the previous move held
        if self.kf is not None:
            self.kf.x = None if x0 is None else np.asarray(x0, dtype=float)
        self._x0 = None if x0 is None else np.asarray(x0, dtype=float)

    def estimate(self, y, v, q) -> np.ndarray:
        """State estimate from the measured outputs y (ny,) [°C].

        With ``settings.offset_gain`` g > 0 (offset-free MPC), the one-step
        prediction error ``e = y - C x̂(k|k-1)`` (the prediction already
        carrying the current drift) updates an integrating disturbance
        ``d += g C⁺ e`` [K/step] on the measured nodes, which the predictor adds
        to every step of the horizon (:attr:`AffinePredictor.offset`): a
        constant model bias (heat the model does not know, a wrong gain at the
        operating point) is then removed in steady state instead of showing up
        as a steady violation of the band.
        """
        y = np.asarray(y, dtype=float)
        g = float(self.settings.offset_gain)
        errors = g > 0.0 or self.settings.gain_adapt > 0.0
        if self.kf is None:  # the state is the measured output (Model A)
            if errors and self._last is not None and self._x_last is not None:
                e = self._adapt_gain(y - self.pred.C @ self.pred.step(self._x_last, *self._last))
                if g > 0.0:
                    self._update_offset(e, g)
            self._x_last = y.copy()
            return y.copy()
        if self.kf.x is None:
            self.kf.initialise(y, v, q, self.u_min)
        elif self._last is not None:
            self.kf.predict(*self._last)
            if errors:
                e = self._adapt_gain(y - self.pred.C @ self.kf.x)
                if g > 0.0:
                    self._update_offset(e, g)
            self.kf.correct(y)
        else:
            self.kf.correct(y)
        return self.kf.x.copy()

    #: [K] a predicted first-step effect of a move change smaller than this says nothing about the gain
    GAIN_MIN_EFFECT = 0.02
    #: [K²] prior weight of θ = 1 in the gain regression (about one step of a 0.1 K predicted effect)
    GAIN_PRIOR = 0.01

    def _adapt_gain(self, e) -> np.ndarray:
        """Update the input-gain correction θ (ny,) from the one-step error ``e`` (ny,) [K]; returns the error
        that θ does not explain (what the offset estimate then gets).

        ``g = G₁ (u(k-1) - u(k-2))`` is the first-step effect the model predicts for the last change of the
        moves; a plant that responds θ times as strongly leaves ``e ≈ (θ - 1) g``. Per output, ``θ - 1`` is the
        discounted least-squares slope of ``e`` on ``g`` (forgetting factor ``1 - gain_adapt``, prior
        :attr:`GAIN_PRIOR` on θ = 1), clipped to ``[1, gain_max]``: only a plant stronger than the model is
        corrected (a weaker one makes the plan slow, not cycle).
        """
        r = float(self.settings.gain_adapt)
        if r <= 0.0 or self._G1 is None or self._u_before is None or self._last is None:
            return e
        g = self._G1 @ (self._last[0] - self._u_before)
        use = np.abs(g) >= self.GAIN_MIN_EFFECT
        lam = 1.0 - r
        self._S_gg = np.where(use, lam * self._S_gg + g * g, self._S_gg)
        self._S_ge = np.where(use, lam * self._S_ge + g * e, self._S_ge)
        self.theta = np.clip(1.0 + self._S_ge / (self._S_gg + self.GAIN_PRIOR), 1.0, self.settings.gain_max)
        engage = self.settings.gain_engage
        self._engaged = (self.theta >= engage) | (self._engaged & (self.theta >= 1.0 + 0.5 * (engage - 1.0)))
        return e - (self.gain_correction - 1.0) * g

    @property
    def gain_correction(self) -> np.ndarray:
        """The gain (ny,) the prediction applies to the effect of changing the moves: θ where engaged, else 1."""
        return np.where(self._engaged, self.theta, 1.0)

    def _corrected(self, y0, G):
        """The prediction ``y0 + G U_b`` with the effect of changing the moves from the previous one scaled by θ
        per output (``settings.gain_adapt``); keeps the uncorrected first-step sensitivity for the estimator."""
        ny, nu = self.pred.ny, self.pred.nu
        self._G1 = np.array(G[:ny, :nu])
        theta = self.gain_correction
        if self.settings.gain_adapt <= 0.0 or np.all(theta == 1.0):
            return y0, G
        rows = np.tile(theta, G.shape[0] // ny)
        held = G @ np.tile(self._u_prev(), G.shape[1] // nu)
        return y0 + (1.0 - rows) * held, rows[:, None] * G

    def _corrected_reduced(self, y0, beta):
        """:meth:`_corrected` for the reduced prediction (long horizons): the problem's forced response
        ``C_r ξ + D_0 w`` is scaled by θ per output (:meth:`ReducedProblem.set_output_gain`) and ``y0`` gets
        ``(1 - θ)`` times the forced response of the previous move held, so the response with that move held stays
        the model's. The first-step sensitivity for the estimator is exact (``C P β_0``: the reduced model's
        feedthrough makes its first Markov parameter the model's)."""
        self._G1 = self.pred.C @ self.pred.basis @ beta[0]
        theta = self.gain_correction if self.settings.gain_adapt > 0.0 else np.ones(self.pred.ny)
        self._problem.set_output_gain(theta)
        if np.all(theta == 1.0):
            return y0
        held = self._problem.forced_response(np.tile(self._u_prev(), (len(self.lengths), 1)))
        return y0 + (1.0 - np.tile(theta, self.N)) * held

    def _update_offset(self, e, g):
        if self._pinv_C is None:
            self._pinv_C = np.linalg.pinv(self.pred.C)
        d = np.zeros(self.pred.nx) if self.pred.offset is None else self.pred.offset
        self.pred.offset = d + g * (self._pinv_C @ e)

    @property
    def offset(self) -> np.ndarray:
        """The estimated drift (nx,) [K/step] of offset-free MPC (zeros when off)."""
        return np.zeros(self.pred.nx) if self.pred.offset is None else self.pred.offset.copy()

    # ----- one step --------------------------------------------------------
    def step(self, y, V, Qg, off=None) -> np.ndarray:
        """Airflows to apply now.

        Parameters
        ----------
        y : array (ny,) [°C] measured outputs (zone temperatures)
        V : array (>= N, nv) disturbance preview from now on
        Qg : array (>= N, nq) internal-gain preview from now on
        off : array (>= N, nu) of bool, optional
            The building's schedule over the horizon: input ``i`` is off
            (limits ``[0, 0]``) in a block whose steps are all off; the
            applied move of an input off now is 0.

        Returns
        -------
        u : array (nu,) [kg/s]
            Always inside ``[u_min, u_max]``: the plan may use the softened
            limits (slack ``eps``), the applied move is its projection onto the
            limits; the difference is counted in :meth:`stats`.
        """
        t0 = time.perf_counter()
        V = self._preview(V, "V")
        Qg = self._preview(Qg, "Qg")
        self._off = None if off is None or not np.any(off) else self._preview(off, "off").astype(bool)
        with self._blas():
            x0 = self.estimate(y, V[0], Qg[0])
            plan = self._plan_step(x0, V, Qg)
        if plan.found:
            u = plan.U[0].copy()
            self._plan = plan
        else:
            self.n_failures += 1
            u = self._fallback_move()
            shifted = self._shifted_plan()
            self._plan = dataclasses.replace(plan, U=shifted) if shifted is not None else None
        if self._off is not None and self._off[0].any():  # off now: 0, and the others projected as usual
            u = np.where(self._off[0], 0.0, self._project(np.where(self._off[0], self.u_min, u)))
            self.n_off_steps += 1
        else:
            u = self._project(u)
        plan.step_time = time.perf_counter() - t0
        self.plans.append(plan)
        self._u_before = None if self._last is None else self._last[0]
        self._last = (u, V[0], Qg[0])
        self.k += 1
        return u

    __call__ = step

    def _preview(self, A, name):
        A = np.atleast_2d(np.asarray(A, dtype=float))
        if A.shape[0] < self.N:
            if A.shape[0] == 0:
                raise ModelError(f"{name} preview is empty")
            A = np.vstack([A, np.repeat(A[-1:], self.N - A.shape[0], axis=0)])
        if not np.all(np.isfinite(A[: self.N])):
            raise ModelError(f"{name} preview contains NaN or infinite values")
        return A[: self.N]

    #: [kg/s] projections smaller than this are rounding (an active-set plan sits on a limit to ~1e-14), not counted
    PROJECT_TOL = 1.0e-9

    def _project(self, u) -> np.ndarray:
        """The move made feasible: clipped to ``[u_min, u_max]``; a difference over :attr:`PROJECT_TOL` is counted."""
        applied = np.clip(u, self.u_min, self.u_max)
        diff = np.abs(np.asarray(u, dtype=float) - applied)
        if float(diff.max(initial=0.0)) > self.PROJECT_TOL:
            self.n_projected += 1
            self.projected_max = max(self.projected_max, float(diff.max()))
            self.projected_sum += float(diff.sum())
        return applied

    def _shifted_plan(self):
        if self._plan is None:
            return None
        U = self._plan.U
        return np.vstack([U[1:], U[-1:]])

    def _fallback_move(self):
        shifted = self._shifted_plan()
        if shifted is not None:
            return shifted[0].copy()
        return np.clip(np.zeros(self.pred.nu), self.u_min, self.u_max)

    # ----- planning ---------------------------------------------------------
    def plan(self, x0, V, Qg) -> Plan:
        """Solve the MPC problem from state x0 (nx,) with previews V (N, nv), Qg (N, nq)."""
        with self._blas():
            return self._plan_step(x0, V, Qg)

    def _blas(self):
        """:func:`one_blas_thread` for models with hidden states or bilinear terms (Model B: 3.5x faster with two
        OpenBLAS threads configured, same plans); a few-state linear model's algebra is too small to notice
        threads, and switching the pool costs more than it saves there."""
        return one_blas_thread() if self.bilinear or self.pred.nx > 20 else contextlib.nullcontext()

    def _plan_step(self, x0, V, Qg) -> Plan:
        s = self.settings
        if not self.bilinear:
            y0, G = self._corrected(*self.pred.affine_prediction(x0, V, Qg, self.lengths))
            if self._problem is None:
                self._problem = CondensedProblem(
                    G, self.u_min, self.u_max, self.pred.ny, s, weights=self.weights, hard=self.hard, caps=self.schedule
                )
            elif self.pred.time_varying or (
                self._theta_in_problem is not None and not np.array_equal(self._theta_in_problem, self.gain_correction)
            ):  # G follows the disturbance forecast (A_k = A + Σ v_j Bxv_j) or the input-gain correction
                self._problem.update_G(G)
            if s.gain_adapt > 0.0:
                self._theta_in_problem = self.gain_correction
            self._problem.set_previous(self._u_prev())
            self._set_block_limits()
            sol = self._problem.solve(y0)
            if not sol.found:
                self._keep_failure(y0, x0, V, Qg)
                return self._failed_plan(sol, 1)
            X = self.pred.simulate(x0, sol.U, V, Qg)
            return Plan(True, sol.status, sol.U, sol.eps, X, X @ self.pred.C.T, sol.obj, 1, True, sol.solve_time)
        # bilinear: sequential convex programming
        shifted = self._shifted_plan()
        Ubar = _blocked(shifted, self.lengths) if shifted is not None else np.tile(self.u_min, (self.N, 1))
        Xbar = self.pred.simulate(x0, Ubar, V, Qg)
        self._Y_held = None
        if s.gain_adapt > 0.0 and not np.all(self.gain_correction == 1.0):
            held = self.pred.simulate(x0, np.tile(self._u_prev(), (self.N, 1)), V, Qg)
            self._Y_held = held[1:] @ self.pred.C.T
        solve_time, best, converged, it, last_delta, last_step = 0.0, None, False, 0, np.inf, None
        for it in range(1, s.max_iter + 1):
            sol, y0 = self._solve_linearised(x0, V, Qg, Xbar, Ubar, s.linearisation)
            solve_time += sol.solve_time
            if not sol.found and s.linearisation == "newton":
                # the full linearisation can be ill-conditioned (solver: numerical error); the frozen one is
                # the paper's and always convex: solve that instead, and count it
                sol, y0 = self._solve_linearised(x0, V, Qg, Xbar, Ubar, "frozen")
                solve_time += sol.solve_time
                self.n_frozen_fallbacks += 1
            if not sol.found:
                self._keep_failure(y0, x0, V, Qg)
                break
            X = self.pred.simulate(x0, sol.U, V, Qg)
            delta = float(np.max(np.abs(sol.U - Ubar)))
            merit = self.merit(sol.U, X)
            if best is None or merit <= best[2] or delta < s.tol:
                best = (sol, X, merit)
            if delta < s.tol:
                converged = True
                break
            step = sol.U - Ubar
            # oscillating (the change reverses) or not contracting: the next reference halfway
            if delta >= 0.9 * last_delta or (last_step is not None and float(np.sum(step * last_step)) < 0.0):
                Ubar = Ubar + 0.5 * step
                Xbar = self.pred.simulate(x0, Ubar, V, Qg)
                step = 0.5 * step
            else:
                Ubar, Xbar = sol.U, X
            last_delta, last_step = delta, step
        if best is None:
            return self._failed_plan(sol, it, solve_time)
        sol, X, merit = best
        return Plan(
            True, sol.status, sol.U, sol.eps, X, X @ self.pred.C.T, sol.obj, it, converged, solve_time, merit=merit
        )

    def _solve_linearised(self, x0, V, Qg, Xbar, Ubar, mode):
        """Solve the convex problem linearised around ``(Xbar, Ubar)`` (``mode``: frozen or newton); (solution, y0)."""
        s = self.settings
        if self.reduced:
            y0, beta, theta = self.pred.reduced_prediction(x0, V, Qg, Xbar=Xbar, Ubar=Ubar, mode=mode, tol=s.rom_tol)
            if self._problem is None:
                rom = self.pred.reduced_model(s.rom_tol)
                self._problem = ReducedProblem(
                    rom["Ar"],
                    rom["Br"],
                    rom["Cr"],
                    rom["D0"],
                    beta,
                    theta,
                    self.u_min,
                    self.u_max,
                    s,
                    self.weights,
                    self.hard,
                    caps=self.schedule,
                )
            else:
                self._problem.update_blocks(beta, theta)
            y0 = self._corrected_reduced(y0, beta)
        else:
            y0, G = self.pred.affine_prediction(x0, V, Qg, self.lengths, Xbar=Xbar, Ubar=Ubar, mode=mode)
            y0, G = self._corrected(y0, G)
            if self._problem is None:
                self._problem = CondensedProblem(
                    G, self.u_min, self.u_max, self.pred.ny, s, weights=self.weights, hard=self.hard, caps=self.schedule
                )
            else:
                self._problem.update_G(G)
        self._problem.set_previous(self._u_prev())
        self._set_block_limits()
        return self._problem.solve(y0), y0

    def _set_block_limits(self) -> None:
        """Limits per block for this step's solve: ``[0, 0]`` for an input off in every step of a block."""
        if self._off is None:
            if getattr(self._problem, "_blocked_limits", False):
                self._problem.set_block_limits()
                self._problem._blocked_limits = False
            return
        starts = np.concatenate([[0], np.cumsum(self.lengths)[:-1]])
        off_b = np.array([self._off[a : a + n].all(axis=0) for a, n in zip(starts, self.lengths)])
        lo = np.where(off_b, 0.0, self.u_min[None, :])
        hi = np.where(off_b, 0.0, self.u_max[None, :])
        self._problem.set_block_limits(lo, hi)
        self._problem._blocked_limits = True

    def merit(self, U, X) -> float:
        """The problem's cost of moves U (N, nu) evaluated on the exact model trajectory X (N+1, nx).

        ``Σ ||u||² + ρ ||eps|| + comfort_penalty Σ band violation`` with the slack
        ``eps`` the moves' actual excess over the limits (shared: the largest
        per input; per step: every step's) and the band violation of the
        simulated outputs, not of the linearisation. A hard band weighs its
        violation by 1e6. Sequential iterations that stop before converging
        return the iterate with the lowest merit (the best plan found).
        """
        s = self.settings
        exc = np.maximum(0.0, np.maximum(U - self.u_max, self.u_min - U))
        eps = exc.max(axis=0) if s.slack == "shared" else exc.ravel()
        pen = float(np.linalg.norm(eps)) if s.formulation == "socp" else float(eps.sum())
        Y = X[1:] @ self.pred.C.T
        if self._Y_held is not None:  # the input-gain correction: the change from the held move scaled by θ
            Y = self._Y_held + self.gain_correction * (Y - self._Y_held)
        lo, hi = s.band
        viol = float(np.sum(np.maximum(0.0, np.maximum(Y - hi, lo - Y))))
        weight = s.comfort_penalty if s.comfort_penalty is not None else 1e6
        move = 0.0
        if s.move_penalty > 0.0:
            Ub = U[_block_starts(self.lengths)]
            prev = self._u_prev()[None]
            move = s.move_penalty * float(np.sum(self.weights * np.diff(np.vstack([prev, Ub]), axis=0) ** 2))
        return float(np.sum(self.weights * U**2)) + s.rho * pen + weight * viol + move

    def _u_prev(self) -> np.ndarray:
        """The move applied at the previous step (the lower limits before the first step), for the move penalty."""
        return self._last[0] if self._last is not None else np.clip(np.zeros(self.pred.nu), self.u_min, self.u_max)

    def _failed_plan(self, sol, it, solve_time=None):
        nan = np.full((self.N + 1, self.pred.nx), np.nan)
        return Plan(
            False,
            sol.status,
            np.full((self.N, self.pred.nu), np.nan),
            sol.eps,
            nan,
            nan @ self.pred.C.T,
            float("nan"),
            it,
            False,
            sol.solve_time if solve_time is None else solve_time,
        )

    def _keep_failure(self, y0, x0, V, Qg):
        arrays = self._problem.snapshot(y0, step=self.k, x0=x0, V=V, Qg=Qg)
        if self.failure_dir is not None:
            self.failed_problems.append(save_problem(self.failure_dir / f"failure_{self.k:05d}.npz", arrays))
        else:
            self.failed_problems.append(arrays)

    # ----- statistics ---------------------------------------------------------
    def stats(self) -> dict:
        """Solve-time, iteration and limit statistics over the steps so far.

        ``projected_steps``: steps whose planned move used the softened input
        limits and was projected onto ``[u_min, u_max]`` (by more than
        :attr:`PROJECT_TOL`); ``projected_max``
        [kg/s] the largest difference of one input, ``projected_sum``
        [kg/s · steps] the summed differences.
        ``solver_fallbacks``: dense (DAQP) solves that failed and were solved
        again by clarabel (:mod:`harness.mpc.dense`).
        """
        st = np.array([p.step_time for p in self.plans]) if self.plans else np.zeros(1)
        it = np.array([p.iterations for p in self.plans]) if self.plans else np.zeros(1)
        return {
            "steps": len(self.plans),
            "failures": self.n_failures,
            "frozen_fallbacks": self.n_frozen_fallbacks,
            "solver_fallbacks": int(getattr(self._problem, "n_solver_fallbacks", 0)),
            "not_converged": int(sum(1 for p in self.plans if p.found and not p.converged)),
            "projected_steps": self.n_projected,
            "projected_max": self.projected_max,
            "projected_sum": self.projected_sum,
            "step_time_median": float(np.median(st)),
            "step_time_max": float(np.max(st)),
            "iterations_mean": float(np.mean(it)),
            "input_gain_max": float(np.max(self.theta)),  # estimated
            "input_gain_engaged": int(np.sum(self._engaged)),  # outputs whose prediction it scales now
        } | ({"off_steps": self.n_off_steps} if self.n_off_steps else {})


def input_mapping(model):
    """``(vavs, input_map)`` of a model whose inputs aggregate boxes (Model A, and extended models
    through their base), or None when the inputs are the boxes themselves (``m_<vav>``)."""
    for m in (model, getattr(model, "base", None)):
        if m is not None and hasattr(m, "input_map") and hasattr(m, "vavs"):
            return tuple(m.vavs), np.asarray(m.input_map, dtype=float)
    return None


def input_limits(model, building=None):
    """Input limits (u_min, u_max) [kg/s] of a model from its building's VAV boxes.

    Model A sums the limits of the boxes behind each input (``input_map``);
    models whose inputs are ``m_<vav>`` take the box limits directly. A model
    carrying ``m_min``/``m_max`` arrays (the synthetic RC network) needs no building.
    """
    if building is None:
        if hasattr(model, "m_min") and hasattr(model, "m_max"):
            return np.asarray(model.m_min, dtype=float), np.asarray(model.m_max, dtype=float)
        raise ModelError("input limits need the building (VAV m_min/m_max)")
    boxes = {v.name: v for v in building.vavs}
    mapped = input_mapping(model)
    if mapped is not None:
        vavs, input_map = mapped
        missing = [b for b in vavs if b not in boxes]
        if missing:
            raise ModelError(f"model VAV boxes {missing} are not in building {building.name!r}")
        lo = np.array([boxes[b].m_min for b in vavs])
        hi = np.array([boxes[b].m_max for b in vavs])
        return input_map @ lo, input_map @ hi
    names = [n[2:] if n.startswith("m_") else n for n in model.inputs]
    missing = [n for n in names if n not in boxes]
    if missing:
        raise ModelError(f"model inputs {missing} are not VAV boxes of building {building.name!r}")
    return np.array([boxes[n].m_min for n in names]), np.array([boxes[n].m_max for n in names])


# --------------------------------------------------------------------------
# pure-Python closed loop
# --------------------------------------------------------------------------
@dataclasses.dataclass
class ClosedLoopResult:
    """A closed-loop run.

    Attributes
    ----------
    u : array (n, nu) [kg/s] applied airflows
    y : array (n+1, ny) [°C] measured outputs (row 0 is the initial measurement)
    x : array (n+1, nx) plant states
    step_time : array (n,) [s] controller time per step
    iterations : array (n,) convex iterations per step
    fallback : array (n,) bool, step used the previous plan
    u_min, u_max : arrays (nu,) [kg/s]
    T_min, T_max : float [°C]
    rho : float
    step : float [s]
    """

    u: np.ndarray
    y: np.ndarray
    x: np.ndarray
    step_time: np.ndarray
    iterations: np.ndarray
    fallback: np.ndarray
    u_min: np.ndarray
    u_max: np.ndarray
    T_min: float
    T_max: float
    rho: float
    step: float
    inputs: tuple = ()
    outputs: tuple = ()

    @property
    def input_excess(self) -> np.ndarray:
        """Applied violation of the input limits (n, nu) [kg/s]."""
        return np.maximum(0.0, np.maximum(self.u - self.u_max, self.u_min - self.u))

    @property
    def energy(self) -> float:
        """Energy proxy Σ_k ||u(k)||² [(kg/s)²]."""
        return float(np.sum(self.u**2))

    @property
    def airflow(self) -> float:
        """Total supplied air Σ_k Σ_i u_i(k) · step [kg]."""
        return float(np.sum(self.u) * self.step)

    @property
    def cost(self) -> float:
        """Paper's cost of the applied moves: Σ_k (||u(k)||² + ρ ||ε(k)||₂)."""
        return self.energy + self.rho * float(np.sum(np.linalg.norm(self.input_excess, axis=1)))

    @property
    def violation_Kh(self) -> float:
        """Comfort violation Σ_k Σ_zones max(0, y - T_max, T_min - y) · step / 3600 [K·h]."""
        y = self.y[1:]
        v = np.maximum(0.0, np.maximum(y - self.T_max, self.T_min - y))
        return float(v.sum() * self.step / 3600.0)

    def summary(self) -> dict:
        return {
            "steps": int(self.u.shape[0]),
            "cost": self.cost,
            "energy_sum_u2": self.energy,
            "airflow_kg": self.airflow,
            "comfort_violation_Kh": self.violation_Kh,
            "input_excess_max": float(self.input_excess.max(initial=0.0)),
            "step_time_median_s": float(np.median(self.step_time)),
            "step_time_max_s": float(np.max(self.step_time)),
            "step_time_total_s": float(np.sum(self.step_time)),
            "iterations_mean": float(np.mean(self.iterations)),
            "failures": int(np.sum(self.fallback)),
        }

    def to_pandas(self) -> pd.DataFrame:
        """One row per step: applied airflows, outputs after the step, controller time."""
        cols = {}
        ins = self.inputs or tuple(f"u{i}" for i in range(self.u.shape[1]))
        outs = self.outputs or tuple(f"y{i}" for i in range(self.y.shape[1]))
        for i, n in enumerate(ins):
            cols[n] = self.u[:, i]
        for j, n in enumerate(outs):
            cols[f"T_{n}"] = self.y[1:, j]
        cols["step_time"] = self.step_time
        cols["iterations"] = self.iterations
        cols["fallback"] = self.fallback
        return pd.DataFrame(cols, index=pd.RangeIndex(self.u.shape[0], name="k"))


def closed_loop(controller: MPCController, plant, x0, V, Qg, n_steps, *, noise_std=0.0, seed=0) -> ClosedLoopResult:
    """Run ``controller`` against ``plant`` (a model used as its own plant) for ``n_steps``.

    Parameters
    ----------
    controller : MPCController
    plant : object with ``step_state(x, u, v, q)`` and ``output(x)`` (any zone model)
    x0 : array (nx_plant,) initial plant state
    V : array (n_steps + N, nv) disturbances (the controller sees them as a perfect preview)
    Qg : array (n_steps + N, nq) internal gains
    n_steps : int
    noise_std : float [K] measurement noise added to the outputs the controller sees
    seed : int

    Returns
    -------
    ClosedLoopResult
    """
    rng = np.random.default_rng(seed)
    V, Qg = np.asarray(V, dtype=float), np.asarray(Qg, dtype=float)
    if V.shape[0] < n_steps or Qg.shape[0] < n_steps:
        raise ModelError(f"need disturbances for {n_steps} steps, got {V.shape[0]} and {Qg.shape[0]}")
    nu = controller.pred.nu
    x = np.asarray(x0, dtype=float)
    X = np.empty((n_steps + 1, x.size))
    Y = np.empty((n_steps + 1, np.size(plant.output(x))))
    U = np.empty((n_steps, nu))
    X[0], Y[0] = x, plant.output(x)
    fallback = np.zeros(n_steps, dtype=bool)
    for k in range(n_steps):
        y_meas = Y[k] + (rng.normal(0.0, noise_std, Y.shape[1]) if noise_std > 0 else 0.0)
        before = controller.n_failures
        U[k] = controller.step(y_meas, V[k : k + controller.N], Qg[k : k + controller.N])
        fallback[k] = controller.n_failures > before
        x = plant.step_state(x, U[k], V[k], Qg[k])
        X[k + 1], Y[k + 1] = x, plant.output(x)
    plans = controller.plans[-n_steps:]
    s = controller.settings
    return ClosedLoopResult(
        u=U,
        y=Y,
        x=X,
        step_time=np.array([p.step_time for p in plans]),
        iterations=np.array([p.iterations for p in plans]),
        fallback=fallback,
        u_min=controller.u_min,
        u_max=controller.u_max,
        T_min=float(np.min(s.T_min)),
        T_max=float(np.max(s.T_max)),
        rho=s.rho,
        step=float(getattr(plant, "step", 900.0)),
        inputs=tuple(getattr(controller.model, "inputs", ())),
        outputs=tuple(getattr(controller.model, "outputs", ())),
    )
