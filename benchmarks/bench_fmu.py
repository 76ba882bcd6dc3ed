"""Benchmark: a year of 15-minute steps through FMPy for each model FMU vs the plain Python model.

Prints medians over repeats (process CPU seconds for the year, microseconds
per step) and the median over repeats of the ratio FMU / Python (each repeat
runs both back to back). Target: at most 5x for the six-zone model.

- ``python``: ``model.simulate`` over the year (what evaluation uses);
- ``python loop``: ``model.step_state`` called once per step (what the FMU calls);
- ``FMPy FMU2Slave``: ``setReal`` / ``doStep`` / ``getReal`` per step, as a user writes it;
- ``FMPy raw``: the same FMI calls on preallocated ctypes arrays (as :mod:`harness.cosim` does).

A second table compares the native FMU (``hvacfmu export --native``: generated C,
no Python at run time) with the pythonfmu FMU of the same model, per step through
the same FMPy calls (target: native at least 20x faster per ``fmi2DoStep``),
gives the floor of an FMPy call (the least a ``doStep`` costs from Python, hence
the largest ratio FMPy can show), the native FMU's cost in a pure C master
(``tests/data/fmi2_master.c``) and its largest difference from the Python model.

Usage: ``python3 benchmarks/bench_fmu.py [--repeats 5] [--kinds lumped zones physics] [--steps N]``
"""

from __future__ import annotations

import argparse
import ctypes
import statistics
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from hvacfmu.emulator import sdh_building
from hvacfmu.errors import HvacfmuWarning
from hvacfmu.fmu import export_fmu
from hvacfmu.fmu_slave import state_from_outputs
from hvacfmu.models.linear import LinearZoneModel

N_YEAR = 365 * 96
#: process CPU time: robust when other jobs share the machine (all work here is single-threaded)
CLOCK = time.process_time
DIST = ("T_out", "T_supply", "I_N", "I_E", "I_S", "I_W")


def make_models(building):
    rng = np.random.default_rng(0)
    nz = len(building.zone_names)
    zones = LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=building.zone_names,
        measured_zones=building.zone_names,
        output_weights=np.eye(nz),
        vavs=building.vav_names,
        input_map=building.zone_vav_matrix(),
        disturbances=DIST,
        A=0.9 * np.eye(nz) + rng.uniform(0, 0.012, (nz, nz)),
        B=-np.diag(rng.uniform(0.5, 1, nz)),
        C=np.column_stack([rng.uniform(0.02, 0.04, (nz, 2)), rng.uniform(0, 2e-4, (nz, 4))]),
        gains={s: rng.uniform(0.6, 1.2, (672, nz)) for s in building.season_names},
    )
    lumped = LinearZoneModel(
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
    from hvacfmu.models.physics import PhysicsModel

    t_storeys = building.physics["physics"]["ground_temperature"]

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        physics = PhysicsModel(
            building=building,
            params=dict(building.physics["physics"]["nominal"]),
            solar=True,
            gains={  # [W] per zone, then the slabs' boundary (the storeys below and above) [°C]
                s: np.column_stack([rng.uniform(500, 3000, (672, nz)), np.full(672, t_storeys)])
                for s in building.season_names
            },
        )
    from hvacfmu.models.extended import ActuationDelay, ExtendedModel, SolarGain, SupplyAirBilinear, ThermalMass

    extended = ExtendedModel(  # the six-zone model with one term of each kind the diagnosis adds
        base=zones,
        terms=(
            SolarGain(zone="S", facade="S", coef=4e-4),
            SupplyAirBilinear(zone="NW", coef=0.02),
            ThermalMass(zone="C", alpha=0.02, beta=0.05),
            ActuationDelay(zone="E", delay=2),
        ),
    )
    return {"lumped": lumped, "zones": zones, "physics": physics, "extended": extended}


def year_inputs(building, model, n, seed=1):
    rng = np.random.default_rng(seed)
    m = rng.uniform(0.05, 0.6, (n, len(building.vav_names)))
    v = np.column_stack([rng.uniform(5, 30, n), rng.uniform(12, 16, n), rng.uniform(0, 400, (n, 4))])
    return m, v[:, : len(model.disturbances)]


def run_python(model, x0, u, v, q):
    t = CLOCK()
    model.simulate(x0, u, v, q)
    return CLOCK() - t


def run_python_loop(model, x0, u, v, q):
    t = CLOCK()
    x = x0
    step = model.step_state
    for k in range(len(u)):
        x = step(x, u[k], v[k], q[k])
    return CLOCK() - t


def open_fmu(path, model, y0, instance, first_inputs):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(path))
    d = extract(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(
        guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier, instanceName=instance
    )
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr[f"T_{z}_start"] for z in model.outputs], list(y0))
    names, values = first_inputs
    fmu.setReal([vr[n] for n in names], [float(x) for x in values])
    fmu.exitInitializationMode()
    return fmu, vr


def run_fmu(path, model, building, m, v, y0, raw, costs=None):
    """A year through one FMU instance; returns (process CPU seconds, outputs).

    With ``raw`` the FMI calls go through FMPy's ``FMU2Slave.fmi2*`` methods on
    preallocated ctypes arrays. ``costs`` (a dict of lists), when given, gets the
    process CPU time per step of: ``loop`` (setReal + doStep + getReal),
    ``setget`` (the same loop without doStep, on the same instance afterwards),
    ``doStep`` (their difference) and ``floor`` (an FMPy call that does nothing in
    the FMU: ``fmi2SetDebugLogging``), all in seconds.
    """
    # all inputs, in the FMU's order; time_of_week = -1 keeps the FMU clock
    names_in = [f"m_{b}" for b in building.vav_names] + list(model.disturbances) + ["time_of_week"]
    W = np.column_stack([m, v, np.full(len(m), -1.0)])
    fmu, vr = open_fmu(path, model, y0, "bench", (names_in, W[0]))
    names_out = [f"T_{z}" for z in model.outputs]
    vin, vout = [vr[n] for n in names_in], [vr[n] for n in names_out]
    n = len(W)
    try:
        if raw:
            a_vin = (ctypes.c_uint32 * len(vin))(*vin)
            a_val = (ctypes.c_double * len(vin))()
            buf = np.frombuffer(a_val, dtype=float)
            a_vout = (ctypes.c_uint32 * len(vout))(*vout)
            a_out = (ctypes.c_double * len(vout))()
            Y = np.empty((n, len(vout)))
            out = np.frombuffer(a_out, dtype=float)
            set_real, do_step, get_real, comp = fmu.fmi2SetReal, fmu.fmi2DoStep, fmu.fmi2GetReal, fmu.component
            nin, nout = len(vin), len(vout)
            t = CLOCK()
            for k in range(n):
                buf[:] = W[k]
                set_real(comp, a_vin, nin, a_val)
                do_step(comp, k * 900.0, 900.0, 1)
                get_real(comp, a_vout, nout, a_out)
                Y[k] = out
            dt = CLOCK() - t
            if costs is not None:
                Y2 = np.empty_like(Y)
                t = CLOCK()
                for k in range(n):
                    buf[:] = W[k]
                    set_real(comp, a_vin, nin, a_val)
                    get_real(comp, a_vout, nout, a_out)
                    Y2[k] = out
                setget = CLOCK() - t
                debug = fmu.fmi2SetDebugLogging
                t = CLOCK()
                for _ in range(n):
                    debug(comp, 0, 0, None)
                floor = CLOCK() - t
                for key, val in (("loop", dt), ("setget", setget), ("doStep", dt - setget), ("floor", floor)):
                    costs.setdefault(key, []).append(val / n)
        else:
            rows = W.tolist()
            Y = []
            t = CLOCK()
            for k in range(n):
                fmu.setReal(vin, rows[k])
                fmu.doStep(k * 900.0, 900.0)
                Y.append(fmu.getReal(vout))
            dt = CLOCK() - t
            Y = np.array(Y)
    finally:
        fmu.terminate()
        fmu.freeInstance()
    return dt, Y


def c_master_us_per_step(path, model, building, m, v, tmp, python=False):
    """Process CPU microseconds per step of an FMU in the C master (None without gcc or, for ``python``, libpython).

    With ``python`` the FMU is a pythonfmu one: the master loads the shared libpython first (``RTLD_GLOBAL``), passes
    the unzipped resources and gets this interpreter's ``sys.path`` as ``PYTHONPATH``. Returns ``(us, outputs)``.
    """
    import os
    import shutil
    import subprocess
    import sys
    import sysconfig
    import zipfile

    from fmpy import read_model_description

    if shutil.which("gcc") is None:
        return None, None
    env = dict(os.environ)
    if python:
        lib_python = Path(sysconfig.get_config_var("LIBDIR") or "") / (sysconfig.get_config_var("INSTSONAME") or "")
        if not lib_python.is_file():
            return None, None
        env["FMI_MASTER_PRELOAD"] = str(lib_python)
        env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    src = Path(__file__).resolve().parents[1] / "tests" / "data" / "fmi2_master.c"
    exe, unz = Path(tmp) / "master", Path(tmp) / f"unz_{model.kind}_{'py' if python else 'native'}"
    if not exe.is_file():
        subprocess.run(["gcc", "-std=c99", "-O2", "-o", str(exe), str(src), "-ldl"], check=True)
    with zipfile.ZipFile(path) as z:
        z.extractall(unz)
    env["FMI_MASTER_RESOURCES"] = (unz / "resources").resolve().as_uri()
    md = read_model_description(str(path))
    vr = {x.name: x.valueReference for x in md.modelVariables}
    names_in = [f"m_{b}" for b in building.vav_names] + list(model.disturbances)
    outs = [f"T_{z}" for z in model.outputs]
    lib = unz / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
    stdin = "\n".join(" ".join(repr(float(x)) for x in row) for row in np.column_stack([m, v]))
    run = subprocess.run(
        [str(exe), str(lib), md.guid, str(len(m)), "900", str(len(names_in)), str(len(outs))]
        + [str(vr[x]) for x in names_in + outs],
        input=stdin,
        capture_output=True,
        text=True,
        check=True,
        env=env,
    )
    outputs = np.loadtxt(run.stdout.splitlines(), ndmin=2)
    return float(run.stderr.split("us_per_step")[1].split()[0]), outputs


def compare_native(kinds, models, building, n, repeats, tmp):
    """Second table: the native FMU against the pythonfmu FMU, per step, same FMPy calls for both."""
    import pandas as pd

    from hvacfmu.fmu_native import export_native_fmu

    index = pd.date_range("2025-01-06", periods=n, freq="15min", tz="UTC")
    print(f"\nnative vs pythonfmu FMU, {n} steps, medians of {repeats} runs, process CPU time [us/step]")
    print(
        "loop: setReal + doStep + getReal through FMPy's FMU2Slave.fmi2* on ctypes arrays; doStep: loop minus the same\n"
        "loop without doStep; floor: an FMPy call that does nothing in the FMU (fmi2SetDebugLogging), the least any\n"
        "FMU's doStep can cost from Python; cap: pythonfmu doStep / native floor, the largest ratio FMPy allows;\n"
        "C master: fmi2GetReal + fmi2SetReal + fmi2DoStep per step in tests/data/fmi2_master.c, native FMU (no Python);\n"
        "C py: the same for the pythonfmu FMU (libpython preloaded by the master), ratio: C py / C master, the FMUs'\n"
        "own per-step costs without FMPy's per-call overhead; max |dT|: native FMU against the Python model and\n"
        "against the pythonfmu FMU in the C master."
    )
    print(
        f"{'model':8s} {'loop py':>8s} {'loop nat':>8s} {'ratio':>6s} {'doStep py':>9s} {'doStep nat':>10s} {'ratio':>6s} "
        f"{'floor':>6s} {'cap':>5s} {'C master':>9s} {'C py':>9s} {'ratio':>6s} {'max |dT| [K]':>12s} {'export [s]':>10s} form"
    )
    for kind in kinds:
        model = models[kind]
        t0 = time.perf_counter()
        native = export_native_fmu(model, Path(tmp) / f"{kind}_native.fmu")
        build = time.perf_counter() - t0
        form = "modal" if "#define HV_MODAL 1" in _native_header(native) else "physical"
        python_fmu = export_fmu(model.save(Path(tmp) / f"{kind}_cmp.json"), Path(tmp) / f"{kind}_cmp.fmu")
        m, v = year_inputs(building, model, n)
        frame = pd.DataFrame({f"m_{b}": m[:, j] for j, b in enumerate(building.vav_names)}, index=index)
        for j, d in enumerate(model.disturbances):
            frame[d] = v[:, j]
        u, _ = model.signals(frame)
        q = model.gains_at(index, list(model.gains)[0])
        y0 = np.full(model.n_outputs, 21.0)
        _, Yref = model.simulate(state_from_outputs(model, y0, u[0], v[0], q[0]), u, v, q)
        py, nat = {}, {}
        for _ in range(repeats):
            run_fmu(python_fmu, model, building, m, v, y0, raw=True, costs=py)
            _, Y = run_fmu(native, model, building, m, v, y0, raw=True, costs=nat)
        med = (
            {k: 1e6 * statistics.median(x) for k, x in py.items()},
            {k: 1e6 * statistics.median(x) for k, x in nat.items()},
        )
        err = float(np.max(np.abs(Y - Yref[1:])))
        c_us, c_nat = c_master_us_per_step(native, model, building, m, v, tmp)
        c_py, c_pyo = c_master_us_per_step(python_fmu, model, building, m, v, tmp, python=True)
        c_txt = f"{c_us:9.2f}" if c_us is not None else f"{'(no gcc)':>9s}"
        c_py_txt = f"{c_py:9.2f} {c_py / c_us:6.0f}" if c_py is not None and c_us else f"{'(none)':>9s} {'':6s}"
        if c_nat is not None and c_pyo is not None:
            err = max(err, float(np.max(np.abs(c_nat - c_pyo))))
        print(
            f"{kind:8s} {med[0]['loop']:8.2f} {med[1]['loop']:8.2f} {med[0]['loop'] / med[1]['loop']:6.1f} "
            f"{med[0]['doStep']:9.2f} {med[1]['doStep']:10.2f} {med[0]['doStep'] / med[1]['doStep']:6.1f} "
            f"{med[1]['floor']:6.2f} {med[0]['doStep'] / med[1]['floor']:5.0f} {c_txt} {c_py_txt} {err:12.2e} {build:10.2f} {form}"
        )


def _native_header(path) -> str:
    import zipfile

    from hvacfmu.fmu_native import HEADER_NAME

    with zipfile.ZipFile(path) as z:
        return z.read(f"sources/{HEADER_NAME}").decode()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--kinds", nargs="+", default=["lumped", "zones", "physics", "extended"])
    ap.add_argument("--steps", type=int, default=N_YEAR, help="steps per run (default a year: 35040)")
    ap.add_argument("--native-only", action="store_true", help="only the native vs pythonfmu table")
    args = ap.parse_args()
    building = sdh_building(nominal=True)
    models = make_models(building)
    n = args.steps
    import pandas as pd

    index = pd.date_range("2025-01-06", periods=n, freq="15min", tz="UTC")  # Monday; no DST, like the FMU clock
    if args.native_only:
        with tempfile.TemporaryDirectory() as tmp:
            compare_native(args.kinds, models, building, n, args.repeats, tmp)
        return
    print(f"{n} steps of 900 s, medians of {args.repeats} runs\n")
    print(
        f"{'model':8s} {'python [s]':>11s} {'loop [s]':>9s} {'FMU2Slave [s]':>14s} {'raw [s]':>8s} "
        f"{'us/step py':>11s} {'us/step FMU':>12s} {'ratio':>6s} {'ratio raw':>10s} {'max |dT| [K]':>13s}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for kind in args.kinds:
            model = models[kind]
            mp = model.save(Path(tmp) / f"{kind}.json")
            t0 = CLOCK()
            path = export_fmu(mp, Path(tmp) / f"{kind}.fmu")
            build_time = CLOCK() - t0
            m, v = year_inputs(building, model, n)
            import pandas as pd

            frame = pd.DataFrame({f"m_{b}": m[:, j] for j, b in enumerate(building.vav_names)}, index=index)
            for j, d in enumerate(model.disturbances):
                frame[d] = v[:, j]
            u, _ = model.signals(frame)
            season = list(model.gains)[0]
            q = model.gains_at(index, season)
            y0 = np.full(model.n_outputs, 21.0)
            x0 = state_from_outputs(model, y0, u[0], v[0], q[0])
            py, loop, fm, raw = [], [], [], []
            for _ in range(args.repeats):
                py.append(run_python(model, x0, u, v, q))
                loop.append(run_python_loop(model, x0, u, v, q))
                dt, Y = run_fmu(path, model, building, m, v, y0, raw=False)
                fm.append(dt)
                dt, Yr = run_fmu(path, model, building, m, v, y0, raw=True)
                raw.append(dt)
            ratio = statistics.median(f / p for f, p in zip(fm, py))
            ratio_raw = statistics.median(r / p for r, p in zip(raw, py))
            # accuracy check over the same year (gains slot from Monday 00:00 = index start)
            _, Yref = model.simulate(x0, u, v, q)
            err = float(np.max(np.abs(Yr - Yref[1:])))
            p, lp, f, r = (statistics.median(a) for a in (py, loop, fm, raw))
            print(
                f"{kind:8s} {p:11.3f} {lp:9.3f} {f:14.3f} {r:8.3f} {1e6 * p / n:11.2f} {1e6 * f / n:12.2f} "
                f"{ratio:6.2f} {ratio_raw:10.2f} {err:13.2e}   (build {build_time:.2f} s)"
            )
        compare_native(args.kinds, models, building, n, args.repeats, tmp)


if __name__ == "__main__":
    main()
