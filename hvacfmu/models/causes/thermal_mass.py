"""Cause ``thermal_mass``: a hidden slow state behind a zone (a slab, heavy walls, furniture).

Term: ``s(k+1) = s + alpha (x_z − s)``, ``x_z(k+1) += beta (s − x_z)`` (``alpha``, ``beta``
[1/step]); one hidden state. Screen: one candidate per zone with time constants from
2.5 h to 125 h (:data:`TIME_CONSTANTS_H`, the same durations at every model step); evidence: correlation of the residual with the
filtered temperature departure by time constant, and the slow mode of the residual's
response (the diagnosis adds the share of the residual's low-frequency power).
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from .base import Candidate, EquationParts, StepContext, Term, corr, num, zone_of
from .signals import ema_last, ema_series

#: Thermal-mass time constants tried [h] (filter constants ``alpha = step / tau``: 0.002 ... 0.1 at 15 min).
TIME_CONSTANTS_H = (125.0, 50.0, 25.0, 12.5, 5.0, 2.5)


def alphas(step: float) -> tuple:
    """Filter constants [1/step] of :data:`TIME_CONSTANTS_H` at model step ``step`` [s] (at most 1)."""
    return tuple(min(float(step) / (tau * 3600.0), 1.0) for tau in TIME_CONSTANTS_H)


@dataclasses.dataclass(frozen=True)
class ThermalMass(Term):
    """Hidden slow state ``s``: ``s+ = s + alpha (x_z − s)``, ``x_z+ += beta (s − x_z)`` [1/step]."""

    cause: ClassVar[str] = "thermal_mass"
    description: ClassVar[str] = "hidden slow thermal mass behind a zone (zone, time constant)"
    zone: str = ""
    alpha: float = 0.01
    beta: float = 0.0

    def zones(self):
        return (self.zone,)

    def location(self):
        return {"zone": self.zone}

    def coefficients(self):
        return {"alpha": float(self.alpha), "beta": float(self.beta)}

    @classmethod
    def from_dict(cls, d, zone_names, problems, std):
        what = f"extension term {cls.cause}"
        a = num(d, "alpha", what, problems)
        if np.isfinite(a) and not 0.0 < a <= 1.0:
            problems.append(f"{what}: alpha must lie in (0, 1], got {a}")
        return cls(
            zone=zone_of(d, "zone", zone_names, what, problems), alpha=a, beta=num(d, "beta", what, problems), std=std
        )

    def n_hidden(self):
        return 1

    def hidden_names(self):
        return [f"s_{self.zone}"]

    def hidden_history(self, Y, U, zi):
        return ema_series(Y[:, zi[self.zone]], self.alpha)[:, None]

    def initial_hidden(self, hist: np.ndarray, fallback: float) -> np.ndarray:
        """Filter state at the last row of the zone's measured ``hist``."""
        return np.array([ema_last(hist, self.alpha, fallback)])

    def features(self, sig, U_eff):
        i = sig.zones.index(self.zone)
        return [(i, "beta", ema_series(sig.Y[:, i], self.alpha) - sig.Y[:, i], 0.0, 1.0)]

    def with_fit(self, sig, coefs, stds):
        return dataclasses.replace(self, beta=coefs.get("beta", 0.0), std={"beta": stds.get("beta", 0.0)})

    def contribute(self, c: StepContext) -> None:
        zi = c.zi[self.zone]
        s = c.x[..., c.off]
        c.Tn[..., zi] += self.beta * (s - c.T[..., zi])
        c.x_new[..., c.off] = s + self.alpha * (c.T[..., zi] - s)

    def add_equations(self, e: EquationParts) -> None:
        zi, o = e.zi[self.zone], e.off
        e.A[zi, zi] -= self.beta
        e.A[zi, o] += self.beta
        e.A[o, o] = 1.0 - self.alpha
        e.A[o, zi] = self.alpha

    @classmethod
    def screen(cls, sig, terms, W, resid, options):
        have = {t.zone for t in terms if isinstance(t, ThermalMass)}
        out = []
        for zi, z in enumerate(sig.zones):
            if z in have:
                continue
            cors = {}
            grid = alphas(sig.step)
            for al in grid:
                f = cls(zone=z, alpha=al).features(sig, None)[0][2]
                cors[f"{al:g}"] = corr(resid[:, zi], W(f))
            out.append(
                Candidate(
                    cls.cause,
                    {"zone": z},
                    [cls(zone=z, alpha=al) for al in grid],
                    1,
                    evidence=slow_mode_evidence(cors, sig.step),
                )
            )
        return out


def slow_mode_evidence(cors: dict, step: float) -> dict:
    """Correlations by filter constant and whether the residual carries a slow mode.

    A hidden mass shows as a residual that follows a *slowly* filtered temperature departure:
    the correlation peaks at a time constant of hours to days (``slow_mode``: the best time
    constant is longer than the fastest one tried and its correlation is positive).
    """
    finite = {a: c for a, c in cors.items() if np.isfinite(c)}
    if not finite:
        return {"corr_by_alpha": cors, "slow_mode": False}
    best = max(finite, key=lambda a: finite[a])
    tau = step / float(best) / 3600.0
    fastest = max(finite, key=float)
    return {
        "corr_by_alpha": cors,
        "best_time_constant_h": tau,
        "best_corr": finite[best],
        "slow_mode": bool(finite[best] > 0 and best != fastest),
    }


def keep_stable_time_constant(c, terms, step: float, joint_problems, rescore) -> None:
    """Keep the best time constant of mass candidate ``c`` whose joint refit passes the load checks (in place).

    A time constant is a searched hyper-parameter of the candidate: the one-step fit (``rescore``) picks the best
    of its variants, but a slow mass that a closed-loop fit pairs with a negative diagonal and a twin zone's
    coupling can make the structure refitted with it diverge (the EnergyPlus apartments: 12.5 h and 5 h in one
    flat, spectral radius 1.14, while 25 h and 2.5 h loaded). While the chosen variant's joint refit fails, that
    time constant is dropped from ``c.variants`` and the rest rescored: the result is the best variant among those
    that load (each variant's score does not depend on the others). The dropped ones and the first problem of each
    go to ``c.evidence["unstable_time_constants_h"]``; a candidate left without variants is ``rejected``.

    Parameters
    ----------
    c : Candidate
        Scored (``c.term`` is its best variant); other causes are left alone.
    terms : list of Term
        The current extension terms.
    step : float [s]
    joint_problems : callable(list of Term) -> list of str
        The load checks' problems of the structure refitted with the given terms.
    rescore : callable()
        Scores ``c`` again over its remaining variants (sets ``c.term`` and ``c.test``).
    """
    if c.cause != ThermalMass.cause or c.term is None:
        return
    unstable = {}
    while True:
        problems = joint_problems(list(terms) + [c.term])
        if not problems:
            break
        unstable[f"{float(step) / float(c.term.alpha) / 3600.0:g}"] = problems[0]
        c.variants = [t for t in c.variants if t.alpha != c.term.alpha]
        if not c.variants:
            c.status = "rejected"
            c.reason = (
                "the structure refitted with this mass fails the load checks at every time constant tried ("
                + "; ".join(f"{tau} h: {why}" for tau, why in unstable.items())
                + ")"
            )
            break
        rescore()
    if unstable:
        c.evidence["unstable_time_constants_h"] = unstable
