"""Native FMUs (generated C, no Python at run time): exactness over a year, model description, a C master
without hvacfmu, bad input, state, rebuilding from the sources, the command line.

FMUs are built once per session (about 1 s each; the physics model's 269 states about 5 s).
"""

from __future__ import annotations

import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from test_fmu import calendar_model, extended_model, lumped_model, physics_model, zones_model

from hvacfmu.errors import FMUError
from hvacfmu.fmu import validate
from hvacfmu.fmu_native import export_native_fmu, native_identifier
from hvacfmu.fmu_slave import box_names, state_from_outputs
from hvacfmu.models.linear import LinearZoneModel

EXACT = 1e-9  # [K] native FMU vs Python model
STEP = 900.0  # [s]
MASTER = Path(__file__).parent / "data" / "fmi2_master.c"

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs the system C compiler gcc")


@pytest.fixture(scope="session")
def sdh():
    from hvacfmu.emulator import sdh_building

    return sdh_building(nominal=True)


@pytest.fixture(scope="session")
def native(tmp_path_factory, sdh):
    """kind -> (model, native FMU path), each built once."""
    d = tmp_path_factory.mktemp("native")
    models = {
        "lumped": lumped_model(sdh),
        "zones": zones_model(sdh),
        "physics": physics_model(sdh),
        "extended": extended_model(sdh),
    }
    return {k: (m, export_native_fmu(m, d / f"{k}.fmu")) for k, m in models.items()}


def signals(model, n, seed=5):
    """Smooth daily/yearly inputs with noise: (index, columns dict, m (n, nb), v (n, nv))."""
    rng = np.random.default_rng(seed)
    idx = pd.date_range("2025-01-06", periods=n, freq="900s", tz="UTC")  # a Monday 00:00, no DST in UTC
    t = np.arange(n) * STEP
    vavs = box_names(model)
    day = 2 * np.pi * t / 86400.0
    m = np.clip(
        0.25 + 0.1 * np.sin(day[:, None] + np.arange(len(vavs))) + 0.05 * rng.standard_normal((n, len(vavs))), 0.0, 0.5
    )
    cols = {}
    for d in model.disturbances:
        if d == "T_out":
            cols[d] = 12 + 8 * np.sin(day) + 5 * np.sin(2 * np.pi * t / (365 * 86400.0))
        elif d.startswith("T_"):
            cols[d] = 14 + 2 * np.sin(2 * np.pi * t / 3e5)
        else:
            cols[d] = np.clip(400 * np.sin(day + 0.3 * rng.standard_normal()), 0, None)
    v = np.column_stack([cols[d] for d in model.disturbances])
    return idx, {**{f"m_{b}": m[:, j] for j, b in enumerate(vavs)}, **cols}, m, v


def reference(model, idx, cols, season, y0):
    """The Python model's outputs at the n+1 instants 0 .. n steps, started like the FMU."""
    u, v = model.signals(pd.DataFrame(cols, index=idx))
    q = model.gains_at(idx, season)
    _, Y = model.simulate(state_from_outputs(model, y0, u[0], v[0], q[0]), u, v, q)
    return Y


def start_values(model, season_index=2, T0=21.0):
    sv = {f"T_{z}_start": T0 for z in model.outputs}
    sv.update(season=season_index, start_time_of_week=0.0)
    return sv


def simulate_year(model, path, n):
    from fmpy import simulate_fmu

    idx, cols, _, _ = signals(model, n)
    sig = np.zeros(n, dtype=[("time", float)] + [(c, float) for c in cols])
    sig["time"] = np.arange(n) * STEP
    for c, x in cols.items():
        sig[c] = x
    res = simulate_fmu(
        str(path),
        start_time=0.0,
        stop_time=(n - 1) * STEP,
        output_interval=STEP,
        input=sig,
        start_values=start_values(model),
        output=[f"T_{z}" for z in model.outputs],
    )
    Y = np.column_stack([res[f"T_{z}"] for z in model.outputs])
    Yref = reference(model, idx, cols, list(model.gains)[1], np.full(len(model.outputs), 21.0))
    return Y, Yref


# ----------------------------------------------------------------------------- exactness
@pytest.mark.slow  # about 8 s of CPU for the three linear kinds: the 8-day check below stays in the fast tier
@pytest.mark.parametrize("kind", ["lumped", "zones", "extended", "physics"])
def test_year_in_fmpy_matches_python_model(native, kind):
    """A year (35,040 steps) through fmpy.simulate_fmu equals the Python model to 1e-9 K."""
    model, path = native[kind]
    n = 35040
    Y, Yref = simulate_year(model, path, n)
    assert Y.shape == (n, len(model.outputs))
    assert_allclose(Y, Yref[:n], rtol=0, atol=EXACT)
    assert np.ptp(Yref) > 5.0  # the trajectory moves: the comparison is not trivial


@pytest.mark.parametrize("kind", ["lumped", "zones", "extended", "physics"])
def test_eight_days_in_fmpy_match_python_model(native, kind):
    """Eight days (768 steps: the gain table wraps from the last slot of the week to the first) equal the
    Python model to 1e-9 K; physics: the 269-state bilinear model (hidden wall states at their steady state).
    The fast tier's form of the year test above (slow tier)."""
    model, path = native[kind]
    n = 768
    Y, Yref = simulate_year(model, path, n)
    assert Y.shape == (n, len(model.outputs))
    assert_allclose(Y, Yref[:n], rtol=0, atol=EXACT)
    assert np.ptp(Yref) > 1.0


# ----------------------------------------------------------------------------- model description
@pytest.mark.parametrize("kind", ["lumped", "zones", "physics", "extended"])
def test_validate_description_and_contents(native, kind):
    from fmpy import read_model_description

    model, path = native[kind]
    assert validate(path) == []
    md = read_model_description(str(path))
    cs = md.coSimulation
    assert cs.modelIdentifier == native_identifier(kind)
    assert cs.canGetAndSetFMUstate and cs.canSerializeFMUstate and not cs.canHandleVariableCommunicationStepSize
    assert not cs.needsExecutionTool
    assert md.buildConfigurations[0].sourceFileSets[0].sourceFiles == ["hvacfmu_native.c"]
    types = {t.name: t for t in md.typeDefinitions}
    assert types["Temperature"].quantity == "ThermodynamicTemperature" and types["Temperature"].unit == "degC"
    assert types["MassFlowRate"].unit == "kg/s"
    for v in md.modelVariables:
        assert v.declaredType is not None and v.declaredType.name in types, v.name
        assert v.description
        if v.causality in ("input", "parameter"):
            assert v.start is not None, v.name
    names = {v.name: v for v in md.modelVariables}
    for b in box_names(model):
        assert names[f"m_{b}"].unit == "kg/s" and b in names[f"m_{b}"].description
    with zipfile.ZipFile(path) as z:
        files = set(z.namelist())
        doc = z.read("documentation/index.html").decode()
    assert {
        "sources/hvacfmu_native.c",
        "sources/hvacfmu_model.h",
        f"binaries/linux64/{cs.modelIdentifier}.so",
        "documentation/index.html",
    } <= files
    assert {f for f in files if f.startswith("resources/")} == {"resources/interface.json"}  # data, no code
    assert not any(f.endswith((".py", ".pyc")) for f in files)
    assert "no Python" in doc


def test_binary_does_not_need_python(native, tmp_path):
    """The shared library links only the C library (no libpython, no libm)."""
    if shutil.which("readelf") is None:
        pytest.skip("readelf not available")
    _, path = native["physics"]
    with zipfile.ZipFile(path) as z:
        z.extractall(tmp_path)
    lib = next((tmp_path / "binaries" / "linux64").glob("*.so"))
    dyn = subprocess.run(["readelf", "-d", str(lib)], capture_output=True, text=True, check=True).stdout
    needed = [line.split("[")[1].rstrip("]") for line in dyn.splitlines() if "(NEEDED)" in line]
    assert needed and all(n.startswith("libc.so") for n in needed), needed


# ----------------------------------------------------------------------------- a C master without hvacfmu
def run_c_master(tmp_path, path, model, n, U, names_in):
    """Compile tests/data/fmi2_master.c and run it on the FMU's binary in an environment without Python paths."""
    from fmpy import read_model_description

    exe = tmp_path / "master"
    subprocess.run(["gcc", "-std=c99", "-O2", "-o", str(exe), str(MASTER), "-ldl"], check=True, timeout=120)
    unz = tmp_path / "fmu"
    with zipfile.ZipFile(path) as z:
        z.extractall(unz)
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    outs = [f"T_{z}" for z in model.outputs]
    lib = unz / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
    stdin = "\n".join(" ".join(repr(float(x)) for x in row) for row in U)
    cmd = [
        "env",
        "-i",
        "PATH=/usr/bin:/bin",
        str(exe),
        str(lib),
        md.guid,
        str(n),
        str(STEP),
        str(len(names_in)),
        str(len(outs)),
    ] + [str(vr[x]) for x in names_in + outs]
    run = subprocess.run(cmd, input=stdin, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    return np.array([[float(x) for x in line.split()] for line in run.stdout.splitlines()]), run.stderr


@pytest.mark.parametrize("kind", ["zones", "physics"])
def test_c_master_without_python_matches_python_model(native, tmp_path, kind):
    """A C program (no Python, env -i) runs 300 steps of the FMU: the Python model's numbers to 1e-9 K.

    The zone model's start values are the FMU defaults (21 degC, season 1, Monday 00:00).
    """
    model, path = native[kind]
    n = 300
    idx, cols, m, v = signals(model, n, seed=11)
    names_in = list(cols)
    U = np.column_stack([cols[c] for c in names_in])
    Y, err = run_c_master(tmp_path, path, model, n, U, names_in)
    Yref = reference(model, idx, cols, list(model.gains)[0], np.full(len(model.outputs), 21.0))
    assert Y.shape == (n + 1, len(model.outputs))
    assert_allclose(Y, Yref, rtol=0, atol=EXACT)
    assert np.ptp(Yref) > 0.5
    assert "us_per_step" in err


def header(path) -> str:
    with zipfile.ZipFile(path) as z:
        return z.read("sources/hvacfmu_model.h").decode()


def test_physics_runs_in_modal_form_small_models_in_physical_form(native):
    assert "#define HV_MODAL 1" in header(native["physics"][1])
    for kind in ("lumped", "zones", "extended"):
        assert "#define HV_MODAL 0" in header(native[kind][1])


@pytest.mark.slow
def test_modal_and_physical_physics_fmus_agree(native, tmp_path):
    """The physics FMU in physical form (dense A, modal=False) gives the modal FMU's numbers in the C master."""
    model, path = native["physics"]
    plain = export_native_fmu(model, tmp_path / "plain.fmu", modal=False)
    assert "#define HV_MODAL 0" in header(plain)
    n = 300
    idx, cols, _, _ = signals(model, n, seed=11)
    names_in = list(cols)
    U = np.column_stack([cols[c] for c in names_in])
    (tmp_path / "m").mkdir()
    (tmp_path / "p").mkdir()
    Ym, _ = run_c_master(tmp_path / "m", path, model, n, U, names_in)
    Yp, _ = run_c_master(tmp_path / "p", plain, model, n, U, names_in)
    assert_allclose(Ym, Yp, rtol=0, atol=EXACT)
    assert np.ptp(Yp) > 0.5


# ----------------------------------------------------------------------------- behaviour
class Native:
    """A native FMU through FMPy's FMU2Slave with logging captured."""

    def __init__(self, path, name="test"):
        from harness.cosim import FMUInstance

        self.inst = FMUInstance(path, instance_name=name)
        self.fmu = self.inst.fmu
        self.vr = {n: v.vr for n, v in self.inst.vars.items()}
        self.log = self.inst.log

    def init(self, sv, inputs=None):
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for k, val in sv.items():
            if k == "season":
                self.fmu.setInteger([self.vr[k]], [int(val)])
            else:
                self.fmu.setReal([self.vr[k]], [float(val)])
        if inputs is not None:
            self.fmu.setReal([self.vr[n] for n in inputs[0]], list(inputs[1]))
        self.fmu.exitInitializationMode()

    def run(self, names_in, U, names_out, k0=0):
        vin, vout = [self.vr[n] for n in names_in], [self.vr[n] for n in names_out]
        Y = [self.fmu.getReal(vout)]
        for k, row in enumerate(U):
            self.fmu.setReal(vin, [float(x) for x in row])
            self.fmu.doStep((k0 + k) * STEP, STEP)
            Y.append(self.fmu.getReal(vout))
        return np.array(Y)

    def close(self):
        self.inst.close()


def test_state_serialised_and_restored_in_a_fresh_instance(native):
    model, path = native["physics"]
    idx, cols, _, _ = signals(model, 200, seed=3)
    names_in, names_out = list(cols), [f"T_{z}" for z in model.outputs]
    U = np.column_stack([cols[c] for c in names_in])
    sv = start_values(model)
    a = Native(path, "a")
    try:
        a.init(sv, (names_in, U[0]))
        a.run(names_in, U[:120], names_out)
        blob = a.fmu.serializeFMUstate(a.fmu.getFMUstate())
        Y2 = a.run(names_in, U[120:], names_out, k0=120)
    finally:
        a.close()
    b = Native(path, "b")
    try:
        b.init(sv, (names_in, U[0]))
        b.fmu.setFMUstate(b.fmu.deSerializeFMUstate(blob))
        Y2b = b.run(names_in, U[120:], names_out, k0=120)
    finally:
        b.close()
    assert_allclose(Y2b, Y2, rtol=0, atol=0)


def test_multi_steps_exact_and_bad_steps_and_inputs_refused(native):
    model, path = native["zones"]
    _, cols, _, _ = signals(model, 4, seed=2)
    names_in, names_out = list(cols), [f"T_{z}" for z in model.outputs]
    row = [float(cols[c][0]) for c in names_in]
    a, b = Native(path, "a"), Native(path, "b")
    try:
        a.init(start_values(model))
        b.init(start_values(model))
        Ya = a.run(names_in, [row] * 4, names_out)
        b.fmu.setReal([b.vr[n] for n in names_in], row)
        b.fmu.doStep(0.0, 4 * STEP)  # one communication step of 4 model steps
        assert_allclose(b.fmu.getReal([b.vr[n] for n in names_out]), Ya[-1], rtol=0, atol=0)
        before = b.fmu.getReal([b.vr[n] for n in names_out])
        for h in (450.0, 1000.0, 0.0, float("nan")):
            with pytest.raises(Exception, match="error"):
                b.fmu.doStep(3600.0, h)
        assert any("not a whole multiple of the model step 900 s" in msg for _, _, msg in b.log)
        with pytest.raises(Exception, match="error"):
            b.fmu.doStep(7200.0, STEP)
        assert any("steps must be contiguous" in msg for _, _, msg in b.log)
        vr_m = b.vr[names_in[0]]
        for bad in (float("nan"), -0.1, 1e3):
            b.fmu.setReal([vr_m], [bad])
            with pytest.raises(Exception, match="error"):
                b.fmu.doStep(3600.0, STEP)
        assert any(f"invalid input value(s): {names_in[0]}=nan" in msg for _, _, msg in b.log)
        assert b.fmu.getReal([b.vr[n] for n in names_out]) == before  # refused steps change nothing
        b.fmu.setReal([vr_m], [row[0]])
        with pytest.raises(Exception, match="error"):
            b.fmu.setReal([b.vr[f"T_{model.outputs[0]}_start"]], [25.0])  # fixed parameter after init
        b.fmu.doStep(3600.0, STEP)  # still usable
    finally:
        a.close()
        b.close()


def test_time_of_week_input_places_the_gains_of_each_step_as_in_the_pythonfmu_fmu(native):
    """The ``time_of_week`` input is the local time of week at the start of each step. The native runtime added
    the step count to it (slot = floor(tow/step) + k), so from the second step on the gains ran k slots ahead:
    1.5-2 K off the pythonfmu FMU in `hvacfmu cosim`, which always sets the input (fleet sweep s10, b000).
    Fed consistently with the clock it must change nothing; shifted by 3 h it equals the clock run started 3 h later."""
    from fmpy import simulate_fmu

    model, path = native["zones"]
    n = 24
    _, cols, _, _ = signals(model, n + 1, seed=4)
    t = np.arange(n + 1) * STEP

    def run(tow_input, tow_start):
        sig = np.zeros(n + 1, dtype=[("time", float)] + [(c, float) for c in cols] + [("time_of_week", float)])
        sig["time"] = t
        for c, x in cols.items():
            sig[c] = x
        sig["time_of_week"] = tow_input
        sv = {**start_values(model), "start_time_of_week": tow_start}
        res = simulate_fmu(str(path), stop_time=n * STEP, output_interval=STEP, input=sig, start_values=sv)
        return np.column_stack([res[f"T_{z}"] for z in model.outputs])

    clock = run(-1.0, 7200.0)
    assert_allclose(run(7200.0 + t, 0.0), clock, rtol=0, atol=1e-12)
    assert_allclose(run(7200.0 + t, 7200.0), clock, rtol=0, atol=1e-12)
    assert np.abs(run(-1.0, 0.0) - clock).max() > 1e-3  # the gains do depend on the time of week


def test_bad_parameters_fail_initialisation_with_a_reason(native):
    model, path = native["lumped"]
    s = Native(path)
    try:
        with pytest.raises(Exception, match="error"):
            s.init({**start_values(model), "season": 9, "T_floor_start": float("nan")})
        assert any("season=9 is not one of 1 = " in msg for _, _, msg in s.log)
        assert any("T_floor_start=nan" in msg for _, _, msg in s.log)
    finally:
        s.close()


# ----------------------------------------------------------------------------- refusals, rebuild, CLI
class NoEquations(LinearZoneModel):
    """A model kind without equations() (stands for any nonlinear kind)."""

    equations = None


def test_models_the_native_fmu_cannot_represent_are_refused(sdh, tmp_path):
    base = zones_model(sdh)
    other = NoEquations(**{f.name: getattr(base, f.name) for f in __import__("dataclasses").fields(base)})
    with pytest.raises(FMUError, match="has no equations\\(\\).*without --native"):
        export_native_fmu(other, tmp_path / "x.fmu")
    with pytest.raises(FMUError, match="depend on the calendar.*--timezone"):
        export_native_fmu(calendar_model(sdh), tmp_path / "c.fmu")
    with pytest.raises(FMUError, match="must end in .fmu"):
        export_native_fmu(base, tmp_path / "x.zip")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("kind", ["lumped", pytest.param("physics", marks=pytest.mark.slow)])
def test_fmpy_compile_rebuilds_the_binary_from_the_sources(native, tmp_path, kind):
    """The sources in the FMU are complete: FMPy's CMake build of them gives the same trajectory
    (physics: the modal form)."""
    if shutil.which("cmake") is None:
        pytest.skip("cmake not available")
    model, path = native[kind]
    rebuilt = tmp_path / "rebuilt.fmu"
    with zipfile.ZipFile(path) as zin, zipfile.ZipFile(rebuilt, "w") as zout:
        for item in zin.infolist():
            if not item.filename.startswith("binaries/"):
                zout.writestr(item, zin.read(item.filename))
    run = subprocess.run(["fmpy", "compile", str(rebuilt)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    with zipfile.ZipFile(rebuilt) as z:
        assert any(n.startswith("binaries/linux64/") and n.endswith(".so") for n in z.namelist())
    Y, Yref = simulate_year(model, rebuilt, 2000)
    assert_allclose(Y, Yref[:2000], rtol=0, atol=EXACT)


def test_command_line_export_native_and_fmpy_simulate(native, tmp_path, cli):
    """`hvacfmu export --native` then `fmpy simulate` without inputs (all inputs at their start values)."""
    model, _ = native["zones"]
    mp = model.save(tmp_path / "zones.json")
    out = tmp_path / "Z.fmu"
    run = cli("export", mp, "-o", out, "--native")  # in-process; the real export subprocess: test_fmu
    assert run.returncode == 0, run.stderr
    assert validate(out) == []
    sim = subprocess.run(
        [
            "fmpy",
            "simulate",
            str(out),
            "--output-interval",
            "900",
            "--stop-time",
            "86400",
            "--output-file",
            str(tmp_path / "out.csv"),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert sim.returncode == 0, sim.stderr + sim.stdout
    res = pd.read_csv(tmp_path / "out.csv")
    assert len(res) == 97 and np.isfinite(res[[f"T_{z}" for z in model.outputs]].to_numpy()).all()
    plant = tmp_path / "truth.json"
    plant.write_text('{"baseline": {}, "zones": []}')
    bad = cli("export", plant, "-o", tmp_path / "P.fmu", "--native")  # in-process: the refusal
    assert bad.returncode != 0 and "cannot be exported as a native FMU" in bad.stderr


@pytest.mark.parametrize(
    "case, expect",
    [
        ("step", "communication step 600 s at t=0 s is not a whole multiple of the model step 900 s"),
        pytest.param("nan", "at t=2700 s: invalid input value(s): T_out=nan", marks=pytest.mark.slow),
        ("range", "at t=4500 s: invalid input value(s): T_out=95"),
    ],
)
def test_fmpy_simulate_fails_loudly_on_a_refused_step(native, tmp_path, case, expect):
    """`fmpy simulate` on a native FMU that refuses a step exits non-zero and prints the FMU's reason (16 p.4).

    The FMU answers fmi2Error (FMPy raises), not fmi2Discard (FMPy would stop quietly, exit 0 and write a
    short result).
    """
    model, path = native["zones"]
    cmd = ["fmpy", "simulate", str(path), "--stop-time", "17100", "--output-file", str(tmp_path / "out.csv")]
    if case == "step":
        cmd += ["--output-interval", "600"]
    else:
        t = np.arange(20) * STEP
        T_out = np.full(20, 10.0)
        if case == "nan":
            T_out[3] = np.nan
        else:
            T_out[5:] = 95.0
        pd.DataFrame({"time": t, "T_out": T_out}).to_csv(tmp_path / "in.csv", index=False, na_rep="nan")
        cmd += ["--output-interval", "900", "--input-file", str(tmp_path / "in.csv")]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    text = run.stdout + run.stderr
    assert run.returncode != 0, text
    assert "[ERROR]" in text and expect in text, text
    assert "fmi2DoStep failed with status 3 (error)" in text
