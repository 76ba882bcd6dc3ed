"""Cause ``supply_air_bilinear``: supply air cools by airflow times temperature difference.

Term ``coef · u_z · (T_supply − x_z)`` [K/step per (kg/s·K)] into a zone (bilinear in the
airflow and the zone temperature). Screen: one candidate per zone; evidence: correlation of
the residual with the bilinear regressor, residual at minimum and at high airflow.

The zone's base airflow coefficient keeps Model A's sign (``b ≤ 0``) with the term as without it, in the
screen and in the refit alike (:func:`hvacfmu.diagnosis.design.zone_design`): the term's gain is then its
own product's, not a sign freedom of ``b`` the screen never charged for; airflow that warms the zone is
``reheat``'s.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from ...errors import ModelError
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
from .reheat import zone_boxes


@dataclasses.dataclass(frozen=True)
class SupplyAirBilinear(Term):
    """``coef [K/step per (kg/s·K)] · u_z · (T_supply − x_z)`` into ``zone``."""

    cause: ClassVar[str] = "supply_air_bilinear"
    description: ClassVar[str] = "airflow times (supply − zone) temperature (zone)"
    zone: str = ""
    coef: float = 0.0

    def columns(self):
        return ("T_supply",)

    def zones(self):
        return (self.zone,)

    def sources(self, sig):
        """``T_supply`` and the supply column of each unit feeding the zone's boxes (the frame's ``T_supply`` is
        their airflow-weighted mean: with one unit, the same column)."""
        return frozenset({"T_supply"} | {sig.supply_of.get(v, "T_supply") for v in zone_boxes(sig.base, self.zone)})

    def location(self):
        return {"zone": self.zone}

    def coefficients(self):
        return {"coef": float(self.coef)}

    @classmethod
    def from_dict(cls, d, zone_names, problems, std):
        what = f"extension term {cls.cause}"
        return cls(zone=zone_of(d, "zone", zone_names, what, problems), coef=num(d, "coef", what, problems), std=std)

    def features(self, sig, U_eff):
        i = sig.zones.index(self.zone)
        return [(i, "coef", U_eff[:, i] * (sig.V["T_supply"] - sig.Y[:, i]), 0.0, np.inf)]

    def contribute(self, c: StepContext) -> None:
        zi = c.zi[self.zone]
        c.Tn[..., zi] += self.coef * c.u_eff[..., zi] * (c.v[..., c.vi["T_supply"]] - c.T[..., zi])

    def add_equations(self, e: EquationParts) -> None:
        zi = e.zi[self.zone]
        if zi in e.u_state:
            raise ModelError(
                f"supply_air_bilinear in zone {self.zone!r} with a delayed airflow is quadratic in "
                "the state: no bilinear equations"
            )
        e.Bvu[zi][zi, e.vi["T_supply"]] += self.coef
        e.Bxu[zi][zi, zi] -= self.coef

    @classmethod
    def screen(cls, sig, terms, W, resid, options):
        from .signals import effective_inputs

        have = {t.zone for t in terms if isinstance(t, SupplyAirBilinear)}
        U_eff = effective_inputs(sig, terms)
        out = []
        for zi, z in enumerate(sig.zones):
            if z in have:
                continue
            t = cls(zone=z)
            f = t.features(sig, U_eff)[0][2]
            r = resid[:, zi]
            u = U_eff[W.rows, zi]
            umin = sig.u_min[zi]
            ev = {
                "corr": corr(r, W(f)),
                "resid_airflow_min": cond_mean(r, u <= umin * 1.05 + 1e-6),
                "resid_airflow_high": cond_mean(r, u >= np.nanquantile(u, 0.9)),
            }
            out.append(Candidate(cls.cause, {"zone": z}, [t], 0, evidence=ev))
        return out
