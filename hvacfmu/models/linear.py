"""Model A: the linear data-driven zone model of Zhou, Hu & Tomlin (section III).

    x(k+1) = A x(k) + B u(k) + C v(k) + q_IG(k)                          (airflow form)

``kind = "lumped"``: x is the area-weighted mean zone temperature, u the summed
airflow of all VAV boxes. ``kind = "zones"``: x holds the zone temperatures, u
the summed airflow of each zone's boxes. ``q_IG`` [°C per step] is a
time-of-week profile per season.

Delivered-heat form (issue 13): the boxes act through the heat their air
delivers, ``Q_b = m_b c_p (T_in,b - x_z(b))`` [kW], with ``T_in,b`` the box's
discharge air temperature ``Td_<vav>`` where measured, else its air handler's
supply temperature::

    x_i(k+1) = sum_j A_ij x_j(k) + sum_c C_ic v_c(k) + q_IG,i(k) + beta_i sum_{b in i} Q_b(k)

u are then the airflows of the individual boxes (``m_<vav>``), the inlet
temperatures are disturbances that enter only through ``Q`` (bilinear in u and
x), and ``beta_i > 0`` [K per step per kW]. The term is zero at zero airflow, so
the supply temperature of an air handler that is off never enters.

References
----------
D. Zhou, Q. Hu, C. J. Tomlin, "Model comparison of a data-driven and a physical
model for simulating HVAC systems", eqs. (1) and (temp_propagation_indiv).
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from ..errors import ModelError
from .base import (
    FORMAT_VERSION,
    SEASONAL_FORMAT_VERSION,
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
from .heat import CP_AIR, delivered_heat


@dataclasses.dataclass(frozen=True, eq=False)
class LinearZoneModel(ZoneModel):
    """Linear zone model (Model A).

    Parameters
    ----------
    kind : {"lumped", "zones"}
    step : float [s]
    outputs : tuple of str
        State/output names: zone names, or ``("floor",)``.
    measured_zones : tuple of str
        Zone names whose ``T_<zone>`` columns are measured.
    output_weights : array (n_outputs, n_measured_zones)
        Measured outputs are ``T_measured @ output_weights.T`` (area weights for lumped).
    vavs : tuple of str
        VAV box names; ``m_<vav>`` columns.
    input_map : array (n_inputs, n_vavs)
        u = m_vav @ input_map.T (sums boxes per zone, or all boxes for lumped).
    disturbances : tuple of str
        Frame columns of v, e.g. ``("T_out", "T_supply", "I_N", "I_E", "I_S", "I_W")``.
    A, B, C : arrays (nx, nx), (nx, nu), (nx, nv)
    gains : dict season -> array (n_time_of_week, nx) [°C per step]
    meta : dict
        Provenance, fit options, uncertainties... (JSON-serialisable).
    beta : array (nx,) or None [K per step per kW]
        Delivered-heat form: response of each state to the heat the boxes deliver
        (None: airflow form). Requires ``input_map`` = identity (u = box airflows).
    inlets : tuple of str
        Delivered-heat form: per box (``vavs`` order) the disturbance holding its
        inlet air temperature [°C] (``Td_<vav>``, ``T_supply_<ahu>`` or ``T_supply``).
    heat_map : array (nx, n_vavs) or None
        Delivered-heat form: 1 where box j heats state i (its zone, or the floor).
    """

    kind: str
    step: float
    outputs: tuple
    measured_zones: tuple
    output_weights: np.ndarray
    vavs: tuple
    input_map: np.ndarray
    disturbances: tuple
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    gains: dict
    meta: dict = dataclasses.field(default_factory=dict)
    beta: np.ndarray | None = None
    inlets: tuple = ()
    heat_map: np.ndarray | None = None
    holidays: tuple = ()

    KINDS: ClassVar[tuple] = ("lumped", "zones")

    def __post_init__(self):
        if self.kind not in self.KINDS:
            raise ModelError(f"LinearZoneModel kind must be one of {self.KINDS}, got {self.kind!r}")
        nx, nu, nv = (
            len(self.outputs),
            self.input_map.shape[0] if np.ndim(self.input_map) == 2 else -1,
            len(self.disturbances),
        )
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 - frozen dataclass normalisation
        set_("outputs", tuple(self.outputs))
        set_("measured_zones", tuple(self.measured_zones))
        set_("vavs", tuple(self.vavs))
        set_("disturbances", tuple(self.disturbances))
        set_("output_weights", check_shape(self.output_weights, (nx, len(self.measured_zones)), "output_weights"))
        set_("input_map", check_shape(self.input_map, (nu, len(self.vavs)), "input_map"))
        set_("A", check_shape(self.A, (nx, nx), "A"))
        set_("B", check_shape(self.B, (nx, nu), "B"))
        set_("C", check_shape(self.C, (nx, nv), "C"))
        set_("gains", {s: check_shape(g, (np.shape(g)[0], nx), f"gains[{s!r}]") for s, g in self.gains.items()})
        if not float(self.step) > 0:
            raise ModelError(f"step must be > 0 s, got {self.step}")
        if self.beta is not None:
            self._check_delivered(nx, nv)

    def _check_delivered(self, nx, nv):
        """Normalise and check the delivered-heat fields (beta, inlets, heat_map)."""
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        nb = len(self.vavs)
        set_("beta", check_shape(self.beta, (nx,), "beta"))
        set_("inlets", tuple(self.inlets))
        set_("heat_map", check_shape(self.heat_map, (nx, nb), "heat_map"))
        if not np.array_equal(self.input_map, np.eye(nb)):
            raise ModelError("delivered-heat form: input_map must be the identity (one input per VAV box)")
        if len(self.inlets) != nb:
            raise ModelError(f"delivered-heat form: {len(self.inlets)} inlet columns for {nb} VAV boxes")
        unknown = [c for c in self.inlets if c not in self.disturbances]
        if unknown:
            raise ModelError(
                f"delivered-heat form: inlet column(s) {unknown} are not disturbances {list(self.disturbances)}"
            )
        if not np.all(self.heat_map.sum(axis=0) == 1.0) or not np.all(np.isin(self.heat_map, (0.0, 1.0))):
            raise ModelError("delivered-heat form: heat_map must assign every box to exactly one state")
        set_("_inlet_idx", np.array([self.disturbances.index(c) for c in self.inlets], dtype=np.int64))
        set_("_box_state", np.argmax(self.heat_map, axis=0))

    @property
    def heat(self) -> str:
        """``"delivered"`` (boxes act through ``m c_p (T_in - x)``) or ``"airflow"`` (the paper's form)."""
        return "airflow" if self.beta is None else "delivered"

    # --- interface ---------------------------------------------------------
    @property
    def n_states(self) -> int:
        return len(self.outputs)

    @property
    def inputs(self) -> tuple:
        if self.beta is not None:
            return tuple(f"m_{b}" for b in self.vavs)
        if self.kind == "lumped":
            return ("m_total",)
        return tuple(f"m_{z}" for z in self.outputs)

    def measured_outputs(self, frame: pd.DataFrame) -> np.ndarray:
        cols = [f"T_{z}" for z in self.measured_zones]
        require_columns(frame, cols, self, "zone temperature")
        return frame[cols].to_numpy(dtype=float) @ self.output_weights.T

    def signals(self, frame: pd.DataFrame):
        cols = [f"m_{b}" for b in self.vavs]
        require_columns(frame, cols, self, "VAV airflow")
        require_columns(frame, self.disturbances, self, "disturbance")
        m = frame[cols].to_numpy(dtype=float)
        v = frame[list(self.disturbances)].to_numpy(dtype=float)
        return m @ self.input_map.T, v

    def step_state(self, x, u, v, q):
        x, u, v = (np.asarray(a, dtype=float) for a in (x, u, v))
        xn = x @ self.A.T + u @ self.B.T + v @ self.C.T + q
        if self.beta is None:
            return xn
        Q = delivered_heat(u, v[..., self._inlet_idx], x[..., self._box_state])
        return xn + (Q @ self.heat_map.T) * self.beta

    def output(self, x):
        return np.asarray(x)

    def equations(self):
        """The model as :class:`~hvacfmu.models.equations.ModelEquations`.

        Airflow form: linear (no bilinear terms). Delivered-heat form: for box j
        serving state i, ``Bxu_j = -beta_i c_p/1000 e_i e_i^T`` and
        ``Bvu_j = beta_i c_p/1000 e_i e_{inlet_j}^T``.
        """
        from .equations import ModelEquations

        nx = self.n_states
        Bxu, Bvu = (), ()
        if self.beta is not None:
            Bxu, Bvu = [], []
            for j, i in enumerate(self._box_state):
                g = self.beta[i] * CP_AIR / 1000.0  # [K per step per (kg/s K)]
                bx = np.zeros((nx, nx))
                bx[i, i] = -g
                bv = np.zeros((nx, len(self.disturbances)))
                bv[i, self._inlet_idx[j]] = g
                Bxu.append(bx)
                Bvu.append(bv)
            Bxu, Bvu = tuple(Bxu), tuple(Bvu)
        return ModelEquations(
            step=float(self.step),
            A=self.A,
            Bu=self.B,
            Bv=self.C,
            Bq=np.eye(nx),
            C=np.eye(nx),
            inputs=self.inputs,
            disturbances=tuple(self.disturbances),
            outputs=tuple(self.outputs),
            gains=dict(self.gains),
            Bxu=Bxu,
            Bvu=Bvu,
        )

    def summary(self) -> str:
        """Readable coefficients, stability, internal-gain levels and fit provenance."""
        ny = len(self.outputs)
        w = max(8, *(len(s) for s in self.outputs))
        fmt = lambda v: f"{v: .4g}".rjust(11)  # noqa: E731
        lines = [f"Model A ({self.kind}), step {self.step:g} s, {ny} state(s)"]
        if self.beta is None:
            lines.append("x(k+1) = A x(k) + B u(k) + C v(k) + q_IG(k)")
        else:
            lines.append("x_i(k+1) = A x(k) + C v(k) + q_IG(k) + beta_i sum_b m_b c_p (T_in,b - x_i) [kW]")
        lines.append("A:" + "".ljust(w - 2) + "".join(o.rjust(11) for o in self.outputs))
        lines += [o.ljust(w) + "".join(fmt(v) for v in row) for o, row in zip(self.outputs, self.A)]
        if self.beta is None:
            lines.append(
                "B [K/step per kg/s]: " + " ".join(f"{o}={v:.4g}" for o, v in zip(self.inputs, np.diag(self.B)))
            )
        else:
            lines.append(
                "delivered heat beta [K/step per kW]: "
                + " ".join(f"{o}={v:.4g}" for o, v in zip(self.outputs, self.beta))
            )
            lines.append("box inlets: " + ", ".join(f"{b}<-{c}" for b, c in zip(self.vavs, self.inlets)))
        cols = [j for j, d in enumerate(self.disturbances) if d not in self.inlets]  # inlets act through beta only
        lines.append("C:" + "".ljust(w - 2) + "".join(self.disturbances[j].rjust(11) for j in cols))
        lines += [o.ljust(w) + "".join(fmt(row[j]) for j in cols) for o, row in zip(self.outputs, self.C)]
        rho = float(np.max(np.abs(np.linalg.eigvals(self.A))))
        lines.append(f"spectral radius of A: {rho:.4f} ({'stable' if rho < 1 else 'UNSTABLE'})")
        for s, g in self.gains.items():
            g = np.asarray(g)
            lines.append(f"q_IG {s}: mean {g.mean():.3f}, min {g.min():.3f}, max {g.max():.3f} K/step")
        bw = (self.meta.get("smoothing") or {}).get("bandwidth_h")
        if bw:
            lines.append("LOESS bandwidths [h]: " + ", ".join(f"{k}={v:g}" for k, v in bw.items()))
        ol = self.meta.get("open_loop") or {}
        if ol.get("used") and "rms_before" in ol:
            lines.append(
                f"refined for 24-h open-loop prediction ({ol.get('why', '')}): training RMS "
                f"{ol['rms_before']:.3f} -> {ol['rms_after']:.3f} K on {ol.get('windows', '?')} windows"
                + (f", {ol['seconds']:g} s" if "seconds" in ol else "")
            )
        for k in ("data_sha256", "fit_time", "fit_seconds"):
            if k in self.meta:
                lines.append(f"{k}: {self.meta[k]}")
        for msg in self.meta.get("warnings", []) or []:
            lines.append(f"warning: {msg}")
        return "\n".join(lines)

    # --- persistence ---------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        d = {
            "kind": self.kind,
            "format_version": FORMAT_VERSION,
            "step": float(self.step),
            "outputs": list(self.outputs),
            "measured_zones": list(self.measured_zones),
            "output_weights": self.output_weights.tolist(),
            "vavs": list(self.vavs),
            "input_map": self.input_map.tolist(),
            "disturbances": list(self.disturbances),
            "A": self.A.tolist(),
            "B": self.B.tolist(),
            "C": self.C.tolist(),
            "gains": gains_to_json(self.gains),
            "meta": self.meta,
        }
        if self.beta is not None:
            d.update(beta=self.beta.tolist(), inlets=list(self.inlets), heat_map=self.heat_map.tolist())
        if self.holidays:
            d["holidays"] = list(self.holidays)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> LinearZoneModel:
        if isinstance(d, dict) and "seasonal" in d:  # one coefficient set per season (SeasonalZoneModel)
            return SeasonalZoneModel.from_dict(d)  # type: ignore[return-value]
        check_version(d)
        what = f"{d.get('kind', '?')} model file"
        keys = [
            "kind",
            "step",
            "outputs",
            "measured_zones",
            "output_weights",
            "vavs",
            "input_map",
            "disturbances",
            "A",
            "B",
            "C",
            "gains",
        ]
        require_keys(d, keys, what)
        names = {k: check_names(d[k], k, what) for k in ("outputs", "measured_zones", "vavs", "disturbances")}
        step = check_number(d["step"], "step", what)
        delivered = d.get("beta") is not None
        try:
            return cls(
                kind=d["kind"],
                step=step,
                gains=gains_from_json(check_mapping(d["gains"], "gains", what), len(names["outputs"]), step),
                meta=check_mapping(d.get("meta", {}), "meta", what),
                beta=np.asarray(d["beta"], dtype=float) if delivered else None,
                inlets=check_names(d.get("inlets", []), "inlets", what) if delivered else (),
                heat_map=np.asarray(d.get("heat_map"), dtype=float) if delivered else None,
                holidays=check_dates(d.get("holidays", []), "holidays", what),
                **names,
                **{k: np.asarray(d[k], dtype=float) for k in ("output_weights", "input_map", "A", "B", "C")},
            )
        except (TypeError, ValueError) as exc:
            if isinstance(exc, ModelError):
                raise
            raise ModelError(f"malformed {what}: {exc}") from None


#: The coefficient fields of one season's set in a :class:`SeasonalZoneModel` (``beta`` only in the delivered-heat form).
SEASON_SET_KEYS = ("A", "B", "C", "beta")

#: The structure every season's set of a :class:`SeasonalZoneModel` shares (names, maps, step, calendar).
_SHARED = ("kind", "step", "outputs", "measured_zones", "vavs", "disturbances", "inlets", "holidays")
_SHARED_ARRAYS = ("output_weights", "input_map", "heat_map")


def _refuse(what: str, seasons) -> ModelError:
    return ModelError(
        f"this Model A holds one coefficient set per season ({', '.join(map(str, seasons))}; fit option "
        f"memory_select='season'): {what} needs the season chosen first (model.for_season(season); FMUs: the "
        "'season' parameter; MPC: the context's season). It never runs one season's set in another season"
    )


@dataclasses.dataclass(frozen=True, eq=False)
class SeasonalZoneModel(ZoneModel):
    """Model A with one coefficient set (``A``, ``B``, ``C``, ``beta``) and gain profile per season (issue 13 p.8).

    The building's seasons are separate regimes on some data (the EnergyPlus apartments float for weeks in winter
    and are held by their thermostats in summer, ``benchmarks/regimes_s20.md``); the fit's memory check
    (option ``memory_select="season"``, :mod:`hvacfmu.models.memory`) then keeps per season the candidate its week
    cross-validation ranks first there. Every season's set is an ordinary :class:`LinearZoneModel` (same zones,
    boxes, disturbances, maps, step and holidays; gains of its own season only), returned by :meth:`for_season`.

    A use that does not choose a season (``step_state``, ``simulate``, ``equations()``, the coefficients ``A``,
    ``B``, ``C``, ``beta``) raises :class:`ModelError`: no consumer silently runs one season's set all year.

    Parameters
    ----------
    sets : dict season -> LinearZoneModel
        Each season's model (one coefficient set, gains of that season; other seasons' profiles are dropped).
    meta : dict
        Provenance of the whole model (the fit's record; ``for_season`` copies it into the season's model with
        ``meta["season_set"]``).
    """

    sets: dict
    meta: dict = dataclasses.field(default_factory=dict)

    seasonal: ClassVar[bool] = True  # type: ignore[misc]

    def __post_init__(self):
        if not isinstance(self.sets, dict) or not self.sets:
            raise ModelError("a seasonal Model A needs at least one season's coefficient set")
        sets = {}
        first = None
        for s, m in self.sets.items():
            if not isinstance(m, LinearZoneModel):
                raise ModelError(
                    f"season {s!r}: a seasonal Model A's set must be a LinearZoneModel, got {type(m).__name__}"
                )
            if s not in m.gains:
                raise ModelError(f"season {s!r}: its coefficient set has no gain profile for that season")
            m = dataclasses.replace(m, gains={s: m.gains[s]})
            first = m if first is None else first
            diff = [k for k in _SHARED if getattr(m, k) != getattr(first, k)]
            diff += [
                k
                for k in _SHARED_ARRAYS
                if (getattr(m, k) is None) != (getattr(first, k) is None)
                or (getattr(m, k) is not None and not np.array_equal(getattr(m, k), getattr(first, k)))
            ]
            if (m.beta is None) != (first.beta is None):
                diff.append("beta (heat form)")
            if diff:
                raise ModelError(f"season {s!r}: its coefficient set differs from the others' structure in {diff}")
            sets[str(s)] = m
        object.__setattr__(self, "sets", sets)
        object.__setattr__(self, "_first", first)

    # --- the structure, shared by every season's set ---------------------------------------------------------
    def __getattr__(self, name):
        # only reached for attributes the class does not define: the structure of the sets (names, maps, step)
        if name.startswith("__") or name == "_first":
            raise AttributeError(name)
        if name in _SHARED + _SHARED_ARRAYS + ("heat", "KINDS"):
            return getattr(self._first, name)
        raise AttributeError(f"{type(self).__name__!s} has no attribute {name!r}")

    @property
    def kind(self) -> str:  # type: ignore[override]
        return self._first.kind

    @property
    def step(self) -> float:  # type: ignore[override]
        return self._first.step

    @property
    def outputs(self) -> tuple:  # type: ignore[override]
        return self._first.outputs

    @property
    def inputs(self) -> tuple:  # type: ignore[override]
        return self._first.inputs

    @property
    def disturbances(self) -> tuple:  # type: ignore[override]
        return self._first.disturbances

    @property
    def holidays(self) -> tuple:  # type: ignore[override]
        return self._first.holidays

    @property
    def gains(self) -> dict:  # type: ignore[override]
        """Season -> that season's gain profile (from its own set)."""
        return {s: m.gains[s] for s, m in self.sets.items()}

    @property
    def n_states(self) -> int:
        return self._first.n_states

    def map_sets(self, fn) -> SeasonalZoneModel:
        """The same seasonal model with ``fn(set)`` in place of every season's set (e.g. without holidays)."""
        return SeasonalZoneModel(sets={s: fn(m) for s, m in self.sets.items()}, meta=self.meta)

    # --- what needs a season ------------------------------------------------------------------------------
    def for_season(self, season: str) -> LinearZoneModel:
        """The ordinary one-set model of ``season`` (its coefficients and gain profile; meta ``season_set``)."""
        if season not in self.sets:
            raise ModelError(
                f"this seasonal Model A has no coefficient set for season {season!r}; it has {list(self.sets)}"
            )
        meta = {**self.meta, "season_set": season}
        plaus = (self.meta.get("plausibility") or {}).get("seasons") if isinstance(self.meta, dict) else None
        if isinstance(plaus, dict) and season in plaus:  # the set's own checks (plausibility.check_fitted)
            meta["plausibility"] = plaus[season]
        return dataclasses.replace(self.sets[season], meta=meta)

    @property
    def A(self):
        raise _refuse("reading its state matrix A", self.sets)

    @property
    def B(self):
        raise _refuse("reading its input matrix B", self.sets)

    @property
    def C(self):
        raise _refuse("reading its disturbance matrix C", self.sets)

    @property
    def beta(self):
        raise _refuse("reading its delivered-heat coefficients beta", self.sets)

    def step_state(self, x, u, v, q):
        raise _refuse("a simulation step", self.sets)

    def equations(self):
        raise _refuse("its equations (matrix form)", self.sets)

    # --- data -> signals (the same for every set) ----------------------------------------------------------
    def measured_outputs(self, frame: pd.DataFrame) -> np.ndarray:
        return self._first.measured_outputs(frame)

    def signals(self, frame: pd.DataFrame):
        return self._first.signals(frame)

    def initial_state(self, frame: pd.DataFrame, k0: int) -> np.ndarray:
        return self._first.initial_state(frame, k0)

    def output(self, x):
        return np.asarray(x)

    def summary(self) -> str:
        """Each season's :meth:`LinearZoneModel.summary`, headed by the season."""
        parts = [f"Model A ({self.kind}) with one coefficient set per season: {', '.join(self.sets)}"]
        for s in self.sets:
            parts.append(f"--- season {s} ---\n" + dataclasses.replace(self.sets[s], meta={}).summary())
        first = next(iter(self.sets))
        bare = set(dataclasses.replace(self.sets[first], meta={}).summary().splitlines())
        provenance = [line for line in self.for_season(first).summary().splitlines() if line not in bare]
        kept = (self.meta.get("memory") or {}).get("kept") if isinstance(self.meta, dict) else None
        if kept:
            provenance.insert(0, f"memory check (week cross-validation) kept {kept}")
        return "\n".join(parts + (["--- the fit ---"] + provenance if provenance else []))

    # --- persistence --------------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """A Model A file (``format_version`` :data:`~hvacfmu.models.base.SEASONAL_FORMAT_VERSION`) without
        top-level ``A``/``B``/``C``/``beta``: its ``seasonal`` block holds them per season; ``gains`` each season's
        profile from its set."""
        d = self._first.to_dict()
        for k in SEASON_SET_KEYS:
            d.pop(k, None)
        d["format_version"] = SEASONAL_FORMAT_VERSION
        d["gains"] = gains_to_json(self.gains)
        d["seasonal"] = {
            s: {
                "A": m.A.tolist(),
                "B": m.B.tolist(),
                "C": m.C.tolist(),
                **({"beta": m.beta.tolist()} if m.beta is not None else {}),
            }
            for s, m in self.sets.items()
        }
        d["meta"] = self.meta
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SeasonalZoneModel:
        what = f"{d.get('kind', '?')} model file"
        check_version(d, what, newest=SEASONAL_FORMAT_VERSION)
        if d.get("format_version") != SEASONAL_FORMAT_VERSION:
            raise ModelError(f"{what}: a 'seasonal' block needs format_version {SEASONAL_FORMAT_VERSION}")
        seasonal = check_mapping(d["seasonal"], "seasonal", what)
        gains = check_mapping(d.get("gains"), "gains", what)
        if not seasonal or set(seasonal) != set(gains):
            raise ModelError(
                f"{what}: the 'seasonal' block's seasons {sorted(seasonal)} must be the gain profiles' "
                f"{sorted(gains)} (one coefficient set per season)"
            )
        delivered = d.get("heat_map") is not None  # the delivered-heat form's shared box-to-state map
        sets = {}
        for s, block in seasonal.items():
            block = check_mapping(block, f"seasonal[{s!r}]", what)
            require_keys(block, ["A", "B", "C"] + (["beta"] if delivered else []), f"{what}, season {s!r}")
            one = {k: v for k, v in d.items() if k not in ("seasonal", "meta")}
            one.update({k: block[k] for k in SEASON_SET_KEYS if k in block})
            one["format_version"] = FORMAT_VERSION
            one["gains"] = {s: gains[s]}
            try:
                sets[s] = LinearZoneModel.from_dict(one)
            except ModelError as exc:
                raise ModelError(f"season {s!r}: {exc}") from None
        return cls(sets=sets, meta=check_mapping(d.get("meta", {}), "meta", what))
