"""An edited model file: its numbers are sealed when written, and box coefficients no supply air can deliver are
refused wherever the model meets its building (export, evaluate, cosim, fit).

Session 19's red-team probe: a model file whose airflow gain was edited to ``B = -50`` K per step per kg/s loaded,
evaluated and exported with exit 0 (the load checks bound stability, signs and a generous steady-state response,
and a nearly integrating EnergyPlus zone legitimately reaches 568 K there).
"""

from __future__ import annotations

import copy
import json
import warnings

import numpy as np
import pytest
from test_properties import BUILDING

from hvacfmu.building import building_from_dict
from hvacfmu.errors import FMUError, HvacfmuWarning, ModelError
from hvacfmu.models import load_model
from hvacfmu.models.loadcheck import MAX_GAP_SHARE, MAX_STEP_DRIVE_K, box_drive, box_drive_problems


def _model(B=-0.1, beta=None, meta=None):
    from hvacfmu.models.linear import LinearZoneModel

    extra = {}
    if beta is not None:
        extra = {"beta": np.full(2, beta), "inlets": ("T_supply", "T_supply"), "heat_map": np.eye(2)}
    return LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=("A", "B"),
        measured_zones=("A", "B"),
        output_weights=np.eye(2),
        vavs=("V1", "V2"),
        input_map=np.eye(2),
        disturbances=("T_out", "T_supply"),
        A=0.9 * np.eye(2),
        B=B * np.eye(2) if beta is None else np.zeros((2, 2)),
        C=[[0.02, 0.0], [0.02, 0.0]],
        gains={"fall": np.full((672, 2), 0.4)},
        meta=meta if meta is not None else {"note": "test"},
        **extra,
    )


def _building():
    d = copy.deepcopy(BUILDING)
    return building_from_dict(d)


def _limits(b):
    return {v.name: v.m_max for v in b.vavs}


def test_box_drive_reads_the_airflow_gain_at_m_max_and_refuses_past_the_supply_air():
    b = _building()
    m = _limits(b)
    drive = box_drive(_model(B=-0.5), b)
    assert drive["A"] == ("K", pytest.approx(0.5 * m["V1"]), 0.0)
    assert box_drive_problems(_model(B=-0.5), b) == []
    big = -1.01 * MAX_STEP_DRIVE_K / min(m["V1"], m["V2"])  # just past the bound in both zones
    problems = box_drive_problems(_model(B=big), b)
    assert len(problems) == 2 and "state A: its boxes at m_max" in problems[0]
    assert f"above {MAX_STEP_DRIVE_K:g} K" in problems[0] and "other units than kg/s" in problems[0]


def test_delivered_heat_closing_more_than_the_gap_in_one_step_is_refused():
    b = _building()
    m_max = min(_limits(b).values())
    beta_ok = 0.5 * MAX_GAP_SHARE / (1.005 * m_max)  # half the gap at m_max [K/step per kW]
    (what, share, _), *_ = box_drive(_model(beta=beta_ok), b).values()
    assert what == "share" and share <= 0.5 * MAX_GAP_SHARE * max(_limits(b).values()) / m_max + 1e-12
    assert box_drive_problems(_model(beta=beta_ok), b) == []
    problems = box_drive_problems(_model(beta=10 * beta_ok * max(_limits(b).values()) / m_max), b)
    assert problems and "of the gap to their inlet air in one step" in problems[0]


def test_a_saved_model_loads_without_a_warning_and_an_edited_one_is_named(tmp_path):
    path = _model().save(tmp_path / "m.json")
    d = json.loads(path.read_text())
    assert len(d["meta"]["coefficients_sha256"]) == 64
    with warnings.catch_warnings():
        warnings.simplefilter("error", HvacfmuWarning)
        load_model(path)  # unchanged: no warning
    d["B"][0][0] = -0.2
    path.write_text(json.dumps(d, indent=2))  # another layout of the same JSON is not an edit; the number is
    with pytest.warns(HvacfmuWarning, match=r"m.json: the model's coefficients were changed after hvacfmu wrote"):
        load_model(path)
    d.pop("meta")  # a file another tool wrote (no seal): nothing to compare, no warning
    path.write_text(json.dumps(d))
    with warnings.catch_warnings():
        warnings.simplefilter("error", HvacfmuWarning)
        load_model(path)


def test_export_refuses_an_edited_airflow_gain_with_the_building(tmp_path):
    from hvacfmu.fmu import export_fmu

    b = _building()
    path = _model(B=-60.0).save(tmp_path / "edited.json")  # loads: stable, right sign, 600 K steady state
    assert load_model(path) is not None
    with pytest.raises(FMUError, match=r"state A: its boxes at m_max \('two rooms'\) move it by 36 K"):
        export_fmu(path, tmp_path / "edited.fmu", building=b)
    assert not (tmp_path / "edited.fmu").exists()


def test_fit_refuses_a_model_whose_boxes_would_overshoot_the_supply_air(short_paths):
    """The bound holds at fit time too (``check_fitted`` with the fit's dataset), so that every model a fit accepts
    exports again: the fitted lumped model passes; its coefficients scaled as by airflows in L/s read as kg/s
    (x 1000 in the drive) are refused, naming the state."""
    import dataclasses

    from hvacfmu.data import prepare
    from hvacfmu.errors import FitError
    from hvacfmu.fitting import fit
    from hvacfmu.models.plausibility import check_fitted

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        ds = prepare(short_paths.measurements, short_paths.building)
        model = fit(ds, "lumped")
    assert box_drive_problems(model, ds.building) == []
    ((what, value, _),) = box_drive(model, ds.building).values()
    assert 0 < value < (MAX_STEP_DRIVE_K / 10 if what == "K" else MAX_GAP_SHARE / 3)  # far inside the bounds
    scaled = (
        dataclasses.replace(model, B=model.B * 1000)
        if what == "K"
        else dataclasses.replace(model, beta=model.beta * 1000)
    )
    with pytest.raises(FitError, match="state floor: its boxes at m_max"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HvacfmuWarning)
            check_fitted(scaled, ds)


def test_evaluate_and_cosim_refuse_a_model_past_the_supply_air(short_paths, tmp_path, cli):
    """Evaluate (library) and ``hvacfmu cosim`` (CLI: exit 2, no traceback) stop on the same reasons as export."""
    import dataclasses

    from hvacfmu.data import prepare
    from hvacfmu.evaluation import evaluate
    from hvacfmu.fitting import fit

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        ds = prepare(short_paths.measurements, short_paths.building)
        model = fit(ds, "lumped")
    key = "B" if model.beta is None else "beta"
    edited = dataclasses.replace(model, **{key: getattr(model, key) * 1000})
    with pytest.raises(ModelError, match=r"(?s)model 'lumped' cannot be a model of building .*state floor: its boxes"):
        evaluate(edited, ds, names=["lumped"])
    path = edited.save(tmp_path / "edited.json")
    fmu = tmp_path / "plant.fmu"  # the model is checked against the building before the plant is opened
    r = cli("cosim", "--fmu", fmu, "--data", short_paths.measurements, "-b", short_paths.building, "--model", path)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr[-2000:]
    assert "cannot be a model of building" in r.stderr and "state floor: its boxes at m_max" in r.stderr
