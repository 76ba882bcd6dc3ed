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
    heat added in cold weather while the zone's boxes sit at their minimum airflow (reheat coils) or are
    off (``u_min`` at 5 % of the box minimum: a heater running while the system is off):
    ``coef · 1[u_z ≤ u_min] · 1[T_out < T_threshold]`` [K per step]; or, where ``Td_`` is measured, the
    discharge air's delivered heat.
``wind_infiltration``
    outdoor air leaking in with the wind: ``coef · wind · (T_out − x_z)`` into a zone
    [K per step per (m/s · K)]; its matrix form multiplies a disturbance by the state
    (``ModelEquations.Bxv``/``Bvv``).

``sensor_offset``
    a zone's measured column reads an offset from a date on (a sensor re-calibrated or replaced):
    ``coef · 1[start <= t < end]`` into the zone [K per step], through the gains (``gains_at``), a calendar
    term like a holiday.

Hidden states (thermal masses, delayed inputs) are appended to the state after
the zone temperatures; :meth:`ExtendedModel.output` returns the zone
temperatures and :meth:`ExtendedModel.initial_state` estimates the hidden states
from the measured history before the start row.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from ..data.idle import IdleStep, hold_idle_supply, idle_step
from ..errors import ModelError, problems_message
from .base import FORMAT_VERSION, ZoneModel, check_version, require_keys
from .causes import (
    ActuationDelay,
    InternalGainSchedule,
    Reheat,
    SolarGain,
    SupplyAirBilinear,
    Term,
    ThermalMass,
    UnusedInput,
    ZoneCoupling,
    cause_names,
    term_from_dict,
)
from .causes.base import EquationParts, StepContext
from .causes.reheat import reheat_feature
from .causes.signals import dst_active, ema_last, ema_series
from .causes.solar_gain import ORIENTATIONS
from .linear import LinearZoneModel

#: Cause ids of the built-in extension terms, in catalogue order (see :func:`hvacfmu.models.causes.causes`
#: for the registry, which plugins may extend).
CAUSES = cause_names()


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
        delays = set()
        for t in self.terms:
            if not isinstance(t, Term):
                problems.append(f"term {t!r} is not an extension Term")
                continue
            for z in t.zones():
                if z not in zn:
                    problems.append(f"{t.cause} term names zone {z!r}, not one of {list(zn)}")
            d = t.delayed_input()
            if d is not None:
                if d[0] in delays:
                    problems.append(f"two actuation_delay terms for zone {d[0]!r}")
                delays.add(d[0])
            if isinstance(t, InternalGainSchedule) and len(t.coef) != len(zn):
                problems.append(f"internal_gain_schedule term has {len(t.coef)} coefficients for {len(zn)} zones")
        if problems:
            raise ModelError(problems_message("Invalid extended model", problems))
        extra = []
        for t in self.terms:
            for c in t.columns():
                if c not in self.base.disturbances and c not in extra:
                    extra.append(c)
        object.__setattr__(self, "_disturbances", tuple(self.base.disturbances) + tuple(extra))
        # hidden-state layout: each term's hidden states after the zone temperatures
        off = len(zn)
        layout = []
        for t in self.terms:
            layout.append((off, t.n_hidden()))
            off += t.n_hidden()
        object.__setattr__(self, "_layout", tuple(layout))
        # the order terms contribute to a step: limiters (held_setpoint) last, they bound the next temperature
        pairs = sorted(zip(self.terms, self._layout), key=lambda p: p[0].limiter)
        object.__setattr__(self, "_step_order", tuple((t, o) for t, (o, _) in pairs))
        object.__setattr__(self, "_nx", off)
        object.__setattr__(self, "_zi", {z: i for i, z in enumerate(zn)})
        object.__setattr__(self, "_vi", {c: i for i, c in enumerate(self._disturbances)})

    # --- names and dimensions ------------------------------------------------
    @property
    def step(self) -> float:
        return float(self.base.step)

    @property
    def holidays(self) -> tuple:
        """The base model's holiday calendar (ISO dates read on Sunday's profile)."""
        return tuple(self.base.holidays)

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
        for t in self.terms:
            names += t.hidden_names()
        return tuple(names)

    @property
    def causes(self) -> tuple:
        return tuple(t.cause for t in self.terms)

    # --- data -> signals -------------------------------------------------------
    def measured_outputs(self, frame: pd.DataFrame) -> np.ndarray:
        return self.base.measured_outputs(frame)

    def signals(self, frame: pd.DataFrame):
        idle = self.meta.get("idle_supply") if isinstance(self.meta, dict) else None
        if idle:
            # diagnosed on data whose idle supply temperature was held (hvacfmu.data.idle): the same here
            rule = {c: f for c, f in idle["rule"].items() if c in frame.columns}
            frame = hold_idle_supply(frame, rule)[0]
        missing = [c for c in self._disturbances if c not in frame.columns]
        if missing:
            derived = {}
            for t in self.terms:
                derived.update(t.derive(frame, self.base))
            if derived:
                frame = frame.assign(**{c: v for c, v in derived.items() if c in missing})
            missing = [c for c in self._disturbances if c not in frame.columns]
        if missing:
            raise ModelError(
                f"extended model needs frame columns {missing} (e.g. facade irradiance from ghi, "
                "discharge air temperatures Td_<vav> for reheat)"
            )
        u, _ = self.base.signals(frame)
        v = frame[list(self._disturbances)].to_numpy(dtype=float)
        return u, v

    def idle_step(self) -> IdleStep | None:
        """The stored idle supply rule (``meta["idle_supply"]``) on the step vectors, or None without one.

        Boxes in ``base.vavs`` order, targets among :attr:`disturbances`, zones among :attr:`outputs`: the form
        the FMUs apply at every model step with their own zone temperatures (:class:`hvacfmu.data.idle.IdleStep`).
        """
        try:
            return idle_step(self.meta, self._disturbances, tuple(self.base.vavs), self.outputs)
        except ValueError as exc:
            raise ModelError(f"extended model: {exc}") from None

    def simulate_boxes(self, x0, m, v, q, idle: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Open-loop simulation from box airflows and raw disturbances, as the model's FMUs run it.

        With ``idle`` and a stored idle supply rule, each step's disturbances are first held by
        :meth:`idle_step` with the zone temperatures the model itself has at the start of the step (where
        :meth:`signals` uses the measured ones).

        Parameters
        ----------
        x0 : array (n_states,)
        m : array (n, n_vav) [kg/s]
            Box airflows in ``base.vavs`` order.
        v : array (n, n_disturbances)
            Raw disturbances (a supply temperature as logged, idle readings included).
        q : array (n, n_q)

        Returns
        -------
        X : array (n+1, n_states)
        Y : array (n+1, n_outputs) [°C]
        """
        m, v, q = (np.asarray(a, dtype=float) for a in (m, v, q))
        u = m @ np.asarray(self.base.input_map, dtype=float).T
        rule = self.idle_step() if idle else None
        if rule is None:
            return self.simulate(x0, u, v, q)
        x = np.asarray(x0, dtype=float)
        X = np.empty((len(u) + 1, x.shape[-1]))
        X[0] = x
        last = None
        for k in range(len(u)):
            vk, last = rule.apply(v[k], m[k], self.output(x), last)
            x = self.step_state(x, u[k], vk, q[k])
            X[k + 1] = x
        return X, self.output(X)

    def gains_at(self, index: pd.DatetimeIndex, season: str) -> np.ndarray:
        q = self.base.gains_at(index, season)
        for t in self.terms:
            adj = t.gain_adjustment(index, np.asarray(self.base.gains[season]), self.step, self.holidays)
            if adj is not None:
                q = q + adj
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
        for t, (off, n) in zip(self.terms, self._layout):
            if n == 0:
                continue
            if isinstance(t, ThermalMass):
                L = int(min(k0, np.ceil(5.0 / t.alpha)))
                zi = self._zi[t.zone]
                hist = self.measured_outputs(frame.iloc[k0 - L : k0 + 1])[:, zi]
                x[off : off + n] = t.initial_hidden(hist, y0[zi])
            elif t.delayed_input() is not None:
                lo = max(0, k0 - n)
                u, _ = self.base.signals(frame.iloc[lo : k0 + 1])
                col = u[:, self._zi[t.delayed_input()[0]]]
                now = col[-1]
                past = col[:-1]
                buf = np.full(n, now)
                if len(past):
                    buf[n - len(past) :] = past
                x[off : off + n] = np.where(np.isfinite(buf), buf, now)
            else:
                h = t.hidden_history(
                    self.measured_outputs(frame.iloc[: k0 + 1]), self.base.signals(frame.iloc[: k0 + 1])[0], self._zi
                )
                x[off : off + n] = h[-1]
        return x

    def teacher_forced_states(self, frame: pd.DataFrame) -> np.ndarray:
        """States (n, n_states) along ``frame`` with zone temperatures taken from the measurements.

        Hidden states follow their own equations driven by measured temperatures and
        airflows (used for one-step-ahead residuals).
        """
        Y = self.measured_outputs(frame)
        u, _ = self.base.signals(frame) if self._nx > Y.shape[1] else (None, None)
        return self.teacher_forced(Y, u)

    def teacher_forced(self, Y: np.ndarray, U: np.ndarray | None) -> np.ndarray:
        """States (n, n_states) from measured outputs ``Y`` [°C] and airflows ``U`` [kg/s]."""
        X = np.empty((len(Y), self._nx))
        X[:, : Y.shape[1]] = Y
        for t, (off, n) in zip(self.terms, self._layout):
            if n:
                X[:, off : off + n] = t.hidden_history(Y, U, self._zi)
        return X

    # --- dynamics ------------------------------------------------------------------
    def step_state(self, x, u, v, q):
        x = np.asarray(x, dtype=float)
        u = np.asarray(u, dtype=float)
        v = np.asarray(v, dtype=float)
        b = self.base
        nz = len(self.outputs)
        # (the copies below skip broadcast_to where the shapes already agree: a CV rollout steps ~10 windows at a
        # time, tens of thousands of times, and the broadcasting cost as much as the arithmetic)
        same = x.shape[:-1] == u.shape[:-1] == v.shape[:-1]
        shape = x.shape[:-1] if same else np.broadcast_shapes(x.shape[:-1], u.shape[:-1], v.shape[:-1])
        x_new = np.empty(shape + (self._nx,))
        c = StepContext(x=x, T=x[..., :nz], u=u, u_eff=u, v=v, Tn=None, x_new=x_new, zi=self._zi, vi=self._vi)
        for t, (off, _) in zip(self.terms, self._layout):
            if t.delayed_input() is not None:
                if c.u_eff is u:
                    c.u_eff = u.copy() if same else np.array(np.broadcast_to(u, shape + u.shape[-1:]))
                c.off = off
                t.shift_input(c)
        nvb = len(b.disturbances)
        Tn = b.step_state(c.T, c.u_eff, v[..., :nvb], q)  # airflow or delivered-heat form
        Tn = np.asarray(Tn)
        c.Tn = np.array(Tn) if Tn.shape == shape + (nz,) else np.array(np.broadcast_to(Tn, shape + (nz,)))
        for t, off in self._step_order:  # limiters last
            c.off = off
            t.contribute(c)
        x_new[..., :nz] = c.Tn
        return x_new

    def equations(self):
        """The model as :class:`~hvacfmu.models.equations.ModelEquations` (augmented state).

        The base matrices on the zone temperatures, then each term's part from its cause module
        (delays: a shift register of past airflows; thermal mass: a slow state; supply air:
        bilinear ``Bxu``/``Bvu``; coupling: ``A``; solar and measured inputs: ``Bv``; on/off
        reheat: a :class:`~hvacfmu.models.equations.Switch`; wind infiltration: ``Bxv``/``Bvv``).

        Raises
        ------
        ModelError
            For calendar terms (holidays, daylight-saving shift, sensor offsets): no time-invariant equations.
        """
        from .equations import ModelEquations

        b = self.base
        nz, nx, nu, nv = len(self.outputs), self._nx, len(self.inputs), len(self._disturbances)
        e = EquationParts(
            A=np.zeros((nx, nx)),
            Bu=np.zeros((nx, nu)),
            Bv=np.zeros((nx, nv)),
            Bxu=[np.zeros((nx, nx)) for _ in range(nu)],
            Bvu=[np.zeros((nx, nv)) for _ in range(nu)],
            switches=[],
            zi=self._zi,
            vi=self._vi,
            u_state={},
            Bxv=[np.zeros((nx, nx)) for _ in range(nv)],
            Bvv=[np.zeros((nx, nv)) for _ in range(nv)],
        )
        beq = b.equations()
        nvb = len(b.disturbances)
        e.A[:nz, :nz] = beq.A
        e.Bu[:nz] = beq.Bu
        e.Bv[:nz, :nvb] = beq.Bv
        for j in range(len(beq.Bxu)):
            e.Bxu[j][:nz, :nz] += beq.Bxu[j]
        for j in range(len(beq.Bvu)):
            e.Bvu[j][:nz, :nvb] += beq.Bvu[j]
        order = sorted(range(len(self.terms)), key=lambda i: self.terms[i].delayed_input() is None)
        for i in order:  # delays first: later terms see which airflows are states
            e.off = self._layout[i][0]
            self.terms[i].add_equations(e)
        bilinear = any(np.any(m) for m in e.Bxu) or any(np.any(m) for m in e.Bvu)
        products = any(np.any(m) for m in e.Bxv) or any(np.any(m) for m in e.Bvv)
        Bq = np.zeros((nx, nz))
        Bq[:nz] = np.eye(nz)
        C = np.zeros((nz, nx))
        C[:, :nz] = np.eye(nz)
        return ModelEquations(
            step=self.step,
            A=e.A,
            Bu=e.Bu,
            Bv=e.Bv,
            Bq=Bq,
            C=C,
            inputs=self.inputs,
            disturbances=self._disturbances,
            outputs=self.outputs,
            gains={s: np.asarray(g) for s, g in b.gains.items()},
            Bxu=tuple(e.Bxu) if bilinear else (),
            Bvu=tuple(e.Bvu) if bilinear else (),
            switches=tuple(e.switches),
            Bxv=tuple(e.Bxv) if products else (),
            Bvv=tuple(e.Bvv) if products else (),
        )

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
    def from_dict(cls, d: dict[str, Any]) -> ExtendedModel:
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
    def with_terms(self, terms, base: LinearZoneModel | None = None, meta: dict | None = None) -> ExtendedModel:
        """A new model with ``terms`` (and optionally another base and meta)."""
        return ExtendedModel(base=base or self.base, terms=tuple(terms), meta=self.meta if meta is None else meta)

    def summary(self) -> str:
        lines = [f"extended model: base {self.base.kind}, {len(self.terms)} extension term(s)"]
        for t in self.terms:
            loc = ", ".join(f"{k}={v}" for k, v in t.location().items())
            coef = ", ".join(f"{k}={v}" for k, v in t.coefficients().items())
            lines.append(f"  {t.cause}: {loc}" + (f"; {coef}" if coef else ""))
        return "\n".join(lines)


__all__ = [
    "CAUSES",
    "ORIENTATIONS",
    "ActuationDelay",
    "ExtendedModel",
    "InternalGainSchedule",
    "Reheat",
    "SolarGain",
    "SupplyAirBilinear",
    "Term",
    "ThermalMass",
    "UnusedInput",
    "ZoneCoupling",
    "dst_active",
    "ema_last",
    "ema_series",
    "reheat_feature",
    "term_from_dict",
]
