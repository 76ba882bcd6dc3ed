"""Cause ``unused_input``: a measured column the model does not use explains a zone's residuals.

Term ``coef · c(k)`` into a zone, ``c`` a frame column the base model ignores: a reheat
command ``rh_<vav>`` [0..1], a discharge air temperature ``Td_<vav>`` [°C] (when the zone's
delivered heat cannot be formed: see the ``reheat`` cause's ``discharge`` variant), an air
handler's own supply temperature ``T_supply_<ahu>`` [°C], global horizontal irradiance
``ghi`` [W/m²] when no facade irradiance is formed. The finding names the column.

Screen: the columns of the zone's own boxes and air handler and the building-wide ones
(:attr:`Signals.extra`), each with its correlation with the residual (within-transformed)
and its coverage on the training rows. A column holding the same values as one the model reads
(one air handler's ``T_supply_<ahu>`` is the frame's ``T_supply``) is not unused: "no evidence".
A column another term already brings into the zone (a discharge ``reheat`` term's ``Td_<vav>``) is
not named again (:meth:`Term.sources`, ``hvacfmu.diagnosis.candidates``).
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from .base import Candidate, EquationParts, StepContext, Term, corr, num, zone_of


def column_sources(column: str, present=None) -> frozenset:
    """What a measured column carries, as :meth:`Term.sources`: a box's ``Td_<vav>`` and ``rh_<vav>`` are one
    quantity, the heat of its coil (the valve command and the discharge air it sets), so either names both
    (the partner only when it is among the ``present`` columns, when given)."""
    for p in ("Td_", "rh_"):
        if column.startswith(p):
            pair = {f"Td_{column[3:]}", f"rh_{column[3:]}"}
            return frozenset({c for c in pair if present is None or c == column or c in present})
    return frozenset({column})


def read_as(sig, x, rows) -> str | None:
    """The column of the base model holding the same values as ``x`` on ``rows`` (None when none does).

    With one air handler the frame's ``T_supply`` is its ``T_supply_<ahu>``: the model reads that column
    already (its coefficient bounded ≥ 0), and a free coefficient on its copy is a second, unbounded
    coefficient on one input, not a column the model ignores (the EnergyPlus bed's ``unused_input
    T_supply_PACU_VAV_mid``: 4 false findings, ``benchmarks/diagnosis_energyplus_s13.md``).
    """
    xr = np.asarray(x, float)[rows]
    for d in sig.base.disturbances:
        v = sig.V.get(d)
        if v is not None and len(xr) and np.allclose(np.asarray(v, float)[rows], xr, equal_nan=True):
            return d
    return None


@dataclasses.dataclass(frozen=True)
class UnusedInput(Term):
    """``coef · column`` into ``zone`` (``coef`` in K/step per unit of the column)."""

    cause: ClassVar[str] = "unused_input"
    description: ClassVar[str] = "a measured column the model ignores (zone, column)"
    zone: str = ""
    column: str = ""
    coef: float = 0.0

    generic: ClassVar[bool] = True

    def columns(self):
        return (self.column,)

    def sources(self, sig):
        return column_sources(self.column, getattr(sig, "extra", None))

    def zones(self):
        return (self.zone,)

    def location(self):
        return {"zone": self.zone, "column": self.column}

    def coefficients(self):
        return {"coef": float(self.coef)}

    @classmethod
    def from_dict(cls, d, zone_names, problems, std):
        what = f"extension term {cls.cause}"
        col = d.get("column")
        if not isinstance(col, str) or not col:
            problems.append(f"{what}: 'column' must name a measured column, got {col!r}")
        return cls(
            zone=zone_of(d, "zone", zone_names, what, problems),
            column=col,
            coef=num(d, "coef", what, problems),
            std=std,
        )

    def features(self, sig, U_eff):
        return [(sig.zones.index(self.zone), "coef", sig.extra[self.column], -np.inf, np.inf)]

    def contribute(self, c: StepContext) -> None:
        c.Tn[..., c.zi[self.zone]] += self.coef * c.v[..., c.vi[self.column]]

    def add_equations(self, e: EquationParts) -> None:
        e.Bv[e.zi[self.zone], e.vi[self.column]] += self.coef

    @classmethod
    def screen(cls, sig, terms, W, resid, options):
        have = {(t.zone, t.column) for t in terms if isinstance(t, UnusedInput)}
        used = {c for t in terms for c in t.columns()}
        out = []
        for col, zones in sig.extra_zones.items():
            if col in used:
                continue
            x = sig.extra[col]
            same = read_as(sig, x, W.rows)
            for zi, z in enumerate(sig.zones):
                if (zones and z not in zones) or (z, col) in have:
                    continue
                xr = x[W.rows]
                if np.nanstd(xr) <= 0:
                    continue
                if same:
                    out.append(
                        Candidate(
                            cls.cause,
                            {"zone": z, "column": col},
                            status="no evidence",
                            evidence={"column": col, "same_values_as": same},
                            reason=f"{col} holds the same values as {same}, which the model reads: not an unused "
                            f"column (one air handler: the frame's T_supply is its supply temperature)",
                        )
                    )
                    continue
                ev = {"column": col, "corr": corr(resid[:, zi], W(x)), "coverage": sig.extra_coverage.get(col)}
                out.append(Candidate(cls.cause, {"zone": z, "column": col}, [cls(zone=z, column=col)], 0, evidence=ev))
        return out
