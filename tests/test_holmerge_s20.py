"""A holiday found week by week is reported as one finding (session 20, ``benchmarks/holmerge_s20.md``).

quad4 2026 case 27 (weeks 3 + 4): session 19's selection finds week 3 in round 1 and week 4 in a later round, two
holiday terms. After the selection they are merged into one term on the union of the dates unless the separate terms
beat it by the acceptance gate, each active day held out alone (``selection.HOLIDAY_MERGE_RULE``). The merged model
is saved, evaluated, exported as an FMU and run under MPC like any other. On main: two holiday findings.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

WEEK3 = [f"2025-09-{d}" for d in range(22, 27)]
WEEK4 = ["2025-09-29", "2025-09-30"] + [f"2025-10-0{d}" for d in range(1, 4)]


@pytest.fixture(scope="module")
def case27():
    """The emulator's quad4 case (16 weeks, seed 47, cached in $HVACFMU_CACHE) and its diagnosis (about 8 CPU-s)."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(
        weeks=16, seed=47, effects=["internal_gain_schedule:kind=holiday,weeks=3+4,factor=0.10"], layout="quad4"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the emulated building works on public holidays: no calendar applied
        ds = prepare(paths.measurements, paths.building, step=900.0)
    return ds, paths, diagnose(ds, progress=False)


def _holidays(findings):
    return [f for f in findings if f["cause"] == "internal_gain_schedule" and f["location"].get("variant") == "holiday"]


@pytest.mark.slow
def test_two_holiday_weeks_are_one_finding_with_all_dates_and_the_gain_of_each_week(case27):
    from hvacfmu.diagnosis.truth import compare_with_truth

    ds, paths, rep = case27
    (hol,) = _holidays(rep.findings)  # main: two findings, one per week
    assert hol["location"]["dates"] == WEEK3 + WEEK4, rep.summary()
    rec = hol["evidence"]["holiday_merge"]
    assert rec["merged"] is True
    # the separate terms add nothing the gate accepts over the merged one on the active days
    assert not (rec["apart_over_merged"]["t"] >= 2.0 and rec["apart_over_merged"]["gain_percent"] >= 1.0)
    assert [p["dates"] for p in rec["parts"]] == [WEEK3, WEEK4]
    for p in rec["parts"]:  # each week's gain when it was found and the merged term's gain on its days
        assert p["cv_when_found"]["gain_percent"] > 20.0 and p["cv_when_found"]["t"] >= 2.0
        assert p["merged_over_none_on_its_days"]["gain_percent"] > 20.0
    cv = hol["cv"]
    assert cv["folds"] == "one per active day" and cv["gain_percent"] > 20.0 and cv["t"] >= 2.0
    assert "one holiday on 10 weekdays" in hol["reason"]
    assert "one holiday on 10 weekdays, found as 2 terms: merged" in rep.format()
    # one holiday term in the saved model, with every date
    (term,) = [t for t in rep.model.terms if t.cause == "internal_gain_schedule" and t.variant == "holiday"]
    assert list(term.dates) == WEEK3 + WEEK4 and max(term.coef) > 0.2
    assert rep.model.meta["diagnosis"]["causes"].count("internal_gain_schedule") == 1
    cmp = compare_with_truth(rep, json.loads(paths.truth.read_text()))
    assert cmp["unsupported"] == [] and cmp["missed"] == [], cmp


@pytest.mark.slow
def test_the_merged_holiday_model_loads_evaluates_exports_and_runs_under_mpc(case27, tmp_path):
    import fmpy
    from fmpy.validation import validate_fmu

    from harness.mpc import MPCController, MPCSettings, closed_loop
    from harness.mpc.predict import make_predictor
    from hvacfmu.evaluation import evaluate
    from hvacfmu.fmu import export_fmu
    from hvacfmu.models import load_model
    from hvacfmu.timeutil import seconds_of_week

    ds, _, rep = case27
    model = load_model(rep.model.save(tmp_path / "extended.json"))
    res = evaluate([model], ds, names=["extended"])
    assert np.isfinite(res.table("extended").loc["all", "mean"])
    # a holiday day of the data: the model reads Sunday's gains there, the FMU must too
    f = ds.frame.loc["2025-09-30"].interpolate(method="time", limit_direction="both").iloc[:96]
    season = next(w.season for w in ds.weeks if w.start <= f.index[0] < w.end)
    u, v = model.signals(f)
    q = model.gains_at(f.index, season)
    q_plain = np.asarray(model.base.gains[season])[((seconds_of_week(f.index) // 900) % len(model.base.gains[season]))]
    assert np.abs(q - q_plain).max() > 1e-3  # the holiday changes the day's gains
    x0 = model.initial_state(f, 0)
    _, Y = model.simulate(x0, u, v, q)
    fmu = export_fmu(tmp_path / "extended.json", tmp_path / "extended.fmu", timezone=ds.building.timezone)
    assert validate_fmu(str(fmu)) == []
    names = [f"m_{b}" for b in model.base.vavs] + list(model.disturbances)
    t = np.arange(len(f)) * 900.0
    sig = np.zeros(len(f), dtype=[("time", float)] + [(n, float) for n in names])
    sig["time"] = t
    for n in names:
        sig[n] = f[n].to_numpy(float)
    sv = {f"T_{z}_start": float(y) for z, y in zip(model.outputs, model.measured_outputs(f.iloc[:1])[0])}
    sv["season"] = list(model.gains).index(season) + 1
    sv["start_time_of_week"] = float(seconds_of_week(f.index[:1])[0])
    sv["start_time"] = float(f.index[0].timestamp())
    out = fmpy.simulate_fmu(
        str(fmu),
        start_time=0.0,
        stop_time=t[-1],
        output_interval=900.0,
        input=sig,
        start_values=sv,
        output=[f"T_{z}" for z in model.outputs],
    )
    Y_fmu = np.column_stack([out[f"T_{z}"] for z in model.outputs])
    assert_allclose(Y_fmu[1:], Y[1 : len(Y_fmu)], rtol=0, atol=1e-6)  # [K]
    # MPC: the predictor equals the model's own step on the holiday's gains, and a short closed loop runs
    pred = make_predictor(model)
    N = 8
    X = np.empty((N + 1, model.n_states))
    X[0] = x0
    for k in range(N):
        X[k + 1] = model.step_state(X[k], u[k], v[k], q[k])
    assert_allclose(pred.simulate(x0, u[:N], v[:N], q[:N]), X, rtol=0, atol=1e-9)  # [K]
    nu = len(model.inputs)
    ctrl = MPCController(model, np.full(nu, 0.05), np.full(nu, 0.8), MPCSettings(horizon=6, T_min=20.0, T_max=23.0))
    loop = closed_loop(ctrl, model, x0, v[:16], q[:16], 10)
    assert loop.summary()["failures"] == 0


def test_mpc_predicts_a_model_with_a_holiday_beside_an_on_off_reheat():
    """A holiday term refuses time-invariant equations and the probe cannot read the reheat's switch: the equations of
    the model without its calendar terms, fed the calendar's gains, are its step (main: refused)."""
    from harness.mpc.predict import make_predictor
    from hvacfmu.models.equations import check_equations
    from hvacfmu.models.extended import ExtendedModel, InternalGainSchedule, Reheat
    from hvacfmu.models.linear import LinearZoneModel

    base = LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=("A", "B", "C"),
        measured_zones=("A", "B", "C"),
        output_weights=np.eye(3),
        vavs=("V1", "V2", "V3"),
        input_map=np.eye(3),
        disturbances=("T_out", "T_supply"),
        A=np.array([[0.9, 0.02, 0.0], [0.03, 0.88, 0.02], [0.0, 0.02, 0.91]]),
        B=np.diag([-0.2, -0.3, -0.25]),
        C=np.array([[0.02, 0.03], [0.02, 0.03], [0.02, 0.03]]),
        gains={"fall": np.full((672, 3), 0.1)},
    )
    hol = InternalGainSchedule(variant="holiday", zone_names=("A", "B", "C"), coef=(0.5,) * 3, dates=("2025-10-29",))
    model = ExtendedModel(base=base, terms=(Reheat(zone="A", coef=0.06, u_min=0.0526, T_threshold=12.0), hol))
    pred = make_predictor(model)
    rng = np.random.default_rng(5)
    N = 12
    U = rng.uniform(0.03, 0.4, (N, 3))  # below and above the reheat's minimum airflow
    V = np.column_stack([rng.uniform(0.0, 20.0, N), rng.uniform(12.0, 16.0, N)])
    Q = 0.2 * rng.random((N, 3))
    x0 = np.full(pred.nx, 21.0)
    X = np.empty((N + 1, pred.nx))
    X[0] = x0
    for k in range(N):
        X[k + 1] = model.step_state(X[k], U[k], V[k], Q[k])
    assert_allclose(pred.simulate(x0, U, V, Q), X, rtol=0, atol=1e-10)  # [K]
    assert check_equations(model, ExtendedModel(base=base, terms=model.terms[:1]).equations()) <= 1e-9


@pytest.mark.slow
def test_holiday_terms_kept_apart_are_reported_as_one_holiday(case27, monkeypatch):
    """The path where the separate terms beat the merged one (forced here: no battery case took it): both terms stay
    in the model, each finding carries the whole holiday (all dates, every part's gains) and the report says so."""
    from hvacfmu.diagnosis import diagnose, selection

    merge = selection._merge_holidays

    def apart(*args, **kwargs):
        out = merge(*args, **kwargs)
        if out is not None:
            out.update(merged=False, why="forced apart")
        return out

    monkeypatch.setattr(selection, "_merge_holidays", apart)
    rep = diagnose(case27[0], progress=False)
    hits = _holidays(rep.findings)
    assert [f["location"]["dates"] for f in hits] == [WEEK3, WEEK4]
    for f in hits:
        rec = f["evidence"]["holiday_merge"]
        assert rec["merged"] is False and rec["dates"] == WEEK3 + WEEK4
        assert [p["dates"] for p in rec["parts"]] == [WEEK3, WEEK4]
    assert sum(t.cause == "internal_gain_schedule" for t in rep.model.terms) == 2
    assert rep.format().count("one holiday on 10 weekdays, found as 2 terms: kept as 2 terms (one holiday)") == 2
