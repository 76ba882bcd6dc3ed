"""Session 20: a zone sensor re-calibrated mid-file (``sensor_offset``): emulator effect, model term, diagnosis.

The emulator's ``sensor_offset`` adds ``delta`` to one zone's measured column from a date on (plant and
controllers unchanged); the cause ``sensor_offset`` carries it as a dated step in the zone's equation (a
calendar term, through ``gains_at``: evaluate, pythonfmu FMU, MPC), and the diagnosis names it at the right zone
and date. Main has neither the effect nor the cause: every test here fails there.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from test_fmu import EXACT, Slave, reference, run_fmu, zones_model

from hvacfmu.errors import FMUError, HvacfmuWarning, ModelError

OFFSET = "sensor_offset:delta=2.5"


@pytest.fixture(scope="module")
def fmu_data(short_paths):
    from hvacfmu.data import prepare

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(short_paths.measurements, short_paths.building)


def _frame(paths):
    f = pd.read_parquet(paths.measurements)
    f["time"] = pd.to_datetime(f["time"], utc=True)
    return f.set_index("time")


def test_emulator_offsets_only_the_measured_column():
    """The zone's column reads +delta from the change on; every other column (airflows: the controllers act on
    the true room) is identical to the same seed without the effect."""
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.emulator.effects import sensor_offset_time

    clean = cached_dataset(weeks=3, seed=5, layout="quad4")
    off = cached_dataset(weeks=3, seed=5, layout="quad4", effects=[OFFSET])
    truth = json.loads(off.truth.read_text())
    (e,) = truth["effects"]
    assert e["name"] == "sensor_offset" and e["delta"] == 2.5 and 5 <= e["day"] < 16  # the middle half
    at = sensor_offset_time(truth["start"], truth["timezone"], e)
    a, b = _frame(clean), _frame(off)
    col = f"T_{e['zone']}"
    d = (b[col] - a[col]).to_numpy()
    on = np.asarray(a.index >= at)
    assert np.allclose(d[~on], 0.0) and np.allclose(d[on], 2.5, atol=0.051)  # quantised at 0.05 K
    rest = [c for c in a.columns if c != col]
    pd.testing.assert_frame_equal(a[rest], b[rest])


def test_effect_is_requested_only_and_checked():
    from hvacfmu.emulator.effects import EFFECT_NAMES, EmulatorError, resolve_effects
    from hvacfmu.emulator.generate import make_truth

    assert "sensor_offset" not in EFFECT_NAMES  # fleets and the battery's draws are unchanged
    bld = make_truth(weeks=4, seed=1, layout="quad4")["baseline"]["building"]
    with pytest.raises(EmulatorError, match="delta must be a non-zero offset"):
        resolve_effects(["sensor_offset:delta=0"], 1, bld, 4)
    with pytest.raises(EmulatorError, match="day must be a whole day number"):
        resolve_effects(["sensor_offset:day=40"], 1, bld, 4)
    (r,) = resolve_effects(["sensor_offset:zone=NE,day=9,delta=-1.5"], 1, bld, 4)
    assert (r["zone"], r["day"], r["delta"], r["hour"]) == ("NE", 9.0, -1.5, 10.0)


def _offset_model(building, start, coef=0.3):
    from hvacfmu.models.causes import SensorOffset
    from hvacfmu.models.extended import ExtendedModel

    base = zones_model(building, seed=4)
    term = SensorOffset(zone=building.zone_names[1], start=start, coef=coef, zone_names=tuple(base.outputs))
    return ExtendedModel(base=base, terms=(term,)), base


def test_term_reloads_applies_its_step_and_runs_as_a_calendar_fmu(fmu_data, tmp_path):
    """The saved model reloads; gains_at adds coef in the zone from the start on (and nothing else); the model is
    calendar-dependent (the native FMU refuses it, the pythonfmu FMU with start_time equals the Python model)."""
    from hvacfmu.fmu import export_fmu, export_native_fmu
    from hvacfmu.fmu_slave import calendar_dependent
    from hvacfmu.models import load_model

    building = fmu_data.building
    tz = building.timezone
    idx = pd.date_range("2025-10-27", periods=288, freq="15min", tz=tz)
    start = idx[150].isoformat()
    model, base = _offset_model(building, start)
    again = load_model(model.save(tmp_path / "offset.json"))
    assert again.terms == model.terms
    dq = again.gains_at(idx, "fall") - base.gains_at(idx, "fall")
    zi = 1
    assert_allclose(dq[:150], 0.0, atol=0)
    assert_allclose(dq[150:, zi], 0.3, atol=1e-12)
    assert_allclose(np.delete(dq, zi, axis=1), 0.0, atol=0)
    assert calendar_dependent(model) and not calendar_dependent(base)
    with pytest.raises(ModelError, match="depends on the date"):
        model.equations()
    with pytest.raises(FMUError, match="depend on the calendar"):
        export_native_fmu(model, tmp_path / "native.fmu", building=building)
    path = export_fmu(tmp_path / "offset.json", tmp_path / "offset.fmu", timezone=tz)
    rng = np.random.default_rng(7)
    m = rng.uniform(0.05, 0.6, (288, len(building.vav_names)))
    v = np.column_stack([rng.uniform(5, 25, 288), rng.uniform(12, 15, 288), rng.uniform(0, 300, (288, 4))])
    y0 = np.full(len(model.outputs), 21.0)
    Yref = reference(model, idx, m, v, y0, "fall")
    assert np.abs(Yref - reference(base, idx, m, v, y0, "fall"))[150:].max() > 0.3  # the step matters
    names_in = [f"m_{b}" for b in building.vav_names] + list(model.disturbances)
    s = Slave(path, "offset")
    try:
        s.init(
            {
                "season": list(model.gains).index("fall") + 1,
                "start_time_of_week": 0.0,
                "start_time": idx[0].timestamp(),
            },
            inputs=(names_in, np.hstack([m, v])[0]),
        )
        Y = run_fmu(s, names_in, np.hstack([m, v]), [f"T_{z}" for z in model.outputs])
    finally:
        s.close()
    assert_allclose(Y, Yref, rtol=0, atol=EXACT)


def test_mpc_probes_the_offset_model_and_predicts_with_its_step(fmu_data):
    """No time-invariant equations: the MPC probes the step (the base's) and reads the offset through the gains
    preview (``gains_at`` on the run's dates), which reproduces the model's own simulation across the change."""
    from harness.mpc.predict import make_predictor, model_equations
    from hvacfmu.models.equations import check_equations

    building = fmu_data.building
    idx = pd.date_range("2025-10-27", periods=96, freq="15min", tz=building.timezone)
    model, base = _offset_model(building, idx[40].isoformat())
    eq = model_equations(model)
    assert check_equations(model, eq, atol=1e-12) <= 1e-12
    rng = np.random.default_rng(3)
    m = rng.uniform(0.05, 0.6, (96, len(building.vav_names)))
    v = np.column_stack([rng.uniform(5, 25, 96), rng.uniform(12, 15, 96), rng.uniform(0, 300, (96, 4))])
    u, _ = model.signals(
        pd.DataFrame(
            {**{f"m_{b}": m[:, j] for j, b in enumerate(building.vav_names)}, **dict(zip(model.disturbances, v.T))},
            index=idx,
        )
    )
    Q = model.gains_at(idx, "fall")
    x0 = np.full(model.n_states, 21.0)
    _, Y = model.simulate(x0, u, v, Q)
    pred = make_predictor(model)
    assert_allclose(pred.simulate(x0, u, v, Q)[:, : len(model.outputs)], Y, rtol=0, atol=1e-9)
    _, Y0 = base.simulate(x0, u, v, base.gains_at(idx, "fall"))
    assert np.abs(Y - Y0)[:41].max() == 0.0 and np.abs(Y - Y0)[41:, 1].min() > 0.2  # the step, from its row on


def test_term_refuses_a_start_without_its_utc_offset():
    from hvacfmu.models.causes import term_from_dict

    with pytest.raises(ModelError, match="ISO time with its UTC offset"):
        term_from_dict({"cause": "sensor_offset", "zone": "A", "start": "2025-10-01T10:00", "coef": 0.1}, ("A", "B"))


def test_truth_match_needs_the_zone_and_the_day():
    from hvacfmu.diagnosis.truth import effect_matches

    truth = {"start": "2025-09-01T00:00:00", "timezone": "America/Los_Angeles"}
    e = {"name": "sensor_offset", "zone": "NE", "day": 46.0, "hour": 10.0, "delta": 2.5}

    def f(zone, start):
        return {"cause": "sensor_offset", "location": {"zone": zone, "start": start}}

    assert effect_matches(f("NE", "2025-10-17T10:00:00-07:00"), e, truth)
    assert effect_matches(f("NE", "2025-10-18T09:00:00-07:00"), e, truth)
    assert not effect_matches(f("NE", "2025-10-18T11:00:00-07:00"), e, truth)
    assert not effect_matches(f("NW", "2025-10-17T10:00:00-07:00"), e, truth)
    # bracketed between training days (a change inside a held-out week): the truth must lie inside the bracket
    inside = f("NE", "2025-10-20T00:00:00-07:00")
    inside["location"]["after"] = "2025-10-12T23:45:00-07:00"
    assert effect_matches(inside, e, truth)
    inside["location"]["after"] = "2025-10-19T23:45:00-07:00"
    assert not effect_matches(inside, e, truth)


def _diagnose(effects, weeks=16):
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.diagnosis.truth import compare_with_truth
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(weeks=weeks, seed=5, layout="quad4", effects=effects)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        ds = prepare(paths.measurements, paths.building, step=900.0)
    rep = diagnose(ds, progress=False)
    return rep, compare_with_truth(rep, json.loads(paths.truth.read_text())), ds


@pytest.mark.slow
def test_diagnosis_names_an_injected_offset_at_its_zone_and_day():
    """quad4, 16 weeks at 15 min, NE reads +2.5 K from 2025-10-17 10:00 on: named there (within a day), with the
    size and what to check; the extended model carries it; no false finding."""
    from hvacfmu.diagnosis.control import terms_on_base

    rep, cmp, ds = _diagnose([OFFSET])
    assert [e["name"] for e in cmp["found"]] == ["sensor_offset"], rep.summary()
    assert cmp["unsupported"] == []
    (f,) = [f for f in rep.findings if f["cause"] == "sensor_offset"]
    assert f["location"]["zone"] == "NE"
    assert abs(f["evidence"]["offset_K"] - 2.5) < 0.4
    assert f["cv"]["t"] >= 2.0
    text = str(rep)
    assert "zone NE reads +2." in text and "check the sensor's history" in text and "setpoint" in text
    assert "sensor_offset" in rep.model.causes
    # the control model (diagnose --control-output) refits it on Model A: the step stays, in NE only
    ctl = terms_on_base(ds, rep.base_model, [t for t in rep.model.terms if t.cause == "sensor_offset"], heat="airflow")
    (t,) = ctl.terms
    idx = pd.date_range("2025-10-16", periods=192, freq="15min", tz=ds.building.timezone)
    dq = ctl.gains_at(idx, "fall") - ctl.base.gains_at(idx, "fall")
    after = np.asarray(idx >= pd.Timestamp(t.start))
    assert t.coef > 0.05 and np.allclose(dq[after, 1], t.coef, rtol=0, atol=1e-12) and not dq[~after].any()


@pytest.mark.slow
def test_diagnosis_names_no_offset_on_the_same_building_without_one():
    rep, cmp, _ = _diagnose([])
    assert not [f for f in rep.findings if f["cause"] == "sensor_offset"], rep.summary()
    cands = [c for c in rep.to_dict()["candidates"] if c["cause"] == "sensor_offset"]
    assert cands and all(c["status"] == "no evidence" for c in cands)


@pytest.mark.slow
def test_a_change_inside_a_held_out_week_is_bracketed_not_placed():
    """The same +2.5 K on day 65 (2025-11-05, inside the held-out week 11-03 .. 11-09): the training rows show no
    jump, so the finding brackets the change by the training rows around that week and says so."""
    rep, cmp, _ = _diagnose(["sensor_offset:delta=2.5,day=65"])
    assert [e["name"] for e in cmp["found"]] == ["sensor_offset"], rep.summary()
    assert cmp["unsupported"] == []
    (f,) = [f for f in rep.findings if f["cause"] == "sensor_offset"]
    assert f["location"]["after"][:10] == "2025-11-02" and f["location"]["start"][:10] == "2025-11-10"
    assert "between 2025-11-02" in str(rep)
