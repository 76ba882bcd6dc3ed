"""Cause ``wind_infiltration``: outdoor air leaking into a zone in proportion to the wind speed.

Term ``coef · wind · (T_out − T_zone)`` into a zone [K/step], ``wind`` the measured wind speed at
the site [m/s] (the data's ``wind`` column), ``coef`` ≥ 0 [K/step per (m/s · K)]: an air change
that grows with the wind (the EnergyPlus ``ZoneInfiltration:DesignFlowRate`` wind coefficient,
a leaky facade, windows) times the temperature difference it carries. A model with only
``T_out`` has the constant part of the infiltration; the wind-driven part changes from day to
day with the weather fronts and is what persistence follows and a time-invariant model cannot.

Screen: one candidate per zone with an exterior facade (every zone of a building that declares
none) when the dataset has a ``wind`` column covering at least
:data:`~hvacfmu.models.causes.signals.MIN_COVERAGE` of the rows. Evidence: the correlation of
the zone's within-transformed one-step residual with ``wind · (T_out − T_zone)``, with
``T_out − T_zone`` alone, and the partial correlation with the wind term beyond what
``T_out − T_zone`` explains (both regressed out of the residual and the wind term).

The ``wind`` column is read only by this cause: :func:`~hvacfmu.models.causes.signals.unused_columns`
does not hand it to ``unused_input`` (a plain ``coef · wind`` would be the same air change without
its temperature difference, a second name for one heat flow).

The term multiplies a disturbance (the wind) by the zone temperature and by ``T_out``: its matrix
form is a product with a disturbance in :class:`~hvacfmu.models.equations.ModelEquations`,
``Bxv[wind][z, z] = −coef`` and ``Bvv[wind][z, T_out] = coef``. With a wind forecast the state
matrix ``A − coef · wind_k`` (on the zone's diagonal) is time-varying but known, so the native
FMU (input ``wind`` [m/s]) runs it and MPC predicts with it exactly.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from .base import Candidate, EquationParts, StepContext, Term, corr, num, zone_of

#: Name of the measured wind speed column [m/s].
WIND_COLUMN = "wind"
#: Largest wind speed the data layer accepts [m/s] (``hvacfmu.data.loading.WIND_MAX``).
WIND_MAX = 60.0


def wind_feature(wind, T_out, T_zone) -> np.ndarray:
    """``wind · (T_out − T_zone)`` [m/s · K]; ``wind`` [m/s], temperatures [°C]."""
    return np.asarray(wind, float) * (np.asarray(T_out, float) - np.asarray(T_zone, float))


def partial_corr(r, x, z) -> float:
    """Correlation of ``r`` with ``x`` after regressing both on ``z`` (and a constant); NaN when undefined."""
    r, x, z = (np.asarray(a, float) for a in (r, x, z))
    ok = np.isfinite(r) & np.isfinite(x) & np.isfinite(z)
    if ok.sum() < 10:
        return float("nan")
    Z = np.column_stack([np.ones(int(ok.sum())), z[ok]])
    rr = r[ok] - Z @ np.linalg.lstsq(Z, r[ok], rcond=None)[0]
    xr = x[ok] - Z @ np.linalg.lstsq(Z, x[ok], rcond=None)[0]
    return corr(rr, xr)


@dataclasses.dataclass(frozen=True)
class WindInfiltration(Term):
    """``coef [K/step per (m/s · K)] · wind · (T_out − T_zone)`` into ``zone``."""

    cause: ClassVar[str] = "wind_infiltration"
    description: ClassVar[str] = "outdoor air leaking in with the wind: wind·(T_out − T_zone) (zone)"
    zone: str = ""
    coef: float = 0.0

    def columns(self):
        return ("T_out", WIND_COLUMN)

    def zones(self):
        return (self.zone,)

    def location(self):
        return {"zone": self.zone}

    def coefficients(self):
        return {"coef": float(self.coef)}

    @classmethod
    def from_dict(cls, d, zone_names, problems, std):
        what = f"extension term {cls.cause}"
        coef = num(d, "coef", what, problems)
        if np.isfinite(coef) and coef < 0:
            problems.append(f"{what}: coef must be >= 0 (air leaking in carries heat towards T_out), got {coef}")
        elif np.isfinite(coef) and coef * WIND_MAX >= 1.0:
            problems.append(
                f"{what}: coef {coef:.4g} K/step per (m/s K) exchanges more than the zone's whole temperature "
                f"difference with outdoors in one step at {WIND_MAX:g} m/s (coef x {WIND_MAX:g} >= 1): not a building"
            )
        return cls(zone=zone_of(d, "zone", zone_names, what, problems), coef=coef, std=std)

    def features(self, sig, U_eff):
        i = sig.zones.index(self.zone)
        return [(i, "coef", wind_feature(sig.extra[WIND_COLUMN], sig.V["T_out"], sig.Y[:, i]), 0.0, np.inf)]

    def contribute(self, c: StepContext) -> None:
        zi = c.zi[self.zone]
        c.Tn[..., zi] += self.coef * wind_feature(c.v[..., c.vi[WIND_COLUMN]], c.v[..., c.vi["T_out"]], c.T[..., zi])

    def add_equations(self, e: EquationParts) -> None:
        zi, w = e.zi[self.zone], e.vi[WIND_COLUMN]
        e.Bxv[w][zi, zi] -= self.coef
        e.Bvv[w][zi, e.vi["T_out"]] += self.coef

    @classmethod
    def screen(cls, sig, terms, W, resid, options):
        if WIND_COLUMN not in sig.extra:
            return []
        have = {t.zone for t in terms if isinstance(t, WindInfiltration)}
        wind = sig.extra[WIND_COLUMN]
        T_out = sig.V["T_out"]
        exterior = any(len(f) for f in sig.facades)
        out = []
        for zi, z in enumerate(sig.zones):
            if z in have or (exterior and not sig.facades[zi]):
                continue
            f = wind_feature(wind, T_out, sig.Y[:, zi])
            if not np.nanstd(f[W.rows]) > 0:
                continue
            fw, dw = W(f), W(T_out - sig.Y[:, zi])
            r = resid[:, zi]
            ev = {
                "corr": corr(r, fw),
                "corr_dT": corr(r, dw),
                "partial_corr_beyond_dT": partial_corr(r, fw, dw),
                "wind_mean_m_s": float(np.nanmean(wind[W.rows])),
                "coverage": sig.extra_coverage.get(WIND_COLUMN),
            }
            out.append(Candidate(cls.cause, {"zone": z}, [cls(zone=z)], 0, evidence=ev))
        return out
