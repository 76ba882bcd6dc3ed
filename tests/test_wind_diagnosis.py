"""The ``wind_infiltration`` cause (issue 13): the term, its screen and the diagnosis on emulated data.

- the term adds ``coef · wind · (T_out − T_zone)``, round-trips through JSON, has a matrix form (products
  with the wind, ``Bxv``/``Bvv``; native FMU and MPC: ``test_wind_mpc.py``) and gives the Python FMU a
  ``wind`` input in m/s;
- the ``wind`` column reaches the diagnosis (``Signals.extra``) but is no ``unused_input`` candidate;
- on the emulator with the effect injected and a wind column, ``diagnose`` names it in the right zone
  with a held-out gain; with a wind column and no effect it names nothing wind-related.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from hvacfmu.errors import HvacfmuWarning, ModelError
from hvacfmu.models import model_from_dict
from hvacfmu.models.causes import WindInfiltration, cause_names
from hvacfmu.models.extended import ExtendedModel, SolarGain
from hvacfmu.models.linear import LinearZoneModel

TZ = "America/Los_Angeles"


def _base():
    return LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=("A", "B"),
        measured_zones=("A", "B"),
        output_weights=np.eye(2),
        vavs=("V1", "V2"),
        input_map=np.eye(2),
        disturbances=("T_out", "T_supply", "I_S"),
        A=np.array([[0.9, 0.02], [0.03, 0.88]]),
        B=np.diag([-0.2, -0.3]),
        C=np.array([[0.02, 0.03, 0.0], [0.02, 0.03, 0.0]]),
        gains={"fall": np.full((672, 2), 0.1)},
    )


def _frame(n=300, seed=0):
    rng = np.random.default_rng(seed)
    idx = pd.date_range("2025-09-01", periods=n, freq="15min", tz=TZ, name="time")
    return pd.DataFrame(
        {
            "T_A": 21 + rng.normal(0, 0.3, n),
            "T_B": 22 + rng.normal(0, 0.3, n),
            "m_V1": rng.uniform(0.05, 0.3, n),
            "m_V2": rng.uniform(0.05, 0.3, n),
            "T_out": 8 + rng.normal(0, 3, n),
            "T_supply": 14 + rng.normal(0, 0.2, n),
            "I_S": rng.uniform(0, 400, n),
            "wind": rng.uniform(0, 9, n),
        },
        index=idx,
    )


def test_wind_infiltration_is_a_registered_cause_whose_term_adds_wind_times_the_outdoor_difference():
    assert "wind_infiltration" in cause_names()
    base = _base()
    m = ExtendedModel(base=base, terms=(WindInfiltration(zone="B", coef=0.002),))
    assert m.disturbances == ("T_out", "T_supply", "I_S", "wind")
    f = _frame()
    u, v = m.signals(f)
    x = f[["T_A", "T_B"]].to_numpy()
    q = np.full((len(f), 2), 0.1)
    got = m.step_state(x, u, v, q)
    plain = base.step_state(x, u, v[:, :3], q)
    assert_allclose(got[:, 0], plain[:, 0], rtol=0, atol=1e-12)
    want = plain[:, 1] + 0.002 * f["wind"].to_numpy() * (f["T_out"].to_numpy() - x[:, 1])
    assert_allclose(got[:, 1], want, rtol=0, atol=1e-12)  # [K]
    again = model_from_dict(json.loads(json.dumps(m.to_dict())))
    assert again.terms == m.terms
    with pytest.raises(ModelError, match="coef must be >= 0"):
        model_from_dict({**m.to_dict(), "terms": [{"cause": "wind_infiltration", "zone": "B", "coef": -1.0}]})


def test_wind_infiltration_has_a_matrix_form_with_the_wind():
    m = ExtendedModel(
        base=_base(), terms=(SolarGain(zone="B", facade="S", coef=1e-3), WindInfiltration(zone="A", coef=0.001))
    )
    eq = m.equations()
    assert eq.Bxv[3][0, 0] == -0.001 and eq.Bvv[3][0, 0] == 0.001  # wind · (T_out − T_A)
    assert not eq.bilinear  # no product with an airflow


def test_python_fmu_of_a_wind_model_has_a_wind_input_in_metres_per_second():
    from hvacfmu.fmu_slave.zone_layout import zone_model_layout

    m = ExtendedModel(base=_base(), terms=(WindInfiltration(zone="A", coef=0.001),))
    layout, _ = zone_model_layout(m)
    wind = [v for v in layout["variables"] if v["name"] == "wind"]
    assert len(wind) == 1 and wind[0]["causality"] == "input" and wind[0]["unit"] == "m/s"
    assert wind[0]["min"] == 0.0 and wind[0]["max"] == 60.0


def test_wind_column_reaches_the_diagnosis_but_is_no_unused_input_candidate():
    from hvacfmu.data.dataset import Dataset
    from hvacfmu.emulator import sdh_building
    from hvacfmu.models.causes.signals import Within, make_signals
    from hvacfmu.models.causes.unused_input import UnusedInput
    from hvacfmu.models.datadriven import fit_lumped

    b = sdh_building(nominal=True)
    n = 96 * 7 * 3
    rng = np.random.default_rng(1)
    idx = pd.date_range("2025-09-01", periods=n, freq="15min", tz=b.timezone)
    cols = {f"T_{z}": 21 + rng.normal(0, 0.3, n) for z in b.zone_names}
    cols |= {f"m_{v}": rng.uniform(0.15, 0.4, n) for v in b.vav_names}
    cols |= {"T_supply": 14 + rng.normal(0, 0.2, n), "T_out": 12 + rng.normal(0, 3, n), "wind": rng.uniform(0, 8, n)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        ds = Dataset.from_frame(pd.DataFrame(cols, index=idx), b)
        base = fit_lumped(ds, open_loop=False, plausibility=False)
    sig = make_signals(ds, base)
    assert "wind" in sig.extra and "wind" not in sig.extra_zones
    W = Within(sig.group, sig.rows("train"))
    resid = rng.normal(0, 0.05, (len(W.rows), sig.nz))
    assert not [c for c in UnusedInput.screen(sig, (), W, resid, {}) if c.location.get("column") == "wind"]
    assert WindInfiltration.screen(sig, (), W, resid, {})


# --------------------------------------------------------------------------------------- emulator
def _diagnosed(effects, seed=0, wind="m/s"):
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.emulator import cached_dataset

    p = cached_dataset(weeks=8, seed=seed, effects=list(effects), start="2025-11-03", wind=wind)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        ds = prepare(p.measurements, p.building)
        return diagnose(ds, progress=False), json.loads(p.truth.read_text())


@pytest.mark.slow
@pytest.mark.parametrize(
    "effect, seed, wind", [("wind_infiltration:zone=NW", 0, "m/s"), ("wind_infiltration", 1, "mph")]
)
def test_wind_infiltration_is_found_in_its_zone_with_a_held_out_gain(effect, seed, wind):
    """8 November-December weeks, 40 W/K per m/s of leak (about 0.6 air changes an hour at 5 m/s)."""
    from hvacfmu.diagnosis.truth import compare_with_truth

    rep, truth = _diagnosed([effect], seed, wind)
    cmp = compare_with_truth(rep, truth)
    assert cmp["unsupported"] == [], cmp["unsupported"]
    assert [e["name"] for e in cmp["found"]] == ["wind_infiltration"]
    zone = truth["effects"][0]["zone"]
    hits = [f for f in rep.findings if f["cause"] == "wind_infiltration"]
    assert [f["location"] for f in hits] == [{"zone": zone}]
    assert hits[0]["heldout"]["gain_percent"] > 2.0
    assert hits[0]["evidence"]["partial_corr_beyond_dT"] > 0.05


@pytest.mark.slow
def test_a_wind_column_without_wind_driven_leaks_names_nothing():
    rep, truth = _diagnosed([], 0)
    assert not [f for f in rep.findings if f["cause"] == "wind_infiltration"]
    screened = [c for c in rep.candidates if c["cause"] == "wind_infiltration"]
    assert len(screened) == 5  # every perimeter zone was tested (the core C has no facade)


def test_python_fmu_of_a_wind_model_follows_the_python_model(tmp_path):
    """Exported (pythonfmu) and stepped through FMPy with a measured wind: the FMU equals ``step_state``."""
    pytest.importorskip("pythonfmu")
    from harness.cosim import FMUInstance
    from hvacfmu.fmu import export_fmu, validate

    m = ExtendedModel(base=_base(), terms=(WindInfiltration(zone="A", coef=0.003),))
    m.save(tmp_path / "m.json")
    path = export_fmu(tmp_path / "m.json", tmp_path / "m.fmu")
    assert validate(path) == []
    f = _frame(n=40)
    u, v = m.signals(f)
    q = m.gains_at(f.index, "fall")
    x = np.array([21.0, 22.0])
    want = [x]
    for k in range(len(f)):
        x = m.step_state(x, u[k], v[k], q[k])
        want.append(x)
    inst = FMUInstance(path, instance_name="wind")
    try:
        vr = {n: var.vr for n, var in inst.vars.items()}
        fmu = inst.fmu
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.setReal([vr["T_A_start"], vr["T_B_start"]], [21.0, 22.0])
        fmu.exitInitializationMode()
        names = ["m_V1", "m_V2", *m.disturbances, "time_of_week"]
        got = [fmu.getReal([vr["T_A"], vr["T_B"]])]
        from hvacfmu.timeutil import seconds_of_week

        tow = seconds_of_week(f.index)
        for k in range(len(f)):
            fmu.setReal([vr[n] for n in names], [*u[k], *v[k], float(tow[k])])
            fmu.doStep(900.0 * k, 900.0)
            got.append(fmu.getReal([vr["T_A"], vr["T_B"]]))
    finally:
        inst.close()
    assert_allclose(np.array(got), np.array(want), rtol=0, atol=1e-9)  # [K]


def test_an_unstable_model_with_a_wind_term_is_still_refused_on_load():
    """The load check's spectral radius of the matrix form (at zero wind the term vanishes): a model the same check
    refuses without the wind term is refused with it."""
    from hvacfmu.models.extended import ZoneCoupling
    from hvacfmu.models.loadcheck import model_problems

    shaky = ZoneCoupling(zone_a="A", zone_b="B", coef_ab=1.5, coef_ba=1.5)
    without = ExtendedModel(base=_base(), terms=(shaky,))
    with_wind = ExtendedModel(base=_base(), terms=(shaky, WindInfiltration(zone="A", coef=0.002)))
    assert any("unstable" in p for p in model_problems(without))
    assert any("unstable: the spectral radius" in p and "2.1" in p for p in model_problems(with_wind))
    assert model_problems(ExtendedModel(base=_base(), terms=(WindInfiltration(zone="A", coef=0.002),))) == []
    with pytest.raises(ModelError, match="more than the zone's whole temperature difference"):
        model_from_dict({**with_wind.to_dict(), "terms": [{"cause": "wind_infiltration", "zone": "A", "coef": 0.02}]})


@pytest.mark.slow
def test_the_control_model_keeps_the_diagnosed_wind_term():
    """MPC needs a matrix form; a wind term has one (``Bxv``/``Bvv``): ``terms_on_base`` (``diagnose
    --control-output``) refits it with the others, without a warning, and the result has equations MPC can use."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis.control import terms_on_base
    from hvacfmu.emulator import cached_dataset

    rep, _ = _diagnosed(["wind_infiltration:zone=NW"], 0)
    assert any(t.cause == "wind_infiltration" for t in rep.model.terms)
    p = cached_dataset(weeks=8, seed=0, effects=["wind_infiltration:zone=NW"], start="2025-11-03", wind="m/s")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        ds = prepare(p.measurements, p.building)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HvacfmuWarning)  # no "leaves out" warning
        ctl = terms_on_base(ds, rep.model.base, rep.model.terms, heat="airflow")
    assert [t.zone for t in ctl.terms if t.cause == "wind_infiltration"] == ["NW"]
    assert "left_out" not in ctl.meta
    assert ctl.equations().disturbance_products
