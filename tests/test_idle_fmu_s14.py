"""Session 14: the idle supply rule of a diagnosed model inside its FMUs, and ``fit(heat="auto")``'s box-off bound.

An extended model that stores ``meta["idle_supply"]`` (``diagnose`` on data whose air handler is off) replaces
the supply temperature of an idle unit; its FMUs (pythonfmu and native) now do the same at every model step
with their own zone temperatures, so a master feeding raw supply temperatures gets the model ``evaluate``
scored. Each FMU runs in FMPy in a subprocess (the native one with hvacfmu blocked) over two weeks of raw
night-off inputs and equals :meth:`ExtendedModel.simulate_boxes`.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from test_fmu import zones_model

from hvacfmu.data.idle import IdleStep, box_off_bounds, hold_idle_supply, idle_step, idle_supply_rule
from hvacfmu.errors import HvacfmuWarning
from hvacfmu.fmu import export_fmu
from hvacfmu.fmu_native import export_native_fmu
from hvacfmu.fmu_slave import state_from_outputs
from hvacfmu.models.extended import ExtendedModel, SupplyAirBilinear, ThermalMass
from hvacfmu.models.heat import OFF_FLOW

ROOT = Path(__file__).resolve().parents[1]
STEP = 900.0  # [s]
EXACT = 1e-10  # [K] FMU vs the Python model


@pytest.fixture(scope="module")
def sdh():
    from hvacfmu.emulator import sdh_building

    return sdh_building(nominal=True)


def idle_model(building, mode):
    """A hand-written extended model (bilinear supply air, a slow mass) carrying an idle supply rule."""
    rule = idle_supply_rule(building, ["T_supply"], box_off_bounds(building, 0.05, OFF_FLOW), mode)
    return ExtendedModel(
        base=zones_model(building, seed=3),
        terms=(SupplyAirBilinear(zone="NW", coef=0.02), ThermalMass(zone="C", alpha=0.02, beta=0.05)),
        meta={"idle_supply": {"mode": mode, "rule": rule}},
    )


def night_off(building, model, n, seed=0):
    """Raw inputs of a unit that is off at night and at weekends: shut boxes read 0..0.005 kg/s of noise (below
    5 % of m_min, 0.006 kg/s) and the supply sensor an idle duct near 24 °C. Returns (index, columns, m, v)."""
    rng = np.random.default_rng(seed)
    idx = pd.date_range("2025-01-06", periods=n, freq="900s", tz="UTC")  # a Monday 00:00
    h = np.asarray((idx.hour + idx.minute / 60.0), dtype=float)
    on = (h >= 6) & (h < 20) & (np.asarray(idx.day_of_week) < 5)
    nb = len(building.vavs)
    m = np.round(np.where(on[:, None], 0.2 + 0.2 * rng.random((n, nb)), 0.005 * rng.random((n, nb))), 3)
    day = 2 * np.pi * np.arange(n) / 96
    cols = {f"m_{v}": m[:, j] for j, v in enumerate(building.vav_names)}
    cols["T_out"] = 5.0 + 5.0 * np.sin(day)
    cols["T_supply"] = np.where(on, 14.0 + 0.5 * np.sin(day), 24.0 + 0.3 * rng.standard_normal(n))
    for o in "NESW":
        cols[f"I_{o}"] = np.clip(300.0 * np.sin(day), 0.0, None)
    v = np.column_stack([cols[d] for d in model.disturbances])
    return idx, cols, m, v


def python_reference(model, idx, m, v, season, y0, idle=True):
    """``simulate_boxes`` started as the FMUs start (the first step's held inputs for the initial state)."""
    q = model.gains_at(idx, season)
    v0 = model.idle_step().apply(v[0], m[0], y0)[0] if idle else v[0]
    u0 = m[0] @ np.asarray(model.base.input_map).T
    _, Y = model.simulate_boxes(state_from_outputs(model, y0, u0, v0, q[0]), m, v, q, idle=idle)
    return Y


_FMPY_SCRIPT = """
import json, sys
import numpy as np
if {block}:
    sys.modules["hvacfmu"] = None  # the native FMU needs no hvacfmu: importing it would fail
from fmpy import simulate_fmu
d = np.load(sys.argv[2])
names = json.loads(sys.argv[3])
sig = np.zeros(len(d["time"]), dtype=[("time", float)] + [(c, float) for c in names])
sig["time"] = d["time"]
for j, c in enumerate(names):
    sig[c] = d["U"][:, j]
res = simulate_fmu(sys.argv[1], start_time=0.0, stop_time=float(d["time"][-1]), output_interval={step},
                   input=sig, start_values=json.loads(sys.argv[4]), output=json.loads(sys.argv[5]))
np.save(sys.argv[6], np.column_stack([res[c] for c in json.loads(sys.argv[5])]))
"""


def run_fmpy(path, tmp_path, cols, start_values, outputs, native):
    """``fmpy.simulate_fmu`` of ``path`` in a subprocess; the native FMU's with hvacfmu blocked, the pythonfmu
    FMU's with this checkout's hvacfmu on the path (it runs in the host's Python)."""
    names = list(cols)
    n = len(cols[names[0]])
    data = tmp_path / "in.npz"
    np.savez(data, time=np.arange(n) * STEP, U=np.column_stack([cols[c] for c in names]))
    script = tmp_path / "run_fmpy.py"
    script.write_text(_FMPY_SCRIPT.format(block=native, step=STEP))
    out = tmp_path / "out.npy"
    env = {k: x for k, x in os.environ.items() if k != "PYTHONPATH"}
    if not native:
        env["PYTHONPATH"] = str(ROOT)
    run = subprocess.run(
        [sys.executable, str(script), str(path), str(data)]
        + [json.dumps(names), json.dumps(start_values), json.dumps(outputs), str(out)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,
        env=env,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    return np.load(out)


def start_values(model, season):
    return {**{f"T_{z}_start": 21.0 for z in model.outputs}, "season": list(model.gains).index(season) + 1}


# ----------------------------------------------------------------------------- the rule on step vectors
def test_idle_step_on_measured_zones_is_the_frame_substitution(sdh):
    """:class:`IdleStep` applied row by row with the measured zone temperatures gives what
    :func:`hold_idle_supply` gives on the frame (``evaluate``'s path): one definition for both."""
    model = idle_model(sdh, "zone")
    n = 400
    idx, cols, m, v = night_off(sdh, model, n)
    T = 20.0 + np.random.default_rng(1).standard_normal((n, len(model.outputs)))
    frame = pd.DataFrame({**cols, **{f"T_{z}": T[:, i] for i, z in enumerate(model.outputs)}}, index=idx)
    rule = model.meta["idle_supply"]["rule"]
    held, counts = hold_idle_supply(frame, rule)
    step = model.idle_step()
    j = list(model.disturbances).index("T_supply")
    mine = np.array([step.apply(v[k], m[k], T[k])[0][j] for k in range(n)])
    assert counts["T_supply"] > n // 3  # the unit is off in many rows
    assert_allclose(mine, held["T_supply"].to_numpy(), rtol=0, atol=1e-12)
    # "last": the last running value once the unit has run (the frame version also fills before it)
    last = idle_model(sdh, "last")
    held_last, _ = hold_idle_supply(frame, last.meta["idle_supply"]["rule"])
    memory, mine_last = None, []
    for k in range(n):
        vk, memory = last.idle_step().apply(v[k], m[k], T[k], memory)
        mine_last.append(vk[j])
    first = int(np.argmax(np.any(m > 0.006, axis=1)))
    assert_allclose(np.array(mine_last)[first:], held_last["T_supply"].to_numpy()[first:], rtol=0, atol=1e-12)
    assert IdleStep.from_dict(step.to_dict()) == step


def test_idle_step_needs_box_and_zone_names(sdh):
    model = idle_model(sdh, "zone")
    meta = model.meta
    assert idle_step({}, model.disturbances, sdh.vav_names, model.outputs) is None
    assert idle_step(meta, ("T_out",), sdh.vav_names, model.outputs) is None  # T_supply is no input: nothing
    with pytest.raises(ValueError, match="are not boxes"):
        idle_step(meta, model.disturbances, sdh.vav_names[1:], model.outputs)
    with pytest.raises(ValueError, match="are not outputs"):
        idle_step(meta, model.disturbances, sdh.vav_names, ("a", "b"))
    lumped = idle_step(meta, model.disturbances, sdh.vav_names, ("floor",))  # one output: the floor's air
    assert lumped.zones == ((0,),)


# ----------------------------------------------------------------------------- the FMUs
@pytest.mark.parametrize(
    "native, mode",
    [
        (False, "zone"),
        pytest.param(False, "last", marks=pytest.mark.slow),  # ~3 CPU-s; the native FMU covers "last" fast
        (True, "zone"),
        (True, "last"),
    ],
    ids=["pythonfmu-zone", "pythonfmu-last", "native-zone", "native-last"],
)
def test_fmu_applies_the_idle_rule_over_two_weeks(sdh, tmp_path, native, mode):
    """Two weeks of raw night-off inputs through FMPy (a subprocess; the native FMU without hvacfmu): the FMU
    equals ``simulate_boxes`` (rule applied with the model's own zone temperatures) to 1e-10 K, and differs
    from the model run on the raw supply temperature by more than 0.5 K (the rule matters). The model
    description says so."""
    if native and shutil.which("gcc") is None:
        pytest.fail("the native FMU needs the system C compiler gcc")
    model = idle_model(sdh, mode)
    n = 2 * 672
    idx, cols, m, v = night_off(sdh, model, n)
    season = list(model.gains)[0]
    y0 = np.full(len(model.outputs), 21.0)
    if native:
        path = export_native_fmu(model, tmp_path / "idle_native.fmu")
    else:
        path = export_fmu(model.save(tmp_path / "idle.json"), tmp_path / "idle.fmu")
    outputs = [f"T_{z}" for z in model.outputs]
    Y = run_fmpy(path, tmp_path, cols, start_values(model, season), outputs, native)
    Yref = python_reference(model, idx, m, v, season, y0)
    Yraw = python_reference(model, idx, m, v, season, y0, idle=False)
    assert Y.shape == (n, len(outputs))
    assert_allclose(Y, Yref[:n], rtol=0, atol=EXACT)  # [K]
    assert np.abs(Yref - Yraw).max() > 0.5  # [K]
    with zipfile.ZipFile(path) as z:
        xml = z.read("modelDescription.xml").decode()
        layout = json.loads(z.read("resources/interface.json"))
    assert "Idle air handler" in xml and "replaced inside the FMU while every box of its unit is off" in xml
    assert layout["idle_supply"]["mode"] == mode and layout["idle_supply"]["columns"][0]["name"] == "T_supply"


def test_native_fmu_state_restores_the_rules_memory(sdh, tmp_path):
    """The "last" rule's memory is part of the FMU state: a run restored mid-way (serialised state, fresh
    instance) continues exactly."""
    if shutil.which("gcc") is None:
        pytest.fail("the native FMU needs the system C compiler gcc")
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    model = idle_model(sdh, "last")
    path = export_native_fmu(model, tmp_path / "last.fmu")
    n = 300
    idx, cols, m, v = night_off(sdh, model, n, seed=4)
    md = read_model_description(str(path))
    vr = {x.name: x.valueReference for x in md.modelVariables}
    names = list(cols)
    U = np.column_stack([cols[c] for c in names])
    unz = extract(str(path))

    def instance():
        fmu = FMU2Slave(guid=md.guid, unzipDirectory=unz, modelIdentifier=md.coSimulation.modelIdentifier)
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.setInteger([vr["season"]], [1])
        fmu.setReal([vr[c] for c in names], list(U[0]))
        fmu.exitInitializationMode()
        return fmu

    def run(fmu, k0, k1):
        out = []
        for k in range(k0, k1):
            fmu.setReal([vr[c] for c in names], list(U[k]))
            fmu.doStep(k * STEP, STEP)
            out.append(fmu.getReal([vr[f"T_{z}"] for z in model.outputs]))
        return np.array(out)

    a = instance()
    full = run(a, 0, n)
    a.terminate()
    a.freeInstance()
    b = instance()
    run(b, 0, 50)  # Monday 12:30: the unit has run since 06:00, the memory holds a value
    blob = b.serializeFMUstate(b.getFMUstate())
    b.terminate()
    b.freeInstance()
    c = instance()
    c.setFMUstate(c.deSerializeFMUstate(blob))
    rest = run(c, 50, n)
    c.terminate()
    c.freeInstance()
    shutil.rmtree(unz, ignore_errors=True)
    assert_allclose(rest, full[50:], rtol=0, atol=0)
    Yref = python_reference(model, idx, m, v, list(model.gains)[0], np.full(len(model.outputs), 21.0))
    assert_allclose(full, Yref[1 : n + 1], rtol=0, atol=EXACT)


# ----------------------------------------------------------------------------- fit --heat auto
def test_fit_heat_auto_sees_noisy_shut_boxes(tmp_path):
    """``generate --schedule night-off``: shut boxes read 0..0.01 kg/s of noise, never exactly 0. With the box-off
    bound of the idle rule (5 % of m_min) ``fit(heat="auto")`` sees the air handler off in about half the
    training steps and picks the delivered-heat form (the exact-zero criterion saw 0 % and kept the airflow
    form, reading the idle duct as a supply temperature)."""
    from hvacfmu.data import prepare
    from hvacfmu.emulator import generate
    from hvacfmu.fitting import fit

    paths = generate(tmp_path / "gen", weeks=2, seed=0, fmt="csv", schedule="night-off")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        data = prepare(paths.measurements, paths.building)
        model = fit(data, "zones", open_loop=False)
    m = data.frame[[f"m_{v}" for v in data.building.vav_names]].to_numpy(float)
    assert (m[np.isfinite(m).all(axis=1)].max(axis=1) > 0.0).all()  # no row with every box at exactly 0
    heat = model.meta["heat"]
    assert heat["form"] == "delivered" and model.heat == "delivered"
    assert 0.3 < heat["air_handler_off_share"] < 0.7
    assert "50 % of its minimum airflow" in heat["reason"]  # the unit-off rule (s14-offrule)


def two_unit_model():
    """Two zones, each served by one box of its own air handler, the box ``a`` with a measured discharge
    temperature: the rule replaces ``T_supply_U1``, ``T_supply_U2`` and ``Td_a``, each on its own boxes."""
    from hvacfmu.building import building_from_dict
    from hvacfmu.models.linear import LinearZoneModel

    b = building_from_dict(
        {
            "name": "two",
            "latitude": 37.9,
            "longitude": -122.3,
            "timezone": "America/Los_Angeles",
            "zones": [{"name": "A", "area": 100.0, "volume": 300.0}, {"name": "B", "area": 100.0, "volume": 300.0}],
            "ahus": [{"name": "U1"}, {"name": "U2"}],
            "vavs": [
                {"name": "a", "zone": "A", "ahu": "U1", "m_min": 0.1, "m_max": 1.0},
                {"name": "b", "zone": "B", "ahu": "U2", "m_min": 0.1, "m_max": 1.0},
            ],
        }
    )
    dist = ("T_out", "T_supply_U1", "T_supply_U2", "Td_a")
    rng = np.random.default_rng(7)
    base = LinearZoneModel(
        kind="zones",
        step=STEP,
        outputs=("A", "B"),
        measured_zones=("A", "B"),
        output_weights=np.eye(2),
        vavs=("a", "b"),
        input_map=b.zone_vav_matrix(),
        disturbances=dist,
        A=[[0.9, 0.01], [0.012, 0.91]],
        B=[[-0.8, 0.0], [0.0, -0.7]],
        C=[[0.02, 0.03, 0.0, 0.02], [0.025, 0.0, 0.04, 0.0]],
        gains={s: rng.uniform(0.3, 0.6, (672, 2)) for s in b.season_names},
    )
    rule = idle_supply_rule(b, dist, box_off_bounds(b, 0.05, OFF_FLOW), "zone")
    assert set(rule) == {"T_supply_U1", "T_supply_U2", "Td_a"}
    return b, ExtendedModel(base=base, terms=(), meta={"idle_supply": {"mode": "zone", "rule": rule}})


@pytest.mark.parametrize("native", [pytest.param(False, marks=pytest.mark.slow), True], ids=["pythonfmu", "native"])
def test_fmu_rule_per_air_handler_and_discharge_column(tmp_path, native):
    """Two air handlers off at different times (and a box's measured discharge air): each column is replaced
    only while its own boxes are off, by its own zones' air; a week in FMPy equals ``simulate_boxes``."""
    if native and shutil.which("gcc") is None:
        pytest.fail("the native FMU needs the system C compiler gcc")
    b, model = two_unit_model()
    n = 672
    rng = np.random.default_rng(2)
    idx = pd.date_range("2025-01-06", periods=n, freq="900s", tz="UTC")
    h = np.asarray(idx.hour, dtype=float)
    on = np.column_stack([(h >= 6) & (h < 18), (h >= 10) & (h < 22)])  # the units run at different hours
    m = np.where(on, 0.3 + 0.4 * rng.random((n, 2)), 0.004 * rng.random((n, 2)))
    day = 2 * np.pi * np.arange(n) / 96
    cols = {"m_a": m[:, 0], "m_b": m[:, 1], "T_out": 4.0 + 4.0 * np.sin(day)}
    cols["T_supply_U1"] = np.where(on[:, 0], 13.0, 25.0)
    cols["T_supply_U2"] = np.where(on[:, 1], 15.0, 26.0)
    cols["Td_a"] = np.where(on[:, 0], 30.0, 25.0)
    v = np.column_stack([cols[d] for d in model.disturbances])
    season = list(model.gains)[0]
    if native:
        path = export_native_fmu(model, tmp_path / "two_native.fmu")
    else:
        path = export_fmu(model.save(tmp_path / "two.json"), tmp_path / "two.fmu")
    Y = run_fmpy(path, tmp_path, cols, start_values(model, season), ["T_A", "T_B"], native)
    Yref = python_reference(model, idx, m, v, season, np.full(2, 21.0))
    Yraw = python_reference(model, idx, m, v, season, np.full(2, 21.0), idle=False)
    assert_allclose(Y, Yref[:n], rtol=0, atol=EXACT)  # [K]
    assert np.abs(Yref - Yraw).max() > 0.5  # [K]
    step = model.idle_step()
    k = int(np.flatnonzero(~on[:, 0] & on[:, 1])[0])  # U1 off, U2 running
    held = step.apply(v[k], m[k], np.array([20.0, 22.0]))[0]
    assert held.tolist() == [v[k, 0], 20.0, v[k, 2], 20.0]  # U1's supply and Td_a by zone A's air; U2 raw


def test_native_fmu_in_modal_form_applies_the_idle_rule(sdh, tmp_path):
    """A model large enough for the native FMU's modal form (26 states: 20 thermal masses, real eigenvalues)
    reads the zone temperatures for the rule from its physical output states: two weeks equal
    ``simulate_boxes`` to 1e-10 K."""
    import dataclasses

    if shutil.which("gcc") is None:
        pytest.fail("the native FMU needs the system C compiler gcc")
    small = idle_model(sdh, "zone")
    A = np.asarray(small.base.A)
    base = dataclasses.replace(small.base, A=0.5 * (A + A.T))  # symmetric: real eigenvalues
    z = base.outputs
    masses = tuple(ThermalMass(zone=z[i % 6], alpha=0.01 + 0.003 * i, beta=0.02 + 0.001 * i) for i in range(20))
    model = ExtendedModel(base=base, terms=masses, meta=small.meta)
    path = export_native_fmu(model, tmp_path / "modal.fmu")
    with zipfile.ZipFile(path) as zf:
        header = zf.read("sources/hvacfmu_model.h").decode()
    assert "#define HV_MODAL 1" in header and "#define HV_NIDLE 1" in header
    n = 2 * 672
    idx, cols, m, v = night_off(sdh, model, n, seed=3)
    season = list(model.gains)[0]
    Y = run_fmpy(path, tmp_path, cols, start_values(model, season), [f"T_{x}" for x in z], True)
    Yref = python_reference(model, idx, m, v, season, np.full(len(z), 21.0))
    assert_allclose(Y, Yref[:n], rtol=0, atol=EXACT)  # [K]
    assert np.abs(Yref - python_reference(model, idx, m, v, season, np.full(len(z), 21.0), idle=False)).max() > 0.5
