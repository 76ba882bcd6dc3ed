"""Random stable RC networks bilinear in VAV airflows, for MPC tests and benchmarks.

A stand-in with Model B's structure (``discrete_matrices()`` returning
``A, Bv, Bq, Bxu, Bvu, C``) that does not depend on an identified building:
zone air nodes (air plus furniture capacity), wall chains of several layers
to the ambient, between adjacent zones or to an adiabatic side, windows as
direct zone–ambient conductances. Box i adds ``u_i c_p (T_supply - T_zone)``
[W] to its zone. Internal gains ``q`` [W] enter the zone air nodes.

Discretisation (step ``dt``): ``A_d = exp(A_c dt)`` and every input term
(including the bilinear ones, with the state frozen over the step) through
``Γ = ∫_0^dt exp(A_c s) ds``.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np
import scipy.linalg

CP_AIR = 1005.0  #: specific heat of air [J/(kg K)]


class BilinearMatrices(NamedTuple):
    """``x+ = A x + Bv v + Bq q + Σ_i u_i (Bxu[i] x + Bvu[i] v)``, ``y = C x``."""

    A: np.ndarray
    Bv: np.ndarray
    Bq: np.ndarray
    Bxu: list
    Bvu: list
    C: np.ndarray


@dataclasses.dataclass(frozen=True, eq=False)
class RCNetworkModel:
    """A bilinear RC network with the ``PhysicsModel`` MPC interface.

    Attributes
    ----------
    step : float [s]
    outputs : tuple of zone names
    inputs : tuple of ``m_<box>`` names
    disturbances : ``("T_out", "T_supply")``
    continuous : BilinearMatrices, per second
    discrete : BilinearMatrices, per step
    box_zone : array (n_boxes,) zone index of every box
    m_min, m_max : arrays (n_boxes,) [kg/s]
    zone_area : array (n_zones,) floor area [m2]
    """

    step: float
    outputs: tuple
    inputs: tuple
    continuous: BilinearMatrices
    discrete: BilinearMatrices
    box_zone: np.ndarray
    m_min: np.ndarray
    m_max: np.ndarray
    zone_area: np.ndarray
    disturbances: tuple = ("T_out", "T_supply")
    kind: str = "physics"

    @property
    def n_states(self) -> int:
        return self.discrete.A.shape[0]

    @property
    def n_inputs(self) -> int:
        return len(self.inputs)

    def discrete_matrices(self) -> BilinearMatrices:
        return self.discrete

    def continuous_matrices(self) -> BilinearMatrices:
        return self.continuous

    def step_state(self, x, u, v, q):
        """x(k+1) (nx,) from x (nx,), u (nu,) [kg/s], v (2,) [°C], q (n_zones,) [W]."""
        d = self.discrete
        out = d.A @ x + d.Bv @ v + d.Bq @ q
        for i, ui in enumerate(u):
            if ui != 0.0:
                out = out + ui * (d.Bxu[i] @ x + d.Bvu[i] @ v)
        return out

    def output(self, x):
        return np.asarray(x) @ self.discrete.C.T

    def simulate(self, x0, u, v, q):
        """Open-loop trajectory X (n+1, nx) and outputs Y (n+1, ny) [°C]."""
        X = np.empty((u.shape[0] + 1, self.n_states))
        X[0] = x0
        for k in range(u.shape[0]):
            X[k + 1] = self.step_state(X[k], u[k], v[k], q[k])
        return X, self.output(X)

    def steady_state(self, u, v, q):
        """Equilibrium state (nx,) for constant u [kg/s], v [°C], q [W]."""
        d = self.discrete
        Au = d.A + sum(ui * M for ui, M in zip(u, d.Bxu))
        c = d.Bv @ v + d.Bq @ q + sum(ui * (M @ v) for ui, M in zip(u, d.Bvu))
        return np.linalg.solve(np.eye(self.n_states) - Au, c)


def random_rc_network(n_zones=3, n_boxes=5, n_states=30, layers=(3, 6), step=900.0, seed=0) -> RCNetworkModel:
    """A random, physically plausible RC network bilinear in the box airflows.

    Parameters
    ----------
    n_zones : int
    n_boxes : int, assigned to zones round-robin
    n_states : int, total nodes (zone air nodes + wall layers), >= 2 n_zones
    layers : (min, max) nodes per wall
    step : float [s], discretisation step
    seed : int

    Returns
    -------
    RCNetworkModel
        ``random_rc_network(6, 21, 289)`` has Model B's size (289 states, 21 boxes, 6 zones).
    """
    rng = np.random.default_rng(seed)
    area = rng.uniform(80.0, 400.0, n_zones)  # floor area [m2]
    caps, edges = _random_walls(rng, area, n_states, layers)
    box_zone = np.arange(n_boxes) % n_zones
    cont = _continuous_matrices(np.asarray(caps), edges, n_zones, box_zone)
    per_zone = np.bincount(box_zone, minlength=n_zones)
    m_max = 3.0e-3 * area[box_zone] / per_zone[box_zone]  # ~ design airflow [kg/s]
    return RCNetworkModel(
        step=float(step),
        outputs=tuple(f"Z{z}" for z in range(n_zones)),
        inputs=tuple(f"m_V{b}" for b in range(n_boxes)),
        continuous=cont,
        discrete=_discretise(cont, step),
        box_zone=box_zone,
        m_min=0.15 * m_max,
        m_max=m_max,
        zone_area=area,
    )


def _random_walls(rng, area, n_states, layers):
    """Node capacities [J/K] and edges ``(i, j, conductance [W/K])`` (``j = -1``: ambient).

    Zone air nodes come first (air + furniture), each with a window to the
    outside; walls of ``layers`` nodes are added round-robin until ``n_states``.
    """
    nz = len(area)
    cap = 1.2 * CP_AIR * 3.0 * area + 10000.0 * area  # air + furniture [J/K]
    caps = list(cap)
    edges = []
    for z in range(nz):  # windows
        edges.append((z, -1, 2.6 * rng.uniform(0.05, 0.12) * area[z]))
    n = nz
    w = 0
    while n < n_states:
        L = int(min(rng.integers(layers[0], layers[1] + 1), n_states - n))
        z = w % nz
        kind = rng.choice(["exterior", "interior", "slab"], p=[0.4, 0.3, 0.3]) if nz > 1 else "exterior"
        wall_area = rng.uniform(15.0, 60.0)
        thick = rng.uniform(0.15, 0.3)
        dx = thick / L
        c_layer = 2300.0 * 880.0 * dx * wall_area
        g_layer = 1.4 / dx * wall_area
        nodes = list(range(n, n + L))
        caps += [c_layer] * L
        edges.append((z, nodes[0], 3.0 * wall_area))  # interior film
        for a, b in zip(nodes[:-1], nodes[1:]):
            edges.append((a, b, g_layer))
        if kind == "exterior":
            edges.append((nodes[-1], -1, 1.0 / (1.0 / (25.0 * wall_area) + 2.0 / (0.04 / 0.08 * wall_area))))
        elif kind == "interior":
            edges.append((nodes[-1], (z + 1) % nz, 3.0 * wall_area))
        # slab: the far side is adiabatic
        n += L
        w += 1
    return caps, edges


def _continuous_matrices(capv, edges, nz, box_zone) -> BilinearMatrices:
    """Continuous-time bilinear matrices [1/s] of the network; the zone air nodes are the outputs."""
    nx = len(capv)
    Ac = np.zeros((nx, nx))
    Bvc = np.zeros((nx, 2))
    for i, j, g in edges:
        Ac[i, i] -= g
        if j >= 0:
            Ac[j, j] -= g
            Ac[i, j] += g
            Ac[j, i] += g
        else:
            Bvc[i, 0] += g
    Ac /= capv[:, None]
    Bvc /= capv[:, None]
    Bqc = np.zeros((nx, nz))
    Bqc[np.arange(nz), np.arange(nz)] = 1.0 / capv[:nz]
    Bxuc, Bvuc = [], []
    for z in box_zone:
        M = np.zeros((nx, nx))
        M[z, z] = -CP_AIR / capv[z]
        Bxuc.append(M)
        Mv = np.zeros((nx, 2))
        Mv[z, 1] = CP_AIR / capv[z]
        Bvuc.append(Mv)
    Cm = np.zeros((nz, nx))
    Cm[np.arange(nz), np.arange(nz)] = 1.0
    return BilinearMatrices(Ac, Bvc, Bqc, Bxuc, Bvuc, Cm)


def _discretise(cont: BilinearMatrices, step: float) -> BilinearMatrices:
    """Zero-order-hold discretisation over ``step`` [s]: exact exponential and its integral."""
    Ac = cont.A
    nx = Ac.shape[0]
    aug = np.zeros((2 * nx, 2 * nx))
    aug[:nx, :nx] = Ac * step
    aug[:nx, nx:] = np.eye(nx) * step
    E = scipy.linalg.expm(aug)
    Ad, Gam = E[:nx, :nx], E[:nx, nx:]
    return BilinearMatrices(
        Ad, Gam @ cont.Bv, Gam @ cont.Bq, [Gam @ M for M in cont.Bxu], [Gam @ M for M in cont.Bvu], cont.C
    )


def steady_state_at(model: RCNetworkModel, v, q, target=21.0) -> np.ndarray:
    """Equilibrium state (nx,) with every zone temperature near ``target`` [°C].

    The boxes of each zone run at a common fraction of their range, found by
    a per-zone bisection (zones are weakly coupled); fractions stay in
    [0, 1], so a zone whose target needs more or less than the limits misses it.
    """
    nz = len(model.outputs)
    lo, hi = np.zeros(nz), np.ones(nz)
    for _ in range(60):
        a = 0.5 * (lo + hi)
        frac = a[model.box_zone]
        x = model.steady_state(model.m_min + frac * (model.m_max - model.m_min), v, q)
        hot = model.output(x) > target
        lo, hi = np.where(hot, a, lo), np.where(hot, hi, a)
    return x


def synthetic_week(model: RCNetworkModel, n_steps=672, seed=0, T_out_mean=16.0, T_supply=13.0):
    """Disturbances and internal gains for a week of office operation.

    Returns
    -------
    V : array (n_steps, 2) [°C]  (T_out, T_supply)
    Q : array (n_steps, n_zones) [W]  internal gains (background + weekday occupancy)
    """
    rng = np.random.default_rng(seed)
    t = np.arange(n_steps) * model.step / 3600.0  # [h]
    hour, day = t % 24.0, (t // 24.0) % 7
    T_out = T_out_mean + 5.0 * np.sin(2 * np.pi * (hour - 9.0) / 24.0) + rng.normal(0, 0.3, n_steps)
    V = np.column_stack([T_out, np.full(n_steps, T_supply) + rng.normal(0, 0.2, n_steps)])
    nz = len(model.outputs)
    zone_area = model.zone_area
    occupied = ((hour >= 8) & (hour < 18) & (day < 5)).astype(float)
    Q = zone_area[None, :] * (8.0 + 14.0 * occupied[:, None]) * rng.uniform(0.9, 1.1, (n_steps, nz))
    return V, Q


@dataclasses.dataclass(frozen=True, eq=False)
class EquationsModel:
    """A zone model defined only by its :class:`~hvacfmu.models.equations.ModelEquations`.

    For tests and benchmarks of the MPC adapter on model structures no fitted
    kind has yet (augmented delay states, switches): ``step_state`` and
    ``output`` are the equations' own.
    """

    eq: object
    m_min: np.ndarray
    m_max: np.ndarray
    kind: str = "equations"

    def equations(self):
        return self.eq

    @property
    def inputs(self) -> tuple:
        return tuple(self.eq.inputs)

    @property
    def outputs(self) -> tuple:
        return tuple(self.eq.outputs)

    @property
    def disturbances(self) -> tuple:
        return tuple(self.eq.disturbances)

    @property
    def n_states(self) -> int:
        return self.eq.n_states

    @property
    def step(self) -> float:
        return float(self.eq.step)

    def step_state(self, x, u, v, q):
        return self.eq.step_state(x, u, v, q)

    def output(self, x):
        return self.eq.output(x)


def delayed_three_zones(delay=1, bilinear=False) -> EquationsModel:
    """Three zones cooled by airflow, zone C's airflow acting ``delay`` steps late (augmented states).

    ``bilinear=True`` adds a supply-air term ``0.02 u_A (T_supply - T_A)`` on zone A and a reheat
    switch on zone B (+0.3 K per step at minimum airflow when ``T_out < 12 °C``), the structure of
    extended models with ``actuation_delay``, a bilinear supply term and ``reheat``.
    """
    from hvacfmu.models.equations import ModelEquations, Switch

    nz, nx = 3, 3 + delay
    A = np.zeros((nx, nx))
    A[:3, :3] = [[0.90, 0.03, 0.00], [0.03, 0.88, 0.04], [0.00, 0.04, 0.90]]
    Bu = np.zeros((nx, 3))
    Bu[0, 0], Bu[1, 1] = -0.8, -1.1
    A[2, 3] = -0.9  # zone C sees the oldest buffered airflow
    for j in range(3, nx - 1):
        A[j, j + 1] = 1.0  # the buffer shifts
    Bu[nx - 1, 2] = 1.0  # the newest entry is today's command
    Bv = np.zeros((nx, 2))
    Bv[:3] = [[0.05, 0.02], [0.05, 0.03], [0.04, 0.02]]
    Bq = np.zeros((nx, nz))
    Bq[:3] = np.eye(3)
    C = np.zeros((nz, nx))
    C[:, :3] = np.eye(3)
    kw = {}
    u_min, u_max = np.array([0.1, 0.05, 0.05]), np.array([1.2, 1.2, 0.9])
    if bilinear:
        Bxu = [np.zeros((nx, nx)) for _ in range(3)]
        Bvu = [np.zeros((nx, 2)) for _ in range(3)]
        Bxu[0][0, 0], Bvu[0][0, 1] = -0.02, 0.02
        g = np.zeros(nx)
        g[1] = 0.3
        kw = dict(
            Bxu=tuple(Bxu),
            Bvu=tuple(Bvu),
            switches=(
                Switch(
                    g,
                    input_index=1,
                    input_below=u_min[1] + 1e-9,
                    disturbance_index=0,
                    disturbance_below=12.0,
                    name="reheat_B",
                ),
            ),
        )
    eq = ModelEquations(
        step=900.0,
        A=A,
        Bu=Bu,
        Bv=Bv,
        Bq=Bq,
        C=C,
        inputs=("m_A", "m_B", "m_C"),
        disturbances=("T_out", "T_supply"),
        outputs=("A", "B", "C"),
        gains={"fall": np.full((672, nz), 0.5)},
        **kw,
    )
    return EquationsModel(eq, u_min, u_max, kind="extended" if bilinear else "equations")
