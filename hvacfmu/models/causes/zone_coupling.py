"""Cause ``zone_coupling``: an undeclared heat exchange between two zones of the model.

Term ``coef_ab · (x_b − x_a)`` into ``a`` and ``coef_ba · (x_a − x_b)`` into ``b`` [1/step],
fitted as one conductance ``k`` shared by both zones (``coef_ab = k V̄/V_a``, ``coef_ba =
k V̄/V_b``). Screen: every pair not coupled in the base structure; evidence: correlation of
each zone's residual with the temperature difference toward the other (a real exchange
shows in both, with opposite signs of the difference); the diagnosis adds the untied fit's
symmetry ratio. :func:`shared_drivers` names what a pair shares that a partner's temperature could stand in
for (a facade orientation, an air handler): where they share neither, the diagnosis scores the coupling zone
by zone with the partner measured and requires the conductance instrumented by the partners' own airflow changes
to be positive (option ``coupling_alone_unshared``, on by default since session 17; README "couplings").
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from .base import Candidate, EquationParts, StepContext, Term, corr, num
from .signals import coupling_ratios


def zone_units(sig, z: int) -> set:
    """Per-unit supply-temperature columns (``T_supply_<ahu>``) of the air handlers serving zone ``z``; empty when
    the data have one ``T_supply`` for every box (then which unit serves which zone is not measured)."""
    base = sig.base
    return {
        sig.supply_of[v]
        for j, v in enumerate(base.vavs)
        if base.input_map[z, j] > 0 and sig.supply_of.get(v, "T_supply") != "T_supply"
    }


def shared_drivers(sig, a: int, b: int) -> list:
    """What zones ``a`` and ``b`` share that one zone's measured temperature could carry into the other's equation
    without any heat exchange: a facade orientation (the same sun on walls and windows the model does not
    describe) and an air handler (the same supply air and its control noise). ``[]`` when they share neither.

    Measured on the emulator's clean floors (``benchmarks/coupling_s16.md``, zone alone with the partner measured,
    ≥ 3 % at t ≥ 2 in both zones): 16 of 20 ``core9`` and 6 of 15 ``row4`` pairs sharing an orientation pass with no
    coupling; of the pairs sharing none, 0 of 20 on ``quad4``, 0 of 8 on ``sdh``, but 10 of 100 on ``core9``
    (2 of them also beyond :class:`OthersPlacebo`). The zone-by-zone score of unshared pairs
    (``coupling_alone_unshared``) is on by default with the instrument check that rejects those two
    (``benchmarks/coupling_s17.md``).
    """
    out = [f"facade {o}" for o in sorted(set(sig.facades[a]) & set(sig.facades[b]))]
    out += [f"unit {u}" for u in sorted(zone_units(sig, a) & zone_units(sig, b))]
    return out


def on_other_storeys(sig, a: int, b: int) -> bool:
    """Zones ``a`` and ``b`` lie on different storeys of one part of the building file (:attr:`Signals.storeys`,
    from its slabs between zones); False when the file tells no storeys or the two lie in parts that no wall or
    slab joins (their storeys are not comparable).

    A facade orientation shared across storeys is not an exclusion from the zone-by-zone score (diagnosis option
    ``coupling_facade_across_storeys``, on by default since session 21): the exclusion was measured on single floors, where the pairs sharing an
    orientation (corner zones along one facade, ``row4``'s end zones) gain alone without any exchange, 22 of 37
    clean pairs in the detectability oracle's records (``core9`` 16/20, ``row4`` 6/15, ``sdh`` 0/2); the
    two-storey ``stack4``'s diagonal pairs, which all share the east facade across the slab, 0 of 30
    (``benchmarks/stack4_s21.md``). Such a pair must pass the instrument with both zones' facade weather held
    (:func:`~hvacfmu.diagnosis.selection.weather_controls`): the shared facade's sun and outdoor air are then in
    both equations, and only the partners' own airflow moves may carry the exchange.
    """
    st = getattr(sig, "storeys", ())
    if not st or a >= len(st) or b >= len(st) or st[a] is None or st[b] is None:
        return False
    return st[a][0] == st[b][0] and st[a][1] != st[b][1]


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


@dataclasses.dataclass(frozen=True)
class OthersPlacebo(ZoneCoupling):
    """Scoring aid, never a finding: ``p · (mean(x_others) − x_a)`` into ``zone_a`` (``p`` free in [−1, 1]).

    ``others`` are every zone but ``zone_a`` and its candidate partner. A partner that only carries drivers every
    zone shares (floors above and below, occupancy, weather) explains a zone no better than the mean of all the
    other zones does; an exchange with that partner does (``benchmarks/coupling_s16.md``). ``zone_b`` equals
    ``zone_a`` (one zone's equation; the fit's coupled blocks read both).
    """

    others: tuple = ()

    def zones(self):
        return (self.zone_a,)

    def location(self):
        return {"zone": self.zone_a, "others": list(self.others)}

    def features(self, sig, U_eff):
        a = sig.zones.index(self.zone_a)
        idx = [sig.zones.index(o) for o in self.others]
        return [(a, "p", sig.Y[:, idx].mean(axis=1) - sig.Y[:, a], -1.0, 1.0)]

    def with_fit(self, sig, coefs, stds):
        return dataclasses.replace(self, coef_ab=float(coefs.get("p", 0.0)), std={"coef_ab": stds.get("p", 0.0)})

    def contribute(self, c: StepContext) -> None:
        a = c.zi[self.zone_a]
        idx = [c.zi[o] for o in self.others]
        c.Tn[..., a] += self.coef_ab * (c.T[..., idx].mean(axis=-1) - c.T[..., a])

    def add_equations(self, e: EquationParts) -> None:
        a = e.zi[self.zone_a]
        for o in self.others:
            e.A[a, e.zi[o]] += self.coef_ab / len(self.others)
        e.A[a, a] -= self.coef_ab
