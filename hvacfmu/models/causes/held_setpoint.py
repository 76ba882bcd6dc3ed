"""Cause ``held_setpoint``: a local thermostat the data do not meter holds the zone within a band.

A zone conditioned by a unit whose heat the data do not carry (a reheat coil without ``Td``, a fan coil, a split
unit, a radiator valve), or whose metered heat the model cannot integrate exactly, is held at its setpoint by that
unit's own loop: its measured temperature piles up at the setpoint and does not cross it, while a model's open-loop
prediction drifts through it. Term: the simulated zone temperature is limited to the band the training data hold,

    x_z(k+1) ← min(max(x_z(k+1), lower), upper)   [°C]

``lower`` (a heating setpoint the zone never falls below) and ``upper`` (a cooling setpoint it never exceeds), and
``cooling_floor`` / ``heating_ceiling`` (the setpoint a running unit stops at: only while the zone's airflow exceeds
``u_on`` with supply air :data:`MODE_DT` colder / warmer than the zone; with ``hold`` the running unit holds it
exactly, an ideal thermostat with spare capacity, below ``u_full``, its full airflow, where it may run short) are each optional (``None``: no edge on that side). It is an ideal thermostat of unknown capacity on the side of each
edge: whatever the model predicts beyond the edge, the unit supplies (its heat is not in the data), and within the
band the model runs free.

Evidence (:func:`held_edges`): on the training rows, a share of at least :data:`MIN_PILE` of the zone's
measurements within :data:`EDGE_TOL` of the edge (the pile-up) and at most :data:`MAX_BEYOND` beyond it by more
than the tolerance (the hard edge).

The term is a limiter, not a linear or bilinear map: it has no :class:`~hvacfmu.models.equations.ModelEquations`
form (``matrix_form`` False). Python FMUs run it (they call the model's ``step_state``); the native C FMU and MPC
refuse it or leave it out (:func:`hvacfmu.diagnosis.control.terms_on_base`): a controller must see the effect of its
own heat, which a limiter that stands for an unmetered unit would hide.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from ...errors import ModelError
from .base import StepContext, Term, num, zone_of

#: names of the band's edges, in the order of :meth:`HeldSetpoint.edges`
EDGES = ("lower", "upper", "cooling_floor", "heating_ceiling")
#: supply air this much colder (warmer) than the zone makes a running unit cool (heat) [K]
MODE_DT = 1.0
#: half-width of the pile-up around an edge [K] (a BMS sensor's resolution, 0.1-0.2 °F)
EDGE_TOL = 0.05
#: least share of the training measurements at an edge for it to be a held setpoint [-]
MIN_PILE = 0.10
#: largest share of the training measurements beyond an edge (by more than EDGE_TOL) [-]
MAX_BEYOND = 0.005
#: least rows (and share of the training rows) in which a unit cools or heats for its edge to be learned: about two
#: days of 15-minute steps, and no share since session 17 (it was 2 %): a mode that runs in one season only is a small
#: share of a year's rows however clear its pile-up, and the pile-up rule and the cross-validation judge the edge. The
#: EnergyPlus apartments' corner flats heat in 482-499 of 27,725 training rows (1.7-1.8 %), 89-90 % of them ending at
#: their 21.1 °C setpoint and 0.2 % above (``benchmarks/apartments_s17.md``)
MIN_MODE_ROWS = 200
MIN_MODE_SHARE = 0.0
#: a box with a minimum airflow runs a mode above this share of its 99th-percentile airflow (:func:`running_threshold`)
ON_SHARE_MODULATING = 0.05
#: a unit without a minimum airflow (it cycles on and off) runs above this share of it: any airflow [-]
ON_SHARE_CYCLING = 0.001
#: at this share of its 99th-percentile airflow a unit runs flat out (``u_full``): ``hold`` lets the zone go there.
#: The apartments' split units end a step at their 24.0 °C setpoint in 84-98 % of the cooling steps below 95 % of
#: full airflow and in 16-27 % of the steps at full airflow (``benchmarks/apartments_s16.md``)
FULL_SHARE = 0.99


def running_threshold(q99: float, u_min: float) -> float:
    """The airflow [kg/s] above which a zone's unit runs (``u_on``), from its 99th-percentile airflow ``q99`` on the
    training rows and its minimum airflow ``u_min``.

    - A box with a minimum airflow (``u_min`` > 0, a VAV box) modulates: it runs a mode when it moves clearly more than
      its minimum, ``max(1.05 u_min, ON_SHARE_MODULATING q99)``.
    - A unit without one (``u_min`` 0: a split unit, a furnace, a packaged unit with a cycling fan) turns on and off
      within the step, so its step-averaged airflow is its duty cycle times its full flow: a short run is a small
      average, and a thermostat that runs it for a minute holds its setpoint as much as one that runs it all step.
      It runs whenever it moves air at all, above ``ON_SHARE_CYCLING q99`` (below a flow meter's zero offset).
    Measured on the EnergyPlus mid-rise apartments (``benchmarks/apartments_s16.md``): the split units' rows with
    airflow between that floor and 5 % of ``q99`` are 7 % of their cooling rows, and 97-100 % of them end at 24.0 °C.
    """
    if u_min > 0:
        return float(max(1.05 * u_min, ON_SHARE_MODULATING * q99) + 1e-6)
    return float(ON_SHARE_CYCLING * q99 + 1e-6)


def held_edges(T, tol: float = EDGE_TOL, min_pile: float = MIN_PILE, max_beyond: float = MAX_BEYOND) -> dict:
    """The hard edges of a zone's measured temperatures ``T`` [°C]: ``{"lower": °C or None, "upper": ..., ...}``.

    An edge is the 0.5 % (``max_beyond``) quantile on its side when at least ``min_pile`` of the finite values lie
    within ``tol`` of it (a pile-up at a setpoint), else None. Also returned: the shares at and beyond each edge.
    """
    T = np.asarray(T, float)
    T = T[np.isfinite(T)]
    out: dict = {"lower": None, "upper": None, "n": int(len(T))}
    if len(T) < 100:
        return out
    for side, q in (("lower", max_beyond), ("upper", 1.0 - max_beyond)):
        e = float(np.quantile(T, q))
        at = float(np.mean(np.abs(T - e) <= tol))
        beyond = float(np.mean(T < e - tol) if side == "lower" else np.mean(T > e + tol))
        out[f"{side}_pile"] = at
        out[f"{side}_beyond"] = beyond
        out[f"{side}_candidate"] = e
        if at >= min_pile and beyond <= max_beyond:
            out[side] = round(e, 3)
    return out


@dataclasses.dataclass(frozen=True)
class HeldSetpoint(Term):
    """``x_z ← clip(x_z, lower, upper)`` after every step (``lower``/``upper`` [°C] or None)."""

    cause: ClassVar[str] = "held_setpoint"
    description: ClassVar[str] = "a local thermostat the data do not meter holds the zone in a band (zone)"
    matrix_form: ClassVar[bool] = False
    #: applied after every other term's contribution (a limiter on the next temperature)
    limiter: ClassVar[bool] = True
    zone: str = ""
    lower: float | None = None
    upper: float | None = None
    cooling_floor: float | None = None
    heating_ceiling: float | None = None
    u_on: float = 0.0
    #: a running unit holds its setpoint exactly (both sides), not only stops at it (conditional edges only)
    hold: bool = False
    #: the supply-air column whose difference to the zone tells a running unit's mode: the zone's own unit's
    #: (``T_supply_<ahu>``) where the zone has one, else the airflow-weighted ``T_supply`` of every unit
    supply: str = "T_supply"
    #: ``hold`` holds the setpoint while the unit runs below this airflow [kg/s]; at or above it the unit runs at full
    #: capacity, may fall short, and only stops at its setpoint (None: at every airflow, the session-14 hold)
    u_full: float | None = None

    def columns(self):
        return (self.supply,) if self.cooling_floor is not None or self.heating_ceiling is not None else ()

    def zones(self):
        return (self.zone,)

    def location(self):
        return {"zone": self.zone, **({"hold": True} if self.hold else {})}

    def to_dict(self) -> dict:
        d = super().to_dict()
        if self.supply != "T_supply":
            d["supply"] = self.supply
        if self.hold and self.u_full is not None:
            d["u_full"] = float(self.u_full)
        return d

    def coefficients(self):
        out = {k: float(v) for k, v in zip(EDGES, self.edges()) if v is not None}
        if self.cooling_floor is not None or self.heating_ceiling is not None:
            out["u_on"] = float(self.u_on)
        return out

    def edges(self) -> tuple:
        """``(lower, upper, cooling_floor, heating_ceiling)`` [°C or None]."""
        return (self.lower, self.upper, self.cooling_floor, self.heating_ceiling)

    @classmethod
    def from_dict(cls, d, zone_names, problems, std):
        what = f"extension term {cls.cause}"
        e = {k: (num(d, k, what, problems) if d.get(k) is not None else None) for k in EDGES}
        if all(v is None for v in e.values()):
            problems.append(f"{what}: needs one of {list(EDGES)} (a held setpoint [°C])")
        for name, v in e.items():
            if v is not None and np.isfinite(v) and not -30.0 <= v <= 60.0:
                problems.append(f"{what}: {name} {v} °C is not a zone setpoint (-30 to 60 °C)")
        lo, hi = e["lower"], e["upper"]
        if lo is not None and hi is not None and np.isfinite(lo) and np.isfinite(hi) and lo > hi:
            problems.append(f"{what}: lower {lo} °C above upper {hi} °C")
        hold = d.get("hold", False)
        if not isinstance(hold, bool):
            problems.append(f"{what}: hold must be true or false, got {hold!r}")
            hold = False
        elif hold and e["cooling_floor"] is None and e["heating_ceiling"] is None:
            problems.append(f"{what}: hold needs a running unit's setpoint (cooling_floor or heating_ceiling)")
        u_on = num(d, "u_on", what, problems, default=0.0)
        if np.isfinite(u_on) and u_on < 0:
            problems.append(f"{what}: u_on must be >= 0 kg/s, got {u_on}")
        supply = d.get("supply", "T_supply")
        if not isinstance(supply, str) or not supply:
            problems.append(f"{what}: supply must be a supply-air column name, got {supply!r}")
            supply = "T_supply"
        u_full = num(d, "u_full", what, problems) if d.get("u_full") is not None else None
        if u_full is not None and np.isfinite(u_full) and u_full <= u_on:
            problems.append(f"{what}: u_full {u_full} kg/s must be above u_on {u_on} kg/s")
        zone = zone_of(d, "zone", zone_names, what, problems)
        return cls(zone=zone, u_on=u_on, hold=hold, supply=supply, u_full=u_full, std=std, **e)

    def with_fit(self, sig, coefs, stds):
        return self

    def contribute(self, c: StepContext) -> None:
        zi = c.zi[self.zone]
        T = c.Tn[..., zi]
        if self.cooling_floor is not None or self.heating_ceiling is not None:
            u = c.u[..., zi]
            on = u > self.u_on
            # a unit at full airflow may run short of capacity: it stops at its setpoint but does not hold it
            hold = self.hold & (u < self.u_full) if self.u_full is not None else self.hold
            dT = c.v[..., c.vi[self.supply]] - c.T[..., zi]
            if self.cooling_floor is not None:
                held = np.where(hold, self.cooling_floor, np.maximum(T, self.cooling_floor))
                T = np.where(on & (dT < -MODE_DT), held, T)
            if self.heating_ceiling is not None:
                held = np.where(hold, self.heating_ceiling, np.minimum(T, self.heating_ceiling))
                T = np.where(on & (dT > MODE_DT), held, T)
        if self.lower is not None:
            T = np.maximum(T, self.lower)
        if self.upper is not None:
            T = np.minimum(T, self.upper)
        c.Tn[..., zi] = T

    def add_equations(self, e) -> None:
        raise ModelError(
            f"held_setpoint in zone {self.zone!r} limits the temperature to a band (an unmetered thermostat): no "
            "linear or bilinear equations (ModelEquations); a native FMU and the MPC cannot carry it"
        )

    @classmethod
    def screen(cls, sig, terms, W, resid, options):
        """None in the forward selection: a limiter has no one-step regressor whose likelihood ratio it could
        test (within the band the one-step prediction is unchanged). The diagnosis tests it after the selection,
        by the same blocked cross-validation of 24-hour open-loop windows (:mod:`hvacfmu.diagnosis.held`)."""
        return []

    def held_rows(self, T, rows) -> np.ndarray:
        """The ``rows`` whose next temperature ``T[k+1]`` sits at an unconditional edge (``lower``/``upper``, within
        :data:`EDGE_TOL`): there an unmetered unit's heat enters the zone, so its free equation is not observed
        (the diagnosis leaves them out of the zone's fit). The conditional edges are not counted: the running
        unit's airflow is measured, its rows are the ones that identify its effect."""
        T = np.asarray(T, float)
        rows = np.asarray(rows, int)
        rows = rows[rows < len(T) - 1]
        nxt = T[rows + 1]
        at = np.zeros(len(rows), bool)
        for e in (self.lower, self.upper):
            if e is not None:
                at |= np.abs(nxt - e) <= EDGE_TOL
        return rows[at]

    @classmethod
    def learn(cls, zone, T, u, T_supply, rows, u_min: float = 0.0, supply: str = "T_supply") -> tuple:
        """The term of ``zone`` learned on ``rows`` (None when no edge holds) and its evidence.

        ``T`` (n,) the zone's measured temperature [°C], ``u`` (n,) its airflow [kg/s], ``T_supply`` (n,) the
        supply air [°C] (None: only the unconditional edges), ``rows`` the training rows (one-step: ``k`` with
        ``T[k+1]``), ``u_min`` the zone's minimum airflow [kg/s]. The conditional edges read ``T[k+1]`` of the
        rows whose unit runs (``u > u_on``) with supply air :data:`MODE_DT` colder (cooling) or warmer (heating)
        than the zone: a running unit's own thermostat stops it at its setpoint. ``supply`` names the column
        ``T_supply`` was read from (the term reads it when simulating).
        """
        T = np.asarray(T, float)
        rows = np.asarray(rows, int)
        rows = rows[rows < len(T) - 1]
        ev: dict = {"always": held_edges(T[rows])}
        edges = {"lower": ev["always"]["lower"], "upper": ev["always"]["upper"]}
        u_on, u_full = 0.0, None
        if T_supply is not None and u is not None:
            u = np.asarray(u, float)
            ur = u[rows]
            q = float(np.nanquantile(ur, 0.99)) if np.isfinite(ur).any() else 0.0
            u_on = running_threshold(q, u_min)
            u_full = FULL_SHARE * q if FULL_SHARE * q > u_on else None
            dT = np.asarray(T_supply, float)[rows] - T[rows]
            on = ur > u_on
            for name, mode, side in (("cooling_floor", on & (dT < -MODE_DT), "lower"),
                                     ("heating_ceiling", on & (dT > MODE_DT), "upper")):  # fmt: skip
                nxt = T[rows[mode] + 1]
                if mode.sum() < max(MIN_MODE_ROWS, MIN_MODE_SHARE * len(rows)):
                    ev[name] = {"n": int(mode.sum())}
                    continue
                e = held_edges(nxt)
                ev[name] = {k: e[k] for k in ("n", side, f"{side}_pile", f"{side}_beyond") if k in e}
                edges[name] = e[side]
        if all(v is None for v in edges.values()):
            return None, ev
        conditional = edges.get("cooling_floor") is not None or edges.get("heating_ceiling") is not None
        term = cls(zone=zone, u_on=u_on if conditional else 0.0, supply=supply if conditional else "T_supply",
                   u_full=u_full if conditional else None, **{k: edges.get(k) for k in EDGES})  # fmt: skip
        return term, ev
