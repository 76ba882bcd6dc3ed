"""Cause ``reheat``: heat added by a zone's reheat coils.

Two forms, one cause:

- ``variant="switch"`` (no discharge temperature measured): on/off heat at minimum airflow in
  cold weather, ``coef · 1[u_z ≤ u_min] · 1[T_out < T_threshold]`` [K/step]; in the matrix form a
  :class:`~hvacfmu.models.equations.Switch`. The screen also offers it with the box off
  (``u_min`` = :data:`BOX_OFF_FRACTION` of the box minimum): heat that runs while the system is off.
- ``variant="discharge"`` (``Td_<vav>`` measured): modulating reheat seen through the
  discharge air, ``coef · Q_z`` with ``Q_z = Σ_boxes m cp (Td − T_supply)`` [kW] the heat the
  coils add to the supply air (cp = 1005 J/(kg K)); a disturbance ``Qrh_<zone>`` the model
  reads from the frame (``reheat_columns``).

Screen: one candidate per zone; evidence: the residual's mean in the reheat regime by
outdoor threshold, and its correlation with the reheat heat where it is measured.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from ...data.idle import BOX_OFF_FRACTION  # airflow bound of the box-off regime, a fraction of the box minimum
from ...errors import ModelError
from ..equations import Switch
from .base import (
    Candidate,
    EquationParts,
    StepContext,
    Term,
    cond_mean,
    corr,
    num,
    zone_of,
)

#: Outdoor-temperature thresholds tried for the on/off form [°C].
REHEAT_THRESHOLDS = (8.0, 10.0, 12.0, 14.0, 16.0)
#: Outdoor-temperature thresholds tried for the box-off form [°C]: the same on/off term with the box shut
#: (airflow ≤ :data:`BOX_OFF_FRACTION` of its minimum), for heat that runs when the system is off (a perimeter
#: heater, a coil on its own thermostat). The minimum-airflow regime also holds in occupied hours at minimum
#: airflow: on the EnergyPlus bed it missed two off-hours heaters that these variants find
#: (benchmarks/diagnosis_energyplus_oracle_s13.md).
OFF_THRESHOLDS = (0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0)
#: Minimum rows in a regime for an on/off reheat candidate to be testable.
MIN_REGIME_ROWS = 50
CP_AIR = 1005.0  #: [J/(kg K)]


def reheat_feature(u_z, T_out, u_min: float, T_threshold: float):
    """``1[u_z ≤ u_min] · 1[T_out < T_threshold]`` (0/1); ``u_z`` [kg/s], ``u_min`` [kg/s], ``T_out`` [°C]."""
    with np.errstate(invalid="ignore"):
        return ((np.asarray(u_z) <= u_min) & (np.asarray(T_out) < T_threshold)).astype(float)


def reheat_column(zone: str) -> str:
    """Name of the derived reheat-heat disturbance of a zone [kW]."""
    return f"Qrh_{zone}"


def reheat_heat(frame, vavs, supply=None) -> np.ndarray | None:
    """``Σ m cp (Td − T_supply)⁺`` [kW] over boxes ``vavs``, or None without their ``Td_<vav>`` columns.

    The supply temperature of a box is the air entering its coil: the column of its own unit,
    ``supply[vav]`` (``T_supply_<ahu>``), when the frame has it, else the frame's ``T_supply``.
    With several units the mean ``T_supply`` is not any box's inlet: a packaged unit's box
    (discharge = its unit's supply) would show "reheat" whenever its unit runs warmer than the mean.
    """
    if not len(vavs) or not all(f"Td_{v}" in frame.columns for v in vavs):
        return None
    supply = dict(supply or {})
    out = np.zeros(len(frame))
    for v in vavs:
        col = supply.get(v, "T_supply")
        ts = frame[col if col in frame.columns else "T_supply"].to_numpy(float)
        td = frame[f"Td_{v}"].to_numpy(float)
        out += frame[f"m_{v}"].to_numpy(float) * CP_AIR * np.maximum(td - ts, 0.0) / 1000.0
    return out


def zone_boxes(base, zone: str) -> list:
    """The boxes of a linear model ``base`` that feed output ``zone``."""
    i = list(base.outputs).index(zone)
    return [v for j, v in enumerate(base.vavs) if base.input_map[i, j] > 0]


def zone_reheat_columns(frame, base, supply=None) -> dict:
    """``{Qrh_<zone>: array [kW]}`` for every output of a linear model whose boxes all have ``Td_``.

    ``supply``: ``{vav: supply column}`` of each box's unit (see :func:`reheat_heat`).
    """
    out = {}
    for z in base.outputs:
        q = reheat_heat(frame, zone_boxes(base, z), supply)
        if q is not None:
            out[reheat_column(z)] = q
    return out


@dataclasses.dataclass(frozen=True)
class Reheat(Term):
    """Reheat heat into ``zone``: on/off (``variant="switch"``) or measured through discharge air."""

    cause: ClassVar[str] = "reheat"
    description: ClassVar[str] = (
        "heat of the reheat coils (zone): on/off at minimum airflow or with the box off, or from Td"
    )
    zone: str = ""
    coef: float = 0.0
    u_min: float = 0.0
    T_threshold: float = 12.0
    variant: str = "switch"
    #: ``variant="discharge"``: ``(vav, supply column)`` of each box of the zone (its unit's inlet air)
    supply: tuple = ()

    def columns(self):
        return ("T_out",) if self.variant == "switch" else (reheat_column(self.zone),)

    def zones(self):
        return (self.zone,)

    def sources(self, sig):
        """The discharge form reads its boxes' ``Td_<vav>`` (and so their ``rh_<vav>`` where measured: one coil's
        heat); the on/off form only airflow and ``T_out``, which every equation reads."""
        if self.variant != "discharge":
            return frozenset()
        vavs = [v for v, _ in self.supply] or zone_boxes(sig.base, self.zone)
        present = getattr(sig, "extra", {})
        return frozenset({f"Td_{v}" for v in vavs} | {f"rh_{v}" for v in vavs if f"rh_{v}" in present})

    def location(self):
        return {"zone": self.zone} if self.variant == "switch" else {"zone": self.zone, "variant": self.variant}

    def to_dict(self) -> dict:
        d = super().to_dict()
        if self.variant == "discharge" and self.supply:
            d["supply"] = dict(self.supply)
        return d

    def coefficients(self):
        if self.variant == "switch":
            return {"coef": float(self.coef), "u_min": float(self.u_min), "T_threshold": float(self.T_threshold)}
        return {"coef": float(self.coef)}

    @classmethod
    def from_dict(cls, d, zone_names, problems, std):
        what = f"extension term {cls.cause}"
        variant = d.get("variant", "switch")
        if variant not in ("switch", "discharge"):
            problems.append(f"{what}: variant must be 'switch' or 'discharge', got {variant!r}")
        z = zone_of(d, "zone", zone_names, what, problems)
        if variant == "discharge":
            sup = d.get("supply", {})
            if not isinstance(sup, dict) or not all(isinstance(k, str) and isinstance(c, str) for k, c in sup.items()):
                problems.append(f"{what}: supply must map box names to supply temperature columns, got {sup!r}")
                sup = {}
            supply = tuple(sorted(sup.items()))
            return cls(zone=z, coef=num(d, "coef", what, problems), variant="discharge", supply=supply, std=std)
        return cls(
            zone=z,
            coef=num(d, "coef", what, problems),
            u_min=num(d, "u_min", what, problems),
            T_threshold=num(d, "T_threshold", what, problems),
            std=std,
        )

    def features(self, sig, U_eff):
        i = sig.zones.index(self.zone)
        if self.variant == "discharge":
            return [(i, "coef", sig.V[reheat_column(self.zone)], 0.0, np.inf)]
        return [(i, "coef", reheat_feature(U_eff[:, i], sig.V["T_out"], self.u_min, self.T_threshold), 0.0, np.inf)]

    def derive(self, frame, base) -> dict:
        if self.variant != "discharge":
            return {}
        q = reheat_heat(frame, zone_boxes(base, self.zone), dict(self.supply))
        return {} if q is None else {reheat_column(self.zone): q}

    def contribute(self, c: StepContext) -> None:
        zi = c.zi[self.zone]
        if self.variant == "discharge":
            c.Tn[..., zi] += self.coef * c.v[..., c.vi[reheat_column(self.zone)]]
        else:
            c.Tn[..., zi] += self.coef * reheat_feature(
                c.u_eff[..., zi], c.v[..., c.vi["T_out"]], self.u_min, self.T_threshold
            )

    def add_equations(self, e: EquationParts) -> None:
        zi = e.zi[self.zone]
        if self.variant == "discharge":
            e.Bv[zi, e.vi[reheat_column(self.zone)]] += self.coef
            return
        if zi in e.u_state:
            raise ModelError(
                f"on/off reheat in zone {self.zone!r} with a delayed airflow: the switch would test a "
                "state, not an input"
            )
        g = np.zeros(e.A.shape[0])
        g[zi] = self.coef
        e.switches.append(
            Switch(
                gain=g,
                input_index=zi,
                input_below=self.u_min,
                disturbance_index=e.vi["T_out"],
                disturbance_below=self.T_threshold,
                name=f"reheat_{self.zone}",
            )
        )

    @classmethod
    def screen(cls, sig, terms, W, resid, options):
        from .signals import effective_inputs

        have = {t.zone for t in terms if isinstance(t, Reheat)}
        U_eff = effective_inputs(sig, terms)
        rows = W.rows
        T_out = sig.V["T_out"]
        out = []
        for zi, z in enumerate(sig.zones):
            if z in have:
                continue
            r = resid[:, zi]
            col = reheat_column(z)
            if col in sig.V:
                q = sig.V[col]
                ev = {
                    "corr_reheat_heat": corr(r, W(q)),
                    "reheat_heat_mean_kW": float(np.nanmean(q[rows])),
                    "share_of_rows_heating": float(np.mean(q[rows] > 0.1)),
                }
                if np.nanmax(q[rows]) > 0:
                    out.append(
                        Candidate(
                            cls.cause,
                            {"zone": z, "variant": "discharge"},
                            [cls(zone=z, variant="discharge", supply=_zone_supply(sig, z))],
                            0,
                            evidence=ev,
                        )
                    )
                # heat that does not pass through the discharge air (a perimeter heater, a coil after the
                # sensor) is still the on/off variant below
            umin = float(sig.u_min[zi] * 1.05 + 1e-6)
            u = U_eff[:, zi]
            variants, regime = [], {}
            for th in REHEAT_THRESHOLDS:
                f = reheat_feature(u[rows], T_out[rows], umin, th)
                regime[f"{th:g}"] = {**cond_mean(r, f > 0), "corr": corr(r, W(reheat_feature(u, T_out, umin, th)))}
                if int((f > 0).sum()) >= MIN_REGIME_ROWS:
                    variants.append(cls(zone=z, u_min=umin, T_threshold=th))
            ev = {"u_min": umin, "resid_in_regime_by_threshold": regime}
            if sig.u_min[zi] > 0:
                uoff = float(sig.u_min[zi] * BOX_OFF_FRACTION)
                off = {}
                for th in OFF_THRESHOLDS:
                    f = reheat_feature(u[rows], T_out[rows], uoff, th)
                    off[f"{th:g}"] = cond_mean(r, f > 0)
                    if int((f > 0).sum()) >= MIN_REGIME_ROWS:
                        variants.append(cls(zone=z, u_min=uoff, T_threshold=th))
                ev.update(u_box_off=uoff, box_off_fraction=BOX_OFF_FRACTION, resid_box_off_by_threshold=off)
            if not variants:
                out.append(
                    Candidate(
                        cls.cause,
                        {"zone": z},
                        status="untestable",
                        evidence=ev,
                        reason=f"fewer than {MIN_REGIME_ROWS} training rows at minimum airflow or with the box "
                        f"off in cold weather (T_out < {max(REHEAT_THRESHOLDS + OFF_THRESHOLDS):g} °C)",
                    )
                )
            else:
                out.append(Candidate(cls.cause, {"zone": z}, variants, 1, evidence=ev))
        return out


def _zone_supply(sig, zone: str) -> tuple:
    """``(vav, supply column)`` of the boxes of ``zone`` (the unit each box is fed by)."""
    return tuple((v, sig.supply_of.get(v, "T_supply")) for v in zone_boxes(sig.base, zone))
