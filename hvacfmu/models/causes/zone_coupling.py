"""Cause ``zone_coupling``: an undeclared heat exchange between two zones of the model.

Term ``coef_ab · (x_b − x_a)`` into ``a`` and ``coef_ba · (x_a − x_b)`` into ``b`` [1/step],
fitted as one conductance ``k`` shared by both zones (``coef_ab = k V̄/V_a``, ``coef_ba =
k V̄/V_b``). Screen: every pair not coupled in the base structure; evidence: correlation of
each zone's residual with the temperature difference toward the other (a real exchange
shows in both, with opposite signs of the difference); the diagnosis adds the untied fit's
symmetry ratio.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from .base import Candidate, EquationParts, StepContext, Term, corr, num
from .signals import coupling_ratios


@dataclasses.dataclass(frozen=True)
class ZoneCoupling(Term):
    """Heat exchange ``coef_ab · (x_b − x_a)`` into ``zone_a`` and ``coef_ba · (x_a − x_b)`` into ``zone_b`` [1/step]."""

    cause: ClassVar[str] = "zone_coupling"
    description: ClassVar[str] = "heat exchange between two zones not coupled in the model (pair)"
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

    @classmethod
    def from_dict(cls, d, zone_names, problems, std):
        what = f"extension term {cls.cause}"
        zs = d.get("zones")
        if not (isinstance(zs, list) and len(zs) == 2 and all(z in zone_names for z in zs) and zs[0] != zs[1]):
            problems.append(f"{what}: 'zones' must be two different zones of {list(zone_names)}, got {zs!r}")
            zs = [None, None]
        return cls(
            zone_a=zs[0],
            zone_b=zs[1],
            coef_ab=num(d, "coef_ab", what, problems),
            coef_ba=num(d, "coef_ba", what, problems),
            std=std,
        )

    def features(self, sig, U_eff):
        a, b = sig.zones.index(self.zone_a), sig.zones.index(self.zone_b)
        ra, rb = coupling_ratios(sig, a, b)
        d = sig.Y[:, b] - sig.Y[:, a]
        return [(a, "k", d * ra, 0.0, 1.0), (b, "k", -d * rb, 0.0, 1.0)]

    def with_fit(self, sig, coefs, stds):
        ra, rb = coupling_ratios(sig, sig.zones.index(self.zone_a), sig.zones.index(self.zone_b))
        k, sk = coefs.get("k", 0.0), stds.get("k", 0.0)
        return dataclasses.replace(self, coef_ab=k * ra, coef_ba=k * rb, std={"coef_ab": sk * ra, "coef_ba": sk * rb})

    def contribute(self, c: StepContext) -> None:
        a, b = c.zi[self.zone_a], c.zi[self.zone_b]
        d = c.T[..., b] - c.T[..., a]
        c.Tn[..., a] += self.coef_ab * d
        c.Tn[..., b] -= self.coef_ba * d

    def add_equations(self, e: EquationParts) -> None:
        a, b = e.zi[self.zone_a], e.zi[self.zone_b]
        e.A[a, b] += self.coef_ab
        e.A[a, a] -= self.coef_ab
        e.A[b, a] += self.coef_ba
        e.A[b, b] -= self.coef_ba

    @classmethod
    def screen(cls, sig, terms, W, resid, options):
        have = {frozenset(t.zones()) for t in terms if isinstance(t, ZoneCoupling)}
        out = []
        zones = sig.zones
        for a in range(len(zones)):
            for b in range(a + 1, len(zones)):
                if b in sig.neighbours[a] or a in sig.neighbours[b] or frozenset((zones[a], zones[b])) in have:
                    continue
                dw = W(np.asarray(sig.Y[:, b] - sig.Y[:, a], float))
                ev = {"corr_a": corr(resid[:, a], dw), "corr_b": corr(resid[:, b], -dw)}
                out.append(
                    Candidate(
                        cls.cause,
                        {"zones": [zones[a], zones[b]]},
                        [cls(zone_a=zones[a], zone_b=zones[b])],
                        0,
                        evidence=ev,
                    )
                )
        return out
