"""The resistance-capacitance network of Model B: assembly from geometry and discretisation.

Assembly follows the BRCM toolbox (Sturzenegger et al.): one temperature node
per zone air volume (air plus furniture), per optional internal-mass node and
per massive construction layer (a thick layer is split into several nodes of at
most ``max_layer_thickness``). Between consecutive nodes of an element the
resistance is the sum of the half-layer conduction resistances, the massless
layers' R-values and, at an element's surfaces, the film resistance
``1 / (gamma * area)``. Windows are resistances ``1 / (U * area)`` between the
zone air node and ambient, without state.

Continuous-time model (per second), with nodal capacities ``c`` [J/K] and
conductance matrix ``L`` [W/K]::

    c * dx/dt = -L x + g_amb T_out + g_gnd T_ground + E f_IG + S I
                + sum_i m_i c_p (T_in,i - x_zone(i))

so ``A = -diag(1/c) L`` and the VAV box terms are bilinear:
``Bxu_i = -c_p/c_z e_z e_z^T`` and ``Bvu_i = c_p/c_z e_z e_{T_in,i}^T``. The inlet
air temperature ``T_in,i`` of box i is a disturbance: ``T_supply`` by default,
or per box its discharge air ``Td_<vav>`` or its air handler's ``T_supply_<ahu>``
(``inlets``; see :mod:`hvacfmu.models.heat`).

Discretisation (step ``h``): exact for the linear part, ``A_d = expm(A h)``, and
zero-order hold for *every* input including the bilinear products ``m_i x`` and
``m_i v``, which are treated as inputs held over the step and passed through the
same integral ``Gamma = int_0^h expm(A s) ds`` (BRCM's choice). Hence
``Bxu_d,i = Gamma Bxu_i``: a matrix with a single non-zero column (the zone's
air node). This is exact for a constant airflow of zero and first-order
accurate in ``m h / c`` otherwise; it keeps the discrete model bilinear with
the structure MPC needs.

``A`` is similar to a symmetric matrix (``diag(c)^{1/2} A diag(c)^{-1/2}``),
so the exponential and its integral are computed from one symmetric
eigendecomposition; the same modal form simulates long horizons and many
segments at once in O(n_states * (n_zones + n_inputs)) per step.

References
----------
D. Sturzenegger, D. Gyalistras, V. Semeraro, M. Morari, R. S. Smith, "BRCM
Matlab Toolbox: Model generation for model predictive building control",
American Control Conference, 2014.
"""

from __future__ import annotations

import dataclasses
import math
from functools import cached_property

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ...building import ORIENTATIONS
from ...errors import ModelError
from ...threads import one_blas_thread
from .geometry import CP_AIR, FILM_PARAMS, PARAM_NAMES, RHO_AIR, PhysicsSpec

_AMBIENT, _GROUND = -1, -2


@dataclasses.dataclass(frozen=True)
class BilinearMatrices:
    """Matrices of the bilinear model ``x+ = A x + Bv v + Bq q + sum_i u_i (Bxu[i] x + Bvu[i] v)``, ``y = C x``.

    In continuous time (:meth:`RCNetwork.continuous_matrices`) the same fields
    give ``dx/dt`` [K/s] and are all ``scipy.sparse`` matrices.

    Attributes
    ----------
    A : (nx, nx)
    Bv : (nx, nv)
    Bq : (nx, nq)
    Bxu : list of n_vav sparse (nx, nx)
    Bvu : list of n_vav (nx, nv)
    C : (ny, nx)
    """

    A: object
    Bv: object
    Bq: object
    Bxu: list
    Bvu: list
    C: object


class NetworkTemplate:
    """The parameter-independent structure of an RC network; :meth:`build` fills in the parameters.

    Every edge resistance has the form ``r0 + sum_p rc[p] / param_p`` (films of
    identified kinds) and every window conductance ``gw * U_win``, so
    re-assembling for new parameters is a few vectorised operations.

    Parameters
    ----------
    spec : PhysicsSpec
    solar : bool
        Model solar gains through windows (disturbances ``I_N..I_W`` [W/m2]).
    inlets : sequence of str, optional
        Per VAV box (``spec.vav_zone`` order) the disturbance column of its inlet
        air temperature [°C]. Default: ``T_supply`` for every box. Columns other
        than ``T_supply`` are appended to the disturbances
        ``("T_out", "T_supply", [I_N, I_E, I_S, I_W])``, which keep their positions.
    """

    def __init__(self, spec: PhysicsSpec, solar: bool = False, inlets=None):
        self.spec = spec
        self.solar = bool(solar)
        asm = _Assembly(spec)
        asm.add_internal_mass()
        for el, label in _labelled(spec.elements):
            asm.add_element(el, label)
        nz = len(spec.zones)
        self.node_names = tuple(asm.names)
        self.n_zones = nz
        self.capacity = np.asarray(asm.cap, dtype=float)
        self.edge_a = np.asarray(asm.ea, dtype=np.int64)
        self.edge_b = np.asarray(asm.eb, dtype=np.int64)
        self.edge_r0 = np.asarray(asm.r0, dtype=float)
        self.edge_rc = np.asarray(asm.rc, dtype=float).reshape(-1, len(PARAM_NAMES))
        self._set_windows(spec, asm.zidx)
        self._set_floors(asm.floor_surfaces, nz)
        self.vav_zone = np.asarray([asm.zidx[z] for z in spec.vav_zone], dtype=np.int64)
        self.has_ground = spec.has_ground
        self._set_inputs(inlets)
        self.q_names = tuple(f"f_ig_{z}" for z in spec.zones) + (("T_ground",) if self.has_ground else ())
        # sparsity pattern of L: internal edges give 4 entries, boundary edges 1
        internal = self.edge_b >= 0
        a, b = self.edge_a, self.edge_b
        self._rows = np.concatenate([a, b[internal], a[internal], b[internal], self.window_zone])
        self._cols = np.concatenate([a, b[internal], b[internal], a[internal], self.window_zone])
        self._internal = internal
        self.n_states = len(asm.names)
        # zone-by-VAV summation matrix
        self.zone_vav = np.zeros((nz, len(self.vav_zone)))
        self.zone_vav[self.vav_zone, np.arange(len(self.vav_zone))] = 1.0

    def _set_windows(self, spec: PhysicsSpec, zidx: dict) -> None:
        """Window conductances (per U_win) and the solar apertures per zone and facade."""
        self.window_zone = np.asarray([zidx[w.zone] for w in spec.windows], dtype=np.int64)
        u_nom = spec.nominal["U_win"]
        self.window_g = np.asarray([w.u_value * w.area / u_nom for w in spec.windows], dtype=float)
        # solar: SHGC * area [m2] per zone and facade orientation; a fraction goes to the air node,
        # the rest is absorbed at the zone's floor surfaces (area-weighted), see RCNetwork.solar_matrix
        self.solar_window = np.zeros((len(spec.zones), len(ORIENTATIONS)))
        for w in spec.windows:
            self.solar_window[zidx[w.zone], ORIENTATIONS.index(w.orientation)] += w.shgc * w.area
        self.solar_air_fraction = spec.solar_air_fraction

    def _set_floors(self, floor_surfaces: list, nz: int) -> None:
        """Floor surfaces that absorb the transmitted sun, with their share of their zone's floor area."""
        fz = np.array([f[0] for f in floor_surfaces], dtype=np.int64)
        self.floor_zone = fz
        self.floor_node = np.array([f[1] for f in floor_surfaces], dtype=np.int64)
        self.floor_r0 = np.array([f[2] for f in floor_surfaces], dtype=float)
        self.floor_rc = np.array([f[3] for f in floor_surfaces], dtype=float).reshape(-1, len(PARAM_NAMES))
        area = np.array([f[4] for f in floor_surfaces], dtype=float)
        zone_floor_area = np.bincount(fz, area, minlength=nz)
        self.floor_share = area / zone_floor_area[fz] if len(fz) else area

    def _set_inputs(self, inlets) -> None:
        """Disturbance columns (outdoor, supply, sun, then other inlet columns) and each box's inlet index."""
        base = ("T_out", "T_supply") + (tuple(f"I_{o}" for o in ORIENTATIONS) if self.solar else ())
        inlets = ("T_supply",) * len(self.vav_zone) if inlets is None or len(inlets) == 0 else tuple(inlets)
        if len(inlets) != len(self.vav_zone):
            raise ModelError(f"inlets: {len(inlets)} inlet columns for {len(self.vav_zone)} VAV boxes")
        self.inlets = inlets
        self.disturbances = base + tuple(dict.fromkeys(c for c in inlets if c not in base))
        self.inlet_idx = np.array([self.disturbances.index(c) for c in inlets], dtype=np.int64)

    def params_vector(self, params) -> np.ndarray:
        """The five parameters as an array in :data:`PARAM_NAMES` order (dict or sequence accepted)."""
        if isinstance(params, dict):
            missing = [p for p in PARAM_NAMES if p not in params]
            extra = [p for p in params if p not in PARAM_NAMES]
            if missing or extra:
                raise ModelError(f"parameters: missing {missing}, unknown {extra}; need {list(PARAM_NAMES)}")
            vec = np.array([params[p] for p in PARAM_NAMES], dtype=float)
        else:
            vec = np.asarray(params, dtype=float).reshape(-1)
            if vec.shape != (len(PARAM_NAMES),):
                raise ModelError(f"parameters: need {len(PARAM_NAMES)} values {list(PARAM_NAMES)}, got {vec.shape}")
        bad = [f"{n}={float(x)!r}" for n, x in zip(PARAM_NAMES, vec) if not (np.isfinite(x) and x > 0)]
        if bad:
            raise ModelError(f"parameters must be finite and > 0: {', '.join(bad)}")
        return vec

    def build(self, params) -> "RCNetwork":
        """The network for parameter values ``params`` (dict or sequence in :data:`PARAM_NAMES` order)."""
        p = self.params_vector(params)
        R = self.edge_r0 + self.edge_rc @ (1.0 / p)
        G = 1.0 / R
        Gw = self.window_g * p[0]
        nx = self.n_states
        internal = self._internal
        data = np.concatenate([G, G[internal], -G[internal], -G[internal], Gw])
        L = sp.csr_matrix((data, (self._rows, self._cols)), shape=(nx, nx))
        g_amb = np.bincount(self.edge_a[self.edge_b == _AMBIENT], G[self.edge_b == _AMBIENT], minlength=nx)
        g_amb += np.bincount(self.window_zone, Gw, minlength=nx)
        g_gnd = np.bincount(self.edge_a[self.edge_b == _GROUND], G[self.edge_b == _GROUND], minlength=nx)
        return RCNetwork(self, p, L, g_amb, g_gnd, self._solar_matrix(p) if self.solar else None)

    def _solar_matrix(self, p):
        """Heat [W] into each node per facade irradiance [W/m2], (nx, 4).

        Transmitted solar ``SHGC * area * I`` goes to the zone air node for a
        fraction ``solar_air_fraction`` and is otherwise absorbed at the zone's
        floor surfaces (area-weighted; all to air if the zone has no floor
        element). A surface is massless: absorbed heat splits between the air
        (film ``1/(gamma_floor A)``) and the slab's first node (fixed
        resistance ``r0``) in inverse proportion to the two resistances.
        """
        nx, nz = self.n_states, self.n_zones
        out = np.zeros((nx, len(ORIENTATIONS)))
        total = self.solar_window  # (nz, 4)
        has_floor = np.bincount(self.floor_zone, minlength=nz) > 0
        a = np.where(has_floor, self.solar_air_fraction, 1.0)
        out[:nz] += a[:, None] * total
        if len(self.floor_zone):
            Rf = self.floor_rc @ (1.0 / p)
            to_air = self.floor_r0 / (Rf + self.floor_r0)
            share = (1.0 - a[self.floor_zone]) * self.floor_share
            heat = share[:, None] * total[self.floor_zone]  # (n_surfaces, 4)
            np.add.at(out, self.floor_zone, to_air[:, None] * heat)
            np.add.at(out, self.floor_node, (1.0 - to_air)[:, None] * heat)
        return out


class RCNetwork:
    """An assembled RC network for given parameters (continuous time).

    Attributes
    ----------
    template : NetworkTemplate
    params : array (5,)
        Parameter values in :data:`PARAM_NAMES` order.
    L : sparse (nx, nx) [W/K]
        Conductance matrix, including conductances to ambient and ground on its diagonal.
    g_amb, g_gnd : array (nx,) [W/K]
        Conductance of each node to ambient and to the ground.
    """

    def __init__(self, template: NetworkTemplate, params, L, g_amb, g_gnd, solar=None):
        self.template = template
        self.solar = solar
        self.params = np.asarray(params, dtype=float)
        self.L = L
        self.g_amb = g_amb
        self.g_gnd = g_gnd

    # --- names and sizes -------------------------------------------------
    @property
    def n_states(self) -> int:
        return self.template.n_states

    @property
    def n_zones(self) -> int:
        return self.template.n_zones

    @property
    def capacity(self) -> np.ndarray:
        """Nodal heat capacities [J/K]."""
        return self.template.capacity

    @property
    def node_names(self) -> tuple:
        return self.template.node_names

    @property
    def param_dict(self) -> dict:
        return dict(zip(PARAM_NAMES, map(float, self.params)))

    # --- continuous-time matrices ------------------------------------------
    def input_matrices(self):
        """Dense continuous input matrices ``(Bv, Bq, Bh)`` [K/s per unit]; ``Bh`` maps zone heat [W]."""
        t = self.template
        c = t.capacity
        nx, nz = self.n_states, self.n_zones
        Bv = np.zeros((nx, len(t.disturbances)))
        Bv[:, 0] = self.g_amb / c
        if t.solar:
            Bv[:, 2 : 2 + len(ORIENTATIONS)] = self.solar / c[:, None]
        Bq = np.zeros((nx, len(t.q_names)))
        Bq[np.arange(nz), np.arange(nz)] = 1.0 / c[:nz]
        if t.has_ground:
            Bq[:, nz] = self.g_gnd / c
        Bh = np.zeros((nx, nz))
        Bh[np.arange(nz), np.arange(nz)] = 1.0 / c[:nz]
        return Bv, Bq, Bh

    def continuous_matrices(self) -> BilinearMatrices:
        """Continuous-time matrices (per second), all ``scipy.sparse`` (CSR)."""
        t = self.template
        c = t.capacity
        nx, nz = self.n_states, self.n_zones
        A = sp.csr_matrix(-sp.diags(1.0 / c) @ self.L)
        Bv, Bq, _ = self.input_matrices()
        nv = len(t.disturbances)
        Bxu, Bvu = [], []
        for z, j in zip(t.vav_zone, t.inlet_idx):
            Bxu.append(sp.csr_matrix(([-CP_AIR / c[z]], ([z], [z])), shape=(nx, nx)))
            Bvu.append(sp.csr_matrix(([CP_AIR / c[z]], ([z], [j])), shape=(nx, nv)))
        C = sp.csr_matrix((np.ones(nz), (np.arange(nz), np.arange(nz))), shape=(nz, nx))
        return BilinearMatrices(A, sp.csr_matrix(Bv), sp.csr_matrix(Bq), Bxu, Bvu, C)

    # --- modal form and discretisation ----------------------------------------
    @cached_property
    def modal(self):
        """``(lam, V, W)`` with ``A = V diag(lam) W`` and ``W = V^{-1}`` (real, from a symmetric eigenproblem)."""
        s = np.sqrt(self.template.capacity)
        S = -(self.L.toarray() / s[:, None]) / s[None, :]
        S = 0.5 * (S + S.T)
        with one_blas_thread():
            lam, Q = np.linalg.eigh(S)
        V = Q / s[:, None]
        W = Q.T * s[None, :]
        return lam, V, W

    def discretize(self, step: float) -> "DiscreteBilinear":
        """The discrete-time model for a step ``step`` [s] (see the module docstring)."""
        if not step > 0:
            raise ModelError(f"step must be > 0 s, got {step}")
        return DiscreteBilinear(self, float(step))

    def wall_steady_state(self, y, T_out, q=None):
        """Steady-state temperatures of the non-air nodes with zone air at ``y``.

        Parameters
        ----------
        y : array (..., n_zones) [°C]
        T_out : array (...) [°C]
        q : array (..., nq), optional
            Only its ground column matters (non-air nodes receive no zone gains).

        Returns
        -------
        x : array (..., n_states) [°C]
        """
        t = self.template
        nz = self.n_zones
        y = np.asarray(y, dtype=float)
        T_out = np.asarray(T_out, dtype=float)
        batch = np.broadcast_shapes(y.shape[:-1], T_out.shape)
        y = np.broadcast_to(y, batch + (nz,)).reshape(-1, nz)
        To = np.broadcast_to(T_out, batch).reshape(-1)
        rhs = self.g_amb[nz:][:, None] * To[None, :] - self._L_wa @ y.T
        if t.has_ground:
            Tg = (
                t.spec.ground_temperature
                if q is None
                else np.broadcast_to(np.asarray(q, dtype=float)[..., nz], batch).reshape(-1)
            )
            rhs = rhs + self.g_gnd[nz:][:, None] * np.broadcast_to(Tg, To.shape)[None, :]
        xw = self._L_ww_lu.solve(rhs) if rhs.shape[0] else rhs
        x = np.concatenate([y, xw.T], axis=1)
        return x.reshape(batch + (self.n_states,))

    @cached_property
    def _L_wa(self):
        nz = self.n_zones
        return self.L[nz:, :nz].tocsr()

    @cached_property
    def _L_ww_lu(self):
        nz = self.n_zones
        Lww = self.L[nz:, nz:].tocsc()
        if Lww.shape[0] == 0:
            return None
        return spla.splu(Lww)


class DiscreteBilinear:
    """The discretised bilinear model, in physical and modal coordinates.

    ``x+ = Ad x + Bv v + Bq q + Gd h`` with the zone heat of the VAV boxes
    ``h_z = c_p * (mt_z - m_z x_z)`` [W] (``m_z`` the summed airflow of zone
    z's boxes [kg/s], ``mt_z = sum_{i in z} u_i T_in,i`` their inlet flux
    [kg/s K], :meth:`inlet_flux`), which equals ``sum_i u_i (Bxu_i x + Bvu_i v)``.

    Modal coordinates ``z = W x``: ``z+ = ed * z + Pv v + Pq q + Ph h``,
    ``x_zone = Vz z``.
    """

    def __init__(self, network: RCNetwork, step: float):
        self.network = network
        self.step = step
        lam, V, W = network.modal
        lh = lam * step
        self.ed = np.exp(lh)
        small = np.abs(lh) < 1e-12
        self.gd = np.where(small, step, np.expm1(lh) / np.where(small, 1.0, lam))
        self.V, self.W = V, W
        nz = network.n_zones
        Bv, Bq, Bh = network.input_matrices()
        WB = W @ np.concatenate([Bv, Bq, Bh], axis=1)
        P = self.gd[:, None] * WB
        nv, nq = Bv.shape[1], Bq.shape[1]
        self.Pv, self.Pq, self.Ph = P[:, :nv], P[:, nv : nv + nq], P[:, nv + nq :]
        self.Vz = V[:nz]
        self.zone_vav = network.template.zone_vav

    @property
    def n_states(self) -> int:
        return self.network.n_states

    @cached_property
    def Ad(self) -> np.ndarray:
        return (self.V * self.ed) @ self.W

    @cached_property
    def Gamma(self) -> np.ndarray:
        """``int_0^h expm(A s) ds`` [s]."""
        return (self.V * self.gd) @ self.W

    @cached_property
    def physical_inputs(self):
        """``(Bv_d, Bq_d, Gd)``: discrete input matrices in physical coordinates."""
        return self.V @ self.Pv, self.V @ self.Pq, self.V @ self.Ph

    def matrices(self) -> BilinearMatrices:
        """The discrete :class:`BilinearMatrices` (A, Bv, Bq dense; Bxu, Bvu sparse, one non-zero column each)."""
        Bv, Bq, Gd = self.physical_inputs
        t = self.network.template
        nx, nz, nv = self.n_states, self.network.n_zones, Bv.shape[1]
        Bxu, Bvu = [], []
        for z, j in zip(t.vav_zone, t.inlet_idx):
            col = Gd[:, z] * CP_AIR
            nzr = np.flatnonzero(col)
            Bxu.append(sp.csc_matrix((-col[nzr], (nzr, np.full(nzr.size, z))), shape=(nx, nx)))
            Bvu.append(sp.csc_matrix((col[nzr], (nzr, np.full(nzr.size, j, dtype=np.int64))), shape=(nx, nv)))
        C = np.zeros((nz, nx))
        C[np.arange(nz), np.arange(nz)] = 1.0
        return BilinearMatrices(self.Ad.copy(), Bv.copy(), Bq.copy(), Bxu, Bvu, C)

    # --- stepping -------------------------------------------------------------
    def inlet_flux(self, u, v):
        """``mt_z = sum_{i in z} u_i T_in,i`` [kg/s K] per zone from box airflows u and disturbances v; batched."""
        u = np.asarray(u, dtype=float)
        T_in = np.asarray(v, dtype=float)[..., self.network.template.inlet_idx]
        return np.where(u == 0.0, 0.0, u * T_in) @ self.zone_vav.T

    def zone_heat(self, x_zone, u, v):
        """VAV heat into each zone ``c_p sum_{i in z} u_i (T_in,i - x_z)`` [W]; batched."""
        m = np.asarray(u, dtype=float) @ self.zone_vav.T
        return CP_AIR * (self.inlet_flux(u, v) - m * x_zone)

    def step_state(self, x, u, v, q):
        """One step in physical coordinates; batched over leading dimensions."""
        x = np.asarray(x, dtype=float)
        nz = self.network.n_zones
        Bv, Bq, Gd = self.physical_inputs
        h = self.zone_heat(x[..., :nz], u, v)
        return x @ self.Ad.T + np.asarray(v, float) @ Bv.T + np.asarray(q, float) @ Bq.T + h @ Gd.T

    def run(self, z0, m, v, q, y=None, Kz=None, n_correct=0, record_states=False, record_pred=False, mt=None):
        """Simulate (and optionally filter) in modal coordinates, batched.

        Parameters
        ----------
        z0 : array (..., nx)
            Initial modal state.
        m : array (..., n, n_zones) [kg/s]
            Summed airflow per zone.
        v : array (..., n, nv)
        q : array (..., n, nq)
        y : array (..., n+1, n_zones) [°C], optional
            Measurements for the corrections (NaN: no correction for that zone).
        Kz : array (nx, n_zones) or (n_gains, nx, n_zones), optional
            Modal Kalman gain ``W K``; a sequence gives the gain of each row
            (the last one for later rows).
        n_correct : int
            Corrections are applied at rows ``0 .. n_correct-1``.
        record_states : bool
            Also return the modal states (..., n+1, nx).
        record_pred : bool
            Also return the outputs before correction (one-step predictions).
        mt : array (..., n, n_zones) [kg/s K], optional
            Inlet flux per zone (:meth:`inlet_flux`); default ``m * T_supply`` (every box fed at ``v[1]``).

        Returns
        -------
        Y : array (..., n+1, n_zones)
            Outputs after correction (filtered) where corrected, else predicted.
        Z : array or None
        Ypred : array or None
        z : array (..., nx)
            The final modal state (after the correction at row n, if any).
        """
        with one_blas_thread():
            return self._run(z0, m, v, q, y, Kz, n_correct, record_states, record_pred, mt)

    def _run(self, z0, m, v, q, y, Kz, n_correct, record_states, record_pred, mt):
        z = np.array(z0, dtype=float)
        n = m.shape[-2]
        batch = np.broadcast_shapes(
            z.shape[:-1], m.shape[:-2], v.shape[:-2], q.shape[:-2], () if y is None else y.shape[:-2]
        )
        z = np.broadcast_to(z, batch + z.shape[-1:]).copy()
        nz = self.Vz.shape[0]
        Y = np.empty(batch + (n + 1, nz))
        Z = np.empty(batch + (n + 1, z.shape[-1])) if record_states else None
        Yp = np.empty(batch + (n + 1, nz)) if record_pred else None
        VzT, PvT, PqT, PhT = self.Vz.T, self.Pv.T, self.Pq.T, self.Ph.T
        ed = self.ed
        KzT = None if Kz is None else np.swapaxes(Kz, -1, -2)
        for k in range(n + 1):
            xz = z @ VzT
            if record_pred:
                Yp[..., k, :] = xz
            if k < n_correct and KzT is not None:
                innov = y[..., k, :] - xz
                innov = np.where(np.isnan(innov), 0.0, innov)
                z = z + innov @ (KzT if KzT.ndim == 2 else KzT[min(k, len(KzT) - 1)])
                xz = z @ VzT
            Y[..., k, :] = xz
            if record_states:
                Z[..., k, :] = z
            if k == n:
                break
            vk = v[..., k, :]
            if mt is None:
                h = CP_AIR * m[..., k, :] * (vk[..., 1:2] - xz)
            else:
                h = CP_AIR * (mt[..., k, :] - m[..., k, :] * xz)
            z = ed * z + vk @ PvT + q[..., k, :] @ PqT + h @ PhT
        return Y, Z, Yp, z


def _labelled(elements) -> list:
    """(element, node label) pairs; repeated element names are numbered ``name#1``, ``name#2``, ..."""
    counts: dict = {}
    for el in elements:
        counts[el.name] = counts.get(el.name, 0) + 1
    seen: dict = {}
    out = []
    for el in elements:
        seen[el.name] = seen.get(el.name, 0) + 1
        out.append((el, el.name if counts[el.name] == 1 else f"{el.name}#{seen[el.name]}"))
    return out


class _Assembly:
    """Nodes and edges of an RC network collected element by element (used by :class:`NetworkTemplate`).

    An edge resistance is ``r0 + rc . (1 / params)``: a fixed part and per-parameter film coefficients.
    Node indices: zones first (their air nodes), then internal masses and layer nodes in order;
    boundaries are negative (``_AMBIENT``, ``_GROUND``).
    """

    def __init__(self, spec: PhysicsSpec):
        self.spec = spec
        self.zidx = {z: i for i, z in enumerate(spec.zones)}
        self.pidx = {p: i for i, p in enumerate(PARAM_NAMES)}
        self.names = [f"air:{z}" for z in spec.zones]
        self.cap = [
            RHO_AIR * CP_AIR * spec.zone_volume[z] + spec.furniture_capacity * spec.zone_area[z] for z in spec.zones
        ]
        self.ea: list = []
        self.eb: list = []
        self.r0: list = []
        self.rc: list = []
        self.floor_surfaces: list = []  # (zone, first massive node, fixed resistance to it, film coefficients, area)

    def edge(self, a, b, r_fixed, coef) -> None:
        if a == b or (a < 0 and b < 0):
            return
        if a < 0:
            a, b = b, a
        self.ea.append(a)
        self.eb.append(b)
        self.r0.append(r_fixed)
        self.rc.append(coef)

    def side_node(self, s):
        if s in self.zidx:
            return self.zidx[s]
        return {"ambient": _AMBIENT, "ground": _GROUND}.get(s)  # None: adiabatic

    def add_internal_mass(self) -> None:
        spec = self.spec
        if spec.internal_mass <= 0:
            return
        for z in spec.zones:
            i = len(self.names)
            self.names.append(f"mass:{z}")
            self.cap.append(spec.internal_mass * spec.zone_area[z])
            coef = np.zeros(len(PARAM_NAMES))
            coef[self.pidx["gamma_interior_wall"]] = 1.0 / spec.zone_area[z]
            self.edge(self.zidx[z], i, 0.0, coef)

    def _film(self, kind, A, acc_c) -> float:
        """Add film ``kind`` of an area ``A`` surface: identified films to ``acc_c``; returns the fixed part."""
        if kind in FILM_PARAMS:
            acc_c[self.pidx[FILM_PARAMS[kind]]] += 1.0 / A
        elif kind == "ambient":
            return 1.0 / (self.spec.ambient_film * A)
        return 0.0

    def add_element(self, el, label: str) -> None:
        """Layer nodes of element ``el`` (massive layers split into sub-layers) and the edges between them."""
        A, con = el.area, el.construction
        nodes = [self.side_node(el.side1)]
        # resistance accumulated since the previous node: fixed part, per-parameter coefficients
        acc_c = np.zeros(len(PARAM_NAMES))
        acc_r = self._film(con.films[0], A, acc_c)
        for li, layer in enumerate(con.layers):
            mat = layer.material
            if mat.massless:
                acc_r += mat.r_value / A
                continue
            n_sub = max(1, math.ceil(layer.thickness / self.spec.max_layer_thickness - 1e-9))
            d = layer.thickness / n_sub
            r_half = d / (2.0 * mat.conductivity * A)
            for j in range(n_sub):
                acc_r += r_half
                i = len(self.names)
                self.names.append(f"{label}[{li}.{j}]" if n_sub > 1 else f"{label}[{li}]")
                self.cap.append(mat.density * mat.specific_heat * d * A)
                if nodes[-1] is not None:
                    self.edge(nodes[-1], i, acc_r, acc_c.copy())
                    if len(nodes) == 1 and nodes[0] >= 0 and con.films[0] == "floor":
                        self.floor_surfaces.append((nodes[0], i, acc_r, acc_c.copy(), A))
                nodes.append(i)
                acc_r, acc_c = r_half, np.zeros(len(PARAM_NAMES))
        acc_r += self._film(con.films[1], A, acc_c)
        end = self.side_node(el.side2)
        if nodes[-1] is not None and end is not None:
            self.edge(nodes[-1], end, acc_r, acc_c.copy())
            if len(nodes) > 1 and end >= 0 and con.films[1] == "floor":
                self.floor_surfaces.append((end, nodes[-1], acc_r, acc_c.copy(), A))
