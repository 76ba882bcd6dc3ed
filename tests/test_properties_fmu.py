"""Property-based tests (issue 17 p.2): mutated FMU inputs and step sizes are refused with a status and a log
line, never turned into a non-finite output.

The six-zone Model A of the emulated floor is exported twice, as a pythonfmu FMU and as a native FMU
(``export --native``), both with the box limits of the building. Hypothesis drives each through FMPy
with a short sequence of steps whose inputs may be NaN, ±inf or outside the bounds the model description
declares, and whose step sizes and times may be wrong (0, negative, NaN, not a multiple of the model
step, not contiguous). Two-sided property, checked against the model description only:

- a step with every input inside its declared ``[min, max]``, a positive whole multiple of the model
  step and the FMU's current time is taken, and every output is finite;
- any other step is refused (FMPy raises on the non-OK status), the log gains a line naming the input
  or the step, and the outputs do not change.

Deterministic: derandomized, 8 sequences per FMU kind (more in the slow tier).
"""

from __future__ import annotations

import math
import os
import shutil

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

STEP = 900.0  # [s] model step
EXPLORE = int(os.environ.get("HVACFMU_HYPOTHESIS_EXAMPLES", "0"))


def _settings(n):
    return settings(
        derandomize=not EXPLORE,
        max_examples=EXPLORE or n,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    )


class Exported:
    """An exported FMU, its declared input bounds and output names (short repr for Hypothesis)."""

    def __init__(self, kind, path):
        from fmpy import read_model_description

        self.kind, self.path = kind, path
        md = read_model_description(str(path))
        self.inputs = {
            v.name: (float(v.min) if v.min is not None else -math.inf, float(v.max) if v.max is not None else math.inf)
            for v in md.modelVariables
            if v.causality == "input" and v.type == "Real"
        }
        self.outputs = [v.name for v in md.modelVariables if v.causality == "output"]
        self.starts = {v.name: v for v in md.modelVariables if v.causality == "parameter"}

    def __repr__(self):
        return f"Exported({self.kind})"


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """kind -> Exported: the same hand-written six-zone model as a pythonfmu and as a native FMU."""
    from test_fmu import zones_model

    from hvacfmu.emulator import sdh_building
    from hvacfmu.fmu import export_fmu, export_native_fmu

    b = sdh_building(nominal=True)
    model = zones_model(b)
    d = tmp_path_factory.mktemp("fmuprop")
    out = {"pythonfmu": Exported("pythonfmu", export_fmu(model.save(d / "zones.json"), d / "py.fmu", building=b))}
    if shutil.which("gcc"):
        out["native"] = Exported("native", export_native_fmu(model, d / "native.fmu", building=b))
    return out


def valid_row(fmu, k):
    """Plausible inputs at step k: airflow mid-range, temperatures and irradiance of a spring day."""
    row = {}
    for name, (lo, hi) in fmu.inputs.items():
        if name.startswith("m_"):
            row[name] = 0.3 * hi / 1.2
        elif name == "T_out":
            row[name] = 12.0 + 5 * math.sin(2 * math.pi * k * STEP / 86400)
        elif name.startswith("T"):
            row[name] = 14.0
        else:
            row[name] = 200.0
        row[name] = min(max(row[name], lo), hi)
    return row


@st.composite
def step_plans(draw, names):
    """A list of steps: (input overrides {name: value}, step-size factor or bad size, time offset)."""
    bad_value = st.one_of(
        st.sampled_from([math.nan, math.inf, -math.inf, -1.0, 1e6, -1e6]),
        st.floats(-200, 2000, allow_nan=False),
    )
    step = st.tuples(
        st.dictionaries(st.sampled_from(names), bad_value, max_size=2),
        st.sampled_from([STEP, STEP, STEP, 2 * STEP, 0.0, -STEP, 450.0, 1000.0, math.nan]),
        st.sampled_from([0.0, 0.0, 0.0, 0.0, STEP, -STEP]),
    )
    return draw(st.lists(step, min_size=2, max_size=6))


def run_plan(fmu, plan):
    from fmpy.fmi1 import FMICallException

    from harness.cosim import FMUInstance

    inst = FMUInstance(fmu.path, instance_name="prop")
    try:
        f, vr = inst.fmu, {n: v.vr for n, v in inst.vars.items()}
        f.setupExperiment(startTime=0.0)
        f.enterInitializationMode()
        f.setReal([vr[f"{o}_start"] for o in fmu.outputs], [21.0] * len(fmu.outputs))
        f.exitInitializationMode()
        out_vr = [vr[n] for n in fmu.outputs]
        t = 0.0
        for k, (override, h, offset) in enumerate(plan):
            row = {**valid_row(fmu, k), **override}
            f.setReal([vr[n] for n in row], [float(x) for x in row.values()])
            ok_inputs = all(fmu.inputs[n][0] <= x <= fmu.inputs[n][1] for n, x in row.items())
            ok_step = h > 0 and math.isfinite(h) and (h / STEP).is_integer() and offset == 0.0
            before, n_log = f.getReal(out_vr), len(inst.log)
            try:
                f.doStep(t + offset, h)
                taken = True
            except FMICallException:
                taken = False
            after = f.getReal(out_vr)
            if ok_inputs and ok_step:
                assert taken, f"a valid step was refused: {inst.log[n_log:]}"
                assert np.all(np.isfinite(after)), f"non-finite output after a valid step: {after}"
                t += h
            else:
                assert not taken, f"a bad step was taken: inputs {override}, step {h} at offset {offset}"
                assert after == before, "a refused step changed the outputs"
                new = " ".join(str(m) for m in inst.log[n_log:])
                assert new, "a refused step left no log line"
                named = [n for n, x in override.items() if not fmu.inputs[n][0] <= x <= fmu.inputs[n][1]]
                assert not named or not ok_step or any(n in new for n in named), new
    finally:
        inst.close()


@pytest.mark.parametrize("kind", ["pythonfmu", "native"])
@_settings(8)
@given(data=st.data())
def test_bad_fmu_inputs_and_steps_are_refused_never_nonfinite(exported, kind, data):
    if kind not in exported:
        pytest.skip("the native FMU needs the C compiler gcc")
    fmu = exported[kind]
    run_plan(fmu, data.draw(step_plans(sorted(fmu.inputs)), label="plan"))


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["pythonfmu", "native"])
@_settings(60)
@given(data=st.data())
def test_bad_fmu_inputs_and_steps_many(exported, kind, data):
    if kind not in exported:
        pytest.skip("the native FMU needs the C compiler gcc")
    fmu = exported[kind]
    run_plan(fmu, data.draw(step_plans(sorted(fmu.inputs)), label="plan"))
