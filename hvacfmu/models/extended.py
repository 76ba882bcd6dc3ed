"""Extended zone model: Model A plus named physical extension terms (the diagnosis' output).

    x(k+1) = A x(k) + B u_eff(k) + C v(k) + q(k) + Σ_terms θ_t · φ_t(x, s, u, v)

The base part is a six-zone (or lumped) :class:`~hvacfmu.models.linear.LinearZoneModel`;
each extension term is a small, JSON-serialisable component named by the physical
cause it models (the cause ids of :mod:`hvacfmu.diagnosis`):

``solar_gain``
    ``coef · I_<facade>`` into a zone [K per step per W/m²].
``supply_air_bilinear``
    ``coef · u_z · (T_supply − x_z)`` into a zone [K per step per (kg/s · K)]:
    the supply air cools by airflow times temperature difference.
``zone_coupling``
    an undeclared heat exchange between two zones: ``coef_ab · (x_b − x_a)`` into
    ``a`` and ``coef_ba · (x_a − x_b)`` into ``b`` [1 per step].
``thermal_mass``
    a hidden slow state ``s`` (e.g. a slab): ``s(k+1) = s + alpha · (x_z − s)``,
    ``x_z(k+1) += beta · (s − x_z)``; ``alpha``, ``beta`` [1 per step].
``actuation_delay``
    the zone's airflow acts ``delay`` steps late: ``u_z(k)`` is replaced by
    ``u_z(k − delay)`` everywhere in the model; the last ``delay`` inputs are
    hidden states.
``internal_gain_schedule``
    internal gains depart from the seasonal time-of-week profile:
    ``variant="holiday"`` — on listed dates the profile of ``ref_weekday``
    (default Sunday) replaces the day's profile, scaled by ``coef`` per zone;
    ``variant="dst_shift"`` — while daylight-saving time is in effect the profile
    is read ``shift`` steps later, scaled by ``coef`` per zone.
``reheat``
    heat added by the boxes' reheat coils at minimum airflow in cold weather:
    ``coef · 1[u_z ≤ u_min] · 1[T_out < T_threshold]`` [K per step].

Hidden states (thermal masses, delayed inputs) are appended to the state after
the zone temperatures; :meth:`ExtendedModel.output` returns the zone
temperatures and :meth:`ExtendedModel.initial_state` estimates the hidden states
from the measured history before the start row.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
from typing import Any, ClassVar

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from ..errors import ModelError
from ..timeutil import time_of_week
from .base import FORMAT_VERSION, ZoneModel, check_version, require_keys
from .linear import LinearZoneModel

ORIENTATIONS = ("N", "E", "S", "W")

#: Cause ids of the extension terms, in catalogue order.
CAUSES = (
    "solar_gain",
    "supply_air_bilinear",
    "zone_coupling",
    "thermal_mass",
    "internal_gain_schedule",
    "actuation_delay",
    "reheat",
)


# ----------------------------------------------------------------------------
# terms
# ----------------------------------------------------------------------------
def _num(d, key, what, problems, default=None):
    if key not in d:
        if default is not None:
            return default
        problems.append(f"{what}: missing {key!r}")
        return np.nan
    try:
        x = float(d[key])
    except (TypeError, ValueError):
        problems.append(f"{what}: {key!r} must be a number, got {d[key]!r}")
        return np.nan
    if not np.isfinite(x):
        problems.append(f"{what}: {key!r} must be finite, got {x}")
    return x


@dataclasses.dataclass(frozen=True)
class Term:
    """One extension term. ``cause`` is the cause id; ``std`` holds 1-sigma uncertainties
    of the fitted coefficients (same keys as the coefficients, JSON-ready)."""

    cause: ClassVar[str] = ""
    std: dict = dataclasses.field(default_factory=dict, compare=False)

    #: extra frame columns this term reads from v
    def columns(self) -> tuple:
        return ()

    def zones(self) -> tuple:
        """Zones the term acts on (its location)."""
        raise NotImplementedError

    def location(self) -> dict:
        """JSON-ready location (zones, facade, pair, delay ...)."""
        raise NotImplementedError

    def coefficients(self) -> dict:
        """Fitted coefficients (name -> float or list)."""
        raise NotImplementedError

    def to_dict(self) -> dict:
        d = {"cause": self.cause}
        d.update(self.location())
        d.update(self.coefficients())
        if self.std:
            d["std"] = dict(self.std)
        return d


@dataclasses.dataclass(frozen=True)
class SolarGain(Term):
    """``coef [K/step per W/m²] · I_<facade>`` into ``zone``."""

    cause: ClassVar[str] = "solar_gain"
    zone: str = ""
    facade: str = "S"
    coef: float = 0.0

    def columns(self):
        return (f"I_{self.facade}",)

    def zones(self):
        return (self.zone,)

    def location(self):
        return {"zone": self.zone, "facade": self.facade}

    def coefficients(self):
        return {"coef": float(self.coef)}


@dataclasses.dataclass(frozen=True)
class SupplyAirBilinear(Term):
    """``coef [K/step per (kg/s·K)] · u_z · (T_supply − x_z)`` into ``zone``."""

    cause: ClassVar[str] = "supply_air_bilinear"
    zone: str = ""
    coef: float = 0.0

    def columns(self):
        return ("T_supply",)

    def zones(self):
        return (self.zone,)

    def location(self):
        return {"zone": self.zone}

    def coefficients(self):
        return {"coef": float(self.coef)}


@dataclasses.dataclass(frozen=True)
class ZoneCoupling(Term):
    """Heat exchange ``coef_ab · (x_b − x_a)`` into ``zone_a`` and ``coef_ba · (x_a − x_b)`` into ``zone_b`` [1/step]."""

    cause: ClassVar[str] = "zone_coupling"
    zone_a: str = ""
    zone_b: str = ""
    coef_ab: float = 0.0
    coef_ba: float = 0.0

    def zones(self):
        return (self.zone_a, self.zone_b)

    def location(self):
        return {"zones": [self.zone_a, self.zone_b]}

    def coefficients(self):
        return {"coef_ab": float(self.coef_ab), "coef_ba": float(self.coef_ba)}


@dataclasses.dataclass(frozen=True)
class ThermalMass(Term):
    """Hidden slow state ``s``: ``s+ = s + alpha (x_z − s)``, ``x_z+ += beta (s − x_z)`` [1/step]."""

    cause: ClassVar[str] = "thermal_mass"
    zone: str = ""
    alpha: float = 0.01
    beta: float = 0.0

    def zones(self):
        return (self.zone,)

    def location(self):
        return {"zone": self.zone}

    def coefficients(self):
        return {"alpha": float(self.alpha), "beta": float(self.beta)}


@dataclasses.dataclass(frozen=True)
class ActuationDelay(Term):
    """The airflow of ``zone`` acts ``delay`` steps late."""

    cause: ClassVar[str] = "actuation_delay"
    zone: str = ""
    delay: int = 1

    def zones(self):
        return (self.zone,)

    def location(self):
        return {"zone": self.zone, "delay": int(self.delay)}

    def coefficients(self):
        return {}


@dataclasses.dataclass(frozen=True)
class InternalGainSchedule(Term):
    """Departures of the internal gains from the seasonal time-of-week profile.

    ``variant="holiday"``: on ``dates`` (ISO ``YYYY-MM-DD``, local) the profile of
    ``ref_weekday`` (0 = Monday ... 6 = Sunday) replaces the day's profile, scaled by
    ``coef`` (one value per zone, 1 = fully replaced).
    ``variant="dst_shift"``: while daylight-saving time is in effect the profile is
    read ``shift`` steps later (negative: earlier), scaled by ``coef`` per zone.
    """

    cause: ClassVar[str] = "internal_gain_schedule"
    variant: str = "holiday"
    zone_names: tuple = ()
    coef: tuple = ()
    dates: tuple = ()
    ref_weekday: int = 6
    shift: int = 0

    def zones(self):
        return tuple(z for z, c in zip(self.zone_names, self.coef) if c != 0.0) or tuple(self.zone_names)

    def location(self):
        loc = {"variant": self.variant, "zones": list(self.zones())}
        if self.variant == "holiday":
            loc["dates"] = list(self.dates)
            loc["ref_weekday"] = int(self.ref_weekday)
        else:
            loc["shift"] = int(self.shift)
        return loc

    def coefficients(self):
        return {"coef": dict(zip(self.zone_names, (float(c) for c in self.coef)))}

    def adjustment(self, index: pd.DatetimeIndex, profile: np.ndarray, step: float) -> np.ndarray:
        """Gain adjustment (n, n_zones) [K per step] from the season's ``profile`` (n_tow, n_zones)."""
        index = pd.DatetimeIndex(index)
        n_tow = profile.shape[0]
        tow = time_of_week(index, step) % n_tow
        coef = np.asarray(self.coef, dtype=float)
        out = np.zeros((len(index), profile.shape[1]))
        if self.variant == "holiday":
            days = np.array([d.isoformat() for d in index.date]) if len(index) else np.array([], dtype=str)
            on = np.isin(days, np.asarray(self.dates, dtype=str))
            if on.any():
                per_day = n_tow // 7
                ref = self.ref_weekday * per_day + tow[on] % per_day
                out[on] = (profile[ref] - profile[tow[on]]) * coef
        else:
            on = dst_active(index)
            if on.any():
                out[on] = (profile[(tow[on] + self.shift) % n_tow] - profile[tow[on]]) * coef
        return out


@dataclasses.dataclass(frozen=True)
class Reheat(Term):
    """``coef [K/step] · 1[u_z ≤ u_min] · 1[T_out < T_threshold]`` into ``zone`` (``u_min`` [kg/s], ``T_threshold`` [°C])."""

    cause: ClassVar[str] = "reheat"
    zone: str = ""
    coef: float = 0.0
    u_min: float = 0.0
    T_threshold: float = 12.0

    def columns(self):
        return ("T_out",)

    def zones(self):
        return (self.zone,)

    def location(self):
        return {"zone": self.zone}

    def coefficients(self):
        return {"coef": float(self.coef), "u_min": float(self.u_min), "T_threshold": float(self.T_threshold)}


TERM_CLASSES = {c.cause: c for c in (SolarGain, SupplyAirBilinear, ZoneCoupling, ThermalMass, ActuationDelay,
                                     InternalGainSchedule, Reheat)}


def dst_active(index: pd.DatetimeIndex) -> np.ndarray:
    """True where daylight-saving time is in effect at the timestamps of a tz-aware ``index``."""
    index = pd.DatetimeIndex(index)
    if index.tz is None or len(index) == 0:
        return np.zeros(len(index), dtype=bool)
    off = (index.tz_localize(None) - index.tz_convert("UTC").tz_localize(None)).total_seconds().to_numpy(dtype=float)
    # standard offset: the smaller of January's and July's offset in this time zone
    y = index[0].year
    jan = pd.Timestamp(_dt.datetime(y, 1, 15), tz=index.tz).utcoffset().total_seconds()
    jul = pd.Timestamp(_dt.datetime(y, 7, 15), tz=index.tz).utcoffset().total_seconds()
    return off > min(jan, jul)


def term_from_dict(d: dict, zone_names: tuple) -> Term:
    """Rebuild one term from its JSON mapping, validating every field."""
    if not isinstance(d, dict) or d.get("cause") not in TERM_CLASSES:
        raise ModelError(f"extension term {d!r}: 'cause' must be one of {list(TERM_CLASSES)}")
    cause = d["cause"]
    what = f"extension term {cause}"
    problems = []
    std = d.get("std", {})
    if not isinstance(std, dict):
        problems.append(f"{what}: 'std' must be a mapping")
        std = {}

    def zone(key="zone"):
        z = d.get(key)
        if z not in zone_names:
            problems.append(f"{what}: {key} {z!r} is not a zone of the model {list(zone_names)}")
        return z

    if cause == "solar_gain":
        f = d.get("facade")
        if f not in ORIENTATIONS:
            problems.append(f"{what}: facade must be one of {ORIENTATIONS}, got {f!r}")
        t = SolarGain(zone=zone(), facade=f, coef=_num(d, "coef", what, problems), std=std)
    elif cause == "supply_air_bilinear":
        t = SupplyAirBilinear(zone=zone(), coef=_num(d, "coef", what, problems), std=std)
    elif cause == "zone_coupling":
        zs = d.get("zones")
        if not (isinstance(zs, list) and len(zs) == 2 and all(z in zone_names for z in zs) and zs[0] != zs[1]):
            problems.append(f"{what}: 'zones' must be two different zones of {list(zone_names)}, got {zs!r}")
            zs = [None, None]
        t = ZoneCoupling(zone_a=zs[0], zone_b=zs[1], coef_ab=_num(d, "coef_ab", what, problems),
                         coef_ba=_num(d, "coef_ba", what, problems), std=std)
    elif cause == "thermal_mass":
        a = _num(d, "alpha", what, problems)
        if np.isfinite(a) and not 0.0 < a <= 1.0:
            problems.append(f"{what}: alpha must lie in (0, 1], got {a}")
        t = ThermalMass(zone=zone(), alpha=a, beta=_num(d, "beta", what, problems), std=std)
    elif cause == "actuation_delay":
        dl = d.get("delay")
        if not (isinstance(dl, int) and 1 <= dl <= 96):
            problems.append(f"{what}: delay must be an integer number of steps in 1..96, got {dl!r}")
            dl = 1
        t = ActuationDelay(zone=zone(), delay=dl, std=std)
    elif cause == "internal_gain_schedule":
        variant = d.get("variant")
        coef = d.get("coef", {})
        if variant not in ("holiday", "dst_shift"):
            problems.append(f"{what}: variant must be 'holiday' or 'dst_shift', got {variant!r}")
        if not isinstance(coef, dict) or any(z not in zone_names for z in coef):
            problems.append(f"{what}: 'coef' must map zone names of {list(zone_names)} to numbers")
            coef = {}
        c = []
        for z in zone_names:
            c.append(_num(coef, z, f"{what} coef", problems, default=0.0))
        dates = tuple(d.get("dates", ()))
        for s in dates:
            try:
                _dt.date.fromisoformat(s)
            except (TypeError, ValueError):
                problems.append(f"{what}: date {s!r} is not ISO YYYY-MM-DD")
        rw, sh = d.get("ref_weekday", 6), d.get("shift", 0)
        if not (isinstance(rw, int) and 0 <= rw <= 6):
            problems.append(f"{what}: ref_weekday must be an integer 0..6, got {rw!r}")
        if not isinstance(sh, int):
            problems.append(f"{what}: shift must be an integer number of steps, got {sh!r}")
        t = InternalGainSchedule(variant=variant, zone_names=tuple(zone_names), coef=tuple(c), dates=dates,
                                 ref_weekday=rw, shift=sh, std=std)
    else:  # reheat
        t = Reheat(zone=zone(), coef=_num(d, "coef", what, problems), u_min=_num(d, "u_min", what, problems),
                   T_threshold=_num(d, "T_threshold", what, problems), std=std)
    if problems:
        from ..errors import problems_message

        raise ModelError(problems_message("Invalid extension term", problems))
    return t


# ----------------------------------------------------------------------------
# the model
# ----------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, eq=False)
class ExtendedModel(ZoneModel):
    """Model A plus extension terms. See the module docstring for the equations.

    Parameters
    ----------
    base : LinearZoneModel
        The linear part (A, B, C, seasonal gains, names, input/output maps).
    terms : tuple of Term
    meta : dict
        Provenance and diagnosis summary (JSON-serialisable).
    """

    base: LinearZoneModel
    terms: tuple = ()
    meta: dict = dataclasses.field(default_factory=dict)

    kind: ClassVar[str] = "extended"

    def __post_init__(self):
        if not isinstance(self.base, LinearZoneModel):
            raise ModelError(f"ExtendedModel base must be a LinearZoneModel, got {type(self.base).__name__}")
        object.__setattr__(self, "terms", tuple(self.terms))
        zn = self.base.outputs
        problems = []
        delays = {}
        for t in self.terms:
            if not isinstance(t, Term):
                problems.append(f"term {t!r} is not an extension Term")
                continue
            for z in t.zones():
                if z not in zn:
                    problems.append(f"{t.cause} term names zone {z!r}, not one of {list(zn)}")
            if isinstance(t, ActuationDelay):
                if t.zone in delays:
                    problems.append(f"two actuation_delay terms for zone {t.zone!r}")
                delays[t.zone] = t.delay
            if isinstance(t, InternalGainSchedule) and len(t.coef) != len(zn):
                problems.append(f"internal_gain_schedule term has {len(t.coef)} coefficients for {len(zn)} zones")
        if problems:
            from ..errors import problems_message

            raise ModelError(problems_message("Invalid extended model", problems))
        extra = []
        for t in self.terms:
            for c in t.columns():
                if c not in self.base.disturbances and c not in extra:
                    extra.append(c)
        object.__setattr__(self, "_disturbances", tuple(self.base.disturbances) + tuple(extra))
        # hidden-state layout
        off = len(zn)
        layout = []
        for t in self.terms:
            n = 1 if isinstance(t, ThermalMass) else (int(t.delay) if isinstance(t, ActuationDelay) else 0)
            layout.append((off, n))
            off += n
        object.__setattr__(self, "_layout", tuple(layout))
        object.__setattr__(self, "_nx", off)
        object.__setattr__(self, "_zi", {z: i for i, z in enumerate(zn)})
        object.__setattr__(self, "_vi", {c: i for i, c in enumerate(self._disturbances)})

    # --- names and dimensions ------------------------------------------------
    @property
    def step(self) -> float:
        return float(self.base.step)

    @property
    def outputs(self) -> tuple:
        return self.base.outputs

    @property
    def inputs(self) -> tuple:
        return self.base.inputs

    @property
    def disturbances(self) -> tuple:
        return self._disturbances

    @property
    def gains(self) -> dict:
        return self.base.gains

    @property
    def n_states(self) -> int:
        return self._nx

    @property
    def state_names(self) -> tuple:
        """Names of the states: zone temperatures, then hidden states."""
        names = [f"T_{z}" for z in self.outputs]
        for t, (_, n) in zip(self.terms, self._layout):
            if isinstance(t, ThermalMass):
                names.append(f"s_{t.zone}")
            elif isinstance(t, ActuationDelay):
                names += [f"u_{t.zone}_lag{t.delay - j}" for j in range(n)]
        return tuple(names)

    @property
    def causes(self) -> tuple:
        return tuple(t.cause for t in self.terms)

    # --- data -> signals -------------------------------------------------------
    def measured_outputs(self, frame: pd.DataFrame) -> np.ndarray:
        return self.base.measured_outputs(frame)

    def signals(self, frame: pd.DataFrame):
        missing = [c for c in self._disturbances if c not in frame.columns]
        if missing:
            raise ModelError(f"extended model needs frame columns {missing} (e.g. facade irradiance from ghi)")
        u, _ = self.base.signals(frame)
        v = frame[list(self._disturbances)].to_numpy(dtype=float)
        return u, v

    def gains_at(self, index: pd.DatetimeIndex, season: str) -> np.ndarray:
        q = self.base.gains_at(index, season)
        for t in self.terms:
            if isinstance(t, InternalGainSchedule):
                q = q + t.adjustment(index, np.asarray(self.base.gains[season]), self.step)
        return q

    def initial_state(self, frame: pd.DataFrame, k0: int) -> np.ndarray:
        """Zone temperatures measured at row ``k0``; hidden states from the history before it.

        Thermal masses: the first-order filter ``s+ = s + alpha (x_z − s)`` run over
        up to ``5/alpha`` steps of measured history (gaps held), started at the first
        measurement. Delayed inputs: the measured airflows of the ``delay`` rows before
        ``k0`` (the airflow at ``k0`` where they are missing).
        """
        x = np.empty(self._nx)
        y0 = self.measured_outputs(frame.iloc[k0 : k0 + 1])[0]
        x[: len(self.outputs)] = y0
        if self._nx == len(self.outputs):
            return x
        for t, (off, n) in zip(self.terms, self._layout):
            if isinstance(t, ThermalMass):
                L = int(min(k0, np.ceil(5.0 / t.alpha)))
                zi = self._zi[t.zone]
                hist = self.measured_outputs(frame.iloc[k0 - L : k0 + 1])[:, zi]
                x[off] = ema_last(hist, t.alpha, fallback=y0[zi])
            elif isinstance(t, ActuationDelay):
                lo = max(0, k0 - n)
                u, _ = self.base.signals(frame.iloc[lo : k0 + 1])
                zi = self._zi[t.zone]
                col = u[:, zi]
                now = col[-1]
                past = col[:-1]
                buf = np.full(n, now)
                if len(past):
                    buf[n - len(past):] = past
                buf = np.where(np.isfinite(buf), buf, now)
                x[off : off + n] = buf
        return x

    def teacher_forced_states(self, frame: pd.DataFrame) -> np.ndarray:
        """States (n, n_states) along ``frame`` with zone temperatures taken from the measurements.

        Hidden states follow their own equations driven by measured temperatures and
        airflows (used for one-step-ahead residuals).
        """
        Y = self.measured_outputs(frame)
        X = np.empty((len(frame), self._nx))
        X[:, : Y.shape[1]] = Y
        if self._nx == Y.shape[1]:
            return X
        u, _ = self.base.signals(frame)
        for t, (off, n) in zip(self.terms, self._layout):
            zi = self._zi[t.zone] if hasattr(t, "zone") else None
            if isinstance(t, ThermalMass):
                X[:, off] = ema_series(Y[:, zi], t.alpha)
            elif isinstance(t, ActuationDelay):
                col = pd.Series(u[:, zi])
                for j in range(n):
                    X[:, off + j] = col.shift(n - j).to_numpy()
        return X

    # --- dynamics ------------------------------------------------------------------
    def step_state(self, x, u, v, q):
        x = np.asarray(x, dtype=float)
        u = np.asarray(u, dtype=float)
        v = np.asarray(v, dtype=float)
        b = self.base
        nz = len(self.outputs)
        T = x[..., :nz]
        x_new = np.empty(np.broadcast_shapes(x.shape[:-1], u.shape[:-1], v.shape[:-1]) + (self._nx,))
        u_eff = u
        for t, (off, n) in zip(self.terms, self._layout):
            if isinstance(t, ActuationDelay):
                if u_eff is u:
                    u_eff = np.array(np.broadcast_to(u, x_new.shape[:-1] + u.shape[-1:]))
                zi = self._zi[t.zone]
                buf = x[..., off : off + n]
                u_eff[..., zi] = buf[..., 0]
                x_new[..., off : off + n - 1] = buf[..., 1:]
                x_new[..., off + n - 1] = u[..., zi]
        nvb = len(b.disturbances)
        Tn = T @ b.A.T + u_eff @ b.B.T + v[..., :nvb] @ b.C.T + q
        Tn = np.array(np.broadcast_to(Tn, x_new.shape[:-1] + (nz,)))
        for t, (off, n) in zip(self.terms, self._layout):
            if isinstance(t, SolarGain):
                Tn[..., self._zi[t.zone]] += t.coef * v[..., self._vi[f"I_{t.facade}"]]
            elif isinstance(t, SupplyAirBilinear):
                zi = self._zi[t.zone]
                Tn[..., zi] += t.coef * u_eff[..., zi] * (v[..., self._vi["T_supply"]] - T[..., zi])
            elif isinstance(t, ZoneCoupling):
                a, c = self._zi[t.zone_a], self._zi[t.zone_b]
                d = T[..., c] - T[..., a]
                Tn[..., a] += t.coef_ab * d
                Tn[..., c] -= t.coef_ba * d
            elif isinstance(t, ThermalMass):
                zi = self._zi[t.zone]
                s = x[..., off]
                Tn[..., zi] += t.beta * (s - T[..., zi])
                x_new[..., off] = s + t.alpha * (T[..., zi] - s)
            elif isinstance(t, Reheat):
                zi = self._zi[t.zone]
                Tn[..., zi] += t.coef * reheat_feature(u_eff[..., zi], v[..., self._vi["T_out"]], t.u_min,
                                                       t.T_threshold)
        x_new[..., :nz] = Tn
        return x_new

    def output(self, x):
        return np.asarray(x)[..., : len(self.outputs)]

    # --- persistence ------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "format_version": FORMAT_VERSION,
            "base": self.base.to_dict(),
            "terms": [t.to_dict() for t in self.terms],
            "meta": self.meta,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "ExtendedModel":
        check_version(d, "extended model file")
        require_keys(d, ["kind", "base", "terms"], "extended model file")
        if d["kind"] != "extended":
            raise ModelError(f"extended model file has kind {d['kind']!r}")
        if not isinstance(d["base"], dict) or d["base"].get("kind") not in LinearZoneModel.KINDS:
            raise ModelError("extended model file: 'base' must be a lumped or zones model mapping")
        base = LinearZoneModel.from_dict(d["base"])
        if not isinstance(d["terms"], list):
            raise ModelError("extended model file: 'terms' must be a list")
        terms = tuple(term_from_dict(t, base.outputs) for t in d["terms"])
        return cls(base=base, terms=terms, meta=dict(d.get("meta", {})))

    # --- convenience ------------------------------------------------------------------
    def with_terms(self, terms, base: LinearZoneModel | None = None, meta: dict | None = None) -> "ExtendedModel":
        """A new model with ``terms`` (and optionally another base and meta)."""
        return ExtendedModel(base=base or self.base, terms=tuple(terms), meta=self.meta if meta is None else meta)

    def summary(self) -> str:
        lines = [f"extended model: base {self.base.kind}, {len(self.terms)} extension term(s)"]
        for t in self.terms:
            loc = ", ".join(f"{k}={v}" for k, v in t.location().items())
            coef = ", ".join(f"{k}={v}" for k, v in t.coefficients().items())
            lines.append(f"  {t.cause}: {loc}" + (f"; {coef}" if coef else ""))
        return "\n".join(lines)


# ----------------------------------------------------------------------------
# shared feature functions (used by the model and by the diagnosis' regressions)
# ----------------------------------------------------------------------------
def reheat_feature(u_z, T_out, u_min: float, T_threshold: float):
    """``1[u_z ≤ u_min] · 1[T_out < T_threshold]`` (0/1); ``u_z`` [kg/s], ``u_min`` [kg/s], ``T_out`` [°C]."""
    with np.errstate(invalid="ignore"):
        return ((np.asarray(u_z) <= u_min) & (np.asarray(T_out) < T_threshold)).astype(float)


def ema_series(y: np.ndarray, alpha: float) -> np.ndarray:
    """``s(k)`` of the filter ``s(k+1) = s(k) + alpha (y(k) − s(k))``, ``s(0) = y(0)``; gaps are held."""
    y = pd.Series(np.asarray(y, dtype=float)).ffill().bfill().to_numpy()
    if len(y) == 0:
        return y
    if not np.isfinite(y[0]):
        return np.full(len(y), np.nan)
    s = np.empty_like(y)
    s[0] = y[0]
    if len(y) > 1:
        zi = np.array([(1 - alpha) * y[0]])
        out, _ = lfilter([alpha], [1.0, -(1.0 - alpha)], y[:-1], zi=zi)
        s[1:] = out
    return s


def ema_last(hist: np.ndarray, alpha: float, fallback: float) -> float:
    """Filter state at the last row of ``hist`` (which is the start row); ``fallback`` without history."""
    hist = np.asarray(hist, dtype=float)
    if len(hist) == 0 or not np.isfinite(hist).any():
        return float(fallback)
    s = ema_series(hist, alpha)
    return float(s[-1]) if np.isfinite(s[-1]) else float(fallback)


__all__ = [
    "CAUSES",
    "ActuationDelay",
    "ExtendedModel",
    "InternalGainSchedule",
    "Reheat",
    "SolarGain",
    "SupplyAirBilinear",
    "TERM_CLASSES",
    "Term",
    "ThermalMass",
    "ZoneCoupling",
    "dst_active",
    "ema_series",
    "reheat_feature",
    "term_from_dict",
]
