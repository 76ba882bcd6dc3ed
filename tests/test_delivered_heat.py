"""Model A in the delivered-heat form: boxes act through m c_p (T_d - T_zone) (issue 13), plausibility (issue 17).

Data are simulated by a known delivered-heat six-zone model (discharge air
modulated 0..16 K above the supply by reheat, random airflows, excitation on
Saturdays) and read back through :func:`hvacfmu.data.prepare`.
"""

from __future__ import annotations

import dataclasses
import json
import re
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

from hvacfmu.errors import FitError, HvacfmuWarning, ModelError
from hvacfmu.models import load_model
from hvacfmu.models.datadriven import fit_lumped, fit_zones
from hvacfmu.models.equations import check_equations
from hvacfmu.models.heat import (
    CP_AIR,
    air_handler_off_share,
    delivered_heat,
    inlet_columns,
)
from hvacfmu.models.linear import LinearZoneModel
from hvacfmu.models.plausibility import check_fitted, linear_problems
from tests.test_datadriven import (
    EDGE,
    STEP,
    simulate_frame,
    six_zone_building_dict,
    true_zone_model,
    write_dataset,
)


def delivered_truth(building):
    """The six-zone truth of test_datadriven with the boxes acting through delivered heat instead of airflow."""
    base = true_zone_model(building)
    vols = np.array([building.zone(z).volume for z in building.zone_names])
    beta = 0.05 * vols.mean() / vols  # [K per step per kW]: a smaller zone warms faster
    inlets = tuple(f"Td_{v}" for v in building.vav_names)
    keep = [0] + list(range(2, len(base.disturbances)))  # drop T_supply: it enters only through the heat
    dist = tuple(base.disturbances[i] for i in keep) + inlets
    C = np.concatenate([base.C[:, keep], np.zeros((base.n_states, len(inlets)))], axis=1)
    return LinearZoneModel(
        kind="zones",
        step=STEP,
        outputs=base.outputs,
        measured_zones=base.outputs,
        output_weights=np.eye(6),
        vavs=building.vav_names,
        input_map=np.eye(len(building.vavs)),
        disturbances=dist,
        A=base.A,
        B=np.zeros((6, len(building.vavs))),
        C=C,
        gains=base.gains,
        beta=beta,
        inlets=inlets,
        heat_map=building.zone_vav_matrix(),
    )


@pytest.fixture(scope="module")
def building():
    from hvacfmu.building import building_from_dict

    return building_from_dict(six_zone_building_dict())


@pytest.fixture(scope="module")
def truth(building):
    return delivered_truth(building)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, building, truth):
    frame = simulate_frame(truth, building, seed=3)
    return write_dataset(tmp_path_factory.mktemp("delivered"), frame, six_zone_building_dict())


@pytest.fixture(scope="module")
def fit(dataset):
    with warnings.catch_warnings():
        warnings.simplefilter("error", HvacfmuWarning)
        warnings.filterwarnings("ignore", message=EDGE, category=HvacfmuWarning)
        return fit_zones(dataset, open_loop=False)  # the paper's one-step estimate (the refinement: 20 s more)


# ----------------------------------------------------------------------------- pure functions
def test_delivered_heat_and_inlets(building):
    import pandas as pd

    assert_allclose(delivered_heat([0.5, 0.0], [30.0, 99.0], [20.0, 20.0]), [0.5 * CP_AIR * 10 / 1000, 0.0])
    idx = pd.date_range("2025-01-06", periods=8, freq="15min", tz="UTC")
    vavs = building.vav_names
    frame = pd.DataFrame({f"m_{v}": np.full(8, 0.2) for v in vavs}, index=idx)
    frame["T_supply"] = 14.0
    frame[f"Td_{vavs[0]}"] = 30.0
    frame[f"Td_{vavs[1]}"] = [30.0] + [np.nan] * 7  # 12 % coverage: falls back, with a note naming it
    inlets, notes = inlet_columns(building, frame)
    assert inlets[0] == f"Td_{vavs[0]}" and inlets[1] == "T_supply" and set(inlets[2:]) == {"T_supply"}
    assert len(notes) == 1 and f"Td_{vavs[1]}" in notes[0] and "12.5 %" in notes[0]
    m = np.full((4, len(vavs)), 0.3)
    m[:2] = 0.0
    assert air_handler_off_share(building, m) == 0.5


# ----------------------------------------------------------------------------- model form
def test_equations_and_round_trip(truth, tmp_path):
    eq = truth.equations()
    assert eq.bilinear and len(eq.Bxu) == len(truth.vavs)
    assert check_equations(truth, eq, atol=1e-12) <= 1e-12
    path = truth.save(tmp_path / "m.json")
    back = load_model(path)
    assert back.heat == "delivered" and back.inlets == truth.inlets
    x, u, v, q = np.full(6, 21.0), np.full(12, 0.3), np.full(len(truth.disturbances), 25.0), np.zeros(6)
    assert_allclose(back.step_state(x, u, v, q), truth.step_state(x, u, v, q), rtol=0, atol=1e-12)
    # zero airflow: no heat, whatever the (idle) inlet temperature says
    v_idle = v.copy()
    v_idle[[truth.disturbances.index(c) for c in truth.inlets]] = 80.0
    assert_allclose(truth.step_state(x, np.zeros(12), v_idle, q), truth.step_state(x, np.zeros(12), v, q), atol=0)


def test_lumped_delivered_equations(dataset):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        m = fit_lumped(dataset)
    assert m.heat == "delivered" and m.beta[0] > 0
    # the delivered form is refined for 24-h prediction although the data hold excitation experiments
    ol = m.meta["open_loop"]
    assert ol["used"] and ol["why"].startswith("delivered heat: the boxes' reheat loops drive the zones"), ol
    assert ol["rms_after"] <= ol["rms_before"], ol
    assert check_equations(m, m.equations(), atol=1e-12) <= 1e-12


# ----------------------------------------------------------------------------- identification
def test_delivered_recovery(fit, truth):
    """beta within 10 %, A as in the airflow-form test (diag 0.06, off-diagonal 0.05), C[T_out] within 0.03.

    beta is well excited (reheat modulated independently of airflow); A carries the
    errors-in-variables attenuation of the airflow-form test.
    """
    assert fit.heat == "delivered" and fit.meta["heat"]["form"] == "delivered"
    assert "discharge air temperatures measured" in fit.meta["heat"]["reason"]
    assert fit.inputs == tuple(f"m_{v}" for v in fit.vavs)
    assert_allclose(fit.beta, truth.beta, rtol=0.10, atol=0)
    E = fit.A - truth.A
    assert np.max(np.abs(np.diag(E))) < 0.06
    assert np.max(np.abs(E - np.diag(np.diag(E)))) < 0.05
    assert_allclose(fit.C[:, 0], truth.C[:, 0], rtol=0, atol=0.03)
    assert "T_supply" not in fit.disturbances  # no linear supply term
    assert fit.meta["plausibility"]["identifiable"] is True


def test_delivered_beats_airflow_form(fit, dataset):
    """On data whose boxes heat by reheat, the airflow form cannot follow; the delivered form can (RMS, 24 h)."""
    from hvacfmu.evaluation import evaluate

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        airflow = fit_zones(dataset, heat="airflow")
    res = evaluate([fit, airflow], dataset, names=["delivered", "airflow"])
    d, a = res.table("delivered").loc["all", "mean"], res.table("airflow").loc["all", "mean"]
    # measured here: delivered 0.10 K, airflow 2.7 K; the bound of the airflow-form test (0.25 K) applies
    assert d < 0.25 and d < 0.2 * a, (d, a)


# ----------------------------------------------------------------------------- plausibility
def test_unstable_model_is_refused(truth):
    bad = dataclasses.replace(truth, A=truth.A * 1.2)
    problems, numbers = linear_problems(bad)
    assert numbers["spectral_radius"] > 1 and "unstable" in problems[0]
    with pytest.raises(FitError, match="(?s)implausible and was refused.*unstable: spectral radius"):
        check_fitted(bad)


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda m: {"A": m.A - 0.04 * (m.A > 0) * (m.A < 0.05)}, r"coupling A\[NW, W\] = -0.02 < 0"),
        (lambda m: {"C": -m.C}, "warmer weather or more sun would cool"),
        (lambda m: {"beta": -m.beta}, "delivered heat cools the zone"),
        (lambda m: {"A": np.diag(np.full(6, 0.99995))}, "slowest time constant .* integrator"),
    ],
)
def test_implausible_signs_and_time_constants(truth, change, message):
    problems, _ = linear_problems(dataclasses.replace(truth, **change(truth)))
    assert any(re.search(message, p) for p in problems), problems


def test_a_bounded_solvers_rounding_of_zero_is_no_sign_error(truth):
    """The diagnosis's joint refit of the EnergyPlus apartments gave C = -1.99e-19: zero, not a cooling sun."""
    C = truth.C.copy()
    C[0, 0] = -1.99e-19
    A = truth.A.copy()
    A[0, 1] = -3e-18
    assert linear_problems(dataclasses.replace(truth, C=C, A=A))[0] == []
    C[0, 0] = -1e-9
    assert any("would cool the zone" in p for p in linear_problems(dataclasses.replace(truth, C=C))[0])


def test_closed_loop_airflow_not_identifiable_is_flagged(building, tmp_path):
    """Data whose airflow has no effect (truth beta ~ 0, fast decay): the fit warns that the model learned a loop."""
    t = delivered_truth(building)
    loop = dataclasses.replace(t, beta=np.full(6, 1e-6), A=np.diag(np.full(6, 0.5)))
    frame = simulate_frame(loop, building, seed=4, weeks=6)
    ds = write_dataset(tmp_path, frame, six_zone_building_dict())
    with pytest.warns(HvacfmuWarning, match="not identifiable from these data.*thermostat loop"):
        m = fit_zones(ds, mu_b=1e-6, open_loop=False)
    assert m.meta["plausibility"]["identifiable"] is False
    assert any("thermostat loop" in w for w in m.meta["warnings"])


@pytest.mark.parametrize("heat", ["auto", "airflow"])
def test_not_identifiable_message_says_what_the_data_hold(building, tmp_path, heat):
    """The identifiability warning must not ask for what the data already have: these data hold excitation
    experiments (Saturdays) and every box's Td_, so neither 'without excitation' nor 'add discharge air
    temperatures' is true; a fit in the airflow form (as diagnose's base) is told that it ignores the Td_ columns
    (seven-winter-week BMS exports, benchmarks/short_winter_s8.md)."""
    t = delivered_truth(building)
    loop = dataclasses.replace(t, beta=np.full(6, 1e-6), A=np.diag(np.full(6, 0.5)))
    frame = simulate_frame(loop, building, seed=4, weeks=6)
    ds = write_dataset(tmp_path, frame, six_zone_building_dict())
    exc = ds.frame["excitation"].to_numpy(float) == 1.0
    train = np.zeros(len(ds.frame), bool)
    for w in ds.train_weeks():
        train |= (ds.frame.index >= w.start) & (ds.frame.index < w.end)
    hours = (exc & train).sum() * ds.step / 3600.0
    assert hours > 0  # the premise: excitation experiments in the training weeks
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = fit_zones(ds, heat=heat, mu_b=1e-6, open_loop=False)
    msg = [str(w.message) for w in caught if "not identifiable from these data" in str(w.message)]
    assert len(msg) == 1, [str(w.message) for w in caught]
    assert "without excitation" not in msg[0] and "Add excitation experiments" not in msg[0], msg[0]
    assert "Add discharge air temperatures" not in msg[0], msg[0]
    assert f"{hours:.0f} h of excitation experiments in the training weeks" in msg[0], msg[0]
    if heat == "auto":
        assert all(c.startswith("Td_") for c in m.inlets)
        assert "Add longer or more frequent excitation experiments, or use the physics model" in msg[0], msg[0]
    else:
        assert m.beta is None
        assert "This fit does not read the data's discharge air temperatures (Td_<vav>)" in msg[0], msg[0]


def test_bandwidth_on_grid_edge_is_named(dataset):
    with pytest.warns(
        HvacfmuWarning, match=r"LOESS bandwidth 2 h .* all \d+ series \(T_\w+, .*\) is on the lower edge"
    ):
        m = fit_zones(dataset, open_loop=False)
    assert any("lower edge" in w for w in m.meta["warnings"])


# ----------------------------------------------------------------------------- model files and zones
def test_model_for_other_zones_is_refused(fit, dataset):
    frame = dataset.frame.rename(columns={"T_NW": "T_X1", "m_V_NW_0": "m_V_X1_0"})
    with pytest.raises(ModelError, match=r"Model zones: \['NW', .*data zones: \[.*'X1'"):
        fit.measured_outputs(frame)
    with pytest.raises(ModelError, match=r"VAV airflow column\(s\) \['m_V_NW_0'\]"):
        fit.signals(frame)


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda d: d.update(outputs="NWWSENEC"), "'outputs' must be a list of names"),
        (lambda d: d.update(step=True), "'step' must be a finite number"),
        (lambda d: d.update(step=0), "'step' must be > 0"),
        (lambda d: d.update(format_version="1"), "no integer 'format_version'"),
        (lambda d: d.update(format_version=99), "newer than this hvacfmu"),
        (lambda d: d["A"][0].__setitem__(0, float("nan")), "A contains NaN"),
        (lambda d: d.update(beta=[0.1, 0.2]), r"beta has shape \(2,\)"),
        (lambda d: d.update(gains=[1, 2]), "'gains' must be a table"),
        (lambda d: d.update(inlets=["Td_nowhere"] * 12), "inlet column.*not disturbances"),
        (lambda d: d.pop("C"), r"missing keys \['C'\]"),
    ],
)
def test_bad_model_files_are_refused(truth, tmp_path, edit, message):
    d = json.loads(json.dumps(truth.to_dict()))
    edit(d)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d).replace("NaN", "NaN"))
    with pytest.raises(ModelError, match=message):
        load_model(path)


def test_air_handler_off_switches_to_delivered_heat(building, tmp_path):
    """Without Td, an air handler off (all boxes at zero flow) in >5 % of the steps selects the delivered form,
    so the idle supply temperature never enters; forcing the airflow form warns about it."""
    from tests.test_datadriven import true_zone_model

    frame = simulate_frame(true_zone_model(building), building, seed=7, weeks=6)
    night = np.asarray(frame.index.hour < 5)  # 21 % of the steps: unit off, supply node drifts to 30 °C
    frame.loc[night, [c for c in frame.columns if c.startswith("m_")]] = 0.0
    frame.loc[night, "T_supply"] = 30.0
    ds = write_dataset(tmp_path, frame, six_zone_building_dict())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        m = fit_zones(ds, open_loop=False)
    assert m.heat == "delivered" and "air handler is off" in m.meta["heat"]["reason"]
    assert "T_supply" not in m.disturbances or "T_supply" in m.inlets
    assert set(m.inlets) == {"T_supply"}
    with pytest.warns(HvacfmuWarning, match="enters linearly although an air handler is off in 21 %"):
        fit_zones(ds, heat="airflow")


def test_diagnosis_refuses_a_delivered_model_and_fits_the_airflow_form(fit, dataset):
    """The diagnosis cause terms assume zone airflow inputs: a delivered-heat model is refused with the fix."""
    from hvacfmu.diagnosis import diagnose

    with pytest.raises(ModelError, match="airflow form .* --heat airflow"):
        diagnose(dataset, model=fit, progress=False)


def test_cli_fit_heat_option(dataset, tmp_path, cli):
    """`hvacfmu fit --heat airflow|delivered` forces the form of Model A; the physics model refuses the option,
    and Model A refuses the physics model's ``--gain-days``."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    data = Path(dataset.source)
    bld = data.parent / "data_building.toml"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    run = lambda *a: subprocess.run(  # noqa: E731
        [
            sys.executable,
            "-m",
            "hvacfmu.cli",
            "-q",
            "fit",
            str(data),
            "-b",
            str(bld),
            *a,
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    r = run("--model", "zones", "--heat", "airflow", "-o", str(tmp_path / "a.json"))
    assert r.returncode == 0, r.stderr
    assert load_model(tmp_path / "a.json").heat == "airflow"
    r = cli("-q", "fit", data, "-b", bld, "--model", "physics", "--heat", "airflow", "-o", tmp_path / "p.json")
    assert r.returncode == 2 and "--heat applies to Model A" in r.stderr and "Traceback" not in r.stderr
    r = cli("-q", "fit", data, "-b", bld, "--model", "zones", "--gain-days", "shrunk", "-o", tmp_path / "g.json")
    assert r.returncode == 2 and "--gain-days applies to the physics model" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "g.json").exists()
