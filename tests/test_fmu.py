"""FMU export: validation, exactness against the Python models, state, step sizes, bad input, FMPy CLI.

FMUs are built once per session (pythonfmu build, about 0.3 s each; the plant
FMU a few seconds) into a temporary folder.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from hvacfmu.errors import FMUError, HvacfmuWarning, ModelError
from hvacfmu.fmu import export_fmu, export_native_fmu, export_plant_fmu, validate
from hvacfmu.fmu_slave import box_names, state_from_outputs
from hvacfmu.models.linear import LinearZoneModel

DIST = ("T_out", "T_supply", "I_N", "I_E", "I_S", "I_W")
EXACT = 1e-9  # [K] FMU vs Python model


# ----------------------------------------------------------------------------- models
def zones_model(building, seed=0):
    """A stable six-zone Model A for ``building`` (hand-written, not fitted)."""
    rng = np.random.default_rng(seed)
    nz = len(building.zone_names)
    A = 0.9 * np.eye(nz) + rng.uniform(0, 0.012, (nz, nz))
    B = -np.diag(rng.uniform(0.5, 1.0, nz))
    C = np.column_stack([rng.uniform(0.02, 0.04, nz), rng.uniform(0.02, 0.04, nz), rng.uniform(0, 2e-4, (nz, 4))])
    # steady state ~21 degC at typical inputs: put the balance into the gains
    return LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=building.zone_names,
        measured_zones=building.zone_names,
        output_weights=np.eye(nz),
        vavs=building.vav_names,
        input_map=building.zone_vav_matrix(),
        disturbances=DIST,
        A=A,
        B=B,
        C=C,
        gains={s: rng.uniform(0.6, 1.2, (672, nz)) for s in building.season_names},
        meta={"note": "hand-written for tests"},
    )


def lumped_model(building, seed=1):
    rng = np.random.default_rng(seed)
    return LinearZoneModel(
        kind="lumped",
        step=900.0,
        outputs=("floor",),
        measured_zones=building.zone_names,
        output_weights=building.area_weights()[None, :],
        vavs=building.vav_names,
        input_map=np.ones((1, len(building.vav_names))),
        disturbances=DIST[:2],
        A=[[0.94]],
        B=[[-0.12]],
        C=[[0.02, 0.02]],
        gains={s: rng.uniform(0.6, 1.0, (672, 1)) for s in building.season_names},
    )


def extended_model(building, seed=3):
    """Model A plus extension terms with hidden states, a bilinear term and solar gain."""
    from hvacfmu.models.extended import ActuationDelay, ExtendedModel, SolarGain, SupplyAirBilinear, ThermalMass

    base = zones_model(building, seed=seed)
    return ExtendedModel(
        base=base,
        terms=(
            SolarGain(zone="S", facade="S", coef=4e-4),
            SupplyAirBilinear(zone="NW", coef=0.02),
            ThermalMass(zone="C", alpha=0.02, beta=0.05),
            ActuationDelay(zone="E", delay=2),
        ),
    )


def _storeys(building, gains):
    """Zone gains [W] and, when slabs face the storeys below/above, their constant temperature [°C]."""
    if not any(e.get("side2") == "ground" for e in building.physics.get("elements", [])):
        return gains
    return np.column_stack([gains, np.full(len(gains), building.physics["physics"]["ground_temperature"])])


def physics_model(building, seed=2):
    from hvacfmu.models.physics import PhysicsModel

    rng = np.random.default_rng(seed)
    params = dict(building.physics["physics"]["nominal"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        nz = len(building.zone_names)
        return PhysicsModel(
            building=building,
            params=params,
            solar=True,
            gains={s: _storeys(building, rng.uniform(500.0, 3000.0, (672, nz))) for s in building.season_names},
        )


# ----------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="session")
def fmu_data(short_paths):
    from hvacfmu.data import prepare

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(short_paths.measurements, short_paths.building)


@pytest.fixture(scope="session")
def sdh_building():
    from hvacfmu.emulator import sdh_building as make

    return make(nominal=True)


@pytest.fixture(scope="session")
def built(tmp_path_factory, fmu_data, sdh_building):
    """kind -> (model, model path, FMU path), each FMU built once."""
    d = tmp_path_factory.mktemp("fmus")
    models = {
        "lumped": lumped_model(fmu_data.building),
        "zones": zones_model(fmu_data.building),
        "physics": physics_model(sdh_building),
        "extended": extended_model(fmu_data.building),
    }
    out = {}
    for kind, model in models.items():
        mp = model.save(d / f"{kind}.json")
        out[kind] = (model, mp, export_fmu(mp, d / f"{kind}.fmu"))
    return out


@pytest.fixture(scope="session")
def plant_fmu(tmp_path_factory, short_paths):
    return export_plant_fmu(short_paths.truth, tmp_path_factory.mktemp("plant") / "Plant.fmu")


def week_inputs(dataset, model, week):
    """Measured-like inputs of a test week, gap-filled: (index, m_vav (n, nb), v (n, nv), y0)."""
    f = dataset.week_frame(week).interpolate(method="time", limit_direction="both")
    m = f[[f"m_{b}" for b in dataset.building.vav_names]].to_numpy(dtype=float)
    v = f[list(model.disturbances)].to_numpy(dtype=float)
    y0 = model.measured_outputs(f.iloc[:1])[0]
    return f.index, m, v, y0


class Slave:
    """A pythonfmu FMU through FMPy's FMU2Slave with logging captured."""

    def __init__(self, path, name="test"):
        from harness.cosim import FMUInstance

        self.inst = FMUInstance(path, instance_name=name)
        self.fmu = self.inst.fmu
        self.vr = {n: v.vr for n, v in self.inst.vars.items()}
        self.log = self.inst.log

    def init(self, start_values=None, t0=0.0, inputs=None):
        """Initialise with parameters and (optionally) the first inputs ``(names, values)``, as FMPy does."""
        self.fmu.setupExperiment(startTime=t0)
        self.fmu.enterInitializationMode()
        for k, val in (start_values or {}).items():
            if isinstance(val, int) and not isinstance(val, bool):
                self.fmu.setInteger([self.vr[k]], [val])
            else:
                self.fmu.setReal([self.vr[k]], [float(val)])
        if inputs is not None:
            self.fmu.setReal([self.vr[n] for n in inputs[0]], [float(x) for x in inputs[1]])
        self.fmu.exitInitializationMode()

    def close(self):
        self.inst.close()


def run_fmu(slave, names_in, U, names_out, t0=0.0, step=900.0, k0=0):
    vin = [slave.vr[n] for n in names_in]
    vout = [slave.vr[n] for n in names_out]
    Y = [slave.fmu.getReal(vout)]
    for k in range(len(U)):
        slave.fmu.setReal(vin, list(U[k]))
        slave.fmu.doStep(t0 + (k0 + k) * step, step)
        Y.append(slave.fmu.getReal(vout))
    return np.array(Y)


def fmu_setup(model, building, dataset, week):
    idx, m, v, y0 = week_inputs(dataset, model, week)
    names_in = ([f"m_{b}" for b in building.vav_names]) + list(model.disturbances)
    names_out = [f"T_{z}" for z in model.outputs]
    sv = {f"T_{z}_start": float(y) for z, y in zip(model.outputs, y0)}
    sv["season"] = list(model.gains).index(week.season) + 1
    from hvacfmu.timeutil import seconds_of_week

    sv["start_time_of_week"] = float(seconds_of_week(idx[:1])[0])
    return idx, np.hstack([m, v]), m, v, y0, names_in, names_out, sv


def reference(model, idx, m, v, y0, season):
    u, _ = model.signals(
        pd.DataFrame(
            {
                **{f"m_{b}": m[:, j] for j, b in enumerate(box_names(model))},
                **{d: v[:, j] for j, d in enumerate(model.disturbances)},
            },
            index=idx,
        )
    )
    q = model.gains_at(idx, season)
    _, Y = model.simulate(state_from_outputs(model, y0, u[0], v[0], q[0]), u, v, q)
    return Y


# ----------------------------------------------------------------------------- tests
@pytest.mark.parametrize("kind", ["lumped", "zones", "physics", "extended"])
def test_validate_and_description(built, kind):
    from fmpy import read_model_description

    model, _, path = built[kind]
    assert validate(path) == []
    md = read_model_description(str(path))
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    assert md.coSimulation.canHandleVariableCommunicationStepSize is False
    assert (
        md.coSimulation.modelIdentifier
        == {
            "lumped": "HvacfmuLumped",
            "zones": "HvacfmuZones",
            "physics": "HvacfmuPhysics",
            "extended": "HvacfmuExtended",
        }[kind]
    )
    names = {v.name: v for v in md.modelVariables}
    assert not [n for n in names if any(c in n for c in ".[]")]
    for v in md.modelVariables:
        assert v.variability is not None and v.causality is not None
        assert v.description
    for z in model.outputs:
        assert names[f"T_{z}"].causality == "output" and names[f"T_{z}"].unit == "degC"
        assert names[f"T_{z}_start"].causality == "parameter"
    for b in box_names(model):
        assert names[f"m_{b}"].unit == "kg/s" and names[f"m_{b}"].causality == "input"
    for d in model.disturbances:
        assert names[d].unit == ("degC" if d.startswith("T_") else "W/m2")
    assert names["season"].type == "Integer" and "1 = fall" in names["season"].description
    assert names["start_time_of_week"].unit == "s"
    assert {u.name for u in md.unitDefinitions} >= {"degC", "kg/s", "s"}
    with zipfile.ZipFile(path) as z:
        assert json.loads(z.read("resources/model.json")) == json.loads(Path(built[kind][1]).read_text())


@pytest.mark.parametrize("kind", ["lumped", "zones", "physics", "extended"])
def test_week_matches_python_model(built, fmu_data, kind):
    """672 steps with measured inputs through FMPy equal the Python model to 1e-9 K."""
    model, _, path = built[kind]
    week = fmu_data.test_weeks()[0]
    idx, U, m, v, y0, names_in, names_out, sv = fmu_setup(model, fmu_data.building, fmu_data, week)
    s = Slave(path)
    try:
        s.init(sv, inputs=(names_in, U[0]))
        Y = run_fmu(s, names_in, U, names_out)
    finally:
        s.close()
    Yref = reference(model, idx, m, v, y0, week.season)
    assert len(Y) == 673
    assert_allclose(Y, Yref, rtol=0, atol=EXACT)
    assert np.ptp(Yref) > 0.5  # the trajectory moves: the comparison is not trivial


@pytest.mark.parametrize("kind", ["zones", "physics", "extended"])
def test_state_save_restore_mid_week(built, fmu_data, kind):
    """Serialised state restored mid-week (also into a fresh instance) reproduces the run exactly."""
    model, _, path = built[kind]
    week = fmu_data.test_weeks()[0]
    idx, U, m, v, y0, names_in, names_out, sv = fmu_setup(model, fmu_data.building, fmu_data, week)
    k_mid = 300
    s = Slave(path, "a")
    try:
        s.init(sv, inputs=(names_in, U[0]))
        Y1 = run_fmu(s, names_in, U[:k_mid], names_out)
        state = s.fmu.getFMUstate()
        blob = s.fmu.serializeFMUstate(state)
        Y2 = run_fmu(s, names_in, U[k_mid:], names_out, k0=k_mid)
        s.fmu.setFMUstate(state)
        Y2b = run_fmu(s, names_in, U[k_mid:], names_out, k0=k_mid)
        s.fmu.freeFMUstate(state)
    finally:
        s.close()
    fresh = Slave(path, "b")
    try:
        fresh.init(sv, inputs=(names_in, U[0]))
        fresh.fmu.setFMUstate(fresh.fmu.deSerializeFMUstate(blob))
        Y2c = run_fmu(fresh, names_in, U[k_mid:], names_out, k0=k_mid)
    finally:
        fresh.close()
    assert_allclose(Y2b, Y2, rtol=0, atol=0)
    assert_allclose(Y2c, Y2, rtol=0, atol=0)
    Yref = reference(model, idx, m, v, y0, week.season)
    assert_allclose(np.vstack([Y1, Y2[1:]]), Yref, rtol=0, atol=EXACT)


def test_multiple_steps_exact_and_other_steps_refused(built, fmu_data):
    model, _, path = built["zones"]
    week = fmu_data.test_weeks()[0]
    idx, U, m, v, y0, names_in, names_out, sv = fmu_setup(model, fmu_data.building, fmu_data, week)
    held = np.repeat(U[:1], 4, axis=0)  # the same inputs for 4 steps
    a, b = Slave(path, "a"), Slave(path, "b")
    try:
        a.init(sv)
        b.init(sv)
        Ya = run_fmu(a, names_in, held, names_out)
        b.fmu.setReal([b.vr[n] for n in names_in], list(U[0]))
        b.fmu.doStep(0.0, 3600.0)  # one communication step of 4 model steps
        assert_allclose(b.fmu.getReal([b.vr[n] for n in names_out]), Ya[-1], rtol=0, atol=0)
        before = b.fmu.getReal([b.vr[n] for n in names_out])
        for h in (450.0, 1000.0, 0.0):
            with pytest.raises(Exception, match=r"status 4 \(fatal\)"):
                b.fmu.doStep(3600.0, h)
        assert any("not a whole multiple of the model step 900 s" in msg for _, _, msg in b.log)
        assert b.fmu.getReal([b.vr[n] for n in names_out]) == before  # refused steps change nothing
        with pytest.raises(Exception, match=r"status 4 \(fatal\)"):
            b.fmu.doStep(7200.0, 900.0)  # not contiguous
        assert any("steps must be contiguous" in msg for _, _, msg in b.log)
        b.fmu.doStep(3600.0, 900.0)  # a host that ignores fmi2Fatal and goes on is safe (no crash, exact state)
    finally:
        a.close()
        b.close()


@pytest.mark.parametrize(
    "setup, message",
    [
        ("before_init", "before initialisation"),
        ("nan", r"invalid input value\(s\): m_VAV_NW_1=nan"),
        ("range", r"T_out=150.0 \(allowed \[-60.0, 60.0\] degC\)"),
        ("negative", r"m_VAV_C_1=-0.1"),
        ("season", r"season=9 is not one of 1 \(fall\)"),
        ("wrong_type", "fmi2SetInteger: invalid value reference"),
        ("bad_state", "fmi2SetFMUstate failed"),
    ],
)
def test_bad_input_is_refused_with_a_log(built, setup, message):
    """Each bad input: fmi2Fatal (pythonfmu's only error status) with a clear log message; the host keeps running."""
    _, _, path = built["zones"]
    s = Slave(path)
    vr = s.vr
    try:
        if setup == "before_init":
            pass
        elif setup == "season":
            s.init({"season": 9})
        else:
            s.init()
        if setup == "nan":
            s.fmu.setReal([vr["m_VAV_NW_1"]], [float("nan")])
        elif setup == "range":
            s.fmu.setReal([vr["T_out"]], [150.0])
        elif setup == "negative":
            s.fmu.setReal([vr["m_VAV_C_1"]], [-0.1])
        elif setup == "wrong_type":
            s.fmu.setInteger([vr["T_out"]], [3])
        elif setup == "bad_state":
            s.fmu.setFMUstate(s.fmu.deSerializeFMUstate(b"not json"))
        with pytest.raises(Exception, match=r"status 4 \(fatal\)"):
            s.fmu.doStep(0.0, 900.0)
        text = "\n".join(msg for _, _, msg in s.log)
        assert re.search(message, text), text
        assert any(status in ("error", "fatal") for status, _, _ in s.log)
    finally:
        s.close()
    # the process is healthy: a new instance of the same FMU runs
    t = Slave(path, "after")
    try:
        t.init()
        t.fmu.doStep(0.0, 900.0)
    finally:
        t.close()


def _rewrite(path, out, name, content):
    with zipfile.ZipFile(path) as zin, zipfile.ZipFile(out, "w") as zout:
        for item in zin.infolist():
            data = content if item.filename == name else zin.read(item.filename)
            zout.writestr(item, data)
    return out


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda d: "{not json", "is not valid JSON"),
        (lambda d: json.dumps(dict(d, format_version=99)), "newer than this hvacfmu understands"),
        (lambda d: json.dumps(dict(d, outputs=list(reversed(d["outputs"])))), "does not match the FMU's variables"),
    ],
)
def test_broken_model_file_in_fmu(built, tmp_path, edit, message):
    """A corrupt, too new or replaced model file: logged at instantiation, every step refused, host fine."""
    _, mp, path = built["zones"]
    d = json.loads(Path(mp).read_text())
    bad = _rewrite(path, tmp_path / "bad.fmu", "resources/model.json", edit(d))
    s = Slave(bad)
    try:
        s.init()
        with pytest.raises(Exception, match=r"status 4 \(fatal\)"):
            s.fmu.doStep(0.0, 900.0)
        text = "\n".join(msg for _, _, msg in s.log)
        assert message in text, text
    finally:
        s.close()


def test_exception_in_slave_is_logged_with_traceback(built, tmp_path):
    """A Python exception inside doStep becomes a logged traceback and fmi2Fatal; a host that goes on is safe."""
    from hvacfmu.fmu import _build
    from hvacfmu.fmu_slave import INTERFACE_FILE, zone_model_layout

    model, mp, _ = built["zones"]
    script = tmp_path / "HvacfmuTestRaises.py"
    script.write_text(
        "from hvacfmu.fmu_slave import define_slave\n"
        "define_slave(globals(), 'ZoneModelSlave')\n\n\n"
        "class HvacfmuTestRaises(ZoneModelSlave):  # noqa: F821\n"
        "    def _advance(self, current_time, step_size):\n"
        "        if current_time >= 1800.0:\n"
        "            raise ZeroDivisionError('injected failure')\n"
        "        return ZoneModelSlave._advance(self, current_time, step_size)  # noqa: F821\n"
    )
    res = tmp_path / "res"
    res.mkdir()
    (res / "model.json").write_text(Path(mp).read_text())
    (res / INTERFACE_FILE).write_text(json.dumps(zone_model_layout(model)[0]))
    path = _build(script, tmp_path / "Raises.fmu", [res / "model.json", res / INTERFACE_FILE])
    s = Slave(path)
    try:
        s.init()
        s.fmu.doStep(0.0, 900.0)
        s.fmu.doStep(900.0, 900.0)
        with pytest.raises(Exception, match=r"status 4 \(fatal\)"):
            s.fmu.doStep(1800.0, 900.0)
        text = "\n".join(msg for _, _, msg in s.log)
        assert "Traceback (most recent call last)" in text and "ZeroDivisionError: injected failure" in text
        s.fmu.getFMUstate()  # still answers (the slave keeps the references pythonfmu releases twice)
    finally:
        s.close()


def test_two_fmus_of_one_kind_in_one_process(built, fmu_data, tmp_path):
    """Same slave class, different models, loaded together: each runs its own model."""
    model_a, _, path_a = built["zones"]
    model_b = zones_model(fmu_data.building, seed=7)
    path_b = export_fmu(model_b.save(tmp_path / "b.json"), tmp_path / "b.fmu")
    week = fmu_data.test_weeks()[0]
    lumped, _, path_l = built["lumped"]
    slaves, results = [], {}
    try:
        for name, model, path in (("a", model_a, path_a), ("b", model_b, path_b), ("l", lumped, path_l)):
            idx, U, m, v, y0, names_in, names_out, sv = fmu_setup(model, fmu_data.building, fmu_data, week)
            s = Slave(path, name)
            slaves.append(s)
            s.init(sv, inputs=(names_in, U[0]))
            results[name] = (
                run_fmu(s, names_in, U[:96], names_out),
                reference(model, idx[:96], m[:96], v[:96], y0, week.season),
            )
    finally:
        for s in slaves:
            s.close()
    for name, (Y, Yref) in results.items():
        assert_allclose(Y, Yref, rtol=0, atol=EXACT, err_msg=name)
    assert np.abs(results["a"][0] - results["b"][0]).max() > 0.1


def test_plant_fmu_matches_plant(plant_fmu, short_paths, fmu_data):
    from hvacfmu.emulator import Plant

    assert validate(plant_fmu) == []
    truth = json.loads(Path(short_paths.truth).read_text())
    plant = Plant.from_truth(truth)
    week = fmu_data.weeks[1]
    f = fmu_data.week_frame(week).interpolate(method="time", limit_direction="both").iloc[:96]
    m = f[[f"m_{b}" for b in plant.vavs]].to_numpy(dtype=float)
    w = f[["T_out", "T_supply", "I_N", "I_E", "I_S", "I_W"]].to_numpy(dtype=float)
    y0 = f[[f"T_{z}" for z in plant.zones]].iloc[0].to_numpy(dtype=float)
    t0 = (f.index[0] - pd.Timestamp(truth["start"]).tz_localize(truth["timezone"])).total_seconds()
    x = plant.initial_state(y0)
    Yref = [plant.zone_temperatures(x)]
    for k in range(len(f)):
        x, T = plant.advance(x, t0 + 900.0 * k, 900.0, m[k], w[k, 0], w[k, 1], w[k, 2:])
        Yref.append(T)
    s = Slave(plant_fmu)
    try:
        s.init({f"T_{z}_start": float(y) for z, y in zip(plant.zones, y0)}, t0=t0)
        Y = run_fmu(
            s,
            [f"m_{b}" for b in plant.vavs] + ["T_out", "T_supply", "I_N", "I_E", "I_S", "I_W"],
            np.hstack([m, w]),
            [f"T_{z}" for z in plant.zones],
            t0=t0,
        )
        with pytest.raises(Exception, match=r"status 4 \(fatal\)"):
            s.fmu.doStep(t0 + 96 * 900.0, 30.0)  # not a multiple of the plant's 60 s
    finally:
        s.close()
    assert_allclose(Y, np.array(Yref), rtol=0, atol=EXACT)


def test_plant_fmu_bounds_come_from_the_emulated_building(plant_fmu, short_paths):
    """Plant airflow inputs: 0..1.2 x m_max, nominal m_max, box and zone named; temperatures in plausible ranges."""
    from fmpy import read_model_description

    truth = json.loads(Path(short_paths.truth).read_text())
    names = {v.name: v for v in read_model_description(str(plant_fmu)).modelVariables}
    boxes = truth["baseline"]["building"]["vavs"]
    for box in boxes:
        v = names[f"m_{box['name']}"]
        assert float(v.min) == 0.0 and float(v.max) == pytest.approx(1.2 * box["m_max"], rel=1e-12)
        assert float(v.nominal) == box["m_max"]
        assert f"VAV box {box['name']} serving zone {box['zone']}" in v.description
    assert (float(names["T_out"].min), float(names["T_out"].max)) == (-60.0, 60.0)
    assert (float(names["T_supply"].min), float(names["T_supply"].max)) == (-60.0, 80.0)  # idle duct
    for z in truth["baseline"]["building"]["zones"]:
        start = names[f"T_{z['name']}_start"]
        assert (float(start.min), float(start.max)) == (-40.0, 60.0) and z["name"] in start.description
    s = Slave(plant_fmu)  # the plant refuses an airflow above its bound, naming it
    try:
        s.init()
        s.fmu.setReal([s.vr[f"m_{boxes[0]['name']}"]], [1.3 * boxes[0]["m_max"]])
        with pytest.raises(Exception, match="fatal"):
            s.fmu.doStep(0.0, 900.0)
        assert any(f"m_{boxes[0]['name']}=" in msg and "invalid input" in msg for _, _, msg in s.log)
    finally:
        s.close()


def test_fmpy_command_line(built, fmu_data, tmp_path):
    """`fmpy info` and `fmpy simulate --input-file ... --output-interval 900` as a user would run them."""
    model, _, path = built["zones"]
    info = subprocess.run(["fmpy", "info", str(path)], capture_output=True, text=True, timeout=120)
    assert info.returncode == 0, info.stderr
    assert "T_NW" in info.stdout and "m_VAV_NW_1" in info.stdout and "degC" in info.stdout
    week = fmu_data.test_weeks()[0]
    idx, U, m, v, y0, names_in, names_out, sv = fmu_setup(model, fmu_data.building, fmu_data, week)
    n = 96
    inp = pd.DataFrame(U[:n], columns=names_in)
    inp.insert(0, "time", np.arange(n) * 900.0)
    inp.to_csv(tmp_path / "in.csv", index=False)
    cmd = [
        "fmpy",
        "simulate",
        str(path),
        "--input-file",
        str(tmp_path / "in.csv"),
        "--output-interval",
        "900",
        "--stop-time",
        str((n - 1) * 900.0),
        "--output-file",
        str(tmp_path / "out.csv"),
        "--output-variables",
        *names_out,
        "--start-values",
    ]
    for k, val in sv.items():
        cmd += [k, str(val)]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr + run.stdout
    out = pd.read_csv(tmp_path / "out.csv")
    assert_allclose(out["time"], np.arange(n) * 900.0, rtol=0, atol=1e-6)
    Yref = reference(model, idx[:n], m[:n], v[:n], y0, week.season)
    assert_allclose(out[names_out].to_numpy(), Yref[:n], rtol=0, atol=1e-9)


@pytest.mark.parametrize("case", ["step", "input"])
def test_fmpy_simulate_exits_nonzero_on_a_refused_step(built, fmu_data, tmp_path, case):
    """`fmpy simulate` with a step the FMU refuses (a step size that is not a multiple of 900 s, or an
    airflow out of range at one row): exit 1 with the reason and the time on stderr, never a short CSV."""
    model, _, path = built["zones"]
    week = fmu_data.test_weeks()[0]
    idx, U, m, v, y0, names_in, names_out, sv = fmu_setup(model, fmu_data.building, fmu_data, week)
    n = 16
    inp = pd.DataFrame(U[:n], columns=names_in)
    inp.insert(0, "time", np.arange(n) * 900.0)
    if case == "input":
        inp.loc[10:, "m_VAV_NW_1"] = -0.5  # from t = 9000 s
    inp.to_csv(tmp_path / "in.csv", index=False)
    interval = "450" if case == "step" else "900"
    cmd = ["fmpy", "simulate", str(path), "--input-file", str(tmp_path / "in.csv"), "--output-interval", interval]
    cmd += ["--stop-time", str((n - 1) * 900.0), "--output-file", str(tmp_path / "out.csv")]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 1, (run.returncode, run.stderr[-3000:])
    assert "fmi2DoStep failed with status 4 (fatal)" in run.stderr, run.stderr[-3000:]
    if case == "step":
        assert "communication step 450.0 s at t=0.0 s is not a whole multiple of the model step 900 s" in run.stderr
    else:
        assert "at t=9000.0 s: invalid input value(s): m_VAV_NW_1=-0.5" in run.stderr, run.stderr[-3000:]
    assert not (tmp_path / "out.csv").exists()


def test_export_command_line_and_errors(built, tmp_path, cli):
    _, mp, _ = built["lumped"]
    ok = subprocess.run(
        [sys.executable, "-m", "hvacfmu.cli", "export", str(mp), "-o", str(tmp_path / "L.fmu")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert ok.returncode == 0, ok.stderr
    assert validate(tmp_path / "L.fmu") == []
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    run = cli("export", bad, "-o", tmp_path / "B.fmu")  # in-process: the refusal's message and exit code
    assert run.returncode == 2 and "not valid JSON" in run.stderr
    with pytest.raises(ModelError, match="newer than this hvacfmu"):
        d = json.loads(Path(mp).read_text())
        d["format_version"] = 99
        (tmp_path / "new.json").write_text(json.dumps(d))
        export_fmu(tmp_path / "new.json", tmp_path / "N.fmu")
    with pytest.raises(FMUError, match="must end in .fmu"):
        export_fmu(mp, tmp_path / "x.zip")


def test_crosstool_libcosimpy_matches_fmpy(built, fmu_data):
    """The same FMU in an independent importer (libcosimpy: OSP libcosim on the FMI Library) gives the same week."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    model, _, path = built["zones"]
    week = fmu_data.test_weeks()[0]
    idx, U, m, v, y0, names_in, names_out, sv = fmu_setup(model, fmu_data.building, fmu_data, week)
    s = Slave(path)
    try:
        s.init(sv, inputs=(names_in, U[0]))
        Y_fmpy = run_fmu(s, names_in, U, names_out)
        vr = dict(s.vr)
    finally:
        s.close()
    ex = CosimExecution.from_step_size(step_size=int(900e9))  # [ns]
    i = ex.add_local_slave(CosimLocalSlave(fmu_path=str(path), instance_name="zones"))
    man = CosimManipulator.create_override()
    ex.add_manipulator(man)
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    for k, val in sv.items():
        if isinstance(val, int):
            ex.integer_initial_value(i, vr[k], val)
        else:
            ex.real_initial_value(i, vr[k], float(val))
    vin, vout = [vr[n] for n in names_in], [vr[n] for n in names_out]
    Y = []
    for k in range(len(U)):
        man.slave_real_values(i, vin, list(U[k]))
        assert ex.step(1), f"libcosim step {k} failed"
        Y.append(obs.last_real_values(i, vout))
    assert_allclose(np.array(Y), Y_fmpy[1:], rtol=0, atol=EXACT)


def test_initial_state_of_unobserved_states(built, fmu_data):
    """Hidden states start at a steady state consistent with the start temperatures and first inputs."""
    y0 = np.array([20.5, 21.0, 21.5, 22.0, 21.2, 20.8])
    ext = built["extended"][0]
    u0 = np.linspace(0.3, 0.8, 6)
    v0 = np.array([15.0, 13.0, 50.0, 80.0, 200.0, 60.0])
    x0 = state_from_outputs(ext, y0, u0, v0, ext.gains["fall"][0])
    assert_allclose(ext.output(x0), y0, rtol=0, atol=1e-12)
    names = ext.state_names
    delayed = [i for i, n in enumerate(names) if n.startswith("u_E_lag")]
    assert len(delayed) == 2
    assert_allclose(x0[delayed], u0[ext.outputs.index("E")], rtol=0, atol=1e-9)  # delayed airflow = airflow
    phys = built["physics"][0]
    xp = state_from_outputs(phys, y0, np.full(21, 0.3), v0, phys.gains["fall"][0])
    assert_allclose(phys.output(xp), y0, rtol=0, atol=1e-9)
    assert np.all((xp > 5.0) & (xp < 35.0))  # walls between outdoor and zone temperatures, not arbitrary


def test_time_of_week_input_follows_daylight_saving(built):
    """Over the end of DST the gains follow local time when the master feeds `time_of_week`."""
    from hvacfmu.timeutil import seconds_of_week

    model, _, path = built["zones"]
    idx = pd.date_range("2025-10-27", periods=672, freq="15min", tz="America/Los_Angeles")  # DST ends Nov 2
    rng = np.random.default_rng(5)
    m = rng.uniform(0.05, 0.6, (672, len(model.vavs)))
    v = np.column_stack([rng.uniform(5, 25, 672), rng.uniform(12, 15, 672), rng.uniform(0, 300, (672, 4))])
    y0 = np.full(6, 21.0)
    tow = seconds_of_week(idx).astype(float)
    names_in = [f"m_{b}" for b in model.vavs] + list(model.disturbances)
    names_out = [f"T_{z}" for z in model.outputs]
    sv = {"season": 1, "start_time_of_week": float(tow[0])}
    Yref = reference(model, idx, m, v, y0, "fall")
    runs = {}
    for clock in (True, False):
        s = Slave(path, f"dst{clock}")
        try:
            U = np.column_stack([m, v, tow]) if clock else np.hstack([m, v])
            names = names_in + ["time_of_week"] if clock else names_in
            s.init(sv, inputs=(names, U[0]))
            runs[clock] = run_fmu(s, names, U, names_out)
        finally:
            s.close()
    assert_allclose(runs[True], Yref, rtol=0, atol=EXACT)
    assert np.abs(runs[False] - Yref).max() > 1e-3  # the FMU clock alone does not know DST


def calendar_model(building, seed=4, dates=("2025-10-29",)):
    """Extended model with calendar terms: a holiday (Sunday profile) and a daylight-saving shift."""
    from hvacfmu.models.extended import ExtendedModel, InternalGainSchedule, ThermalMass

    nz = len(building.zone_names)
    return ExtendedModel(
        base=zones_model(building, seed=seed),
        terms=(
            InternalGainSchedule(
                variant="holiday", zone_names=building.zone_names, coef=(1.0,) * nz, dates=tuple(dates), ref_weekday=6
            ),
            InternalGainSchedule(
                variant="dst_shift", zone_names=building.zone_names, coef=tuple(np.linspace(0.5, 1.0, nz)), shift=4
            ),
            ThermalMass(zone="C", alpha=0.02, beta=0.05),
        ),
    )


def test_a_plain_model_with_a_holiday_calendar_fmu_follows_it(fmu_data, tmp_path):
    """A zones model carrying the data's holidays (hvacfmu.data.holidays): its pythonfmu FMU gets start_time and
    reads Sunday's gains on the holiday, equal to the Python model; the native export warns that it cannot."""
    import dataclasses

    from hvacfmu.fmu_native import native_equations
    from hvacfmu.fmu_slave import calendar_dependent

    building = fmu_data.building
    tz = building.timezone
    base = calendar_model(building).base
    model = dataclasses.replace(base, holidays=("2025-10-29",))
    assert calendar_dependent(model) and not calendar_dependent(base)
    native_equations(model)  # not refused: the calendar is the master's (a warning at export, below)
    path = export_fmu(model.save(tmp_path / "holiday.json"), tmp_path / "holiday.fmu", timezone=tz)
    idx = pd.date_range("2025-10-27", periods=288, freq="15min", tz=tz)  # Mon..Wed, the holiday last
    rng = np.random.default_rng(7)
    m = rng.uniform(0.05, 0.6, (288, len(building.vav_names)))
    v = np.column_stack([rng.uniform(5, 25, 288), rng.uniform(12, 15, 288), rng.uniform(0, 300, (288, 4))])
    y0 = np.full(len(model.outputs), 21.0)
    names_in = [f"m_{b}" for b in building.vav_names] + list(model.disturbances)
    names_out = [f"T_{z}" for z in model.outputs]
    U = np.hstack([m, v])
    Yref = reference(model, idx, m, v, y0, "fall")
    assert np.abs(Yref - reference(base, idx, m, v, y0, "fall")).max() > 1e-2  # the holiday matters
    s = Slave(path, "holiday")
    try:
        s.init(
            {
                "season": list(model.gains).index("fall") + 1,
                "start_time_of_week": 0.0,
                "start_time": idx[0].timestamp(),
            },
            inputs=(names_in, U[0]),
        )
        Y = run_fmu(s, names_in, U, names_out)
    finally:
        s.close()
    assert_allclose(Y, Yref, rtol=0, atol=EXACT)
    with pytest.warns(HvacfmuWarning, match="time_of_week input to Sunday"):
        export_native_fmu(model, tmp_path / "holiday_native.fmu", building=building)


def test_calendar_model_fmu_follows_holidays_and_dst(fmu_data, tmp_path, cli):
    """An extended model with holiday and DST terms: with `start_time` the FMU equals the Python model."""
    from hvacfmu.fmu_slave import calendar_dependent

    building = fmu_data.building
    tz = building.timezone
    model = calendar_model(building)
    assert calendar_dependent(model) and not calendar_dependent(extended_model(building))
    mp = model.save(tmp_path / "calendar.json")
    path = export_fmu(mp, tmp_path / "calendar.fmu", timezone=tz)
    assert validate(path) == []
    with zipfile.ZipFile(path) as z:
        assert json.loads(z.read("resources/interface.json"))["timezone"] == tz
    # without a time zone: a warning, and no start_time parameter
    with pytest.warns(HvacfmuWarning, match="depend on the calendar.*--timezone"):
        plain = export_fmu(mp, tmp_path / "plain.fmu")
    with pytest.raises(FMUError, match="unknown time zone 'Mars/Olympus'"):
        export_fmu(mp, tmp_path / "bad.fmu", timezone="Mars/Olympus")
    run = cli("export", mp, "-o", tmp_path / "cli.fmu", "--timezone", tz)  # in-process (the option's path)
    assert run.returncode == 0, run.stderr
    with zipfile.ZipFile(tmp_path / "cli.fmu") as z:
        assert json.loads(z.read("resources/interface.json"))["timezone"] == tz

    # a week with the holiday (Wed 2025-10-29) and the end of DST (Sun 2025-11-02), in the fall season
    idx = pd.date_range("2025-10-27", periods=672, freq="15min", tz=tz)
    rng = np.random.default_rng(6)
    m = rng.uniform(0.05, 0.6, (672, len(building.vav_names)))
    v = np.column_stack([rng.uniform(5, 25, 672), rng.uniform(12, 15, 672), rng.uniform(0, 300, (672, 4))])
    y0 = np.full(len(model.outputs), 21.0)
    season = "fall"
    names_in = [f"m_{b}" for b in building.vav_names] + list(model.disturbances)
    names_out = [f"T_{z}" for z in model.outputs]
    U = np.hstack([m, v])
    Yref = reference(model, idx, m, v, y0, season)
    sv = {
        "season": list(model.gains).index(season) + 1,
        "start_time_of_week": 0.0,  # ignored with start_time
        "start_time": idx[0].timestamp(),
    }
    runs = {}
    for name, fmu, values in (
        ("calendar", path, sv),
        ("unset", path, {**sv, "start_time": -1.0}),
        ("plain", plain, {k: x for k, x in sv.items() if k != "start_time"}),
    ):
        s = Slave(fmu, name)
        try:
            if name != "calendar":
                from hvacfmu.timeutil import seconds_of_week

                values["start_time_of_week"] = float(seconds_of_week(idx[:1])[0])
            s.init(values, inputs=(names_in, U[0]))
            runs[name] = run_fmu(s, names_in, U, names_out)
            if name == "unset":
                assert any(st == "warning" and "start_time is not set" in msg for st, _, msg in s.log)
        finally:
            s.close()
    assert_allclose(runs["calendar"], Yref, rtol=0, atol=EXACT)
    q_plain = LinearZoneModel.gains_at(model.base, idx, season)
    assert np.abs(model.gains_at(idx, season) - q_plain).max() > 0.1  # the calendar terms change the gains
    for name in ("unset", "plain"):  # the time-of-week profile alone misses the holiday and DST terms
        assert np.abs(runs[name] - Yref).max() > 1e-2
    assert_allclose(runs["unset"], runs["plain"], rtol=0, atol=EXACT)

    # the serialised state mid-week, restored into a fresh instance, continues on the calendar exactly
    k_mid = 300
    s = Slave(path, "calendar_a")
    try:
        s.init(sv, inputs=(names_in, U[0]))
        run_fmu(s, names_in, U[:k_mid], names_out)
        blob = s.fmu.serializeFMUstate(s.fmu.getFMUstate())
    finally:
        s.close()
    fresh = Slave(path, "calendar_b")
    try:
        fresh.init({**sv, "start_time": 0.0}, inputs=(names_in, U[0]))  # the state brings its own start_time
        fresh.fmu.setFMUstate(fresh.fmu.deSerializeFMUstate(blob))
        Y2 = run_fmu(fresh, names_in, U[k_mid:], names_out, k0=k_mid)
    finally:
        fresh.close()
    assert_allclose(Y2, Yref[k_mid:], rtol=0, atol=EXACT)


def test_cosim_sets_start_time_of_calendar_fmu(fmu_data, tmp_path):
    """run_cosim gives a calendar FMU its start_time: a replayed week with a holiday equals the Python model."""
    from harness.controllers import ReplayController
    from harness.cosim import run_cosim

    week = fmu_data.test_weeks()[0]
    holiday = (week.start + pd.Timedelta(days=2)).date().isoformat()
    model = calendar_model(fmu_data.building, dates=(holiday,))
    path = export_fmu(
        model.save(tmp_path / "calendar.json"), tmp_path / "calendar.fmu", timezone=fmu_data.building.timezone
    )
    # no warm-up: the comparison starts both from state_from_outputs at the first row (an extended model's extra
    # states would otherwise be warmed up a week by default, harness.cosim._unset_states)
    r = run_cosim(path, fmu_data, ReplayController(), week=week.number, model=model, warmup=0.0)
    rows = r.table.iloc[:-1]
    u, v = model.signals(rows)
    q = model.gains_at(rows.index, week.season)
    assert np.abs(q - LinearZoneModel.gains_at(model.base, rows.index, week.season)).max() > 0.1
    y0 = r.table[[f"T_{z}" for z in model.outputs]].iloc[0].to_numpy()
    _, Y = model.simulate(state_from_outputs(model, y0, u[0], v[0], q[0]), u, v, q)
    assert_allclose(r.table[[f"T_{z}" for z in model.outputs]].to_numpy(), Y, rtol=0, atol=EXACT)
    # left unset, the FMU warns at initialisation, which the harness refuses
    with pytest.raises(FMUError, match="start_time is not set"):
        run_cosim(path, fmu_data, ReplayController(), week=week.number, model=model, start_values={"start_time": -1.0})


def test_calendar_export_takes_the_building_files_time_zone(fmu_data, tmp_path):
    """Fourth EnergyPlus round: `diagnose --control-output` found a holiday in the restaurant's data, and
    `hvacfmu export ctl.json -b building.toml` warned that the FMU would ignore it for want of --timezone, although the
    building file names the site's zone; the native export's refusal sent the user to --timezone too."""
    model = calendar_model(fmu_data.building)
    mp = model.save(tmp_path / "calendar.json")
    with warnings.catch_warnings():
        warnings.simplefilter("error", HvacfmuWarning)  # no "without a time zone" warning
        path = export_fmu(mp, tmp_path / "calendar.fmu", building=fmu_data.building)
    with zipfile.ZipFile(path) as z:
        layout = json.loads(z.read("resources/interface.json"))
    assert layout["timezone"] == fmu_data.building.timezone
    assert any(v["name"] == "start_time" for v in layout["variables"])


# ----------------------------------------------------------------------------- slave scripts
def test_slave_scripts_in_fmus_are_the_template():
    """fmus/*.py are exactly what hvacfmu.fmu writes when installed without the source tree."""
    from hvacfmu.fmu import slave_source, slave_specs

    SLAVE_SPECS = slave_specs()

    folder = Path(__file__).resolve().parents[1] / "fmus"
    assert sorted(p.stem for p in folder.glob("*.py")) == sorted(SLAVE_SPECS)
    for name in SLAVE_SPECS:
        assert (folder / f"{name}.py").read_text(encoding="utf-8") == slave_source(name), name


def test_export_without_source_tree(tmp_path, monkeypatch, sdh_building, fmu_data):
    """An installation without fmus/ writes the slave scripts into the cache and still exports."""
    import hvacfmu.fmu as fmu_mod

    monkeypatch.delenv("HVACFMU_SLAVE_DIR", raising=False)
    monkeypatch.setenv("HVACFMU_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(fmu_mod, "__file__", str(tmp_path / "site-packages" / "hvacfmu" / "fmu.py"))
    folder = fmu_mod.slave_dir()
    assert folder.is_relative_to(tmp_path / "cache")
    model_path = zones_model(sdh_building).save(tmp_path / "zones.json")
    out = export_fmu(model_path, tmp_path / "zones.fmu")
    assert validate(out) == []
    monkeypatch.setenv("HVACFMU_SLAVE_DIR", str(tmp_path / "nowhere"))
    with pytest.raises(FMUError, match="holds no slave scripts"):
        fmu_mod.slave_dir()


# ----------------------------------------------------------------------------- model descriptions users can trust
@pytest.mark.parametrize("kind", ["zones", "physics"])
def test_types_bounds_and_documentation(built, kind):
    """TypeDefinitions with quantity, declaredType everywhere, box bounds from the building, documentation."""
    from fmpy import read_model_description

    model, _, path = built[kind]
    md = read_model_description(str(path))
    types = {t.name: t for t in md.typeDefinitions}
    assert types["Temperature"].quantity == "ThermodynamicTemperature" and types["MassFlowRate"].unit == "kg/s"
    for v in md.modelVariables:
        assert v.declaredType is not None and v.declaredType.name in types, v.name
        if v.causality in ("input", "parameter"):
            assert v.start is not None, v.name
    names = {v.name: v for v in md.modelVariables}
    assert float(names["T_out"].min) == -60.0 and float(names["T_out"].max) == 60.0
    if kind == "physics":  # the model carries its building: 1.2 x m_max, nominal m_max, zone named
        for vav in model.building.vavs:
            v = names[f"m_{vav.name}"]
            assert float(v.max) == pytest.approx(1.2 * vav.m_max) and float(v.nominal) == vav.m_max
            assert f"serving zone {vav.zone}" in v.description
    with zipfile.ZipFile(path) as z:
        doc = z.read("documentation/index.html").decode()
    from importlib.metadata import version

    assert f"numpy {version('numpy')}" in doc and "hvacfmu" in doc


def test_export_with_building_file_bounds_the_box_inputs(built, fmu_data, tmp_path):
    """A data-driven model file keeps no box limits; `--building` puts them into the model description."""
    from fmpy import read_model_description

    _, mp, _ = built["zones"]
    path = export_fmu(mp, tmp_path / "Z.fmu", building=fmu_data.building)
    names = {v.name: v for v in read_model_description(str(path)).modelVariables}
    for vav in fmu_data.building.vavs:
        assert float(names[f"m_{vav.name}"].max) == pytest.approx(1.2 * vav.m_max)
    generic = {v.name: v for v in read_model_description(str(built["zones"][2])).modelVariables}
    assert float(generic[f"m_{fmu_data.building.vavs[0].name}"].max) == 50.0
    s = Slave(path)  # the FMU runs with its stored limits and refuses more than 1.2 x m_max
    try:
        s.init({"season": 1})
        vav = fmu_data.building.vavs[0]
        s.fmu.setReal([s.vr[f"m_{vav.name}"]], [1.3 * vav.m_max])
        with pytest.raises(Exception, match=r"status 4 \(fatal\)"):
            s.fmu.doStep(0.0, 900.0)
        assert any(f"m_{vav.name}=" in msg and "invalid input" in msg for _, _, msg in s.log)
    finally:
        s.close()


def test_pythonfmu_fmu_without_its_python_packages_says_so(built, tmp_path):
    """Loaded where hvacfmu cannot be imported, the FMU refuses to instantiate and says what it needs: in the
    FMU log, and on stderr for `fmpy simulate` (exit 1), whose FMU log is off; the host does not crash."""
    _, _, path = built["zones"]
    script = tmp_path / "host.py"
    script.write_text(
        "import sys\n"
        "sys.modules['hvacfmu'] = None  # as if hvacfmu were not installed in this interpreter\n"
        "from fmpy import simulate_fmu\n"
        "msgs = []\n"
        "def logger(*args):\n"
        "    msgs.append(args[-1].decode() if isinstance(args[-1], bytes) else str(args[-1]))\n"
        "try:\n"
        f"    simulate_fmu({str(path)!r}, stop_time=1800.0, output_interval=900.0, logger=logger,\n"
        "                 debug_logging=True)\n"
        "except Exception as exc:\n"
        "    print('EXC', exc)\n"
        "print('\\n'.join(msgs))\n"
    )
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "EXC Failed to instantiate" in run.stdout, run.stdout + run.stderr
    assert "needs the Python packages hvacfmu, numpy" in run.stdout, run.stdout + run.stderr
    assert "hvacfmu export --native" in run.stdout
    cli = (
        "import sys\n"
        "sys.modules['hvacfmu'] = None\n"
        "from fmpy.cli import main\n"
        f"sys.argv = ['fmpy', 'simulate', {str(path)!r}, '--output-interval', '900', '--stop-time', '1800']\n"
        "main()\n"
    )
    run = subprocess.run([sys.executable, "-c", cli], capture_output=True, text=True, timeout=300)
    assert run.returncode == 1, (run.returncode, run.stderr[-2000:])
    assert "needs the Python packages hvacfmu, numpy" in run.stderr and "Failed to instantiate" in run.stderr


@pytest.mark.parametrize("kind", ["zones", "physics"])
def test_fmpy_simulate_without_solar_inputs(built, fmu_data, tmp_path, kind):
    """`fmpy simulate` with an input file that has no facade irradiance columns: those inputs keep their
    start value (0 W/m2, no sun) and the run covers the requested time, as the README documents."""
    model, _, path = built[kind]
    week = fmu_data.test_weeks()[0]
    idx, U, m, v, y0, names_in, names_out, sv = fmu_setup(model, fmu_data.building, fmu_data, week)
    n = 48
    keep = [c for c in names_in if not c.startswith("I_")]
    inp = pd.DataFrame(U[:n], columns=names_in)[keep]
    inp.insert(0, "time", np.arange(n) * 900.0)
    inp.to_csv(tmp_path / "in.csv", index=False)
    cmd = [
        "fmpy",
        "simulate",
        str(path),
        "--input-file",
        str(tmp_path / "in.csv"),
        "--output-interval",
        "900",
        "--stop-time",
        str((n - 1) * 900.0),
        "--output-file",
        str(tmp_path / "out.csv"),
        "--start-values",
    ]
    for k, val in sv.items():
        cmd += [k, str(val)]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr + run.stdout
    out = pd.read_csv(tmp_path / "out.csv")
    assert len(out) == n and out["time"].iloc[-1] == (n - 1) * 900.0
    dark = v.copy()
    dark[:, [list(model.disturbances).index(d) for d in model.disturbances if d.startswith("I_")]] = 0.0
    Yref = reference(model, idx[:n], m[:n], dark[:n], y0, week.season)
    assert_allclose(out[names_out].to_numpy(), Yref[:n], rtol=0, atol=1e-9)


def test_fmu_exported_with_other_descriptions_runs(built, tmp_path):
    """A pythonfmu FMU runs with the host's hvacfmu, which checks ``resources/model.json`` against the variables
    of ``interface.json``. It compared the descriptions and units too, so an FMU exported before a wording change
    (round 2 of fleet sweep s10: the reheat heat input ``Qrh_<zone>`` gained a unit and a description) was refused
    at initialisation with "does not match the FMU's variables ...; was the file replaced?". Documentation no
    longer counts; a different variable (a replaced model) still does."""
    _, _, path = built["zones"]
    with zipfile.ZipFile(path) as z:
        d = json.loads(z.read("resources/interface.json"))
    d["description"] = "older wording"
    for e in d["variables"]:
        e["description"] = "older wording of " + e["name"]
        e["unit"] = None if e.get("unit") == "W/m2" else e.get("unit")
    old = _rewrite(path, tmp_path / "old.fmu", "resources/interface.json", json.dumps(d))
    s = Slave(old)
    try:
        s.init()
        s.fmu.doStep(0.0, 900.0)
        assert not any(status in ("error", "fatal") for status, _, _ in s.log)
    finally:
        s.close()
