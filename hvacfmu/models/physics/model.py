"""Model B as a :class:`~hvacfmu.models.base.ZoneModel`: the RC network of a building, bilinear in VAV airflows.

    x(k+1) = A x(k) + Bv v(k) + Bq q(k) + sum_i u_i(k) (Bxu_i x(k) + Bvu_i v(k))
    y(k)   = C x(k)

``u`` are the airflows of the VAV boxes [kg/s], ``v = [T_out, T_supply]``
[°C] (plus facade irradiance ``I_N..I_W`` [W/m2] when solar gains are
modelled, plus the boxes' own inlet air temperatures ``Td_<vav>`` or
``T_supply_<ahu>`` [°C] when ``inlets`` names them: a box then delivers
``m c_p (T_in - T_zone)`` with its own inlet), ``q`` the internal heat gain of each zone ``f_IG`` [W] (plus a
constant ground temperature [°C] when elements face the ground) and ``y`` the
zone air temperatures [°C].

References
----------
D. Zhou, Q. Hu, C. J. Tomlin, "Model comparison of a data-driven and a
physical model for simulating HVAC systems", section IV, eq. (physics_model).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from ...building import Building, building_from_dict
from ...calendars import gain_slots
from ...errors import BuildingError, ModelError
from ...threads import one_blas_thread
from ...timeutil import n_time_of_week
from ..base import (
    FORMAT_VERSION,
    ZoneModel,
    check_dates,
    check_mapping,
    check_names,
    check_number,
    check_shape,
    check_version,
    gains_from_json,
    gains_to_json,
    require_columns,
    require_keys,
)
from .geometry import PARAM_NAMES, parse_physics
from .network import BilinearMatrices, NetworkTemplate

#: Default Kalman filter settings: process noise per step on air and on other
#: nodes [K], measurement noise [K], warm-up length [steps].
DEFAULT_KALMAN = {"observer": "kalman", "q_air": 0.1, "q_mass": 0.05, "r": 0.05, "warmup_steps": 192}
OBSERVERS = ("gain_injection", "kalman")


def _check_options(options: dict) -> None:
    """Refuse non-numeric, non-finite or negative numbers in a loaded model's ``options`` (ModelError naming the key)."""
    kalman = check_mapping(options.get("kalman", {}), "options.kalman", "physics model file")
    numbers = {f"options.{k}": v for k, v in options.items() if k != "kalman" and not isinstance(v, str)}
    numbers.update({f"options.kalman.{k}": v for k, v in kalman.items() if k not in ("observer", "airflow")})
    numbers.update({f"options.kalman.airflow[{i}]": v for i, v in enumerate(kalman.get("airflow") or [])})
    for key, v in numbers.items():
        if v is not None and check_number(v, key, "physics model file", positive=False) < 0:
            raise ModelError(f"physics model file: '{key}' must be >= 0, got {v!r}; refit the model")


def building_hash(building_dict: dict) -> str:
    """SHA-256 of a building mapping in canonical JSON form."""
    return hashlib.sha256(json.dumps(building_dict, sort_keys=True, allow_nan=False).encode()).hexdigest()


def kalman_gain(disc, airflow, q_air, q_mass, r) -> np.ndarray:
    """Steady-state Kalman filter gain (physical coordinates) of the model linearised at ``airflow``.

    The bilinear model is frozen at a constant zone airflow (typically the
    training mean); the gain of that linear time-invariant system is used as a
    fixed observer gain for the bilinear model.

    Parameters
    ----------
    disc : DiscreteBilinear
    airflow : array (n_zones,) [kg/s]
    q_air, q_mass : float [K]
        Standard deviation of the process noise per step on zone air nodes and on other nodes.
    r : float [K]
        Standard deviation of the temperature measurement noise.

    Returns
    -------
    K : array (n_states, n_zones)
        Filter gain: ``x(k|k) = x(k|k-1) + K (y(k) - C x(k|k-1))``.
    """
    import scipy.linalg as sl

    from .geometry import CP_AIR

    nx, nz = disc.n_states, disc.Vz.shape[0]
    A = disc.Ad.copy()
    Gd = disc.physical_inputs[2]
    A[:, :nz] -= CP_AIR * Gd * np.asarray(airflow, dtype=float)[None, :]
    C = np.zeros((nz, nx))
    C[np.arange(nz), np.arange(nz)] = 1.0
    Q = np.diag(np.r_[np.full(nz, q_air**2), np.full(nx - nz, q_mass**2)])
    R = np.eye(nz) * r**2
    with one_blas_thread():
        P = sl.solve_discrete_are(A.T, C.T, Q, R)
    S = P[:nz, :nz] + R
    return np.linalg.solve(S, P[:nz, :]).T


def gain_injection(disc) -> np.ndarray:
    """Observer gain ``B_IG (C B_IG)^{-1}`` (physical coordinates, (n_states, n_zones)).

    The Kalman gain in the limit of process noise entering only through the
    zones' internal gains and vanishing sensor noise: the correction at each
    step is the heat input that makes the zone air match the measurement.
    """
    nz = disc.Vz.shape[0]
    Bq = disc.physical_inputs[1][:, :nz]
    return Bq @ np.linalg.inv(Bq[:nz])


def fill_signals(a, default):
    """Fill NaNs of a (n, ncol) array forward then backward in time; columns entirely NaN take ``default``."""
    a = np.array(a, dtype=float)
    if not np.isnan(a).any():
        return a
    out = pd.DataFrame(a).ffill().bfill().to_numpy()
    d = np.broadcast_to(np.asarray(default, dtype=float), out.shape)
    return np.where(np.isnan(out), d, out)


@dataclasses.dataclass(frozen=True, eq=False)
class PhysicsModel(ZoneModel):
    """Model B: the RC network of ``building`` with parameters ``params``.

    Parameters
    ----------
    building : Building
        With physics tables (materials, constructions, windows, elements, [physics]).
    params : dict
        ``U_win`` [W/(m2 K)], ``gamma_interior_wall``, ``gamma_exterior_wall``,
        ``gamma_floor``, ``gamma_ceiling`` [W/(m2 K)].
    gains : dict season -> array (672, nq)
        Internal heat gain ``f_IG = f_IG^c + f_IG,m^v(k)`` of each zone [W]
        by time of week (plus a constant ground-temperature column [°C] when
        elements face the ground).
    step : float [s]
    solar : bool
        Model solar gains through windows (SHGC * area * facade irradiance).
    options : dict
        ``max_layer_thickness`` [m], ``furniture_capacity`` [J/(K m2)],
        ``internal_mass`` [J/(K m2)] (override the building file's values),
        ``kalman``: ``q_air``, ``q_mass``, ``r`` [K], ``warmup_steps``,
        ``airflow`` (zone airflows [kg/s] at which the filter gain is computed).
    f_ig_const : array (n_zones,) [W]
        The constant internal gain ``f_IG^c`` (already included in ``gains``).
    meta : dict
        Provenance, parameter uncertainty and identifiability flags.
    inlets : tuple of str
        Per VAV box (``building.vav_names`` order) the column of its inlet air
        temperature [°C]: ``Td_<vav>`` (measured discharge air), ``T_supply_<ahu>``
        or ``T_supply``; empty: ``T_supply`` for every box
        (:func:`hvacfmu.models.heat.inlet_columns` chooses them for a dataset).
    """

    building: Building
    params: dict
    gains: dict
    step: float = 900.0
    solar: bool = False
    options: dict = dataclasses.field(default_factory=dict)
    f_ig_const: np.ndarray | None = None
    meta: dict = dataclasses.field(default_factory=dict)
    inlets: tuple = ()
    holidays: tuple = ()

    kind: ClassVar[str] = "physics"

    def __post_init__(self):
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 - frozen dataclass normalisation
        if not float(self.step) > 0:
            raise ModelError(f"step must be > 0 s, got {self.step}")
        set_("step", float(self.step))
        opts = dict(self.options)
        unknown = sorted(
            set(opts) - {"max_layer_thickness", "furniture_capacity", "internal_mass", "solar_air_fraction", "kalman"}
        )
        if unknown:
            raise ModelError(f"unknown physics model option(s) {unknown}")
        try:
            spec = parse_physics(self.building, **{k: opts[k] for k in opts if k != "kalman"})
        except BuildingError as exc:
            raise ModelError(str(exc)) from None
        set_("inlets", tuple(self.inlets))
        if self.inlets and len(self.inlets) != len(self.building.vavs):
            raise ModelError(f"inlets: {len(self.inlets)} inlet columns for {len(self.building.vavs)} VAV boxes")
        template = NetworkTemplate(spec, solar=self.solar, inlets=self.inlets or None)
        network = template.build(self.params)
        set_("params", network.param_dict)
        nz = len(spec.zones)
        kal = dict(DEFAULT_KALMAN)
        kal.update(opts.get("kalman", {}))
        unknown = sorted(set(kal) - set(DEFAULT_KALMAN) - {"airflow"})
        if unknown:
            raise ModelError(f"unknown Kalman option(s) {unknown}")
        if kal["observer"] not in OBSERVERS:
            raise ModelError(f"options.kalman.observer must be one of {OBSERVERS}, got {kal['observer']!r}")
        if "airflow" not in kal:
            kal["airflow"] = [
                float(sum(0.5 * (v.m_min + v.m_max) for v in self.building.vavs_of(z))) for z in spec.zones
            ]
        kal["airflow"] = check_shape(kal["airflow"], (nz,), "options.kalman.airflow").tolist()
        opts["kalman"] = kal
        opts.setdefault("max_layer_thickness", spec.max_layer_thickness)
        opts.setdefault("furniture_capacity", spec.furniture_capacity)
        opts.setdefault("internal_mass", spec.internal_mass)
        opts.setdefault("solar_air_fraction", spec.solar_air_fraction)
        set_("options", opts)
        nq = len(template.q_names)
        n_tow = n_time_of_week(self.step)
        if not self.gains:
            raise ModelError("a physics model needs an internal-gain profile for at least one season")
        gains = {}
        for s, g in self.gains.items():
            if s not in self.building.season_names:
                raise ModelError(f"gains: season {s!r} is not a season of the building {self.building.season_names}")
            gains[s] = check_shape(g, (n_tow, nq), f"gains[{s!r}]")
        set_("gains", gains)
        fc = np.zeros(nz) if self.f_ig_const is None else self.f_ig_const
        set_("f_ig_const", check_shape(fc, (nz,), "f_ig_const"))
        set_("_spec", spec)
        set_("_template", template)
        set_("_network", network)
        set_("_disc", network.discretize(self.step))
        set_("_cache", {})

    # --- structure ---------------------------------------------------------------
    @property
    def network(self):
        """The assembled continuous-time :class:`~.network.RCNetwork`."""
        return self._network

    @property
    def discrete(self):
        """The :class:`~.network.DiscreteBilinear` model at ``self.step``."""
        return self._disc

    @property
    def n_states(self) -> int:
        return self._template.n_states

    @property
    def state_names(self) -> tuple:
        return self._template.node_names

    @property
    def outputs(self) -> tuple:
        return self._spec.zones

    @property
    def inputs(self) -> tuple:
        return tuple(f"m_{v}" for v in self.building.vav_names)

    @property
    def disturbances(self) -> tuple:
        return self._template.disturbances

    @property
    def q_names(self) -> tuple:
        """Names of the columns of ``q``: ``f_ig_<zone>`` [W] (and ``T_ground`` [°C])."""
        return self._template.q_names

    def continuous_matrices(self) -> BilinearMatrices:
        """Continuous-time sparse matrices (per second), before discretisation."""
        return self._network.continuous_matrices()

    def discrete_matrices(self) -> BilinearMatrices:
        """Discrete-time matrices at ``self.step`` (see :class:`~.network.BilinearMatrices`)."""
        return self._disc.matrices()

    # --- data -> signals -----------------------------------------------------------
    def measured_outputs(self, frame: pd.DataFrame) -> np.ndarray:
        cols = [f"T_{z}" for z in self.outputs]
        require_columns(frame, cols, self, "zone temperature")
        return frame[cols].to_numpy(dtype=float)

    def signals(self, frame: pd.DataFrame):
        require_columns(frame, self.inputs, self, "VAV airflow")
        require_columns(frame, self.disturbances, self, "disturbance")
        u = frame[list(self.inputs)].to_numpy(dtype=float)
        v = frame[list(self.disturbances)].to_numpy(dtype=float, copy=True)
        if self.inlets and "T_supply" not in self.inlets:
            # every box takes its own inlet column, so T_supply has no coefficient (its Bv and Bvu columns are
            # zero): a gap in it must neither turn a simulation into NaN nor skip an evaluation window
            j = self.disturbances.index("T_supply")
            v[:, j] = np.where(np.isfinite(v[:, j]), v[:, j], 0.0)
        return u, v

    def gains_for_rows(self, index: pd.DatetimeIndex) -> np.ndarray:
        """``q`` (n, nq) at each timestamp, each row in its own season (mean profile if a season is missing)."""
        return gains_for_rows(self.gains, self.building, float(self.step), index, self.holidays)

    # --- dynamics -----------------------------------------------------------------
    def step_state(self, x, u, v, q):
        return self._disc.step_state(x, u, v, q)

    def equations(self):
        """The model as :class:`~hvacfmu.models.equations.ModelEquations` (bilinear in the airflows)."""
        from ..equations import ModelEquations

        m = self.discrete_matrices()
        dense = lambda M: M.toarray() if hasattr(M, "toarray") else np.asarray(M, dtype=float)  # noqa: E731
        A = dense(m.A)
        return ModelEquations(
            step=float(self.step),
            A=A,
            Bu=np.zeros((A.shape[0], len(self.inputs))),
            Bv=dense(m.Bv),
            Bq=dense(m.Bq),
            C=dense(m.C),
            inputs=tuple(self.inputs),
            disturbances=tuple(self.disturbances),
            outputs=tuple(self.outputs),
            gains=dict(self.gains),
            Bxu=tuple(dense(b) for b in m.Bxu),
            Bvu=tuple(dense(b) for b in m.Bvu),
        )

    def output(self, x):
        return np.asarray(x)[..., : len(self.outputs)]

    def simulate(self, x0, u, v, q):
        """Open-loop simulation (modal coordinates internally, exact to rounding); see :meth:`ZoneModel.simulate`."""
        d = self._disc
        x0 = np.asarray(x0, dtype=float)
        u, v, q = (np.asarray(a, dtype=float) for a in (u, v, q))
        m = u @ d.zone_vav.T
        _, Z, _, _ = d.run(x0 @ d.W.T, m, v, q, record_states=True, mt=d.inlet_flux(u, v))
        with one_blas_thread():
            X = Z @ d.V.T
        return X, self.output(X)

    # --- state estimation -------------------------------------------------------------
    @property
    def kalman_gain(self) -> np.ndarray:
        """Filter gain (n_states, n_zones) of the state estimator, computed on first use.

        ``observer = "kalman"`` (default): steady-state Kalman gain of the
        model linearised at ``airflow``, with white process noise ``q_air``,
        ``q_mass`` [K per step] and sensor noise ``r`` [K] (one DARE, about
        2-3 s at 270 states). ``observer = "gain_injection"``: the limit of the
        Kalman filter whose process noise is the unknown internal gain of each
        zone and whose sensor noise vanishes, ``K = B_IG (C B_IG)^{-1}``: each
        measured zone temperature is explained by a heat input to that zone's
        air and the walls follow physically. On the emulated floor the Kalman
        gain gives better 24-hour predictions (mean RMS 0.21 K vs 0.28 K):
        its wall states adapt within the warm-up.
        """
        if "K" not in self._cache:
            k = self.options["kalman"]
            if k["observer"] == "kalman":
                self._cache["K"] = kalman_gain(self._disc, k["airflow"], k["q_air"], k["q_mass"], k["r"])
            else:
                self._cache["K"] = gain_injection(self._disc)
        return self._cache["K"]

    def initial_state(self, frame: pd.DataFrame, k0: int) -> np.ndarray:
        """State at row ``k0`` estimated by a Kalman filter over the preceding ``warmup_steps`` rows.

        The filter starts from the steady state of the walls for the mean zone
        and outdoor temperatures of the warm-up window, runs with the measured
        inputs and the season's internal gains, and is corrected by every
        measured zone temperature up to and including row ``k0``.
        """
        return self.initial_states(frame, [k0])[0]

    def initial_states(self, frame: pd.DataFrame, k0s) -> np.ndarray:
        """Batched :meth:`initial_state` for several rows ``k0s``; returns (len(k0s), n_states)."""
        k0s = np.asarray(k0s, dtype=np.int64).reshape(-1)
        n = len(frame)
        if np.any((k0s < 0) | (k0s >= n)):
            raise ModelError(
                f"initial_state: rows {k0s[(k0s < 0) | (k0s >= n)].tolist()} outside the frame (0..{n - 1})"
            )
        nw = int(self.options["kalman"]["warmup_steps"])
        short = k0s < nw
        if short.any() and not short.all():  # rows near the start of the data get the warm-up they can
            out = np.empty((len(k0s), self.n_states))
            out[~short] = self.initial_states(frame, k0s[~short])
            for i in np.flatnonzero(short):
                out[i] = self.initial_states(frame, k0s[i : i + 1])[0]
            return out
        w = int(min(nw, k0s.min()))
        rows = k0s[:, None] + np.arange(-w, 1)[None, :]
        need = np.unique(rows)
        sub = frame.iloc[need]
        pos = np.searchsorted(need, rows)
        y = self.measured_outputs(sub)
        u, v = self.signals(sub)
        q = self.gains_for_rows(sub.index)
        return self._filter_windows(y[pos], u[pos[:, :-1]], v[pos[:, :-1]], q[pos[:, :-1]])

    def _filter_windows(self, y, u, v, q, disc=None, K=None):
        """Filtered state at the last row of each window; y (B, w+1, nz), u/v/q (B, w, .)."""
        d = self._disc if disc is None else disc
        K = self.kalman_gain if K is None else K
        return filter_windows(d, K, y, u, v, q)

    # --- persistence ---------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        bdict = self.building.to_dict()
        return {
            "kind": self.kind,
            "format_version": FORMAT_VERSION,
            "step": self.step,
            "building": bdict,
            "building_sha256": building_hash(bdict),
            "params": {k: float(self.params[k]) for k in PARAM_NAMES},
            "solar": bool(self.solar),
            "options": self.options,
            "outputs": list(self.outputs),
            "inputs": list(self.inputs),
            "disturbances": list(self.disturbances),
            "q_names": list(self.q_names),
            "f_ig_const": self.f_ig_const.tolist(),
            "gains": gains_to_json(self.gains),
            "meta": self.meta,
            "inlets": list(self.inlets),
        } | ({"holidays": list(self.holidays)} if self.holidays else {})

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "PhysicsModel":
        check_version(d, "physics model file")
        require_keys(d, ["kind", "step", "building", "building_sha256", "params", "gains"], "physics model file")
        if d["kind"] != cls.kind:
            raise ModelError(f"not a physics model file (kind {d['kind']!r})")
        try:
            same = isinstance(d["building"], dict) and building_hash(d["building"]) == d["building_sha256"]
        except (TypeError, ValueError):  # a NaN/inf or a non-JSON value in the embedded building
            same = False
        if not same:
            raise ModelError(
                "physics model file: the embedded building does not match its sha256 (file edited?); "
                "refit the model (hvacfmu fit --model physics) instead of editing the file"
            )
        try:
            building = building_from_dict(d["building"])
        except BuildingError as exc:
            raise ModelError(f"physics model file: embedded building is invalid: {exc}") from None
        try:
            gains = {s: np.asarray(g, dtype=float) for s, g in d["gains"].items()}
            nq = next(iter(gains.values())).shape[1] if gains else 0
            model = cls(
                building=building,
                params=dict(d["params"]),
                gains=gains_from_json(d["gains"], nq, float(d["step"])),
                step=float(d["step"]),
                solar=bool(d.get("solar", False)),
                options=dict(d.get("options", {})),
                f_ig_const=np.asarray(d.get("f_ig_const"), dtype=float) if d.get("f_ig_const") is not None else None,
                meta=check_mapping(d.get("meta", {}), "meta", "physics model file"),
                inlets=check_names(d.get("inlets", []), "inlets", "physics model file"),
                holidays=check_dates(d.get("holidays", []), "holidays", "physics model file"),
            )
        except (TypeError, ValueError, IndexError) as exc:
            if isinstance(exc, ModelError):
                raise
            raise ModelError(f"malformed physics model file: {exc}") from None
        _check_options(model.options)
        for key in ("outputs", "inputs", "disturbances", "q_names"):
            if key in d and check_names(d[key], key, "physics model file") != tuple(getattr(model, key)):
                raise ModelError(
                    f"physics model file: {key} {d[key]} do not match the rebuilt model's {list(getattr(model, key))}"
                )
        return model

    # --- reporting -------------------------------------------------------------------------
    def summary(self) -> str:
        """Parameter estimates with uncertainty and identifiability flags, as text."""
        lines = [
            f"Model B (physics): {self.n_states} states, {len(self.outputs)} zones, "
            f"{len(self.inputs)} VAV boxes, step {self.step:g} s"
        ]
        est = self.meta.get("estimates", {})
        for name in PARAM_NAMES:
            e = est.get(name, {})
            std = e.get("rel_std")
            s = f"  {name:22s} = {self.params[name]:9.4g} W/(m2 K)"
            if std is not None:
                s += f"   rel. std {100 * std:7.1f} %"
            if e.get("flags"):
                s += "   [" + "; ".join(e["flags"]) + "]"
            lines.append(s)
        for i, z in enumerate(self.outputs):
            e = est.get(f"f_ig_const_{z}", {})
            s = f"  f_IG^c {z:15s} = {self.f_ig_const[i]:9.1f} W"
            if e.get("std") is not None:
                s += f"   std {e['std']:7.1f} W"
            if e.get("flags"):
                s += "   [" + "; ".join(e["flags"]) + "]"
            lines.append(s)
        if self.inlets and set(self.inlets) != {"T_supply"}:
            lines.append("  box inlet air: " + ", ".join(f"{b}<-{c}" for b, c in zip(self.inputs, self.inlets)))
        gain_line = _gain_profile_line(self.meta)
        if gain_line:
            lines.append(gain_line)
        flagged = self.meta.get("unidentifiable", [])
        if flagged:
            lines.append("  not identifiable from these data: " + ", ".join(flagged))
        if "fit_rms" in self.meta:
            lines.append(
                f"  step-1 weekend simulation RMS: {self.meta['fit_rms']:.3f} K "
                f"({self.meta.get('n_segments', '?')} segments)"
            )
        return "\n".join(lines)


def gains_for_rows(gains, building, step: float, index, holidays=()) -> np.ndarray:
    """``q`` (n, nq) from the seasonal profiles ``gains`` at each timestamp of ``index``, each row in its own
    season of ``building`` (the mean profile for a season without one); ``holidays`` (ISO dates) read Sunday's
    profile (:func:`hvacfmu.calendars.gain_slots`)."""
    index = pd.DatetimeIndex(index)
    slots = gain_slots(index, step, holidays)
    md = index.month.to_numpy() * 100 + index.day.to_numpy()
    first = np.asarray(next(iter(gains.values())))
    out = np.empty((len(index), first.shape[1]))
    seasons: dict = {}
    for key in np.unique(md):
        s = building.season_of(pd.Timestamp(2001, key // 100, key % 100))
        seasons.setdefault(s, []).append(key)
    for s, keys in seasons.items():
        rows = np.isin(md, keys)
        prof = np.asarray(gains[s]) if s in gains else np.mean([np.asarray(g) for g in gains.values()], axis=0)
        out[rows] = prof[slots[rows] % prof.shape[0]]
    return out


def _gain_profile_line(meta: dict) -> str:
    """The fit report's line on step 2's gain profile (``gain_days``; with ``"auto"`` the choice and its CV scores)."""
    asked = (meta.get("fit_options") or {}).get("gain_days")
    if asked is None:
        return ""
    auto = (meta.get("gains") or {}).get("auto")
    if asked != "auto" or not auto:
        return f"  step-2 gain profile: {asked}"
    scores = ", ".join(f"{g} {v:.3f}" for g, v in auto.get("cv_rms", {}).items())
    line = f"  step-2 gain profile: auto -> {auto['chosen']}"
    if scores:
        return line + (
            f" (blocked CV over {auto['folds']} training weeks, {auto['windows']} windows; 24-h open-loop RMS "
            f"{scores} K)"
        )
    return line + f" ({auto.get('note', 'no CV score')})"


def filter_windows(disc, K, y, u, v, q):
    """Kalman-filtered state at the last row of each window (batched).

    The filter starts from the steady state of the non-air nodes for the
    window's mean zone and outdoor temperatures, with the air nodes at the
    first measured zone temperatures. Missing inputs are filled forward and
    backward within the window; missing zone temperatures skip the correction.

    Parameters
    ----------
    disc : DiscreteBilinear
    K : array (nx, n_zones)
        Physical filter gain.
    y : array (B, w+1, n_zones) [°C]
    u : array (B, w, n_vav) [kg/s]
    v : array (B, w, nv)
    q : array (B, w, nq)

    Returns
    -------
    x : array (B, nx)
    """
    y = np.asarray(y, dtype=float)
    u = np.array(u, dtype=float)
    v = np.array(v, dtype=float)
    q = np.asarray(q, dtype=float)
    B, n1, nz = y.shape
    with np.errstate(all="ignore"):
        ymean = np.nanmean(y, axis=1)
        other = np.nanmean(ymean, axis=1, keepdims=True)
    # zones never measured in a window: mean of the other zones, else 20 °C
    ymean = np.where(np.isnan(ymean), other, ymean)
    ymean = np.where(np.isnan(ymean), 20.0, ymean)
    y0 = np.where(np.isnan(y[:, 0]), ymean, y[:, 0])
    temps = np.r_[0, 1, disc.network.template.inlet_idx]
    for b in np.flatnonzero(np.isnan(v).any(axis=(1, 2)) | np.isnan(u).any(axis=(1, 2))):
        dv = np.zeros(v.shape[-1])
        dv[temps] = ymean[b].mean()  # no outdoor / inlet temperature at all: assume no temperature difference
        v[b] = fill_signals(v[b], dv)
        u[b] = fill_signals(u[b], 0.0)
    if n1 > 1:
        T_out = v[:, :, 0].mean(axis=1)
        x0 = disc.network.wall_steady_state(ymean, T_out, q[:, 0])
    else:
        x0 = disc.network.wall_steady_state(ymean, ymean.mean(axis=1))
    x0[:, :nz] = y0
    m = u @ disc.zone_vav.T
    Kz = disc.W @ K
    *_, z = disc.run(x0 @ disc.W.T, m, v, q, y=y, Kz=Kz, n_correct=n1, mt=disc.inlet_flux(u, v))
    return z @ disc.V.T
