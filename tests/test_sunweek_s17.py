"""A week set down to the weather stays down in later rounds (session 17, benchmarks/diagnosis_sunweek_s17.md).

quad4 hold-out case 8 (seed 2031, a 30-min delay in SE, no holiday): in round 1 the holiday screen proposed the
darkest week (week 13, weekday ghi 38 W/m²) at γ 0.44 and the sun regression set it down (0.11). Once the
diagnosis had found the solar terms, the residual's regression on the facades' irradiance anomaly had little left
to remove: the screen proposed the week again at γ 0.30 (0.24 with the sun regressed out, 0.80 of it kept) and it
was accepted as a holiday (+20.7 %, t 5.9). The screen now remembers, across the rounds of one diagnosis
(``options["_holiday_weather"]``), what it set down to the weather.
"""

from __future__ import annotations

import types

import numpy as np
from test_holiday_s17 import N_TOW, NZ, _clouds, _ordinary_days, _signals

from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS
from hvacfmu.models.causes.internal_gain_schedule import holiday_candidate


def _resid(sig, day_gamma: np.ndarray, sun_k: float, seed: int) -> np.ndarray:
    """One-step residuals: weekdays toward Sunday by ``day_gamma``, plus ``sun_k`` times each zone's facades'
    irradiance anomaly (as ``test_holiday_s17._screen``)."""
    per_day = N_TOW // 7
    prof = sig.base_profiles["fall"]
    toward_sunday = prof[6 * per_day + sig.tow % per_day] - prof[sig.tow]
    day_no = np.asarray((sig.index - sig.index[0]).days)
    rng = np.random.default_rng(seed)
    resid = day_gamma[day_no][:, None] * toward_sunday + rng.normal(0.0, 1e-3, (len(sig.index), NZ))
    for j, fac in enumerate(sig.facades):
        for o in fac:
            irr = sig.V[f"I_{o}"]
            mean = np.bincount(sig.tow, irr, minlength=N_TOW) / np.bincount(sig.tow, minlength=N_TOW)
            resid[:, j] += sun_k * (irr - mean[sig.tow])
    return resid


def _two_rounds(seed: int, memo, holiday_week: int | None = None):
    """Round 1: a dark week whose departure is the sun's (set down). Round 2: the same week's departure no longer
    linear in the irradiance anomaly (what the residual keeps once solar terms are in the model), γ 0.35."""
    sig = _signals(_clouds(14, seed))
    W = types.SimpleNamespace(rows=np.arange(len(sig.index)))
    g = _ordinary_days(seed)
    if holiday_week is not None:
        g[7 * holiday_week : 7 * holiday_week + 5] += 0.4
    opts = {**DEFAULT_OPTIONS}
    if memo is not None:
        opts["_holiday_weather"] = memo
    first = holiday_candidate(sig, W, {**opts, "_resid_all": _resid(sig, g, 2e-5, seed)})
    g2 = g.copy()
    g2[7 * 14 : 7 * 14 + 5] += 0.35
    second = holiday_candidate(sig, W, {**opts, "_resid_all": _resid(sig, g2, 0.0, seed)})
    return first, second


def _weeks(c) -> set:
    return {w["week"] for w in c.evidence["weeks"]} | {w["week"] for w in c.evidence["zone_weeks"]}


def test_a_week_set_down_to_the_weather_stays_down():
    for seed in (0, 1):
        first, second = _two_rounds(seed, {})
        assert 14 in {w["week"] for w in first.evidence["weather_explained"]["weeks"]}
        assert second.status == "not significant", second.evidence
        (wk,) = second.evidence["weather_explained"]["weeks"]
        assert wk["week"] == 14 and wk["earlier_round"] and wk["gamma_sun"] < 0.15
        assert "once the sun is accounted for" in second.reason


def test_without_the_record_the_second_round_proposes_the_week():
    """The round-2 residual alone does read week 14 as a holiday (what the diagnosis accepted before)."""
    for seed in (0, 1):
        _, second = _two_rounds(seed, None)
        assert 14 in _weeks(second)


def test_another_holiday_week_is_still_proposed():
    for seed in (0, 1):
        first, second = _two_rounds(seed, {}, holiday_week=6)
        assert _weeks(first) == {6} and _weeks(second) == {6}, second.evidence
        assert [w["week"] for w in second.evidence["weather_explained"]["weeks"]] == [14]
