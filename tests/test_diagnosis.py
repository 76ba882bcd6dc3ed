"""Diagnosis: residual tests, cause detection, no false alarms, messiness, report, CLI.

Two kinds of data:

- *synthetic*: a three-zone floor (A–B–C in a row, A and C not adjacent) simulated at
  the model step from a known Model A, optionally extended with one catalogue term,
  with process noise (fast unit tests of the math);
- *emulator*: the SDH-like emulator of :mod:`hvacfmu.emulator` with an effect injected
  (end to end; 16-week datasets shared through ``cached_dataset``).

The diagnosis is never told what was injected; assertions compare its findings with
the generator's truth afterwards.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import subprocess
import sys
from typing import ClassVar

import numpy as np
import pandas as pd
import pytest

from hvacfmu.building import building_from_dict
from hvacfmu.data.dataset import Dataset
from hvacfmu.diagnosis import CAUSES, SCHEMA, diagnose
from hvacfmu.diagnosis.residuals import acf, cumulated_periodogram, whiteness
from hvacfmu.diagnosis.truth import compare_with_truth
from hvacfmu.models.causes import Candidate, Term, register_cause, unregister_cause
from hvacfmu.models.extended import (
    ActuationDelay,
    ExtendedModel,
    InternalGainSchedule,
    Reheat,
    SolarGain,
    SupplyAirBilinear,
    ThermalMass,
    ZoneCoupling,
)
from hvacfmu.models.linear import LinearZoneModel

TZ = "America/Los_Angeles"

ROW = {
    "name": "three rooms in a row",
    "latitude": 37.875,
    "longitude": -122.259,
    "timezone": TZ,
    "zones": [
        {
            "name": "A",
            "area": 100.0,
            "volume": 300.0,
            "adjacent": ["B"],
            "facades": [{"orientation": "S", "window_area": 10.0, "wall_area": 20.0}],
        },
        {"name": "B", "area": 100.0, "volume": 300.0, "adjacent": ["A", "C"], "facades": []},
        {
            "name": "C",
            "area": 100.0,
            "volume": 300.0,
            "adjacent": ["B"],
            "facades": [{"orientation": "W", "window_area": 8.0, "wall_area": 20.0}],
        },
    ],
    "vavs": [
        {"name": "V1", "zone": "A", "m_min": 0.05, "m_max": 0.6},
        {"name": "V2", "zone": "B", "m_min": 0.05, "m_max": 0.6},
        {"name": "V3", "zone": "C", "m_min": 0.05, "m_max": 0.6},
    ],
}


def row_model() -> LinearZoneModel:
    """A plausible six-zone-style Model A for the three rooms (time constants of a few hours)."""
    tow = np.arange(672)
    hour, day = (tow % 96) / 4.0, tow // 96
    occ = ((hour > 8) & (hour < 18) & (day < 5)).astype(float)
    prof = 0.05 + 0.25 * occ
    gains = {
        s: np.column_stack([prof * f for f in (1.0, 1.1, 0.9)]) * (0.6 if s == "winter" else 1.0)
        for s in ("fall", "winter", "spring", "summer")
    }
    return LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=("A", "B", "C"),
        measured_zones=("A", "B", "C"),
        output_weights=np.eye(3),
        vavs=("V1", "V2", "V3"),
        input_map=np.eye(3),
        disturbances=("T_out", "T_supply"),
        A=np.array([[0.90, 0.03, 0.0], [0.03, 0.89, 0.03], [0.0, 0.03, 0.90]]),
        B=np.diag([-0.30, -0.35, -0.33]),
        C=np.array([[0.04, 0.03]] * 3),
        gains=gains,
    )


def simulate_dataset(
    model, weeks=12, seed=0, noise=0.02, ghi=True, gaps=False, start="2025-09-01", at_min=0.0
) -> Dataset:
    """Inputs and weather drawn at random, temperatures simulated from ``model`` with process noise [K].

    ``at_min``: fraction of hours whose airflow sits at the boxes' minimum (reheat regime).
    """
    rng = np.random.default_rng(seed)
    building = building_from_dict(ROW)
    idx = pd.date_range(start, periods=weeks * 672, freq="15min", tz=TZ, name="time")
    n = len(idx)
    hour = np.asarray(idx.hour) + np.asarray(idx.minute) / 60.0
    days = np.arange(n) / 96.0
    T_out = 12 + 5 * np.sin(2 * np.pi * (hour - 9) / 24) + 4 * np.sin(2 * np.pi * days / 23.0) + rng.normal(0, 0.3, n)
    T_supply = 14 + 0.5 * np.sin(2 * np.pi * days / 3.1) + rng.normal(0, 0.1, n)
    u = rng.uniform(0.06, 0.5, (n // 4 + 1, 3)).repeat(4, axis=0)[:n]
    low = (rng.random(n // 4 + 1) < at_min).repeat(4)[:n]
    u[low] = 0.05
    cloud = np.repeat(rng.uniform(0.3, 1.0, weeks * 7), 96)[:n]
    frame = pd.DataFrame({"T_out": T_out, "T_supply": T_supply}, index=idx)
    for j, v in enumerate(("V1", "V2", "V3")):
        frame[f"m_{v}"] = u[:, j]
    if ghi:
        frame["ghi"] = np.maximum(0, np.sin(np.pi * (hour - 6.5) / 13)) * 850 * cloud
    simulate_zones(model, frame, building, seed, rng, noise)
    if gaps:
        frame.iloc[1000:1100, frame.columns.get_loc("T_A")] = np.nan
        frame.iloc[3000:3040] = np.nan
    return Dataset.from_frame(frame, building, step=900.0, seed=seed)


def simulate_zones(model, frame, building, seed, rng, noise) -> None:
    """Fill ``T_A..T_C`` of ``frame`` (in place) with ``model`` simulated on its inputs, process noise [K] from
    ``rng``."""
    for z in "ABC":
        frame[f"T_{z}"] = 21.0
    ds0 = Dataset.from_frame(frame, building, step=900.0, seed=seed)
    uu, vv = model.signals(ds0.frame)
    n = len(frame)
    q = np.zeros((n, 3))
    season = ds0.season_of_row
    for s in np.unique(season):
        m = season == s
        q[m] = model.gains_at(frame.index[m], s)
    x = np.asarray(model.initial_state(ds0.frame, 0), float)  # 21 °C, hidden states from the inputs
    Y = np.empty((n, 3))
    for k in range(n):
        Y[k] = model.output(x)
        x = model.step_state(x, uu[k], vv[k], q[k])
        x[:3] += rng.normal(0, noise, 3)
    for j, z in enumerate("ABC"):
        frame[f"T_{z}"] = Y[:, j]


def _found(report, cause, **loc):
    out = []
    for f in report.findings:
        if f["cause"] == cause and all(f["location"].get(k) == v for k, v in loc.items()):
            out.append(f)
    return out


# ---------------------------------------------------------------------------------------------
# residual tests on arrays
# ---------------------------------------------------------------------------------------------
def test_whiteness_of_white_and_coloured_noise(rng):
    e = rng.normal(size=5000)
    w = whiteness(e, 900.0)
    assert w["white"] is True
    assert abs(w["acf_lag1"]) < 0.05
    ar = np.zeros(5000)
    for k in range(1, 5000):
        ar[k] = 0.8 * ar[k - 1] + e[k]
    w2 = whiteness(ar, 900.0)
    assert w2["white"] is False
    assert w2["ljung_box"]["p_value"] < 1e-6
    # a daily cycle is located by the periodogram peak
    t = np.arange(96 * 60)
    w3 = whiteness(np.sin(2 * np.pi * t / 96) + 0.3 * rng.normal(size=len(t)), 900.0)
    assert w3["white"] is False
    np.testing.assert_allclose(w3["peak_period_h"], 24.0, rtol=0, atol=0.5)


def _dst_signals(standard_time_occupancy: bool, seed: int, late_mornings_until=None):
    """Ten weeks of 15-min apparent gains around the end of DST (2025-11-02), three zones.

    Weekday occupancy ramps up at 08:00 and down at 17:30 on the local clock, or on standard
    time (one hour late on the local clock while DST is on); a solar-like bump at solar noon
    (13:00 local under DST, 12:00 after) is the same on every day; AR(1) noise on top.
    ``late_mornings_until`` (a date): before it the mornings ramp up 90 min later, the evenings
    unchanged (a change of the morning start, e.g. with the weather, that is no clock).
    """
    from types import SimpleNamespace

    from hvacfmu.models.extended import dst_active
    from hvacfmu.timeutil import n_time_of_week, time_of_week

    rng = np.random.default_rng(seed)
    idx = pd.date_range("2025-09-29", periods=10 * 7 * 96, freq="15min", tz="America/Los_Angeles")
    dst = dst_active(idx)
    hour = idx.hour.to_numpy() + idx.minute.to_numpy() / 60.0
    occ_hour = hour - 1.0 * dst if standard_time_occupancy else hour
    weekday = idx.day_of_week.to_numpy() < 5
    start = np.full(len(idx), 8.0)
    if late_mornings_until is not None:
        start[idx < pd.Timestamp(late_mornings_until, tz=idx.tz)] = 9.5
    occ = weekday / (1 + np.exp(-(occ_hour - start) / 0.35)) / (1 + np.exp(-(17.5 - occ_hour) / 0.5))
    solar = np.exp(-(((hour - dst - 12.0) / 2.5) ** 2))
    e = np.zeros((len(idx), 3))
    for k in range(1, len(idx)):
        e[k] = 0.7 * e[k - 1] + rng.normal(0.0, 0.004, 3)
    gains = 0.05 * occ[:, None] * np.array([1.0, 0.8, 1.2]) + 0.04 * solar[:, None] + e
    n_tow = n_time_of_week(900.0)
    sig = SimpleNamespace(
        index=idx,
        n_tow=n_tow,
        step=900.0,
        tow=time_of_week(idx, 900.0) % n_tow,
        season=np.full(len(idx), "fall", dtype=object),
        seasons=("fall",),
        dst=dst,
    )
    return sig, gains


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_dst_profile_lag_sees_the_schedule_jump_not_the_sun(seed):
    from hvacfmu.diagnosis.candidates import dst_profile_lag

    sig, gains = _dst_signals(True, seed)
    rows = np.arange(len(gains))
    lag = dst_profile_lag(sig, gains, rows)
    assert abs(lag["lag_steps"] - 4) <= 1, lag
    assert lag["scale_at_lag"] > 0.6 and lag["r2_at_lag"] > 0.5
    assert lag["seasons"]["fall"]["weekdays_dst"] == 25 and lag["seasons"]["fall"]["weekdays_standard"] == 25
    # occupancy on the local clock: the sun still jumps by an hour at the change, but it is the
    # same on weekends and cancels
    sig, gains = _dst_signals(False, seed)
    lag = dst_profile_lag(sig, gains, rows)
    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS as opt

    shifted = 2 * abs(lag["lag_steps"]) >= 4
    assert not (shifted and lag["r2_at_lag"] >= opt["dst_min_r2"] and lag["scale_at_lag"] >= opt["dst_min_scale"]), lag
    assert lag["scale_at_lag"] < 0.25, lag


def _dst_screen(sig, gains):
    """The daylight-saving candidate of :func:`_dst_signals`'s data (the gains are the residual of a zero profile)."""
    from types import SimpleNamespace

    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS
    from hvacfmu.models.causes.internal_gain_schedule import dst_candidate
    from hvacfmu.models.causes.signals import Within

    zones = ("A", "B", "C")
    full = SimpleNamespace(**vars(sig), zones=zones, nz=len(zones), base_profiles={"fall": np.zeros((sig.n_tow, 3))})
    W = Within(sig.tow, np.arange(len(gains)))
    return dst_candidate(full, W, {**DEFAULT_OPTIONS, "_resid_all": gains})


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_dst_candidate_needs_the_whole_schedule_to_move(seed):
    """A clock moves the evening ramp-down with the morning ramp-up; a morning start that changes on another date
    (the mornings of the DST weeks mostly late, the evenings on the local clock, as in EnergyPlus's Chicago runs of
    the medium office, benchmarks/diagnosis_dst_s14.md) passes the morning screen but is no daylight-saving shift."""
    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS as opt

    # late mornings until a week before the change: the morning screen sees a shift, the evening does not move
    c = _dst_screen(*_dst_signals(False, seed, late_mornings_until="2025-10-27"))
    ev = c.evidence
    assert ev["lag_h"] >= 0.5 and ev["r2_at_lag"] >= opt["dst_min_r2"] and ev["scale_at_lag"] >= opt["dst_min_scale"]
    assert c.status == "not significant" and not c.variants, c.reason
    assert "evening" in c.reason and ev["evening"]["r2_at_legal_lag"] < opt["dst_min_r2"]
    # occupancy on standard time: both ramps move by the hour, the shift is proposed
    c = _dst_screen(*_dst_signals(True, seed))
    assert c.status not in ("not significant", "untestable"), c.reason
    assert c.variants[0].shift == -4
    assert c.evidence["evening"]["r2_at_legal_lag"] >= opt["dst_min_r2"]


def test_acf_and_cpgram_handle_gaps(rng):
    e = rng.normal(size=2000)
    e[100:150] = np.nan
    r = acf(e, 10)
    assert r[0] == pytest.approx(1.0)
    assert np.all(np.abs(r[1:]) < 0.1)
    f, C, bound, period, share = cumulated_periodogram(e)
    assert C[-1] == pytest.approx(1.0)
    assert 0 < bound < 0.1


# ---------------------------------------------------------------------------------------------
# synthetic data: each catalogue term is found at its location, nothing else
# ---------------------------------------------------------------------------------------------
# magnitudes: 0.0008 K/step per W/m² (~0.7 K/h of extra warming at 900 W/m²), coupling 0.04-0.05/step,
# slab with a 12.5-h time constant, 30-min delay, bilinear 0.03/step per kg/s·K, reheat 0.05 K/step
SYNTHETIC_CASES = [
    (SolarGain(zone="A", facade="S", coef=0.0008), 0, {"zone": "A", "facade": "S"}),
    pytest.param(SolarGain(zone="C", facade="W", coef=0.0005), 1, {"zone": "C", "facade": "W"}, marks=pytest.mark.slow),
    (ZoneCoupling(zone_a="A", zone_b="C", coef_ab=0.04, coef_ba=0.04), 0, {"zones": ["A", "C"]}),
    pytest.param(
        ZoneCoupling(zone_a="A", zone_b="C", coef_ab=0.05, coef_ba=0.05),
        1,
        {"zones": ["A", "C"]},
        marks=pytest.mark.slow,
    ),
    (ThermalMass(zone="B", alpha=0.02, beta=0.05), 0, {"zone": "B"}),
    pytest.param(ThermalMass(zone="A", alpha=0.01, beta=0.06), 1, {"zone": "A"}, marks=pytest.mark.slow),
    (ActuationDelay(zone="C", delay=2), 0, {"zone": "C", "delay": 2}),
    pytest.param(ActuationDelay(zone="A", delay=3), 1, {"zone": "A", "delay": 3}, marks=pytest.mark.slow),
    (SupplyAirBilinear(zone="A", coef=0.03), 0, {"zone": "A"}),
    pytest.param(SupplyAirBilinear(zone="B", coef=0.02), 1, {"zone": "B"}, marks=pytest.mark.slow),
    (Reheat(zone="A", coef=0.06, u_min=0.0526, T_threshold=12.0), 0, {"zone": "A"}),
    pytest.param(Reheat(zone="C", coef=0.04, u_min=0.0526, T_threshold=10.0), 1, {"zone": "C"}, marks=pytest.mark.slow),
]


@pytest.mark.parametrize("term, seed, loc", SYNTHETIC_CASES, ids=lambda x: getattr(x, "cause", None))
def test_synthetic_effect_is_found(term, seed, loc):
    base = row_model()
    ds = simulate_dataset(ExtendedModel(base=base, terms=(term,)), weeks=12, seed=seed, at_min=0.3)
    rep = diagnose(ds, model=base, progress=False)
    hits = _found(rep, term.cause, **loc)
    assert hits, f"{term.cause} at {loc} not found: {rep.summary()}"
    assert [f["cause"] for f in rep.findings] == [term.cause], rep.summary()
    f = hits[0]
    assert f["heldout"]["gain_percent"] > 0
    assert f["test"]["delta_bic"] > rep.options["bic_margin"]
    # fitted parameters recover the simulated ones within 4 standard deviations (or 20 %)
    for name, true in term.coefficients().items():
        if name in ("u_min", "T_threshold", "alpha"):
            continue
        est = f["parameters"][name]
        tol = max(4 * (est["std"] or 0.0), 0.2 * abs(true))
        assert abs(est["value"] - true) <= tol, (name, est, true)


@pytest.mark.parametrize(
    "terms, zones_idx, affine",
    [
        ((), (0,), True),
        ((ThermalMass(zone="A", alpha=0.02), SupplyAirBilinear(zone="A")), (0,), True),
        ((ZoneCoupling(zone_a="A", zone_b="C"),), (0, 2), True),
        ((Reheat(zone="B", T_threshold=12.0, u_min=0.05),), (1,), True),
        # a delayed airflow feeding the bilinear term is quadratic in the state: step-by-step fallback
        ((ActuationDelay(zone="B", delay=2), SupplyAirBilinear(zone="B")), (1,), False),
    ],
)
def test_fold_scores_equal_the_step_by_step_simulation(terms, zones_idx, affine):
    """The cross-validation's vectorised open loop (one affine map per row, every fold at once)
    gives the step-by-step ``step_state`` simulation's window RMS to 1e-9 K, NaN windows included."""
    from hvacfmu.diagnosis import crossval as CV
    from hvacfmu.diagnosis.design import make_signals

    ds = simulate_dataset(row_model(), weeks=6, seed=3, gaps=True)
    sig = make_signals(ds, row_model())
    plan = CV.make_plan(sig, 10, 96)
    models = CV.fold_fits(sig, plan, list(terms), zones_idx)
    assert (CV.affine_steps(sig, models[0], plan.starts[0], 96) is not None) == affine
    fast = CV.fold_scores(sig, plan, models, zones_idx)
    for m, st, f in zip(models, plan.starts, fast):
        slow = CV.zone_open_loop_rms(sig, m, st, zones_idx, 96)
        assert np.array_equal(np.isnan(slow), np.isnan(f))
        assert np.nanmax(np.abs(slow - f)) < 1e-9
    assert any(np.isnan(f).any() for f in fast)  # the gaps make some windows unusable


def test_windows_and_time_constants_are_durations_not_step_counts():
    """At 5 min the cross-validation predicts 24 h (288 steps), not 8 h, and the thermal-mass
    candidates try the same time constants [h] as at 15 min (every 5-min mass was missed when
    both were step counts)."""
    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS, horizon_steps
    from hvacfmu.models.causes.thermal_mass import TIME_CONSTANTS_H, alphas

    assert DEFAULT_OPTIONS["horizon"] is None
    assert horizon_steps(900.0) == 96 and horizon_steps(300.0) == 288 and horizon_steps(3600.0) == 24
    assert horizon_steps(300.0, 50) == 50  # an explicit option stays a step count
    assert alphas(900.0) == (0.002, 0.005, 0.01, 0.02, 0.05, 0.1)  # 15-min grid unchanged
    for step in (60.0, 300.0, 900.0):
        taus = [step / a / 3600.0 for a in alphas(step)]
        assert np.allclose(taus, TIME_CONSTANTS_H)


def test_one_step_residuals_use_the_column_of_an_unused_input_term():
    """An accepted ``unused_input`` term reads a column the base model ignores (``sig.extra``, not
    ``sig.V``). The one-step residuals that feed the holiday and daylight-saving screens and the final
    whiteness must use it: they were NaN on every row, so on four of four BMS-like buildings of a
    12-building fleet (seed 7001) every later round said "holiday untestable: only 0 weekdays with data"."""
    from hvacfmu.diagnosis.design import make_signals
    from hvacfmu.diagnosis.selection import one_step_residuals
    from hvacfmu.models.extended import UnusedInput

    ds = simulate_dataset(row_model(), weeks=3, seed=1)
    rh = np.clip(np.sin(np.arange(len(ds.frame)) / 40.0), 0.0, 1.0)
    ds = Dataset.from_frame(ds.frame.assign(rh_V2=rh), ds.building, step=900.0, seed=1)
    sig = make_signals(ds, row_model())
    assert "rh_V2" in sig.extra and "rh_V2" not in sig.V
    before = one_step_residuals(sig, ExtendedModel(base=row_model(), terms=()))
    after = one_step_residuals(
        sig, ExtendedModel(base=row_model(), terms=(UnusedInput(zone="B", column="rh_V2", coef=0.1),))
    )
    ok = np.isfinite(before).all(axis=1)
    assert ok.sum() > 1000
    assert np.array_equal(np.isfinite(after).all(axis=1), ok)
    # the term moves zone B's prediction by 0.1 K per unit of rh_V2 and nothing else
    assert np.allclose(after[ok, 1], before[ok, 1] - 0.1 * rh[ok], atol=1e-12)
    assert np.allclose(after[ok][:, [0, 2]], before[ok][:, [0, 2]], atol=1e-12)


def test_calendar_term_is_tested_on_its_active_days():
    """A term acting on 10 of 65 days: its gain is measured on those days, not diluted by the rest."""
    from hvacfmu.diagnosis.crossval import CVPlan, paired_test, paired_test_days

    rng = np.random.default_rng(0)
    weeks = np.repeat(np.arange(13), 5)
    folds = np.array_split(np.arange(65), 10)
    before = [0.3 + 0.05 * rng.random((len(f), 2)) for f in folds]
    active = [np.isin(f, np.r_[10:15, 40:45]) for f in folds]
    after = [b - np.where(a[:, None], 0.1 + 0.01 * rng.random(b.shape), 0.0) for b, a in zip(before, active)]
    plan = CVPlan(
        folds=folds, fit_rows=[], within=[], starts=folds, week_of_start=[weeks[f] for f in folds], horizon=96
    )
    days = paired_test_days(plan, before, after, active)
    every = paired_test(plan, before, after)
    assert days["n_days"] == 10 and days["n_folds_active"] >= 2
    assert days["gain_percent"] > 25 and days["t"] > 20
    assert every["gain_percent"] < days["gain_percent"] / 4  # diluted by the 11 weeks it does not act on
    assert every["t"] < days["t"] / 5
    none = paired_test_days(plan, before, before, [np.zeros(len(f), bool) for f in folds])
    assert none["gain_percent"] is None


def test_day_plan_leaves_out_one_active_day_at_a_time():
    """Each fold of a calendar term's day plan holds out exactly its 24-hour window's rows."""
    from hvacfmu.diagnosis.crossval import day_plan
    from hvacfmu.diagnosis.design import make_signals

    ds = simulate_dataset(row_model(), weeks=4, seed=1)
    sig = make_signals(ds, row_model())
    rows = sig.rows("train")
    starts = [s for s in np.flatnonzero((sig.index.hour == 0) & (sig.index.minute == 0)) if s in set(rows)][:3]
    plan = day_plan(sig, starts, 96)
    assert len(plan.folds) == 3
    for st, fr, w in zip(starts, plan.fit_rows, plan.week_of_start):
        held = set(rows) - set(fr)
        assert held == set(range(st, st + 96)) & set(rows) and len(held) == 96
        assert list(w) == [sig.week[st]]


def test_holiday_with_too_few_scored_days_is_decided_by_the_every_week_test():
    """A holiday is accepted when it is better on its active days, **or** when it passes the week test
    over every week (README, calendar terms). With fewer than 3 of its days scored (gaps in their
    24-h windows: fleet building b006, seed 7001, 2 of 4 days) the day test has no gain; the week test
    (+1.2 ± 0.6 %, t 2.06 there) must still decide, and the reasons must quote it."""
    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS, _cv_accepts, _found_reason, _rejected_reason

    def candidate(every_t):
        term = InternalGainSchedule(variant="holiday", zone_names=("A",), coef=(0.4,), dates=("2025-10-06",))
        c = Candidate("internal_gain_schedule", {"variant": "holiday"}, [term], 1)
        c.term, c.test = term, {"delta_bic": 50.0}
        c.cv = {"n_days": 2, "gain_percent": None, "se_percent": None, "t": None, "unit": "active day"}
        c.evidence["cv_all_weeks"] = {
            "n_weeks": 22,
            "n_folds": 10,
            "gain_abs": 0.0035,
            "gain_percent": 1.2,
            "se_percent": 0.58,
            "t": every_t,
        }
        return c

    ok = candidate(2.06)
    assert _cv_accepts(ok, DEFAULT_OPTIONS)
    assert "cross-validated gain 1.2 ± 0.6 % over 22 weeks, paired t = 2.1" in _found_reason(ok, DEFAULT_OPTIONS)
    weak = candidate(1.0)
    assert not _cv_accepts(weak, DEFAULT_OPTIONS)
    assert "(t = 1.00) below 1 % with t ≥ 2" in _rejected_reason(weak, DEFAULT_OPTIONS)


def test_a_holiday_accepted_by_the_week_test_competes_as_a_rival_with_that_test():
    """Once such a holiday can be accepted it can be the rival of another finding: the comparison and the
    reasons use the test that decided it (``decisive_cv``), not the empty day test (fleet b010, seed 7001:
    ``TypeError`` formatting its t = None, the whole diagnosis failed)."""
    from types import SimpleNamespace

    from hvacfmu.diagnosis.selection import _cv_rival, decisive_cv

    hol = InternalGainSchedule(variant="holiday", zone_names=("A", "B"), coef=(0.4, 0.4), dates=("2025-10-06",))
    o = Candidate("internal_gain_schedule", {"variant": "holiday"}, [hol], 1)
    o.term, o.cv = hol, {"n_days": 2, "gain_percent": None, "se_percent": None, "t": None, "unit": "active day"}
    o.evidence["cv_all_weeks"] = {"n_weeks": 22, "gain_abs": 0.004, "gain_percent": 1.2, "se_percent": 0.6, "t": 2.5}
    solar = SolarGain(zone="A", facade="S")
    c = Candidate("solar_gain", {"zone": "A", "facade": "S"}, [solar], 1)
    c.term, c.cv = solar, {"n_weeks": 22, "gain_abs": 0.004, "gain_percent": 1.5, "se_percent": 0.7, "t": 2.1}
    assert decisive_cv(o)["t"] == 2.5 and decisive_cv(c) is c.cv
    assert _cv_rival(SimpleNamespace(zones=("A", "B")), None, [], c, [c, o], None, {}) is o
    assert c.evidence["rival"]["cv_t"] == 2.5 and c.evidence["rival"]["favoured"] == "internal_gain_schedule"


def test_holiday_and_dst_scale_gates():
    """A holiday needs mean scale >= holiday_min_scale (0.33), a daylight-saving shift >= 0.5.

    Measured (README, calendar terms): spurious holiday weeks 0.24-0.30, injected ones 0.35-0.54.
    """
    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS, _gate

    def gated(variant, scale):
        term = InternalGainSchedule(variant=variant, zone_names=("A",), coef=(scale,), dates=("2025-10-06",))
        c = Candidate("internal_gain_schedule", {"variant": variant}, [term], 1, evidence={"scale_mean": scale})
        c.term, c.test = term, {"delta_bic": 50.0}
        _gate(c, DEFAULT_OPTIONS)
        return c.status

    assert DEFAULT_OPTIONS["holiday_min_scale"] == 0.33 and DEFAULT_OPTIONS["schedule_min_scale"] == 0.5
    assert gated("holiday", 0.35) == "not tested"  # case 27's week 4 goes on to the cross-validation
    assert gated("holiday", 0.30) == "not significant"  # the largest spurious week measured
    assert gated("dst_shift", 0.45) == "not significant"


def test_coupling_gate_reason_names_the_zone_at_zero_instead_of_a_factor_inf():
    """One zone's own coupling coefficient at its bound 0 makes the symmetry ratio infinite; the reason
    said "differ by a factor inf" (fleet sweep s10, b000 R1+R3). It names the zone instead."""
    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS, _gate

    ev = {"symmetry_ratio": float("inf"), "asymmetry_t": 3.1, "untied_coef_R1": 0.0123, "untied_coef_R3": 0.0}
    c = Candidate("zone_coupling", {"zones": "R1+R3"}, [], 1, evidence=ev)
    c.test = {"delta_bic": 50.0}
    _gate(c, DEFAULT_OPTIONS)
    assert c.status == "no evidence"
    assert "inf" not in c.reason and "R3's own coefficient is at its bound 0 (R1's 0.0123)" in c.reason
    ev = {**ev, "symmetry_ratio": 10.49, "untied_coef_R3": 0.001}
    c = Candidate("zone_coupling", {"zones": "R1+R3"}, [], 1, evidence=ev)
    c.test = {"delta_bic": 50.0}
    _gate(c, DEFAULT_OPTIONS)
    assert "differ by a factor 10.49 (volume-scaled)" in c.reason


def _weekday_profile(n_tow: int, nz: int) -> np.ndarray:
    """A season profile (n_tow, nz) [K/step]: weekday occupancy 8-18 h with one-hour ramps, Sunday low."""
    per_day = n_tow // 7
    h = np.arange(per_day) * 24.0 / per_day
    day = np.clip(np.minimum(h - 7.0, 19.0 - h), 0.0, 1.0)
    prof = np.zeros((n_tow, nz))
    for d in range(7):
        level = 1.0 if d < 5 else (0.4 if d == 5 else 0.1)
        prof[d * per_day : (d + 1) * per_day] = 0.01 * level * day[:, None] * np.arange(1, nz + 1)
    return prof


def test_holiday_under_a_dst_shift_reads_the_reference_day_on_the_clock_the_gains_follow():
    """Case 9 of the EnergyPlus test bed (s9): once a ``dst_shift`` term reads the gain profile an hour
    later while daylight saving is on, a holiday on a daylight-saving weekday must give the gains of the
    reference Sunday *as the model reads them that day*. On the local clock (before) the holiday's
    replacement was an hour off the gains it replaces: at the ramps the day kept a slice of the weekday
    profile and lost a slice of Sunday's."""
    from hvacfmu.timeutil import time_of_week

    step, n_tow, nz, shift = 900.0, 672, 2, -4
    prof = _weekday_profile(n_tow, nz)
    idx = pd.date_range("2017-04-10 02:00", "2017-04-10 22:00", freq="15min", tz="America/Chicago")
    sun = idx + pd.Timedelta(days=6)  # the Sunday of the same week, same local times
    dst = InternalGainSchedule(variant="dst_shift", zone_names=("A", "B"), coef=(1.0, 1.0), shift=shift)
    hol = InternalGainSchedule(
        variant="holiday", zone_names=("A", "B"), coef=(1.0, 1.0), dates=("2017-04-10",), shift=shift
    )

    def gains(index, terms):
        q = prof[time_of_week(index, step) % n_tow]
        return q + sum(t.adjustment(index, prof, step) for t in terms)

    np.testing.assert_allclose(gains(idx, (dst, hol)), gains(sun, (dst,)), atol=1e-12)
    # on a standard-time day the shift changes nothing
    jan = pd.date_range("2017-01-23 02:00", "2017-01-23 22:00", freq="15min", tz="America/Chicago")
    local = dataclasses.replace(hol, dates=("2017-01-23",), shift=0)
    np.testing.assert_allclose(
        dataclasses.replace(hol, dates=("2017-01-23",)).adjustment(jan, prof, step), local.adjustment(jan, prof, step)
    )
    assert hol.location()["shift"] == shift and "shift" not in local.location()
    back = InternalGainSchedule.from_dict(hol.to_dict(), ("A", "B"), [], {})
    assert back.shift == shift and back.dates == hol.dates


def test_holiday_screen_proposes_a_week_that_shows_in_one_zone_only():
    """A holiday week whose departure shows in one zone while the others read the opposite (EnergyPlus case 9:
    the core at 0.82 in January, the perimeters heated by the night cycle through boxes the model reads as
    cooling; battery case 19: zone C at 0.77): pooled over the zones the week's scale is negative, zone by
    zone it is the week the screen must propose (``holiday_gamma`` at ``holiday_z`` among that zone's weeks)."""
    import types

    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS
    from hvacfmu.models.causes.internal_gain_schedule import holiday_candidate
    from hvacfmu.timeutil import time_of_week

    step, n_tow, nz = 900.0, 672, 3
    prof = _weekday_profile(n_tow, nz)
    idx = pd.date_range("2025-09-01", periods=12 * n_tow, freq="15min", tz="UTC")
    week = np.asarray((idx - idx[0]).days // 7)
    hol = InternalGainSchedule(
        variant="holiday",
        zone_names=("A", "B", "C"),
        coef=(1.0, -0.5, -0.5),  # A departs fully toward Sunday, B and C the other way
        dates=tuple(f"2025-10-{d:02d}" for d in range(6, 11)),
    )
    noise = np.random.default_rng(1).normal(0.0, 2e-3, (len(idx), nz))
    resid = hol.adjustment(idx, prof, step) + noise
    sig = types.SimpleNamespace(
        index=idx,
        n_tow=n_tow,
        step=step,
        tow=time_of_week(idx, step) % n_tow,
        week=week,
        zones=("A", "B", "C"),
        nz=nz,
        seasons=("fall",),
        season=np.array(["fall"] * len(idx)),
        base_profiles={"fall": prof},
    )
    W = types.SimpleNamespace(rows=np.arange(len(idx) - 1))
    c = holiday_candidate(sig, W, {**DEFAULT_OPTIONS, "_resid_all": resid})
    assert c.location["dates"] == list(hol.dates)
    assert c.evidence["weeks"] == []  # the pooled week rule does not see it
    assert c.evidence["week_means"]["5"] < 0
    (zw,) = c.evidence["zone_weeks"]
    assert zw["week"] == 5 and list(zw["zones"]) == ["A"] and zw["zones"]["A"]["gamma"] == pytest.approx(1.0, abs=0.05)
    assert c.hyper == 1
    # without the holiday the screen proposes nothing
    quiet = holiday_candidate(sig, W, {**DEFAULT_OPTIONS, "_resid_all": noise})
    assert quiet.status == "not significant" and quiet.evidence["zone_weeks"] == []


def test_a_holiday_found_before_a_dst_shift_moves_to_its_clock():
    """Found first (on the local clock), a holiday takes the shift of a ``dst_shift`` term accepted later, so
    the final model's holiday replaces the gains the model reads that day (forward selection applies it
    after every round)."""
    from hvacfmu.models.causes.internal_gain_schedule import on_gain_clock

    hol = InternalGainSchedule(variant="holiday", zone_names=("A", "B"), coef=(0.5, 0.5), dates=("2017-04-10",))
    dst = InternalGainSchedule(variant="dst_shift", zone_names=("A", "B"), coef=(1.0, 1.0), shift=-4)
    mass = ThermalMass(zone="A", alpha=0.05, beta=0.01)
    out = on_gain_clock([hol, mass, dst])
    assert out[0].shift == -4 and out[0].dates == hol.dates and out[1] is mass and out[2] is dst
    assert on_gain_clock([hol, mass])[0] is hol


def test_holiday_screen_reads_the_days_on_the_dst_clock_of_the_model():
    """The holiday screen's departure scale of a daylight-saving holiday is ~1 when read on the clock of the
    model's ``dst_shift`` (``shift``), not an hour off it (case 9 of the EnergyPlus test bed: 10-12 April
    read 0.1-0.2 on the local clock, 0.7 on the model's)."""
    import types

    from hvacfmu.models.causes.internal_gain_schedule import day_departures
    from hvacfmu.timeutil import time_of_week

    step, n_tow, nz, shift = 900.0, 672, 2, -4
    prof = _weekday_profile(n_tow, nz)
    idx = pd.date_range("2017-04-03", "2017-04-23 23:45", freq="15min", tz="America/Chicago")
    tow = time_of_week(idx, step) % n_tow
    hol = InternalGainSchedule(
        variant="holiday", zone_names=("A", "B"), coef=(1.0, 1.0), dates=("2017-04-11", "2017-04-12"), shift=shift
    )
    noise = np.random.default_rng(0).normal(0.0, 1e-4, (len(idx), nz))
    resid = hol.adjustment(idx, prof, step) + noise  # the gains the model misses on the holiday
    sig = types.SimpleNamespace(
        index=idx,
        n_tow=n_tow,
        step=step,
        tow=tow,
        week=np.asarray((idx - idx[0]).days // 7),
        seasons=("spring",),
        season=np.array(["spring"] * len(idx)),
        base_profiles={"spring": prof},
    )
    on_model = {d["date"]: d["gamma"] for d in day_departures(sig, resid, shift=shift)}
    on_local = {d["date"]: d["gamma"] for d in day_departures(sig, resid)}
    assert on_model["2017-04-11"] == pytest.approx(1.0, abs=0.02)
    assert on_model["2017-04-12"] == pytest.approx(1.0, abs=0.02)
    assert abs(on_model["2017-04-10"]) < 0.02 and abs(on_model["2017-04-13"]) < 0.02
    assert on_local["2017-04-11"] < 0.95  # an hour off: the ramps of the departure are missed


def test_holiday_screen_leaves_out_the_days_of_the_models_holiday_calendar():
    """A closed week (6-10 Oct) holding a day of the model's holiday calendar (8 Oct, read on Sunday's profile
    by the base model: hvacfmu.calendars): the screen proposes the week's other four days, not the calendar
    day, whose gains the model already takes from Sunday (as a holiday term's date it would get Sunday's
    departure a second time). Before: the day was screened on its weekday clock (gamma ~0) and listed."""
    import types

    from hvacfmu.calendars import gain_slots
    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS
    from hvacfmu.models.causes.internal_gain_schedule import day_departures, holiday_candidate

    step, n_tow, nz = 900.0, 672, 2
    prof = _weekday_profile(n_tow, nz)
    idx = pd.date_range("2025-09-01", periods=12 * n_tow, freq="15min", tz="UTC")
    calendar = ("2025-10-08",)
    week_days = tuple(f"2025-10-{d:02d}" for d in range(6, 11))
    hol = InternalGainSchedule(variant="holiday", zone_names=("A", "B"), coef=(1.0, 1.0), dates=week_days)
    noise = np.random.default_rng(2).normal(0.0, 2e-3, (len(idx), nz))
    # the gains the model misses: Sunday's departure on the closed days but the calendar day, whose gains the
    # model already reads on Sunday's profile
    resid = hol.adjustment(idx, prof, step)
    resid[np.asarray(idx.normalize() == pd.Timestamp("2025-10-08", tz="UTC"))] = 0.0
    resid = resid + noise
    sig = types.SimpleNamespace(
        index=idx,
        n_tow=n_tow,
        step=step,
        tow=gain_slots(idx, step, calendar) % n_tow,
        week=np.asarray((idx - idx[0]).days // 7),
        zones=("A", "B"),
        nz=nz,
        seasons=("fall",),
        season=np.array(["fall"] * len(idx)),
        base_profiles={"fall": prof},
    )
    W = types.SimpleNamespace(rows=np.arange(len(idx) - 1))
    assert "2025-10-08" not in {d["date"] for d in day_departures(sig, resid, rows=W.rows)}
    c = holiday_candidate(sig, W, {**DEFAULT_OPTIONS, "_resid_all": resid})
    assert c.location["dates"] == [d for d in week_days if d not in calendar]


@pytest.mark.slow
def test_one_week_holiday_is_cross_validated_day_by_day():
    """A holiday in one training week: each of its days is predicted by a fit on the others.

    With every active day in one block, the block test compared two equal predictions (gain
    0 ± 0); left out one at a time, the week's days are predicted far better with the term.
    """
    import datetime as dt

    base = row_model()
    dates = tuple((dt.date(2025, 10, 6) + dt.timedelta(days=i)).isoformat() for i in range(5))
    hol = InternalGainSchedule(variant="holiday", zone_names=("A", "B", "C"), coef=(0.8, 0.8, 0.8), dates=dates)
    ds = simulate_dataset(ExtendedModel(base=base, terms=(hol,)), weeks=12, seed=4)
    rep = diagnose(ds, model=base, progress=False)
    assert rep.causes == ["internal_gain_schedule"]
    f = rep.to_dict()["findings"][0]
    assert f["location"]["dates"] == list(dates)
    assert f["cv"]["folds"] == "one per active day" and f["cv"]["n_days"] == 5
    assert f["cv"]["gain_percent"] > 30 and f["cv"]["t"] > 5
    assert f["evidence"]["cv_blocks"]["n_folds_active"] == 1


@functools.cache
def two_effects_case():
    """``(dataset, base)``: solar gain in A and a 30-min delay in C simulated on :func:`row_model` (12 weeks, seed
    3); computed once per worker (test_diagnosis_budget.py uses the same data)."""
    base = row_model()
    terms = (SolarGain(zone="A", facade="S", coef=0.0006), ActuationDelay(zone="C", delay=2))
    return simulate_dataset(ExtendedModel(base=base, terms=terms), weeks=12, seed=3), base


@functools.cache
def two_effects_report():
    """``diagnose`` of :func:`two_effects_case` with its base and the default options, once per worker."""
    ds, base = two_effects_case()
    return diagnose(ds, model=base, progress=False)


def test_two_synthetic_effects_are_both_found():
    rep = two_effects_report()
    assert _found(rep, "solar_gain", zone="A", facade="S")
    assert _found(rep, "actuation_delay", zone="C", delay=2)
    assert sorted(rep.causes) == ["actuation_delay", "solar_gain"]
    assert rep.heldout["gain_percent"]["A"] > 0 and rep.heldout["gain_percent"]["C"] > 0


class _SharedDriver:
    """``model`` plus an unmeasured slow driver (AR(1), 6-h time constant, ``size`` K/step) in zones A and C.

    Stands for the emulator's floors above/below and its day-to-day occupancy level: heat that
    reaches several zones at once and that no measured column carries.
    """

    def __init__(self, model, weeks, seed, size=0.03, loads=(1.0, 0.0, 1.0)):
        self.model = model
        idx = pd.date_range("2025-09-01", periods=weeks * 672, freq="15min", tz=TZ)
        rng = np.random.default_rng(seed + 100)
        a = np.exp(-1.0 / 24.0)
        d = np.zeros(len(idx))
        e = rng.normal(0.0, size * np.sqrt(1 - a * a), len(idx))
        for k in range(1, len(idx)):
            d[k] = a * d[k - 1] + e[k]
        self.driver = pd.Series(d, index=idx)
        self.loads = np.asarray(loads)

    def __getattr__(self, name):
        return getattr(self.model, name)

    def gains_at(self, index, season):
        return self.model.gains_at(index, season) + self.driver.reindex(index).to_numpy()[:, None] * self.loads


def test_bilinear_screen_and_refit_give_the_airflow_coefficient_the_same_bound():
    """Issue 15: a cause's gain must be its own. In zone A the airflow warms the room (b > 0: the heat of a
    hot discharge the base model's b <= 0 cannot take) and no supply-air product acts. The bilinear candidate's
    screen (fast path: the current design, b <= 0, plus its column) and the structure refit with the term
    (what cross-validation fits) must see the same likelihood ratio: before, the refit released b's bound
    whenever a bilinear term was in the zone, and the freedom alone gave the term a gain it does not have."""
    from hvacfmu.diagnosis import selection as S
    from hvacfmu.diagnosis.design import Within, fit_structure, make_signals
    from hvacfmu.models.causes.signals import effective_inputs

    warm = dataclasses.replace(row_model(), B=np.diag([0.15, -0.35, -0.33]))
    ds = simulate_dataset(warm, weeks=6, seed=0)
    sig = make_signals(ds, row_model())
    rows = sig.rows("train")
    W = Within(sig.group, rows)
    cur = fit_structure(sig, [], rows)
    rss0 = [ls.rss for ls in cur.zone_ls]
    (c,) = [c for c in SupplyAirBilinear.screen(sig, [], W, cur.resid, {}) if c.location["zone"] == "A"]
    factors = [S.ess_factor(S.lag1(cur.resid[:, z])) for z in range(sig.nz)]
    cache = {"U_eff": effective_inputs(sig, []), "feats": []}
    S.score_candidate(sig, W, [], rss0, factors, c, S.DEFAULT_OPTIONS, cache=cache)
    lr_screen = c.test["lr"]
    refit = fit_structure(sig, [SupplyAirBilinear(zone="A")], rows)
    lr_refit = len(W.rows) * np.log(rss0[0] / refit.zone_ls[0].rss)
    assert lr_refit == pytest.approx(lr_screen, rel=1e-6, abs=1e-6)
    assert refit.model.base.B[0, 0] <= 0.0  # Model A's sign: airflow cools


def _scored_coupling(ds, options=None):
    """``(signals, the A+C coupling candidate)`` of ``ds`` screened and scored on the training rows (base:
    :func:`row_model`). ``options`` default: the pair rule (``coupling_alone_unshared`` off; A and C share no
    facade, so the default scores them zone by zone, ``tests/test_coupling_s17.py``)."""
    from hvacfmu.diagnosis import selection as S

    options = {**S.DEFAULT_OPTIONS, "coupling_alone_unshared": False} if options is None else options
    from hvacfmu.diagnosis.design import Within, fit_structure, make_signals

    sig = make_signals(ds, row_model())
    rows = sig.rows("train")
    W = Within(sig.group, rows)
    cur = fit_structure(sig, [], rows)
    (c,) = [c for c in ZoneCoupling.screen(sig, [], W, cur.resid, {}) if c.location["zones"] == ["A", "C"]]
    factors = [S.ess_factor(S.lag1(cur.resid[:, z])) for z in range(sig.nz)]
    S.score_candidate(sig, W, [], [ls.rss for ls in cur.zone_ls], factors, c, options)
    return sig, c


def _coupling_evidence(ds, alone=True):
    """Screen, untied symmetry and cross-validation of the A+C coupling on ``ds`` (base: :func:`row_model`)."""
    from hvacfmu.diagnosis import selection as S
    from hvacfmu.diagnosis.crossval import fold_fits, fold_scores, make_plan, paired_test

    sig, c = _scored_coupling(ds)
    plan = make_plan(sig, 10, 96)
    S.cross_validate(sig, plan, [], c, {})
    scores = []
    for z in (0, 2) if alone else ():  # each zone simulated with its partner measured
        before = fold_scores(sig, plan, fold_fits(sig, plan, [], (z,)), (z,))
        scores.append(paired_test(plan, before, fold_scores(sig, plan, fold_fits(sig, plan, [c.term], (z,)), (z,))))
    return c, scores


def test_couplings_a_shared_driver_passes_the_one_step_screen_and_closed_loop_hides_a_real_one():
    """Issue 15, couplings (README "Diagnosis", couplings; numbers of this machine in the comments).

    1. An unmeasured driver reaching zones A and C (not B) gives the A+C pair a one-step coupling
       as significant and symmetric as a real one, and each zone simulated alone with its partner
       measured gains 20-30 % (the partner's temperature carries the driver); the pair simulated
       together shows no gain, so the rule rejects it (the emulator's clean-case trap).
    2. In closed loop (boxes answering their zone's temperature), a real 0.04/step exchange with
       nothing unmeasured is found by the one-step fit at its true value, but the 24-h prediction
       of the pair barely changes: the controllers hold both zones at the same temperature, so the
       conductance carries almost no heat (the emulator's missed couplings).
    """
    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS, _cv_accepts, _rejected_reason

    c, alone = _coupling_evidence(simulate_dataset(_SharedDriver(row_model(), 12, 0), weeks=12, seed=0))
    # measured: ΔBIC 253, symmetry 0.78, alone +24.4 % (t 10.0) / +27.7 % (t 12.7), pair +1.1 % (t 0.5)
    assert c.test["delta_bic"] > 10 * DEFAULT_OPTIONS["bic_margin"]
    assert 0.5 < c.evidence["symmetry_ratio"] < 2.0
    assert all(r["gain_percent"] > 10 and r["t"] > 4 for r in alone)
    assert c.cv["gain_percent"] < DEFAULT_OPTIONS["coupling_min_gain_percent"]
    assert not _cv_accepts(c, DEFAULT_OPTIONS)
    assert "not decided, not absent" in _rejected_reason(c, DEFAULT_OPTIONS)
    assert 0.05 < c.evidence["dT_within_std_K"] < 1.0

    true = ZoneCoupling(zone_a="A", zone_b="C", coef_ab=0.04, coef_ba=0.04)
    c2, _ = _coupling_evidence(closed_loop_dataset(ExtendedModel(base=row_model(), terms=(true,))), alone=False)
    # measured: untied 0.042 / 0.041, ΔBIC 128, pair +0.2 % (t 0.5); the same data in open loop: +19.8 % (t 13.0)
    assert c2.test["delta_bic"] > 5 * DEFAULT_OPTIONS["bic_margin"]
    for z in "AC":
        assert abs(c2.evidence[f"untied_coef_{z}"] - 0.04) < 0.01
    assert abs(c2.cv["gain_percent"]) < 1.0
    assert c2.evidence["dT_within_std_K"] < 0.1  # held together by the controllers (open loop: 0.17 K)


class _NoisyZone(_SharedDriver):
    """``model`` plus white process noise of ``size`` K/step in the zones of ``loads`` (an imprecise zone)."""

    def __init__(self, model, weeks, seed, size=0.5, loads=(1.0, 0.0, 0.0)):
        super().__init__(model, weeks, seed, size, loads)
        rng = np.random.default_rng(seed + 200)
        self.driver = pd.Series(rng.normal(0.0, size, len(self.driver)), index=self.driver.index)


def _coupling_gate(ds):
    """The A+C coupling candidate of ``ds`` screened, scored and gated (base: :func:`row_model`), no CV."""
    from hvacfmu.diagnosis import selection as S

    _, c = _scored_coupling(ds)
    S._gate(c, S.DEFAULT_OPTIONS)
    return c


def test_coupling_symmetry_gate_rejects_a_one_sided_effect_far_beyond_its_standard_error():
    """A one-sided effect (0.03/step into C, nothing into A) on quiet data: asymmetric, and significantly so."""
    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS

    one_sided = ExtendedModel(
        base=row_model(), terms=(ZoneCoupling(zone_a="A", zone_b="C", coef_ab=0.0, coef_ba=0.03),)
    )
    c = _coupling_gate(simulate_dataset(one_sided, weeks=12, seed=1))
    # measured: ΔBIC 224, untied A 0.001 (free 0.001), C 0.030, asymmetry t 6.1 (week-clustered)
    assert c.test["delta_bic"] > DEFAULT_OPTIONS["bic_margin"]
    assert abs(c.evidence["untied_free_C"] - 0.03) < 0.005 and abs(c.evidence["untied_free_A"]) < 0.005
    assert c.evidence["asymmetry_t"] > 4.0
    assert c.status == "no evidence" and c.reason.startswith("asymmetric")


@pytest.mark.xfail(
    strict=True,
    reason="the symmetry gate compares the ratio of the bounded point estimates with [1/4, 4]; gating on "
    "asymmetry_t instead (the exchange not rejected here) let a false coupling through on battery case 31 "
    "(benchmarks/diagnosis_energyplus_s8.md, case 2)",
)
def test_coupling_symmetry_gate_keeps_a_symmetric_exchange_whose_one_side_is_imprecise():
    """A real symmetric exchange (0.02/step both ways) whose zone A carries white process noise (0.5 K/step).

    A's untied coefficient is imprecise and its bounded value sits at 0 (ratio 0, outside [1/4, 4]), but
    the data do not exclude a symmetric exchange (asymmetry t 0.8): the candidate should go on to the
    cross-validation. Seeds 0-5: A's free coefficient 0.045, 0.006, -0.020, -0.020, 0.011, 0.047 (the
    ratio rule rejects seeds 2 and 3), asymmetry t <= 0.9.
    """
    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS

    m = DEFAULT_OPTIONS["coupling_max_asymmetry"]
    real = ExtendedModel(base=row_model(), terms=(ZoneCoupling(zone_a="A", zone_b="C", coef_ab=0.02, coef_ba=0.02),))
    c = _coupling_gate(simulate_dataset(_NoisyZone(real, 12, 2), weeks=12, seed=2))
    # measured: ΔBIC 1863, untied A 0.000 (free -0.020), C 0.020, asymmetry t 0.8
    assert c.test["delta_bic"] > DEFAULT_OPTIONS["bic_margin"]
    assert not 1.0 / m <= c.evidence["symmetry_ratio"] <= m  # the point estimates alone look one-sided
    assert c.evidence["asymmetry_t"] < 2.0
    assert c.status == "not tested", c.reason  # fails here: rejected as asymmetric


# ---------------------------------------------------------------------------------------------
# a cause is a plugin: a toy cause registered from this file is screened, fitted and exported
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class OutdoorSquared(Term):
    """Toy cause: ``coef · ((T_out − 15) / 10)²`` into a zone [K/step] (no such physics in Model A)."""

    cause: ClassVar[str] = "toy_outdoor_squared"
    zone: str = ""
    coef: float = 0.0

    def columns(self):
        return ("T_out",)

    def zones(self):
        return (self.zone,)

    def location(self):
        return {"zone": self.zone}

    def coefficients(self):
        return {"coef": float(self.coef)}

    @classmethod
    def from_dict(cls, d, zone_names, problems, std):
        return cls(zone=d["zone"], coef=float(d["coef"]), std=std)

    @staticmethod
    def _f(T_out):
        return ((np.asarray(T_out) - 15.0) / 10.0) ** 2

    def features(self, sig, U_eff):
        return [(sig.zones.index(self.zone), "coef", self._f(sig.V["T_out"]), 0.0, np.inf)]

    def contribute(self, c):
        c.Tn[..., c.zi[self.zone]] += self.coef * self._f(c.v[..., c.vi["T_out"]])

    @classmethod
    def screen(cls, sig, terms, W, resid, options):
        have = {t.zone for t in terms if isinstance(t, cls)}
        return [
            Candidate(cls.cause, {"zone": z}, [cls(zone=z)], 0, evidence={"toy": True})
            for z in sig.zones
            if z not in have
        ]


@pytest.fixture
def toy_cause():
    register_cause(OutdoorSquared)
    yield OutdoorSquared
    unregister_cause(OutdoorSquared.cause)


@pytest.mark.slow
def test_toy_cause_plugin_is_screened_fitted_and_exported(toy_cause, tmp_path):
    import fmpy
    from fmpy.validation import validate_fmu

    from hvacfmu.fmu import export_fmu
    from hvacfmu.timeutil import seconds_of_week

    base = row_model()
    ds = simulate_dataset(ExtendedModel(base=base, terms=(OutdoorSquared(zone="B", coef=0.08),)), weeks=12, seed=2)
    rep = diagnose(ds, model=base, progress=False)
    assert [f["cause"] for f in rep.findings] == ["toy_outdoor_squared"], rep.summary()
    assert rep.findings[0]["location"] == {"zone": "B"}
    est = rep.findings[0]["parameters"]["coef"]
    assert abs(est["value"] - 0.08) <= max(4 * est["std"], 0.016)
    # the saved model reloads through the registry and runs as an FMU like the built-in causes
    path = rep.model.save(tmp_path / "toy.json")
    fmu = export_fmu(path, tmp_path / "toy.fmu")
    assert validate_fmu(str(fmu)) == []
    model = rep.model
    week = ds.test_weeks()[0]
    f = ds.week_frame(week).interpolate(method="time", limit_direction="both").iloc[:96]
    u, v = model.signals(f)
    y0 = model.measured_outputs(f.iloc[:1])[0]
    q = model.gains_at(f.index, week.season)
    _, Y = model.simulate(model.initial_state(f, 0), u, v, q)
    names = [f"m_{b}" for b in model.base.vavs] + list(model.disturbances)
    t = np.arange(len(f)) * 900.0
    sig = np.zeros(len(f), dtype=[("time", float)] + [(n, float) for n in names])
    sig["time"] = t
    for n in names:
        sig[n] = f[n].to_numpy(float)
    sv = {f"T_{z}_start": float(y) for z, y in zip(model.outputs, y0)}
    sv["season"] = list(model.gains).index(week.season) + 1
    sv["start_time_of_week"] = float(seconds_of_week(f.index[:1])[0])
    res = fmpy.simulate_fmu(
        str(fmu),
        start_time=0.0,
        stop_time=t[-1],
        output_interval=900.0,
        input=sig,
        start_values=sv,
        output=[f"T_{z}" for z in model.outputs],
    )
    Y_fmu = np.column_stack([res[f"T_{z}"] for z in model.outputs])
    n = min(len(Y), len(Y_fmu))
    np.testing.assert_allclose(Y_fmu[:n], Y[:n], rtol=0, atol=1e-6)  # [K]


def closed_loop_dataset(model, weeks=12, seed=0, gain=0.25, noise=0.02) -> Dataset:
    """Model A data where every box answers its zone's temperature at once (P control, no delay)."""
    rng = np.random.default_rng(seed)
    ds0 = simulate_dataset(model, weeks=weeks, seed=seed, noise=noise)
    frame = ds0.frame.copy()
    n = len(frame)
    u, v = model.signals(frame)
    q = np.zeros((n, 3))
    for s in np.unique(ds0.season_of_row):
        m = ds0.season_of_row == s
        q[m] = model.gains_at(frame.index[m], s)
    x = np.full(3, 21.0)
    Y, M = np.empty((n, 3)), np.empty((n, 3))
    for k in range(n):
        Y[k] = x
        uk = np.clip(0.2 + gain * (x - 21.5) + rng.normal(0, 0.03, 3), 0.05, 0.6)  # feedback, same step
        M[k] = uk
        x = model.step_state(x, uk, v[k], q[k]) + rng.normal(0, noise, 3)
    for j, z in enumerate("ABC"):
        frame[f"T_{z}"] = Y[:, j]
        frame[f"m_V{j + 1}"] = M[:, j]
    return Dataset.from_frame(frame, ds0.building, step=900.0, seed=seed)


@pytest.mark.parametrize("seed", [0, 1])
def test_feedback_is_not_delay(seed):
    """Closed-loop data without any delay: the residual leads the airflow (the controller answers the
    error), which must not be read as an actuation delay."""
    rep = diagnose(closed_loop_dataset(row_model(), seed=seed), model=row_model(), progress=False)
    assert not [f for f in rep.findings if f["cause"] == "actuation_delay"], rep.summary()
    assert rep.findings == [], rep.summary()


def history_closed_loop_dataset(weeks=12, seed=0, a2=0.6, lag=2, gain=0.25, noise=0.02) -> Dataset:
    """Closed loop (P control, no delay) where zone B's next temperature also depends on its own
    temperature ``lag`` steps back (weight ``a2``, taken from its own ``a``): a second, fast state
    Model A lacks, as the air node and furniture of a detailed simulation."""
    base = row_model()
    rng = np.random.default_rng(seed)
    ds0 = simulate_dataset(base, weeks=weeks, seed=seed, noise=noise)
    frame = ds0.frame.copy()
    n = len(frame)
    _u, v = base.signals(frame)
    q = np.zeros((n, 3))
    for s in np.unique(ds0.season_of_row):
        m = ds0.season_of_row == s
        q[m] = base.gains_at(frame.index[m], s)
    A = base.A.copy()
    A[1, 1] -= a2
    x = np.full(3, 21.0)
    Y, M = np.full((n, 3), 21.0), np.empty((n, 3))
    for k in range(n):
        Y[k] = x
        uk = np.clip(0.2 + gain * (x - 21.5) + rng.normal(0, 0.03, 3), 0.05, 0.6)  # feedback, same step
        M[k] = uk
        x = A @ x + base.B @ uk + base.C @ v[k] + q[k] + rng.normal(0, noise, 3)
        x[1] += a2 * Y[max(k - lag, 0), 1]
    for j, z in enumerate("ABC"):
        frame[f"T_{z}"] = Y[:, j]
        frame[f"m_V{j + 1}"] = M[:, j]
    return Dataset.from_frame(frame, ds0.building, step=900.0, seed=seed)


@pytest.mark.parametrize("seed", [0, pytest.param(1, marks=pytest.mark.slow)])
def test_feedback_standing_in_for_temperature_history_is_not_delay(seed):
    """Feedback is not delay (issue 15): under P control u(k − d) is the controller's answer to T(k − d), so
    in a zone that depends on its own past temperature the airflow of 3 steps before "explains" the zone
    (before: actuation_delay B, delay 3, ΔBIC 400, cross-validated +15 %, t 7.5–9.9, as the EnergyPlus Core's
    false delay). Given the zone's own temperatures of the last hour its likelihood ratio is negative."""
    rep = diagnose(history_closed_loop_dataset(seed=seed), model=row_model(), progress=False)
    assert not [f for f in rep.findings if f["cause"] == "actuation_delay"], rep.summary()
    d = rep.to_dict()
    (cand,) = [c for c in d["candidates"] if c["cause"] == "actuation_delay" and c["location"]["zone"] == "B"]
    assert cand["test"]["delta_bic"] > 100  # the plain screen still passes it ...
    assert cand["status"] == "no evidence" and "feedback" in cand["reason"]
    assert cand["evidence"]["history"]["delta_bic"] < 0  # ... the history takes it all


def test_a_true_delay_survives_the_temperature_history():
    """The synthetic 2-step delay in C (no controller: the airflow is drawn at random) and the history test."""
    base = row_model()
    ds = simulate_dataset(ExtendedModel(base=base, terms=(ActuationDelay(zone="C", delay=2),)), weeks=12, seed=3)
    rep = diagnose(ds, model=base, progress=False)
    (f,) = _found(rep, "actuation_delay", zone="C", delay=2)
    h = f["evidence"]["history"]
    assert h["lags"] == 4 and h["delta_bic"] > 100 and h["b"] < 0


def test_an_extended_model_that_would_not_load_is_said(monkeypatch):
    """The model a report saves goes through the load checks first: one that export, evaluate and cosim would
    refuse is named in a warning and the report's notes (a diagnosis once wrote such a file without a word)."""
    import hvacfmu.diagnosis.pipeline as pipeline
    from hvacfmu.errors import HvacfmuWarning

    monkeypatch.setattr(pipeline, "model_problems", lambda m: ["base: airflow warms zone A"])
    with pytest.warns(HvacfmuWarning, match="will refuse it: base: airflow warms zone A"):
        rep = diagnose(closed_loop_dataset(row_model(), seed=0), model=row_model(), progress=False)
    assert any("will refuse it: base: airflow warms zone A" in n for n in rep.notes)


@pytest.mark.parametrize(
    "past, future, causal",
    [
        ({"0": -0.3, "1": 0.05, "2": 0.25}, {"1": 0.1, "2": 0.05}, True),  # residual follows u(k-2): a delay
        ({"0": -0.3, "1": 0.05, "2": 0.10}, {"1": 0.35, "2": 0.2}, False),  # residual leads u: feedback
    ],
)
def test_delay_gate_compares_past_and_future_airflow(past, future, causal):
    from hvacfmu.diagnosis.selection import _delay_is_causal

    c = Candidate(
        "actuation_delay",
        {"zone": "A"},
        evidence={"xcorr_resid_airflow_by_lag": past, "xcorr_resid_future_airflow_by_lag": future},
    )
    c.term = ActuationDelay(zone="A", delay=2)
    assert _delay_is_causal(c) is causal
    assert set(c.evidence["delay_past_vs_future"]) == {"past_at_delay", "future_max"}


@pytest.mark.parametrize(
    "seed", [10, pytest.param(11, marks=pytest.mark.slow), pytest.param(12, marks=pytest.mark.slow)]
)
def test_no_false_alarm_on_model_a_data(seed):
    base = row_model()
    ds = simulate_dataset(base, weeks=12, seed=seed, at_min=0.2)
    rep = diagnose(ds, model=base, progress=False)
    assert rep.findings == [], rep.summary()
    assert rep.verdict == "nothing missing"
    assert rep.unexplained == []
    assert "nothing missing" in rep.format()


def test_missing_ghi_makes_solar_untestable_not_absent():
    base = row_model()
    ds = simulate_dataset(base, weeks=8, seed=4, ghi=False)
    assert not ds.has_solar
    rep = diagnose(ds, model=base, progress=False)
    solar = [c for c in rep.candidates if c["cause"] == "solar_gain"]
    assert solar and all(c["status"] == "untestable" for c in solar)
    d = rep.to_dict()
    solar_untestable = {u["location"]["zone"] for u in d["untestable"] if u["cause"] == "solar_gain"}
    assert solar_untestable == {"A", "C"}
    assert "Untestable (not absent)" in rep.format()


def test_gaps_do_not_break_it():
    base = row_model()
    ds = simulate_dataset(
        ExtendedModel(base=base, terms=(ThermalMass(zone="B", alpha=0.02, beta=0.05),)), weeks=10, seed=5, gaps=True
    )
    assert ds.frame["T_A"].isna().sum() >= 100
    rep = diagnose(ds, model=base, progress=False)
    assert _found(rep, "thermal_mass", zone="B")


# ---------------------------------------------------------------------------------------------
# report, JSON schema, CLI, extended model round trip
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def solar_case(tmp_path_factory):
    base = row_model()
    ds = simulate_dataset(
        ExtendedModel(base=base, terms=(SolarGain(zone="A", facade="S", coef=0.0008),)), weeks=8, seed=6
    )
    folder = tmp_path_factory.mktemp("solar")
    frame = ds.frame.drop(columns=[c for c in ds.frame.columns if c.startswith("I_") or c == "excitation"])
    frame.reset_index().to_csv(folder / "data.csv", index=False)
    ds.building.save(folder / "building.toml")
    base.save(folder / "base.json")
    return ds, base, folder


def test_report_json_schema(solar_case, tmp_path):
    ds, base, _ = solar_case
    rep = diagnose(ds, model=base, progress=False, plots=tmp_path / "figs")
    d = json.loads(rep.save_json(tmp_path / "r.json").read_text())
    assert d["schema"] == SCHEMA
    for key in (
        "verdict",
        "summary",
        "data",
        "base_model",
        "options",
        "findings",
        "candidates",
        "untestable",
        "unexplained",
        "whiteness",
        "errors",
        "heldout",
        "rounds",
        "notes",
        "model",
    ):
        assert key in d, key
    f = d["findings"][0]
    assert set(f) >= {"cause", "location", "status", "evidence", "test", "parameters", "heldout"}
    assert f["cause"] in CAUSES and f["status"] == "found"
    assert set(f["test"]) >= {"lr", "lr_adjusted", "dof", "delta_bic", "p_value", "n"}
    assert f["parameters"]["coef"]["std"] > 0
    assert set(f["heldout"]["zones"]["A"]) == {"before", "after"}
    assert all(c["cause"] in CAUSES for c in d["candidates"])
    for by in ("season", "hour", "day_type", "airflow_regime", "T_out_band", "sky", "zone"):
        assert by in d["errors"]["open_loop"], by
    assert set(d["whiteness"]["before"]["A"]) >= {"acf_lag1", "ljung_box", "cpgram_departure", "peak_period_h"}
    assert d["heldout"]["zones"] == ["A", "B", "C"]
    figs = sorted(p.name for p in (tmp_path / "figs").iterdir())
    assert figs == [
        "acf.png",
        "cumulated_periodogram.png",
        "heldout_before_after.png",
        "residuals_by_hour_weekday.png",
        "residuals_by_zone.png",
    ]


def test_cli_diagnose_then_evaluate(solar_case, tmp_path, cli):
    _, _, folder = solar_case
    out = tmp_path / "ext.json"
    cmd = [
        sys.executable,
        "-m",
        "hvacfmu.cli",
        "-q",
        "diagnose",
        str(folder / "data.csv"),
        "-b",
        str(folder / "building.toml"),
        "-m",
        str(folder / "base.json"),
        "--json",
        str(tmp_path / "r.json"),
        "-o",
        str(out),
        "--control-output",
        str(tmp_path / "control.json"),
    ]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "solar_gain" in r.stdout and "Verdict: found" in r.stdout
    control, base = json.loads((tmp_path / "control.json").read_text()), json.loads((folder / "base.json").read_text())
    assert control["kind"] == "extended" and [t["cause"] for t in control["terms"]] == ["solar_gain"]
    assert control["base"]["A"] == base["A"] and control["base"]["B"] == base["B"]
    assert json.loads((tmp_path / "r.json").read_text())["findings"][0]["location"] == {"zone": "A", "facade": "S"}
    saved = json.loads(out.read_text())
    assert saved["kind"] == "extended" and saved["terms"][0]["cause"] == "solar_gain"
    r2 = cli("evaluate", folder / "data.csv", "-b", folder / "building.toml", "-m", out)  # in-process
    assert r2.returncode == 0, r2.stderr
    assert "extended" in r2.stdout


def test_bad_options_and_models(solar_case):
    ds, base, _ = solar_case
    with pytest.raises(TypeError, match="unknown diagnosis options"):
        diagnose(ds, model=base, progress=False, bic_margins=3)
    from hvacfmu.errors import FitError

    phys = type("P", (), {"kind": "physics"})()
    with pytest.raises(FitError, match="Model A base"):
        diagnose(ds, model=phys, progress=False)


# ---------------------------------------------------------------------------------------------
# emulator: end to end
# ---------------------------------------------------------------------------------------------
emulator = pytest.importorskip("hvacfmu.emulator")


def _emulated(weeks, seed, effects=()):
    from hvacfmu.data import prepare

    paths = emulator.cached_dataset(weeks=weeks, seed=seed, effects=list(effects))
    return prepare(paths.measurements, paths.building), json.loads(paths.truth.read_text())


_CACHE = {}


def _diagnosed(seed, effects=(), weeks=16):
    """Diagnosis of an emulated dataset (default Model A base), cached per worker."""
    key = (weeks, seed, tuple(effects))
    if key not in _CACHE:
        ds, truth = _emulated(weeks, seed, effects)
        _CACHE[key] = (diagnose(ds, progress=False), truth, ds)
    return _CACHE[key]


def _assert_truthful(rep, truth):
    from hvacfmu.models.loadcheck import model_problems

    assert model_problems(rep.model) == [], "the saved extended model would be refused on load"
    cmp = compare_with_truth(rep, truth)
    assert cmp["unsupported"] == [], f"false alarm(s): {cmp['unsupported']}"
    return cmp


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_emulator_baseline_findings_are_all_in_truth(seed):
    """Baseline emulator data: window solar, bilinear supply air, wall mass and reheat coils
    may be found (they are in truth.json's baseline structure); nothing else."""
    rep, truth, _ = _diagnosed(seed)
    _assert_truthful(rep, truth)
    assert {f["cause"] for f in rep.findings} <= {"solar_gain", "supply_air_bilinear", "thermal_mass", "reheat"}
    # the occupancy follows the local clock: no daylight-saving jump of the weekday mornings
    dst = [c for c in rep.candidates if c["location"].get("variant") == "dst_shift"]
    assert dst and dst[0]["status"] == "not significant", dst
    assert rep.heldout["mean_extended"] < rep.heldout["mean_base"]


def _effect_finding(rep, truth, name):
    from hvacfmu.diagnosis.truth import effect_matches

    e = [x for x in truth["effects"] if x["name"] == name][0]
    hits = [f for f in rep.findings if effect_matches(f, e, truth, rep.data["step"])]
    assert hits, f"{name} {e} not found; findings: {rep.summary()}"
    return hits[0]


# Magnitudes (emulator parameters) — moderate and realistic for an office floor:
#   solar_gain: extra SHGC 0.2 of one facade's windows straight to the air (blinds left open);
#   zone_coupling: 1200 W/K between two non-adjacent zones (open double doors / a transfer duct);
#   reheat: 3000 W (seed 0) and 4000 W (seed 1) at minimum airflow below 13 °C outdoors;
#   actuation_delay: 30 and 45 minutes between logged and delivered airflow;
#   thermal_mass: 2e8 J/K (a concrete core wall) coupled by 1000 W/K;
#   internal_gain_schedule: two holiday weeks with weekday gains at 20 %; or occupancy kept on
#   standard time all year (one hour late on the local clock until DST ends on 2025-11-02).
EFFECT_CASES = [
    ("solar_gain:zone=NE,facade=E", 0),
    ("solar_gain:zone=W,facade=S", 1),
    pytest.param(
        "zone_coupling:ua=1200",
        0,
        marks=pytest.mark.xfail(
            strict=True,
            reason="known miss: ΔBIC significant but the pair's 24-h CV gain is -1.0 ± 1.0 %: the controllers hold "
            "the zones together, and one step ahead a shared driver looks the same (README, Diagnosis: couplings)",
        ),
    ),
    pytest.param(
        "zone_coupling:ua=1200",
        1,
        marks=pytest.mark.xfail(
            strict=True,
            reason="known miss at seed 1 as at seed 0 (README, Diagnosis: couplings; no false finding; open, issue 15)",
        ),
    ),
    ("reheat", 0),
    ("reheat:power=4000", 1),
    ("actuation_delay", 0),
    ("actuation_delay:minutes=45", 1),
    ("thermal_mass", 0),
    ("thermal_mass:zone=W", 0),
    ("internal_gain_schedule", 0),
    ("internal_gain_schedule", 1),
    ("internal_gain_schedule:kind=dst", 0),
    # seed 1: found after four solar terms displaced it as rivals (retested, not screened out again)
    ("internal_gain_schedule:kind=dst", 1),
]


@pytest.mark.slow
@pytest.mark.parametrize("effect, seed", EFFECT_CASES)
def test_emulator_effect_is_found(effect, seed):
    name = effect.split(":")[0]
    rep, truth, _ = _diagnosed(seed, (effect,))
    cmp = _assert_truthful(rep, truth)
    assert [e["name"] for e in cmp["found"]] == [name]
    f = _effect_finding(rep, truth, name)
    h = f["heldout"]
    if h.get("measurable", True):
        assert h["gain_percent"] > 0
    if name == "solar_gain":
        # the injected path is measured stronger than the same path in the baseline data
        base_rep, _, _ = _diagnosed(seed)
        loc = f["location"]
        base_hits = _found(base_rep, "solar_gain", **loc)
        base_coef = base_hits[0]["parameters"]["coef"]["value"] if base_hits else 0.0
        assert f["parameters"]["coef"]["value"] > 1.5 * base_coef
    if "kind=dst" in effect:
        # gains one hour late under daylight saving: the profile is read one hour earlier
        assert f["location"]["variant"] == "dst_shift"
        assert f["location"]["shift"] == -round(3600 / rep.data["step"]), f["location"]
        # the screen's lag, of this round or (retested after a rival was accepted) of the round it passed
        screen = f["evidence"].get("screen_passed", f["evidence"])
        assert 0.5 <= screen["lag_h"] <= 2.0, f["evidence"]
        assert f["evidence"]["scale_mean"] > 0.5
    if name == "reheat":
        top = max((g for g in rep.findings if g["cause"] == "reheat"), key=lambda g: g["test"]["delta_bic"])
        assert top["location"] == f["location"]


@pytest.mark.slow
@pytest.mark.parametrize(
    "seed, effects",
    [
        (0, ("reheat", "actuation_delay")),
        (1, ("internal_gain_schedule:kind=dst", "reheat:power=4000")),
    ],
)
def test_emulator_two_effects_are_both_found(seed, effects):
    rep, truth, _ = _diagnosed(seed, effects)
    cmp = _assert_truthful(rep, truth)
    assert sorted(e["name"] for e in cmp["found"]) == sorted(e.split(":")[0] for e in effects)
    assert cmp["missed"] == []


def test_emulator_short_dataset():
    """Four weeks (one season, one test week) and the emulator's gaps do not break it."""
    rep, truth, ds = _diagnosed(0, (), weeks=4)
    assert ds.frame.isna().any().any()
    assert rep.data["n_weeks"] == 4
    _assert_truthful(rep, truth)
    assert rep.verdict in ("found", "nothing missing", "unexplained")
    assert rep.format()


@pytest.fixture(scope="module")
def fitted_model_a():
    """Model A (six zones, with solar) fitted on 16 emulated weeks, and that dataset."""
    from hvacfmu.fitting import fit

    ds, _ = _emulated(16, 0)
    return fit(ds, "zones", progress=False), ds


# slow: 16 emulated weeks generated and fitted (9 CPU-s on an empty cache); the not-slow tier's case of the same
# path (diagnose on data a Model A simulated, with that model given: no finding) is test_no_false_alarm_on_model_a_data
@pytest.mark.slow
@pytest.mark.parametrize("noise_seed", [0, 1, 2])
def test_no_false_alarm_on_data_simulated_from_fitted_model_a(fitted_model_a, noise_seed):
    """Temperatures simulated at the model step from a fitted Model A (measured airflows and
    weather of the emulator, the model's own gain profiles, 0.05 K process noise): the base
    structure contains the truth, so nothing may be found."""
    model, ds = fitted_model_a
    rng = np.random.default_rng(100 + noise_seed)
    frame = ds.frame.copy()
    u, v = model.signals(frame)
    u = pd.DataFrame(u).ffill().bfill().to_numpy()
    v = pd.DataFrame(v).ffill().bfill().to_numpy()
    season = ds.season_of_row
    q = np.zeros((len(frame), model.n_states))
    for s in np.unique(season):
        m = season == s
        q[m] = model.gains_at(frame.index[m], s if s in model.gains else next(iter(model.gains)))
    x = np.nan_to_num(model.initial_state(frame, 0), nan=21.0)
    Y = np.empty((len(frame), model.n_states))
    for k in range(len(frame)):
        Y[k] = x
        x = model.step_state(x, u[k], v[k], q[k]) + rng.normal(0, 0.05, model.n_states)
    for j, z in enumerate(model.outputs):
        frame[f"T_{z}"] = np.where(frame[f"T_{z}"].isna(), np.nan, Y[:, j])
    sim = Dataset.from_frame(frame, ds.building, step=ds.step, seed=0)
    rep = diagnose(sim, model=model, progress=False)
    assert rep.findings == [], rep.summary()
    assert rep.verdict in ("nothing missing", "unexplained")


# ---------------------------------------------------------------------------------------------
# a slice of the randomised battery (benchmarks/bench_diagnosis_battery.py) on the other layouts
# ---------------------------------------------------------------------------------------------
def _battery():
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_diagnosis_battery.py"
    spec = importlib.util.spec_from_file_location("bench_diagnosis_battery", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


#: The term budget the battery slice gives its core9 (nine-zone) case, explicitly.
CORE9_BUDGET = 20


@pytest.mark.slow
@pytest.mark.parametrize(
    "case_id",
    [
        0,  # row4, 15 min, clean
        12,  # row4, 15 min, holiday weeks 10 + 12 after the DST change + slow mass in R2 (no false dst_shift)
        13,  # core9, 15 min, holiday week + solar gain of NE's east facade
        22,  # row4, 15 min, reheat in R1
        pytest.param(
            25,
            marks=pytest.mark.xfail(
                strict=True,
                reason="known miss: the row4 R1+R4 coupling (928 W/K) scores -0.1 % cross-validated; the pair "
                "differs by 0.14 K beyond its time-of-week profile (README, Diagnosis: couplings)",
            ),
        ),
        35,  # row4, 5 min, slow mass behind R1 (missed while windows and time constants were step counts)
    ],
)
def test_battery_slice(case_id):
    bat = _battery()
    case = bat.make_cases(48, 2026)[case_id]
    assert case["layout"] in ("row4", "core9", "sdh")
    # core9 at the term budget of sessions 9-13 (20; the default max(20, 4 x zones) is 36 there): 1.7x less CPU,
    # the same two effects found and no false finding (benchmarks/diagnosis_budget_s14.md, section 6)
    r = bat.run_case(case, weeks=16, **({"max_terms": CORE9_BUDGET} if case["layout"] == "core9" else {}))
    assert r["unsupported"] == [], f"false finding(s) on {case}: {r['unsupported']}"
    assert r["missed"] == [], f"missed on {case}: {r['missed']}"
    assert len(r["found"]) == len(case["effects"])


@pytest.mark.slow
@pytest.mark.parametrize(
    "case_id",
    [
        25,  # row4 coupling redrawn by the detectability gate: R2+R4 at 2871 W/K (the R1+R4 pair never passes)
        42,  # row4 north-window solar gain, made 1.5x stronger three times (shgc 0.675)
    ],
)
def test_detectability_checked_battery_slice(case_id):
    """The battery with every effect checked detectable (``--detectable``, README "Battery and speed"): the
    gated case as recorded in benchmarks/battery_checked_cases.jsonl is found at its place, nothing else."""
    import json
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "battery_checked_cases.jsonl"
    (rec,) = [r for r in map(json.loads, path.read_text().splitlines()) if r["case"]["id"] == case_id]
    bat = _battery()
    assert rec["case"] == bat.make_cases(48, 2026)[case_id] and rec["detectable"]
    case = rec["checked"]
    assert case != rec["case"]  # the gate changed it
    r = bat.run_case(case, weeks=16)
    assert r["unsupported"] == [], f"false finding(s) on {case}: {r['unsupported']}"
    assert r["missed"] == [], f"missed on {case}: {r['missed']}"
    assert len(r["found"]) == len(case["effects"])


def test_displaced_dst_shift_is_carried_to_the_next_round_until_decided():
    """A daylight-saving shift that passed its screen and CV but lost to a rival of another cause is
    retested in the next rounds (the rival changes what its screen reads); its own CV decision ends it."""
    from hvacfmu.diagnosis.selection import _carry_displaced_dst
    from hvacfmu.models.extended import InternalGainSchedule

    term = InternalGainSchedule(variant="dst_shift", zone_names=("A", "B"), coef=(0.5, 0.5), shift=-4)
    screen = {"lag_steps": 5, "lag_h": 1.25, "r2_at_lag": 0.36, "scale_at_lag": 0.41}

    def cand(status, favoured):
        c = Candidate("internal_gain_schedule", {"variant": "dst_shift"}, [term], 1, evidence=dict(screen))
        c.term, c.status = term, status
        if favoured:
            c.evidence["rival"] = {"cause": favoured, "favoured": favoured}
        return c

    opts: dict = {}
    _carry_displaced_dst([cand("no evidence", "internal_gain_schedule")], opts)  # its own cause favoured
    assert opts == {}
    _carry_displaced_dst([cand("no evidence", "solar_gain")], opts)
    assert opts["_dst_retest"] == {"shift": -4, "screen_passed": screen}
    # a retested candidate keeps the screen numbers of the round it passed
    later = cand("no evidence", "solar_gain")
    later.evidence.update(lag_steps=1, lag_h=0.25, screen_passed=screen)
    _carry_displaced_dst([later], opts)
    assert opts["_dst_retest"]["screen_passed"] == screen
    _carry_displaced_dst([cand("no cross-validated gain", None)], opts)
    assert "_dst_retest" not in opts


def test_retested_dst_evidence_prints_the_screen_it_passed():
    from hvacfmu.diagnosis.report import _short_evidence

    ev = {"lag_h": 0.25, "r2_at_lag": 0.23, "scale_at_lag": 1.43, "dst_fraction_of_training_rows": 0.68}
    f = {"cause": "internal_gain_schedule", "location": {"variant": "dst_shift", "shift": -4}, "evidence": ev}
    assert "+15 min later" in _short_evidence(f) and "retested" not in _short_evidence(f)
    ev["screen_passed"] = {"lag_steps": 5, "lag_h": 1.25, "r2_at_lag": 0.36, "scale_at_lag": 0.41}
    text = _short_evidence(f)
    assert "+75 min later" in text and "R² 0.36, scale 0.41" in text and "retested" in text, text
    ev["screen_passed"]["evening"] = {"legal_lag_h": 1.0, "r2_at_legal_lag": 0.55}
    assert "evening ramp-down +60 min (R² 0.55)" in _short_evidence(f)


def test_reheat_heat_of_each_box_is_against_its_own_units_supply():
    """Two air handlers: a box whose discharge air is its own unit's supply (a packaged unit without a
    coil) has no reheat heat, though its unit runs 5 K warmer than the other (and the mean)."""
    from hvacfmu.models.causes.signals import make_signals

    ds = simulate_dataset(row_model(), weeks=2, seed=3, ghi=False)
    d = json.loads(json.dumps(ROW))
    d["ahus"] = [{"name": "U1"}, {"name": "U2"}]
    for v in d["vavs"]:
        v["ahu"] = "U1" if v["name"] == "V1" else "U2"
    frame = ds.frame.copy()
    frame["T_supply_U1"], frame["T_supply_U2"], frame["T_supply"] = 18.0, 13.0, 13.0
    frame["Td_V1"], frame["Td_V2"], frame["Td_V3"] = 18.0, 25.0, 13.0
    ds2 = Dataset.from_frame(frame, building_from_dict(d), step=900.0, seed=3)
    sig = make_signals(ds2, row_model())
    assert sig.supply_of == {"V1": "T_supply_U1", "V2": "T_supply_U2", "V3": "T_supply_U2"}
    assert np.nanmax(np.abs(sig.V["Qrh_A"])) == 0.0  # before: m cp (18 - 13) on every row
    np.testing.assert_allclose(sig.V["Qrh_B"], frame["m_V2"].to_numpy() * 1005.0 * 12.0 / 1000.0)


def test_rival_with_higher_t_that_fails_its_own_rule_does_not_read_as_favoured():
    from hvacfmu.diagnosis.report import _finding_lines

    f = {
        "cause": "solar_gain",
        "location": {"zone": "P", "facade": "S"},
        "test": {"lr": 127.3, "lr_adjusted": 123.1, "dof": 1, "delta_bic": 112.8},
        "evidence": {
            "rival": {
                "cause": "zone_coupling",
                "location": {"zones": ["P", "F"]},
                "cv_gain_percent": 2.1,
                "cv_t": 4.7,
                "favoured": "zone_coupling",
            }
        },
    }
    line = next(x for x in _finding_lines(1, f) if "competing cause" in x)
    assert "the data favour" not in line and "fails its own acceptance rule (cross-validated gain 2.1 %)" in line
    f["evidence"]["rival"]["favoured"] = "solar_gain"
    line = next(x for x in _finding_lines(1, f) if "competing cause" in x)
    assert line.endswith("the data favour solar_gain")


def test_a_competitor_a_gate_turned_down_says_why_not_that_it_was_significant():
    # the DOE supermarket: "also significant here: internal_gain_schedule at ... dst_shift ... (ΔBIC 5321.1, not
    # significant)" under three findings, with the gate's reason (too small a schedule change) left out
    from hvacfmu.diagnosis.report import _finding_lines

    f = {
        "cause": "thermal_mass",
        "location": {"zone": "Produce"},
        "test": {"lr": 544.8, "lr_adjusted": 417.9, "dof": 2, "delta_bic": 397.3},
        "competitors": [
            {
                "cause": "internal_gain_schedule",
                "location": {"variant": "dst_shift", "shift": 4},
                "delta_bic": 5321.1,
                "status": "not significant",
                "reason": "mean scale 0.12 of the schedule change < 0.5: too small for a schedule change",
                "cv_gain_percent": None,
            },
            {"cause": "reheat", "location": {"zone": "Produce"}, "delta_bic": 62.1, "status": "not tested"},
        ],
    }
    lines = [x for x in _finding_lines(1, f) if "here:" in x]
    assert lines[0].startswith("    also tested here: internal_gain_schedule")
    assert lines[0].endswith(
        "(ΔBIC 5321.1, not significant: mean scale 0.12 of the schedule change < 0.5: too small for a schedule change)"
    )
    assert lines[1] == "    also significant here: reheat at zone=Produce (ΔBIC 62.1, not tested)"


def test_bounded_ls_with_an_all_zero_regressor_says_unidentified_without_overflow(rng):
    """A regressor that is zero on every row of a fold: coefficient 0, infinite variance, no overflow warning."""
    import warnings as _w

    from hvacfmu.diagnosis.design import bounded_ls

    X = np.column_stack([rng.normal(size=200), np.zeros(200), rng.normal(size=200)])
    y = X @ np.array([0.5, 0.0, -0.2]) + 0.01 * rng.normal(size=200)
    with _w.catch_warnings():
        _w.simplefilter("error")
        ls = bounded_ls(X, y, [-1, -1, -1], [1, 1, 1])
    assert ls.theta[1] == 0.0 and np.isinf(ls.cov[1, 1]) and ls.cov[0, 1] == 0.0
    np.testing.assert_allclose(ls.theta[[0, 2]], [0.5, -0.2], atol=0.01)
    assert np.isfinite(ls.cov[[0, 2]][:, [0, 2]]).all()


@pytest.mark.slow
def test_heat_outside_the_discharge_air_is_found_where_td_is_measured():
    """Reheat-mode data (every box's discharge air measured) with an extra 3 kW heater in W at minimum
    airflow in cold weather that does not pass through the discharge air (a perimeter heater): the on/off
    reheat variant is still offered beside the discharge one, and finds it (before, only the discharge
    variant was tried where Td is measured, and it was missed; fleet sweep b006)."""
    from hvacfmu.data import prepare

    paths = emulator.cached_dataset(
        weeks=16, seed=0, effects=["reheat:zone=W"], hvac="reheat", start="2025-11-03T00:00:00"
    )
    ds = prepare(paths.measurements, paths.building)
    rep = diagnose(ds, progress=False)
    cmp = compare_with_truth(rep, json.loads(paths.truth.read_text()))
    assert [e["name"] for e in cmp["found"]] == ["reheat"] and cmp["missed"] == [], cmp
    assert {"zone": "W"} in [f["location"] for f in rep.findings if f["cause"] == "reheat"]
    # the truth file has no rule for unused_input: those name measured Td_/rh_ columns of boxes that reheat
    others = [u for u in cmp["unsupported"] if u["cause"] != "unused_input"]
    assert others == [] and all(u["location"]["column"][:3] in ("Td_", "rh_") for u in cmp["unsupported"]), cmp


def test_a_round_whose_joint_refit_fails_the_load_checks_is_rejected(solar_case, monkeypatch):
    """Terms that each pass but together give a model no file check lets load (a diverging mode: the EnergyPlus
    apartments, spectral radius 1.198) are rejected with the reason; the model before them is what is saved."""
    from hvacfmu.diagnosis import selection as S
    from hvacfmu.models.loadcheck import model_problems

    ds, base, _ = solar_case
    real = S._new_load_problems
    calls = []

    def diverging(model, before):
        calls.append(len(model.terms))
        return ["a mode with spectral radius 1.198 > 1 (test)"] if model.terms else real(model, before)

    monkeypatch.setattr(S, "_new_load_problems", diverging)
    rep = diagnose(ds, model=base, progress=False)
    assert calls and rep.findings == []
    (rej,) = [c for c in rep.candidates if c["status"] == "rejected"]
    assert rej["cause"] == "solar_gain" and "spectral radius 1.198" in rej["reason"]
    assert rep.model.terms == () and model_problems(rep.model) == []
    assert "left out first, until the refit passes" in rep.format()
    assert sum(len(r.get("rejected_unstable", [])) for r in rep.rounds) == 1
