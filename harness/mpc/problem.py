"""The energy-efficient MPC problem of Zhou, Hu & Tomlin as a conic program.

For a prediction that is affine in the airflows over the horizon,

    Y = y0 + G U,        Y = [y(1); ...; y(N)],   U = [u(0); ...; u(N-1)],

the problem (eq. ``ee_controller`` of the paper) is

    min_{U, eps}  Σ_k ||u(k)||² + ρ ||eps||_2
    s.t.          u_min - eps <= u(k) <= u_max + eps      k = 0..N-1
                  T_min <= y(k) <= T_max                  k = 1..N

with ``eps`` one slack per input (it carries no time index in the paper).
Two formulations are assembled from the same rows:

``"socp"``
    the problem as written: ``ρ t`` with ``(t, eps)`` in a second-order cone,
    solved with clarabel's own API (problem data are updated in place between
    steps when only the right-hand side changes).
``"qp"``
    the exact-penalty QP ``ρ ||eps||_1`` (``eps >= 0``), with clarabel's own
    API too (data updated in place; qpsolvers rebuilt the solver every step).

Both have the same minimiser when the input limits are not violated: if the
SOCP optimum has ``eps = 0``, the hard-limit problem's input-limit multipliers
``μ`` (summed over the horizon, one per input) satisfy ``||μ||_2 <= ρ``, hence
``||μ||_∞ <= ρ``, which is the exactness condition of the ℓ1 penalty; the
cost is strictly convex in ``U``, so the controls coincide.

With ``comfort_penalty`` set, the band becomes ``T_min - s <= y <= T_max + s``,
``s >= 0``, with the exact ℓ1 penalty ``comfort_penalty · Σ s``: the solution
equals the hard-band one whenever that is feasible and its band multipliers
are below the penalty, and a step never fails for an unreachable band. The
initial state is never softened (it is data, not a variable).

Move blocking holds ``u`` constant over blocks of steps (``blocks`` lengths
summing to N); the cost then weights each block value by its length.
``slack="per_step"`` gives every block its own slack (weighted by its length).

The prediction enters as equality rows: :class:`CondensedProblem` writes
``y - G U = y0`` (dense ``G``, horizons up to ~24 steps);
:class:`ReducedProblem` writes the forced response of a reduced-order
state-space model step by step (sparse rows banded in time, long horizons).

References
----------
D. Zhou, Q. Hu, C. J. Tomlin, "Model comparison of a data-driven and a
physical model for simulating HVAC systems", section V.B, eq. (ee_controller).
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import numpy as np
from scipy import sparse

from hvacfmu.errors import SolverError, problems_message

from .dense import DenseQP, daqp_available

FORMULATIONS = ("socp", "qp")
SOLVERS = ("auto", "clarabel", "daqp")
LINEARISATIONS = ("frozen", "newton")


@dataclasses.dataclass(frozen=True)
class MPCSettings:
    """Settings of the energy-efficient MPC.

    Parameters
    ----------
    horizon : int
        Prediction horizon N [steps]. The paper uses 3 (15-minute steps).
    T_min, T_max : float [°C]
        Comfort band on every output (zone temperature) at steps 1..N.
    rho : float
        Penalty on the input-limit slack ``eps`` [1/(kg/s)] (paper: 100).
    formulation : {"socp", "qp"}
        ``"socp"``: ``ρ ||eps||_2`` as a second-order cone (clarabel API);
        ``"qp"``: exact penalty ``ρ ||eps||_1`` (clarabel API).
    comfort_penalty : float or None
        ℓ1 penalty on band violation [1/K per output and step]; ``None`` keeps
        the band hard (a step may then be infeasible and fall back).
    blocks : tuple of int or None
        Move-blocking lengths summing to ``horizon``; ``None`` = every move free.
        ``"auto"`` picks :func:`default_blocks`.
    linearisation : {"frozen", "newton"}
        Bilinear models only. ``"frozen"``: the state in the bilinear terms is
        frozen at the previous predicted trajectory, an exact QP in ``u`` with
        a time-varying input matrix. ``"newton"``: full first-order
        linearisation around the previous iterate (its fixed points are KKT
        points of the bilinear problem).
    max_iter : int
        Sequential convex iterations per step (bilinear models). When an
        iteration reverses the previous change of the plan (an oscillation
        between active sets) or does not contract it, the next reference is
        halfway between the last two plans (same fixed points, damped cycle). A step that meets no ``tol`` within ``max_iter`` applies the
        iterate with the lowest merit and is counted (``not_converged``).
    tol : float [kg/s]
        Converged when the largest change of a planned airflow between two
        iterations is below it.
    solver_tol : float
        clarabel feasibility and gap tolerances.
    u_floor : float or None [kg/s]
        Hard lower bound on every planned airflow (an airflow cannot be
        negative, whatever the slack allows); ``None`` keeps only the paper's
        soft limits.
    prediction : {"auto", "condensed", "reduced"}
        Bilinear models only. ``"condensed"``: exact ``Y = y0 + G U``;
        ``"reduced"``: forced response from a balanced truncation of the
        airflow-to-zone map (sparse rows, linear cost in N; the free response
        and the first step stay exact). ``"auto"``: reduced for N > 24.
    rom_tol : float
        Balanced-truncation tolerance (``2 Σ tail σ <= rom_tol σ_1``).
    slack : {"shared", "per_step"}
        ``"shared"``: one input-limit slack per input for the whole horizon, as
        in the paper (``eps`` has no time index). Over long horizons this lets
        one future step that needs slack open the limits for every step;
        ``"per_step"`` gives every step (block) its own slack, with
        ``||eps||`` taken over all steps.
    move_penalty : float [1/(kg/s)²]
        Weight ``w`` of ``w Σ_j ||u_b(j) - u_b(j-1)||²`` over the blocked moves (each input scaled by
        its cost weight),
        ``u_b(-1)`` the move applied at the previous step (move suppression).
        0 (default) is the paper's cost. A model whose airflow gain is smaller
        than the plant's makes an unpenalised plan swing between the limits
        from step to step (measured on the plant FMU with Model A); a few
        units damp that.
    offset_gain : float
        Offset-free MPC: gain in [0, 1] of the integrating disturbance
        observer (:meth:`~harness.mpc.controller.MPCController.estimate`). Each
        step the one-step prediction error of the measured outputs is added,
        times this gain, to a constant drift of the zone air nodes [K/step]
        that the prediction carries over the horizon; 0 (default) turns it
        off (the model is trusted as it is, right when it is its own plant).
    gain_adapt : float
        Input-gain adaptation rate in [0, 1) (0, default: off). A model whose
        first-step response to a move is several times smaller than the
        plant's makes the plan cycle between the input limits (full reheat,
        then maximum airflow) even with move suppression and the offset
        estimate, which only sees the mean error. With ``gain_adapt`` = r > 0 the
        controller regresses each output's one-step error on the first-step
        effect the model predicted for the last *change* of the moves
        (recursive least squares, forgetting factor 1 - r; steps whose predicted
        effect is under 0.02 K carry no information and are skipped) and scales
        the predicted effect of changing the moves away from the previous one by
        that output's gain ``θ`` in [1, ``gain_max``] once ``θ`` reaches
        ``gain_engage`` (until it falls below halfway back to 1); the response with the
        previous move held stays the model's (plus the offset estimate).
        (:meth:`~harness.mpc.controller.MPCController.estimate`.) Both
        predictions: the condensed ``G`` rows are scaled, and the reduced
        prediction of long horizons scales its forced response
        (:meth:`ReducedProblem.set_output_gain`); the estimator uses the
        first-step effect, which both give exactly.
    gain_max : float
        Largest input-gain correction ``θ`` (default 8).
    gain_engage : float
        The estimated gain from which the correction is applied (default 3): move
        suppression alone damps a plant up to about twice as strong as the model
        (``tests/test_mpc_plant.py``), and Model A on the emulator's plant,
        about half the plant's airflow gain (θ 1.5-2.6 estimated), keeps the
        tuned plans it had.
    back_off : float [K]
        The optimiser keeps the outputs in ``[T_min + back_off, T_max -
        back_off]``: a margin for the plant-model mismatch left after the
        offset correction; the comfort figures still use ``[T_min, T_max]``.
    solver : {"auto", "clarabel", "daqp"}
        ``"clarabel"``: interior point on the sparse form (every case).
        ``"daqp"``: the condensed ``"qp"`` form in dense variables, solved by a
        warm-started dual active-set method (:mod:`harness.mpc.dense`; falls
        back to clarabel, counted, when it fails). ``"auto"`` (default): daqp
        for ``formulation="qp"`` with the condensed prediction when the package
        is installed (measured 15-30x faster on Model A, 2-3x on Model B at
        N = 12, README "MPC"), clarabel otherwise (the SOCP, the reduced
        prediction of long horizons).
    """

    horizon: int = 3
    T_min: float = 20.0
    T_max: float = 22.0
    rho: float = 100.0
    formulation: str = "socp"
    comfort_penalty: float | None = 1.0e4
    blocks: tuple | str | None = None
    linearisation: str = "frozen"
    max_iter: int = 10
    tol: float = 1.0e-4
    solver_tol: float = 1.0e-8
    u_floor: float | None = 0.0
    prediction: str = "auto"
    rom_tol: float = 1.0e-3
    slack: str = "shared"
    move_penalty: float = 0.0
    offset_gain: float = 0.0
    back_off: float = 0.0
    solver: str = "auto"
    gain_adapt: float = 0.0
    gain_max: float = 8.0
    gain_engage: float = 3.0

    def __post_init__(self):
        problems = []
        if not (isinstance(self.horizon, (int, np.integer)) and self.horizon >= 1):
            problems.append(f"horizon must be an integer >= 1, got {self.horizon!r}")
        if not self.T_min < self.T_max:
            problems.append(f"need T_min < T_max, got [{self.T_min}, {self.T_max}] °C")
        if not self.rho > 0:
            problems.append(f"rho must be > 0, got {self.rho}")
        if self.formulation not in FORMULATIONS:
            problems.append(f"formulation must be one of {FORMULATIONS}, got {self.formulation!r}")
        if self.linearisation not in LINEARISATIONS:
            problems.append(f"linearisation must be one of {LINEARISATIONS}, got {self.linearisation!r}")
        if self.comfort_penalty is not None and not self.comfort_penalty > 0:
            problems.append(f"comfort_penalty must be > 0 or None, got {self.comfort_penalty}")
        if not (isinstance(self.max_iter, (int, np.integer)) and self.max_iter >= 1):
            problems.append(f"max_iter must be an integer >= 1, got {self.max_iter!r}")
        if not self.tol > 0 or not self.solver_tol > 0:
            problems.append(f"tol and solver_tol must be > 0, got {self.tol}, {self.solver_tol}")
        if self.prediction not in ("auto", "condensed", "reduced"):
            problems.append(f"prediction must be 'auto', 'condensed' or 'reduced', got {self.prediction!r}")
        if self.slack not in ("shared", "per_step"):
            problems.append(f"slack must be 'shared' or 'per_step', got {self.slack!r}")
        if not 0 < self.rom_tol < 1:
            problems.append(f"rom_tol must be in (0, 1), got {self.rom_tol}")
        if not (np.isfinite(self.move_penalty) and self.move_penalty >= 0.0):
            problems.append(f"move_penalty must be finite and >= 0, got {self.move_penalty}")
        if not 0.0 <= self.offset_gain <= 1.0:
            problems.append(f"offset_gain must be in [0, 1], got {self.offset_gain}")
        if not 0.0 <= self.gain_adapt < 1.0:
            problems.append(f"gain_adapt must be in [0, 1), got {self.gain_adapt}")
        if not (np.isfinite(self.gain_max) and self.gain_max >= 1.0):
            problems.append(f"gain_max must be finite and >= 1, got {self.gain_max}")
        if not 1.0 <= self.gain_engage <= self.gain_max:
            problems.append(f"gain_engage must be in [1, gain_max], got {self.gain_engage}")
        if not (self.back_off >= 0.0 and 2.0 * self.back_off < np.min(np.subtract(self.T_max, self.T_min))):
            problems.append(f"back_off must be >= 0 K and leave a band: 2 x {self.back_off} K >= T_max - T_min")
        if self.solver not in SOLVERS:
            problems.append(f"solver must be one of {SOLVERS}, got {self.solver!r}")
        elif self.solver == "daqp" and self.formulation != "qp":
            problems.append("solver 'daqp' needs formulation='qp' (the SOCP's cone is not a QP)")
        if self.u_floor is not None and not np.isfinite(self.u_floor):
            problems.append(f"u_floor must be finite or None, got {self.u_floor}")
        if self.blocks is not None and self.blocks != "auto" and not problems:
            b = tuple(int(x) for x in self.blocks)
            if any(x < 1 for x in b) or sum(b) != self.horizon:
                problems.append(f"blocks {b} must be positive and sum to the horizon {self.horizon}")
        if problems:
            raise SolverError(problems_message("invalid MPC settings", problems))

    @property
    def band(self) -> tuple:
        """The band the optimiser holds, ``(T_min + back_off, T_max - back_off)`` [°C]."""
        return (
            np.asarray(self.T_min, dtype=float) + self.back_off,
            np.asarray(self.T_max, dtype=float) - self.back_off,
        )

    @property
    def block_lengths(self) -> tuple:
        """Move-blocking lengths actually used (all ones without blocking)."""
        if self.blocks is None:
            return (1,) * self.horizon
        if self.blocks == "auto":
            return default_blocks(self.horizon)
        return tuple(int(x) for x in self.blocks)

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["blocks"] = list(self.block_lengths)
        return d


def default_blocks(horizon: int, first_free: int = 2, max_len: int = 8) -> tuple:
    """Move blocks 1, 1, 2, 4, 8, 8, ... covering ``horizon`` steps.

    The first ``first_free`` moves are free; later blocks double in length up
    to ``max_len`` steps; the last takes the remainder. ``default_blocks(96)``
    gives 15 blocks instead of 96 moves. Longer blocks were measured to hurt:
    with 32-step blocks a short need for slack far ahead is paid over the
    whole block, so the plan pre-empts it with the free early moves (applied
    input-limit excess about 8x larger over 150 steps at N = 96).
    """
    out = [1] * min(max(int(first_free), 1), horizon)
    total = len(out)
    while total < horizon:
        take = min(2 * out[-1], int(max_len), horizon - total)
        out.append(take)
        total += take
    return tuple(out)


def blocking_index(block_lengths) -> np.ndarray:
    """Block number of every step of the horizon."""
    return np.repeat(np.arange(len(block_lengths)), block_lengths)


@dataclasses.dataclass
class QPSolution:
    """Outcome of one condensed solve (qpsolvers ``Solution`` in spirit)."""

    found: bool
    status: str
    U: np.ndarray  #: (N, nu) planned airflows [kg/s] (block values repeated)
    eps: np.ndarray  #: (nu,) input-limit slack [kg/s], or (N, nu) with ``slack="per_step"``
    s: np.ndarray  #: (N, ny) comfort slack [K] (zeros for a hard band)
    Y: np.ndarray  #: (N, ny) [°C] outputs predicted by the problem's (linearised) model
    obj: float  #: Σ u² + ρ||eps|| (+ comfort penalty)
    solve_time: float  #: wall time of the solver call [s]
    z: np.ndarray | None = None  #: raw solver variables
    solver: str = "clarabel"  #: which solver produced it ("daqp": the dense active-set path)


class _MPCProblem:
    """The MPC problem with the prediction as equality rows; subclasses define those rows.

    Variables ``z = [U_b (n_blocks*nu), eps (one per softened input, or per block and softened input
    with ``slack="per_step"``; none for ``hard`` inputs), t (socp only), s (N*ny, soft band only),
    y (N*ny), extra]``; constraints ``A z + slack = b`` with ``slack`` in the
    zero cone (prediction rows), the nonnegative cone (limits, band) and, for
    ``"socp"``, the second-order cone ``(t, eps)``. Only the prediction rows'
    right-hand side depends on the current state; matrix blocks that change
    between solves (a new linearisation) keep fixed slots in ``A.data``, so
    clarabel's data are updated in place and its symbolic factorisation reused.
    """

    n_extra = 0
    #: [kg/s] the cap of an open U entry (no schedule limit)
    CAP_OPEN = 1.0e6
    _blocked_limits = False  # set_block_limits gave limits other than u_min/u_max (the building's schedule)

    def __init__(self, u_min, u_max, ny, settings: MPCSettings, problems=(), weights=None, hard=None, caps=False):
        self.settings = settings
        # hard upper caps per U entry (rows U <= cap, cap = CAP_OPEN unless set_block_limits closes a block): the
        # building's schedule, where an input that is off must stay at 0 even when the softened limits' shared
        # slack is in use elsewhere
        self.caps = bool(caps)
        self.lengths = np.asarray(settings.block_lengths)
        self.N, self.nb = int(self.lengths.sum()), len(self.lengths)
        self.u_min = np.asarray(u_min, dtype=float).ravel()
        self.u_max = np.asarray(u_max, dtype=float).ravel()
        self.nu, self.ny = self.u_min.size, int(ny)
        problems = list(problems)
        if self.u_max.shape != self.u_min.shape:
            problems.append(f"u_min has {self.u_min.size} entries, u_max {self.u_max.size}")
        elif np.any(self.u_min > self.u_max):
            problems.append(f"u_min > u_max for inputs {np.flatnonzero(self.u_min > self.u_max).tolist()}")
        self.hard = np.zeros(self.nu, dtype=bool) if hard is None else np.asarray(hard, dtype=bool).ravel()
        if self.hard.shape != (self.nu,):
            problems.append(f"hard has {self.hard.size} entries, expected one per input ({self.nu})")
        if problems:
            raise SolverError(problems_message("invalid MPC problem", problems))
        self.soft = settings.comfort_penalty is not None
        self.socp = settings.formulation == "socp"
        nU, nu, nY = self.nb * self.nu, self.nu, self.N * self.ny
        self.per_step = settings.slack == "per_step"
        # inputs with softened limits (the paper's eps); hard inputs keep u_min <= u <= u_max as it is
        self.soft_inputs = np.flatnonzero(~self.hard)
        ns = self.soft_inputs.size
        self.ne = self.nb * ns if self.per_step else ns  # slack entries: per block and soft input, or per soft input
        # weight of each slack entry: the number of steps it covers (per_step), so ||eps|| is over steps
        self.eps_w = np.repeat(self.lengths, ns).astype(float) if self.per_step else np.ones(ns)
        # the U entries (block-major, ascending) whose limits are softened: one row each, per side
        self.soft_entries = (np.arange(self.nb)[:, None] * nu + self.soft_inputs[None, :]).ravel()
        self.i_eps = nU
        self.i_t = nU + self.ne
        self.i_s = self.i_t + (1 if self.socp else 0)
        self.i_y = self.i_s + (nY if self.soft else 0)
        self.i_x = self.i_y + nY
        self.nz = self.i_x + self.n_extra
        pdiag = np.zeros(self.nz)
        self.weights = np.ones(nu) if weights is None else np.asarray(weights, dtype=float).ravel()
        if self.weights.shape != (nu,) or not np.all(self.weights > 0.0):
            raise SolverError(f"input weights must be {nu} positive numbers, got {self.weights!r}")
        pdiag[:nU] = 2.0 * np.repeat(self.lengths, nu) * np.tile(self.weights, self.nb)
        self.P = sparse.diags(pdiag, format="csc")
        self.w_move = float(settings.move_penalty)
        if self.w_move > 0.0:  # w Σ ||u_b(j) - u_b(j-1)||², u_b(-1) = the previous move (linear term, set_previous)
            D = sparse.eye(self.nb) - sparse.eye(self.nb, k=-1)
            PU = 2.0 * self.w_move * sparse.kron(D.T @ D, sparse.diags(self.weights))
            self.P = (self.P + sparse.block_diag([PU, sparse.csc_matrix((self.nz - nU, self.nz - nU))])).tocsc()
        self.q = np.zeros(self.nz)
        if self.socp:
            self.q[self.i_t] = settings.rho
        else:
            self.q[self.i_eps : self.i_eps + self.ne] = settings.rho * self.eps_w
        if self.soft:
            self.q[self.i_s : self.i_y] = settings.comfort_penalty
        lo, hi = settings.band
        self.T_min = np.array(np.broadcast_to(lo, (self.N, self.ny))).ravel()
        self.T_max = np.array(np.broadcast_to(hi, (self.N, self.ny))).ravel()
        self._solver = None
        self._A_changed = False
        self._q_changed = False
        self._move_const = 0.0

    def set_previous(self, u_prev) -> None:
        """The move applied at the previous step (nu,) [kg/s], for the move penalty (no effect without it)."""
        if self.w_move <= 0.0:
            return
        u_prev = np.asarray(u_prev, dtype=float).ravel()
        self.q[: self.nu] = -2.0 * self.w_move * self.weights * u_prev
        self._move_const = self.w_move * float(self.weights @ u_prev**2)
        self._q_changed = True

    # ----- assembly ------------------------------------------------------
    def _prediction_rows(self, put, slot):
        """Add the zero-cone prediction rows; return their count. ``slot(name)`` marks the next ``put`` as updatable."""
        raise NotImplementedError

    def _prediction_rhs(self, y0) -> np.ndarray:
        raise NotImplementedError

    def _assemble(self):
        nU, nY = self.nb * self.nu, self.N * self.ny
        rows, cols, vals = [], [], []
        self._slots = {}
        state = {"r0": 0, "n": 0}

        def put(r, c, v):
            r, c = np.asarray(r), np.asarray(c)
            rows.append(r + state["r0"])
            cols.append(c)
            v = np.asarray(v, dtype=float)
            vals.append(v.ravel() if v.size == r.size else np.broadcast_to(v, r.shape).ravel())
            state["n"] += r.size

        def slot(name):
            self._slots.setdefault(name, []).append(state["n"])

        n_eq = self._prediction_rows(put, slot)
        state["r0"] = n_eq
        self.n_eq = n_eq
        iU = np.arange(nU)
        rows_eps, cols_eps = self.soft_entries, self.eps_columns()
        iY = np.arange(nY)
        put(iU, iU, 1.0)  # U - eps <= u_max (hard inputs: U <= u_max)
        put(rows_eps, cols_eps, -1.0)
        state["r0"] += nU
        put(iU, iU, -1.0)  # -U - eps <= -u_min
        put(rows_eps, cols_eps, -1.0)
        state["r0"] += nU
        put(np.arange(self.ne), self.i_eps + np.arange(self.ne), -1.0)  # -eps <= 0
        state["r0"] += self.ne
        for sign in (1.0, -1.0):  # ±y - s <= ±T_max/min
            put(iY, self.i_y + iY, sign)
            if self.soft:
                put(iY, self.i_s + iY, -1.0)
            state["r0"] += nY
        if self.soft:
            put(iY, self.i_s + iY, -1.0)  # -s <= 0
            state["r0"] += nY
        if self.settings.u_floor is not None:
            put(iU, iU, -1.0)  # -U <= -u_floor
            state["r0"] += nU
        if self.caps:
            put(iU, iU, 1.0)  # U <= cap (hard; the schedule's off blocks)
            state["r0"] += nU
        self.n_nonneg = state["r0"] - n_eq
        if self.socp:  # (t, eps) in the second-order cone
            put(np.array([0]), np.array([self.i_t]), -1.0)
            put(1 + np.arange(self.ne), self.i_eps + np.arange(self.ne), -np.sqrt(self.eps_w))
            state["r0"] += 1 + self.ne
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        self._coo_data = np.concatenate(vals).astype(float)
        tag = sparse.csc_matrix((np.arange(1, rows.size + 1, dtype=float), (rows, cols)), shape=(state["r0"], self.nz))
        tag.sort_indices()
        if tag.nnz != rows.size:
            raise SolverError("internal error: duplicate entries in the MPC constraint matrix")
        self._perm = tag.data.astype(np.int64) - 1  # A.data = coo_data[perm]
        self.A = sparse.csc_matrix((self._coo_data[self._perm], tag.indices, tag.indptr), shape=tag.shape)
        self._b_const = np.concatenate(
            [
                np.tile(self.u_max, self.nb),
                -np.tile(self.u_min, self.nb),
                np.zeros(self.ne),
                self.T_max,
                -self.T_min,
                np.zeros(nY if self.soft else 0),
                np.full(nU if self.settings.u_floor is not None else 0, -(self.settings.u_floor or 0.0)),
                np.full(nU if self.caps else 0, self.CAP_OPEN),
                np.zeros(1 + self.ne if self.socp else 0),
            ]
        )

    def eps_columns(self) -> np.ndarray:
        """The slack variable (column of ``z``) in the softened limit row of each of :attr:`soft_entries`: its own
        (per step), or its input's in every block (shared)."""
        per_row = np.arange(self.ne) if self.per_step else np.tile(np.arange(self.soft_inputs.size), self.nb)
        return self.i_eps + per_row

    def full_eps(self, eps) -> np.ndarray:
        """Slack values per input: (nu,) shared or (N, nu) per step, zero for hard inputs."""
        if self.per_step:
            out = np.zeros(self.nb * self.nu)
            out[self.soft_entries] = eps
            return np.repeat(out.reshape(self.nb, self.nu), self.lengths, axis=0)
        out = np.zeros(self.nu)
        out[self.soft_inputs] = eps
        return out

    def _update_slots(self, **blocks):
        for name, values in blocks.items():
            v = np.asarray(values, dtype=float).ravel()
            for start in self._slots[name]:
                self._coo_data[start : start + v.size] = v
        self.A.data[:] = self._coo_data[self._perm]
        self._A_changed = True

    def set_block_limits(self, lo=None, hi=None) -> None:
        """Input limits per block ``(nb, nu)`` [kg/s] for the next solves (None: ``u_min``/``u_max`` in every block).

        The building's schedule (:mod:`harness.schedule`): an input whose boxes are all off in a block gets
        ``[0, 0]`` there, so the plan knows the unit will be off. Call before :meth:`solve`. A problem built
        with ``caps=True`` makes a block whose ``hi`` is 0 hard (``U <= 0`` without slack).
        """
        nU = self.nb * self.nu
        lo = np.tile(self.u_min, self.nb) if lo is None else np.asarray(lo, dtype=float).ravel()
        hi = np.tile(self.u_max, self.nb) if hi is None else np.asarray(hi, dtype=float).ravel()
        if lo.size != nU or hi.size != nU or np.any(lo > hi):
            raise SolverError(f"block limits must be two ({self.nb}, {self.nu}) arrays with lo <= hi")
        if not hasattr(self, "_b_const"):
            self._assemble()
        self._b_const[:nU] = hi
        self._b_const[nU : 2 * nU] = -lo
        if self.caps:
            i0 = 2 * nU + self.ne + 2 * self.N * self.ny + (self.N * self.ny if self.soft else 0)
            i0 += nU if self.settings.u_floor is not None else 0
            self._b_const[i0 : i0 + nU] = np.where(hi <= 0.0, 0.0, self.CAP_OPEN)
        dense = getattr(self, "dense", None)
        if dense is not None:
            dense.set_limits(lo, hi)

    def rhs(self, y0) -> np.ndarray:
        """Constraint right-hand side ``b`` for the free response ``y0`` (N*ny,) [°C]."""
        return np.concatenate([self._prediction_rhs(np.asarray(y0, dtype=float).ravel()), self._b_const])

    def cones(self):
        import clarabel

        c = [clarabel.ZeroConeT(self.n_eq), clarabel.NonnegativeConeT(self.n_nonneg)]
        if self.socp:
            c.append(clarabel.SecondOrderConeT(1 + self.ne))
        return c

    def _clarabel_settings(self):
        import clarabel

        s = clarabel.DefaultSettings()
        s.verbose = False
        s.presolve_enable = False  # keep rows fixed so b can be updated in place
        s.direct_solve_method = "qdldl"
        s.tol_feas = s.tol_gap_abs = s.tol_gap_rel = self.settings.solver_tol
        return s

    # ----- solving -------------------------------------------------------
    def solve(self, y0) -> QPSolution:
        """Solve for the free response ``y0`` (N*ny,) [°C]; never raises on solver failure."""
        b = self.rhs(y0)
        return self._solve_clarabel(b)

    def _solve_clarabel(self, b) -> QPSolution:
        import clarabel

        t0 = time.perf_counter()
        try:
            if self._solver is None:
                self._solver = clarabel.DefaultSolver(
                    sparse.triu(self.P, format="csc"), self.q, self.A, b, self.cones(), self._clarabel_settings()
                )
            else:
                data = {"b": b}
                if self._A_changed:
                    data["A"] = self.A.data.copy()
                if self._q_changed:
                    data["q"] = self.q.copy()
                self._solver.update(**data)
            self._A_changed = self._q_changed = False
            res = self._solver.solve()
            status = str(res.status)
            z = np.asarray(res.x, dtype=float)
        except BaseException as exc:  # noqa: BLE001 - a failed step must not stop the week
            if isinstance(exc, (KeyboardInterrupt, SystemExit)):
                raise
            self._solver = None
            status, z = f"exception: {exc}", np.full(self.nz, np.nan)
        dt = time.perf_counter() - t0
        found = status in ("Solved", "AlmostSolved") and bool(np.all(np.isfinite(z)))
        return self._solution(found, status, z, dt)

    def _solution(self, found, status, z, dt) -> QPSolution:
        nU, nu = self.nb * self.nu, self.nu
        Ub = z[:nU].reshape(self.nb, nu)
        U = np.repeat(Ub, self.lengths, axis=0)
        eps = z[self.i_eps : self.i_eps + self.ne]
        s = z[self.i_s : self.i_y].reshape(self.N, self.ny) if self.soft else np.zeros((self.N, self.ny))
        obj = 0.5 * float(z @ (self.P @ z)) + float(self.q @ z) + self._move_const if found else float("nan")
        if found and self.socp:  # report ρ||eps||_2 itself, not the cone variable t
            obj += self.settings.rho * (float(np.linalg.norm(np.sqrt(self.eps_w) * eps)) - float(z[self.i_t]))
        eps = self.full_eps(eps)  # per input (nu,), or per step (N, nu) like U
        Y = z[self.i_y : self.i_x].reshape(self.N, self.ny)
        return QPSolution(found, status, U, eps, s, Y, obj, dt, z)

    # ----- replay --------------------------------------------------------
    def snapshot(self, y0, **context) -> dict:
        """Arrays that reproduce this problem exactly (for :func:`save_problem`)."""
        A = self.A.tocsc()
        out = {
            "P_data": self.P.data,
            "P_indices": self.P.indices,
            "P_indptr": self.P.indptr,
            "P_shape": np.array(self.P.shape),
            "q": self.q,
            "A_data": A.data,
            "A_indices": A.indices,
            "A_indptr": A.indptr,
            "A_shape": np.array(A.shape),
            "b": self.rhs(y0),
            "n_zero": np.array(self.n_eq),
            "n_nonneg": np.array(self.n_nonneg),
            "n_soc": np.array(1 + self.ne if self.socp else 0),
            "settings_json": np.array(json.dumps(self.settings.to_dict())),
        }
        for k, v in context.items():
            out[f"ctx_{k}"] = np.asarray(v)
        return out


class CondensedProblem(_MPCProblem):
    """The MPC problem for the condensed prediction ``Y = y0 + G U_b``.

    Parameters
    ----------
    G : array (N*ny, n_blocks*nu)
        Output sensitivity to the blocked moves [K/(kg/s)].
    u_min, u_max : array (nu,) [kg/s]
        Input limits (softened by ``eps``).
    ny : int
        Number of outputs.
    settings : MPCSettings
    weights : array (nu,) or None
        Weight of each input in the cost ``Σ_k Σ_i w_i u_i(k)²`` (default ones: the paper's ``Σ ||u||²``;
        reheat inputs [kW] get their own, :mod:`harness.mpc.heating`).

    Notes
    -----
    ``G`` appears once, in the equality rows ``y - G U = y0``; the band acts on
    the sparse variables ``y``. (Writing the band as ``±G U <= ...`` doubles the
    dense block and was 4x slower with clarabel at N = 96.)
    """

    def __init__(self, G, u_min, u_max, ny, settings: MPCSettings, weights=None, hard=None, caps=False):
        G = np.asarray(G, dtype=float)
        super().__init__(u_min, u_max, ny, settings, weights=weights, hard=hard, caps=caps)
        if G.shape != (self.N * self.ny, self.nb * self.nu):
            raise SolverError(f"G has shape {G.shape}, expected {(self.N * self.ny, self.nb * self.nu)}")
        self.G = G
        self._assemble()
        self.dense = DenseQP(self) if self._wants_dense() else None
        self.n_solver_fallbacks = 0  #: dense solves that failed and were solved again with clarabel

    def _wants_dense(self) -> bool:
        s = self.settings.solver
        if s == "daqp":
            return True
        return s == "auto" and not self.socp and daqp_available()

    def set_previous(self, u_prev) -> None:
        super().set_previous(u_prev)
        if self.dense is not None and self.w_move > 0.0:
            self.dense.set_linear_term(self.q[: self.nu])

    def solve(self, y0) -> QPSolution:
        """Solve for the free response ``y0`` (N*ny,) [°C]: the dense active-set path first when enabled
        (``settings.solver``), clarabel when it fails (counted in :attr:`n_solver_fallbacks`); never raises."""
        if self.dense is None:
            return super().solve(y0)
        y0 = np.asarray(y0, dtype=float).ravel()
        found, status, z, fval, dt = self.dense.solve(y0)
        if found:
            nU, ne = self.nb * self.nu, self.ne
            Y = (y0 + self.G @ z[:nU]).reshape(self.N, self.ny)
            s = z[nU + ne :].reshape(self.N, self.ny) if self.soft else np.zeros((self.N, self.ny))
            U = np.repeat(z[:nU].reshape(self.nb, self.nu), self.lengths, axis=0)
            eps = self.full_eps(z[nU : nU + ne])
            return QPSolution(True, "Solved", U, eps, s, Y, fval + self._move_const, dt, z, solver="daqp")
        self.n_solver_fallbacks += 1
        sol = super().solve(y0)
        sol.status = f"{status}; clarabel: {sol.status}"
        sol.solve_time += dt
        return sol

    def _prediction_rows(self, put, slot):
        nY, nU = self.N * self.ny, self.nb * self.nu
        put(np.arange(nY), self.i_y + np.arange(nY), 1.0)
        gr, gc = np.divmod(np.arange(nY * nU), nU)
        slot("G")
        put(gr, gc, -self.G.ravel())
        return nY

    def _prediction_rhs(self, y0):
        return y0

    def update_G(self, G):
        """Replace the output sensitivity in place (bilinear models: a new linearisation)."""
        G = np.asarray(G, dtype=float)
        if G.shape != self.G.shape:
            raise SolverError(f"G has shape {G.shape}, expected {self.G.shape}")
        self._update_slots(G=-G)
        self.G = G
        if self.dense is not None:  # solver="daqp" on a changing G: new data, the active set is kept
            self.dense.update_G(G)


class ReducedProblem(_MPCProblem):
    """The MPC problem with the forced response from a reduced-order state-space model.

    With ``w(k)`` the heat-flow inputs of the reduced model (r per step) and
    ``u_b(k)`` the move of step k's block, for k = 0..N-1:

        w(k)   = β_k u_b(k) + Θ_k ξ(k)                (Θ_k = 0 for the frozen linearisation)
        ξ(k+1) = A_r ξ(k) + B_r w(k),   ξ(0) = 0
        y(k+1) = y0(k+1) + C_r ξ(k+1) + D_0 w(k)

    All rows are sparse and banded in time (A_r is diagonal in modal
    coordinates), so the cost grows linearly with the horizon, instead of the
    dense (N ny) x (n_blocks nu) block of the condensed form.

    Parameters
    ----------
    Ar : array (nr,) diagonal or (nr, nr);  Br : (nr, r);  Cr : (ny, nr);  D0 : (ny, r)
    beta : array (N, r, nu);  theta : array (N, r, nr) or None
    u_min, u_max, settings, weights : as :class:`CondensedProblem`
    """

    def __init__(
        self, Ar, Br, Cr, D0, beta, theta, u_min, u_max, settings: MPCSettings, weights=None, hard=None, caps=False
    ):
        self.Ar, self.Br = np.asarray(Ar, float), np.asarray(Br, float)
        self.Cr, self.D0 = np.asarray(Cr, float), np.asarray(D0, float)
        self.nr, self.r = self.Br.shape
        self.has_theta = theta is not None
        self.n_extra = settings.horizon * (self.nr + self.r)
        super().__init__(u_min, u_max, self.Cr.shape[0], settings, weights=weights, hard=hard, caps=caps)
        self._beta = np.asarray(beta, float)
        self._theta = None if theta is None else np.asarray(theta, float)
        self._gain = np.ones(self.ny)  # per-output scale of the forced response (set_output_gain)
        self._check_blocks(beta=self._beta, theta=self._theta)
        self._assemble()

    def _check_blocks(self, beta=None, theta=None):
        bad = []
        if beta is not None and beta.shape != (self.N, self.r, self.nu):
            bad.append(f"beta has shape {beta.shape}, expected {(self.N, self.r, self.nu)}")
        if theta is not None and theta.shape != (self.N, self.r, self.nr):
            bad.append(f"theta has shape {theta.shape}, expected {(self.N, self.r, self.nr)}")
        if bad:
            raise SolverError(problems_message("invalid reduced prediction", bad))

    def _prediction_rows(self, put, slot):
        N, nr, r_, ny, nu = self.N, self.nr, self.r, self.ny, self.nu
        blk = np.repeat(np.arange(self.nb), self.lengths)
        i_w = self.i_x + N * nr
        grid = lambda a, b: np.divmod(np.arange(a * b), b)  # noqa: E731
        bi, bj = grid(r_, nu)
        ti, tj = grid(r_, nr)
        ri, rj = grid(nr, r_)
        ci, cj = grid(ny, nr)
        di, dj = grid(ny, r_)
        row = 0
        for k in range(N):
            wk, xk, xk1 = i_w + k * r_, self.i_x + (k - 1) * nr, self.i_x + k * nr
            put(row + np.arange(r_), wk + np.arange(r_), 1.0)  # w(k) - β_k u - Θ_k ξ(k) = 0
            slot("beta")
            put(row + bi, blk[k] * nu + bj, -self._beta[k])
            if self.has_theta and k > 0:
                slot("theta")
                put(row + ti, xk + tj, -self._theta[k])
            row += r_
            put(row + np.arange(nr), xk1 + np.arange(nr), 1.0)  # ξ(k+1) - A_r ξ(k) - B_r w(k) = 0
            if k > 0:
                if self.Ar.ndim == 1:
                    put(row + np.arange(nr), xk + np.arange(nr), -self.Ar)
                else:
                    ai, aj = grid(nr, nr)
                    put(row + ai, xk + aj, -self.Ar)
            put(row + ri, wk + rj, -self.Br)
            row += nr
            put(row + np.arange(ny), self.i_y + k * ny + np.arange(ny), 1.0)  # y - C_r ξ(k+1) - D_0 w(k) = y0
            slot("Cr")  # scaled per output by set_output_gain
            put(row + ci, xk1 + cj, -self._gain[:, None] * self.Cr)
            slot("D0")
            put(row + di, wk + dj, -self._gain[:, None] * self.D0)
            row += ny
        return row

    def _prediction_rhs(self, y0):
        out = np.zeros((self.N, self.r + self.nr + self.ny))
        out[:, self.r + self.nr :] = y0.reshape(self.N, self.ny)
        return out.ravel()

    def update_blocks(self, beta, theta=None):
        """Replace the time-varying blocks in place (a new linearisation)."""
        beta = np.asarray(beta, float)
        theta = None if theta is None else np.asarray(theta, float)
        self._check_blocks(beta=beta, theta=theta)
        for k, start in enumerate(self._slots["beta"]):
            self._coo_data[start : start + beta[k].size] = -beta[k].ravel()
        if self.has_theta and theta is not None:
            for k, start in zip(range(1, self.N), self._slots["theta"]):
                self._coo_data[start : start + theta[k].size] = -theta[k].ravel()
        self._beta, self._theta = beta, theta if theta is not None else self._theta
        self._update_slots()

    def set_output_gain(self, gain) -> None:
        """Scale the forced response ``C_r ξ(k+1) + D_0 w(k)`` of each output by ``gain`` (ny,) (the input-gain
        correction of :class:`~harness.mpc.controller.MPCController`; ones: the model as it is)."""
        gain = np.asarray(gain, dtype=float).ravel()
        if gain.shape != (self.ny,):
            raise SolverError(f"output gain has {gain.size} entries, expected one per output ({self.ny})")
        if np.array_equal(gain, self._gain):
            return
        self._gain = gain.copy()
        self._update_slots(Cr=-gain[:, None] * self.Cr, D0=-gain[:, None] * self.D0)

    def forced_response(self, U_b) -> np.ndarray:
        """The unscaled forced response (N ny,) [K] of the current blocks (β, Θ) to the blocked moves ``U_b``
        (n_blocks, nu) [kg/s]: the outputs the problem's rows give for these moves from ``y0 = 0``, before
        :meth:`set_output_gain`."""
        U_b = np.asarray(U_b, dtype=float).reshape(self.nb, self.nu)
        U = np.repeat(U_b, self.lengths, axis=0)
        Ar = np.diag(self.Ar) if self.Ar.ndim == 1 else self.Ar
        xi = np.zeros(self.nr)
        Y = np.empty((self.N, self.ny))
        for k in range(self.N):
            w = self._beta[k] @ U[k]
            if self.has_theta and self._theta is not None and k > 0:
                w = w + self._theta[k] @ xi
            xi = Ar @ xi + self.Br @ w
            Y[k] = self.Cr @ xi + self.D0 @ w
        return Y.ravel()


def save_problem(path, arrays: dict) -> Path:
    """Save a problem snapshot as ``.npz`` (no pickled objects; load with ``allow_pickle=False``)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **arrays)
    return path


def replay_problem(path, **clarabel_settings):
    """Re-solve a saved problem with clarabel.

    Parameters
    ----------
    path : path of an ``.npz`` written by :func:`save_problem`
    **clarabel_settings : attributes set on ``clarabel.DefaultSettings``

    Returns
    -------
    clarabel solution object (``.x``, ``.status``, ``.obj_val``)
    """
    import clarabel

    d = np.load(path, allow_pickle=False)
    P = sparse.csc_matrix((d["P_data"], d["P_indices"], d["P_indptr"]), shape=tuple(d["P_shape"]))
    A = sparse.csc_matrix((d["A_data"], d["A_indices"], d["A_indptr"]), shape=tuple(d["A_shape"]))
    cones = [clarabel.ZeroConeT(int(d["n_zero"])), clarabel.NonnegativeConeT(int(d["n_nonneg"]))]
    if int(d["n_soc"]):
        cones.append(clarabel.SecondOrderConeT(int(d["n_soc"])))
    s = clarabel.DefaultSettings()
    s.verbose = False
    for k, v in clarabel_settings.items():
        setattr(s, k, v)
    return clarabel.DefaultSolver(P, d["q"], A, d["b"], cones, s).solve()
