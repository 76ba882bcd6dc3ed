"""The equations of a zone model as plain matrices: one form for native FMUs and MPC.

Every model kind whose dynamics are linear or bilinear in its inputs (lumped and
six-zone Model A, physics Model B, extended models whose terms are linear or
bilinear in an augmented state) describes itself with :class:`ModelEquations`:

.. math::

    x_{k+1} = A x_k + B_u u_k + B_v v_k + B_q q_k
              + \\sum_i u_{k,i} (B_{xu,i} x_k + B_{vu,i} v_k)
              + \\sum_j v_{k,j} (B_{xv,j} x_k + B_{vv,j} v_k)
              + \\sum_s [\\text{switch } s \\text{ on}] \\, g_s

    y_k = C x_k

with ``u`` the model's controlled inputs (``model.inputs`` order), ``v`` its
disturbances (``model.disturbances`` order: outdoor and supply or discharge air
temperatures [°C], facade irradiance [W/m²] ...) and ``q`` the internal-gain
term of the model's seasonal time-of-week profile (``model.gains[season]``,
one row per time-of-week slot). A switch adds a constant vector ``g_s`` (scaled
by one signal) when a condition on one input and one disturbance holds; it
covers piecewise terms such as reheat at minimum airflow in cold weather.
The products with a disturbance ``v_j`` (``Bxv``, ``Bvv``; empty for most models)
hold terms such as wind-driven infiltration ``coef · wind · (T_out − T_zone)``:
for a known disturbance forecast the state matrix ``A + Σ_j v_j B_{xv,j}`` is
time-varying but known, and ``Σ_j v_j B_{vv,j} v`` is a known drift.

Consumers: the native C FMU generator (:mod:`hvacfmu.fmu`), the MPC adapters
(:mod:`harness.mpc`). A model kind provides ``equations() -> ModelEquations``;
:func:`check_equations` verifies it against the model's own ``step_state``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import ModelError


@dataclasses.dataclass(frozen=True)
class Switch:
    """A piecewise-constant contribution ``scale(signal) * gain`` active when a condition holds.

    The condition is ``u[input_index] <= input_below`` (skipped when ``input_index`` is None)
    and ``v[disturbance_index] < disturbance_below`` (skipped when ``disturbance_index`` is None).
    The contribution is ``gain`` (nx,) times ``1`` (``scale_by`` None) or times
    ``v[scale_by]``.
    """

    gain: np.ndarray
    input_index: int | None = None
    input_below: float = np.inf
    disturbance_index: int | None = None
    disturbance_below: float = np.inf
    scale_by: int | None = None
    name: str = ""

    def active(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        on = np.ones(np.broadcast_shapes(u.shape[:-1], v.shape[:-1]), dtype=bool)
        if self.input_index is not None:
            on &= u[..., self.input_index] <= self.input_below
        if self.disturbance_index is not None:
            on &= v[..., self.disturbance_index] < self.disturbance_below
        return on


@dataclasses.dataclass(frozen=True)
class ModelEquations:
    """Discrete-time matrices of a zone model (see the module docstring for the equation).

    Attributes
    ----------
    step : float [s]
    A : array (nx, nx)
    Bu : array (nx, nu)
    Bv : array (nx, nv)
    Bq : array (nx, nq)
    Bxu : tuple of nu arrays (nx, nx) or () when the model is linear in u
    Bvu : tuple of nu arrays (nx, nv) or ()
    Bxv : tuple of nv arrays (nx, nx) or () when no disturbance multiplies the state
    Bvv : tuple of nv arrays (nx, nv) or () when no disturbance multiplies another
    C : array (ny, nx)
    inputs, disturbances, outputs : tuple of str
    gains : dict season -> array (n_time_of_week, nq)
    switches : tuple of Switch
    """

    step: float
    A: np.ndarray
    Bu: np.ndarray
    Bv: np.ndarray
    Bq: np.ndarray
    C: np.ndarray
    inputs: tuple
    disturbances: tuple
    outputs: tuple
    gains: dict
    Bxu: tuple = ()
    Bvu: tuple = ()
    switches: tuple = ()
    Bxv: tuple = ()
    Bvv: tuple = ()

    def __post_init__(self):
        nx = self.A.shape[0]
        nu, nv = len(self.inputs), len(self.disturbances)
        shapes = {"A": (nx, nx), "Bu": (nx, nu), "Bv": (nx, nv), "C": (len(self.outputs), nx)}
        for name, shape in shapes.items():
            if np.shape(getattr(self, name)) != shape:
                raise ModelError(f"equations: {name} has shape {np.shape(getattr(self, name))}, expected {shape}")
        if self.Bq.shape[0] != nx:
            raise ModelError(f"equations: Bq has {self.Bq.shape[0]} rows, expected {nx}")
        for name, mats, n, shape in (
            ("Bxu", self.Bxu, nu, (nx, nx)),
            ("Bvu", self.Bvu, nu, (nx, nv)),
            ("Bxv", self.Bxv, nv, (nx, nx)),
            ("Bvv", self.Bvv, nv, (nx, nv)),
        ):
            if mats and (len(mats) != n or any(np.shape(m) != shape for m in mats)):
                raise ModelError(f"equations: {name} must hold {n} matrices of shape {shape}")

    @property
    def n_states(self) -> int:
        return self.A.shape[0]

    @property
    def bilinear(self) -> bool:
        return bool(self.Bxu) or bool(self.Bvu)

    @property
    def disturbance_products(self) -> bool:
        """True when a disturbance multiplies the state or another disturbance (``Bxv``/``Bvv``): the state
        matrix ``A + Σ_j v_j Bxv_j`` varies with the disturbances (known from their forecast)."""
        return bool(self.Bxv) or bool(self.Bvv)

    def state_matrix(self, v=None) -> np.ndarray:
        """``A + Σ_j v_j Bxv_j`` at disturbances ``v`` (nv,) (``A`` when v is None or there is no ``Bxv``)."""
        A = np.asarray(self.A, dtype=float)
        if v is None or not self.Bxv:
            return A
        return A + sum(float(vj) * np.asarray(M, dtype=float) for vj, M in zip(np.asarray(v, float), self.Bxv))

    def step_state(self, x, u, v, q) -> np.ndarray:
        """Reference implementation of one step (batched over leading dimensions)."""
        x, u, v, q = (np.asarray(a, dtype=float) for a in (x, u, v, q))
        xn = x @ self.A.T + u @ self.Bu.T + v @ self.Bv.T + q @ self.Bq.T
        for i in range(len(self.inputs)):
            if self.Bxu:
                xn = xn + u[..., i : i + 1] * (x @ np.asarray(self.Bxu[i]).T)
            if self.Bvu:
                xn = xn + u[..., i : i + 1] * (v @ np.asarray(self.Bvu[i]).T)
        for j in range(len(self.disturbances)):
            if self.Bxv:
                xn = xn + v[..., j : j + 1] * (x @ np.asarray(self.Bxv[j]).T)
            if self.Bvv:
                xn = xn + v[..., j : j + 1] * (v @ np.asarray(self.Bvv[j]).T)
        for s in self.switches:
            scale = 1.0 if s.scale_by is None else v[..., s.scale_by : s.scale_by + 1]
            xn = xn + s.active(u, v)[..., None] * scale * s.gain
        return xn

    def output(self, x) -> np.ndarray:
        return np.asarray(x, dtype=float) @ self.C.T


def check_equations(model, equations: ModelEquations, n: int = 20, seed: int = 0, atol: float = 1e-9) -> float:
    """Largest difference between ``equations.step_state`` and ``model.step_state`` on random signals.

    Raises :class:`ModelError` when it exceeds ``atol`` [K].
    """
    rng = np.random.default_rng(seed)
    nx, nu, nv = equations.n_states, len(equations.inputs), len(equations.disturbances)
    nq = equations.Bq.shape[1]
    x = 20 + rng.normal(size=(n, nx))
    u = rng.uniform(0, 1, size=(n, nu))
    v = 15 + 10 * rng.normal(size=(n, nv))
    q = 0.1 * rng.normal(size=(n, nq))
    err = float(np.max(np.abs(equations.step_state(x, u, v, q) - model.step_state(x, u, v, q)), initial=0.0))
    if err > atol:
        raise ModelError(f"equations of {getattr(model, 'kind', '?')} model differ from its step_state by {err:.3g}")
    return err
