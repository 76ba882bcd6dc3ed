"""Cause ``solar_gain``: solar gain through one facade of a zone, ``coef · I_<facade>`` [K/step per W/m²].

Screen: one candidate per exterior facade of each zone that the model does not already
heat by that facade. Evidence: correlation of the residual with the facade irradiance
(both within-transformed), residual on sunny vs cloudy hours, and the hour of the day at
which the residual's daytime mean peaks against the facade's own peak hour.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

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
from .signals import base_solar

ORIENTATIONS = ("N", "E", "S", "W")


def peak_hour(sig, values: np.ndarray, rows: np.ndarray) -> float | None:
    """Local hour [h] at which the mean of ``values`` (on ``rows``) over the day is largest (daytime only)."""
    hour = (sig.tow[rows] % (sig.n_tow // 7)) * sig.step / 3600.0
    ok = np.isfinite(values)
    if ok.sum() < 50:
        return None
    h = np.floor(hour[ok]).astype(int)
    means = np.bincount(h, weights=values[ok], minlength=24) / np.maximum(np.bincount(h, minlength=24), 1)
    day = np.arange(24)
    means[(day < 6) | (day > 20)] = -np.inf
    return float(np.argmax(means)) + 0.5


@dataclasses.dataclass(frozen=True)
class SolarGain(Term):
    """``coef [K/step per W/m²] · I_<facade>`` into ``zone``."""

    cause: ClassVar[str] = "solar_gain"
    description: ClassVar[str] = "solar gain through a facade (zone, facade)"
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

    @classmethod
    def from_dict(cls, d, zone_names, problems, std):
        what = f"extension term {cls.cause}"
        f = d.get("facade")
        if f not in ORIENTATIONS:
            problems.append(f"{what}: facade must be one of {ORIENTATIONS}, got {f!r}")
        return cls(
            zone=zone_of(d, "zone", zone_names, what, problems), facade=f, coef=num(d, "coef", what, problems), std=std
        )

    def features(self, sig, U_eff):
        return [(sig.zones.index(self.zone), "coef", sig.V[f"I_{self.facade}"], 0.0, np.inf)]

    def contribute(self, c: StepContext) -> None:
        c.Tn[..., c.zi[self.zone]] += self.coef * c.v[..., c.vi[f"I_{self.facade}"]]

    def add_equations(self, e: EquationParts) -> None:
        e.Bv[e.zi[self.zone], e.vi[f"I_{self.facade}"]] += self.coef

    @classmethod
    def screen(cls, sig, terms, W, resid, options):
        out = []
        have = {(t.zone, t.facade) for t in terms if isinstance(t, SolarGain)}
        rows = W.rows
        for zi, z in enumerate(sig.zones):
            for o in sig.facades[zi]:
                loc = {"zone": z, "facade": o}
                if not sig.has_solar:
                    out.append(
                        Candidate(
                            cls.cause,
                            loc,
                            status="untestable",
                            reason="no solar data (ghi or facade irradiance) in the dataset",
                        )
                    )
                    continue
                if (z, o) in have or base_solar(sig, zi, o) != 0.0:
                    continue  # already a solar path of the model
                out.append(
                    Candidate(
                        cls.cause,
                        loc,
                        [cls(zone=z, facade=o)],
                        0,
                        evidence=solar_evidence(sig, W, resid[:, zi], o, rows),
                    )
                )
        return out


def solar_evidence(sig, W, r, facade, rows) -> dict:
    """Correlation with the facade irradiance, sunny/cloudy residual means, peak hours."""
    I = sig.V[f"I_{facade}"]
    Ir = I[rows]
    day = Ir > 20.0
    hi = day & (Ir >= np.quantile(Ir[day], 0.75)) if day.any() else day
    lo = day & (Ir <= np.quantile(Ir[day], 0.25)) if day.any() else day
    ph_r, ph_i = peak_hour(sig, r, rows), peak_hour(sig, Ir, rows)
    return {
        "corr": corr(r, W(np.asarray(I, float))),
        "resid_sunny": cond_mean(r, hi),
        "resid_cloudy": cond_mean(r, lo),
        "resid_peak_hour": ph_r,
        "facade_peak_hour": ph_i,
        "peak_hour_gap_h": None if ph_r is None or ph_i is None else abs(ph_r - ph_i),
    }
