"""The model-kind registry: every registered kind goes fit -> save -> load -> evaluate -> export -> FMU
simulate (FMPy), and the FMU agrees with the Python model (1e-9 K); the registry's errors and entries."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

from hvacfmu.errors import HvacfmuWarning, ModelError
from hvacfmu.models import load_model
from hvacfmu.models.registry import ModelKind, fittable_kinds, get_kind, kind_names, kinds, register_kind

EXACT = 1e-9  # [K] FMU vs Python model


@pytest.fixture(scope="module")
def short_dataset(short_paths):
    from hvacfmu.data import prepare

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(short_paths.measurements, short_paths.building)


def _make(kind, dataset):
    """A model of ``kind`` from the data: its registered fit, or for ``extended`` (made by the diagnosis)
    the fitted six-zone Model A plus one solar-gain term, built without the diagnosis."""
    from hvacfmu.fitting import fit

    if get_kind(kind).fit is not None:
        return fit(dataset, kind, progress=False)
    assert kind == "extended", f"test does not know how to make kind {kind!r} without a fit function"
    from hvacfmu.models.extended import ExtendedModel, SolarGain

    base = fit(dataset, "zones", progress=False)
    return ExtendedModel(base=base, terms=(SolarGain(zone=base.outputs[0], facade="S", coef=2e-4),))


def _fmu_run(path, model, frame, season):
    """Simulate the FMU with FMPy over ``frame``'s rows; returns outputs (n, ny) [°C] at the step ends."""
    from fmpy import read_model_description, simulate_fmu

    from hvacfmu.timeutil import seconds_of_week

    md = read_model_description(str(path))
    names = {v.name for v in md.modelVariables}
    inputs = [v.name for v in md.modelVariables if v.causality == "input" and v.name in frame.columns]
    step = float(model.step)
    t = np.arange(len(frame)) * step
    signal = np.zeros(len(frame), dtype=[("time", float)] + [(n, float) for n in inputs])
    signal["time"] = t
    for n in inputs:
        signal[n] = frame[n].to_numpy(float)
    y0 = model.measured_outputs(frame.iloc[:1])[0]
    start = {f"T_{z}_start": float(y) for z, y in zip(model.outputs, y0)}
    start["season"] = list(model.gains).index(season) + 1
    start["start_time_of_week"] = float(seconds_of_week(frame.index[:1])[0])
    start = {k: v for k, v in start.items() if k in names}
    res = simulate_fmu(
        str(path),
        start_time=0.0,
        stop_time=t[-1],
        step_size=step,
        output_interval=step,
        input=signal,
        start_values=start,
        output=[f"T_{z}" for z in model.outputs],
    )
    return np.column_stack([res[f"T_{z}"] for z in model.outputs])


def _reference(model, frame, season):
    from hvacfmu.models.state import state_from_outputs

    u, v = (np.asarray(a, float) for a in model.signals(frame))
    q = np.asarray(model.gains_at(frame.index, season), float)
    y0 = model.measured_outputs(frame.iloc[:1])[0]
    _, Y = model.simulate(state_from_outputs(model, y0, u[0], v[0], q[0]), u[:-1], v[:-1], q[:-1])
    return np.asarray(Y)


def _two_days(dataset, model):
    """Two gap-filled days of a test week whose clock has no DST change (the FMU clock has none)."""
    for week in dataset.test_weeks():
        if week.season not in model.gains:
            continue
        f = dataset.week_frame(week).interpolate(method="time", limit_direction="both").iloc[: 2 * 96 + 1]
        if len({o.utcoffset() for o in f.index}) == 1 and f.notna().all().all():
            return week, f
    pytest.skip("no test week without a DST change in the short dataset")  # pragma: no cover


@pytest.mark.parametrize(
    "kind",
    # physics takes over 20 s: slow tier (the not-slow tier stays under 3 min)
    [pytest.param(k, marks=pytest.mark.slow) if k == "physics" else k for k in kind_names()],
)
def test_every_kind_fit_save_load_evaluate_export_fmu(kind, short_dataset, tmp_path):
    from hvacfmu.evaluation import evaluate
    from hvacfmu.fmu import export_fmu, validate

    entry = get_kind(kind)
    model = _make(kind, short_dataset)
    assert model.kind == kind
    assert isinstance(model, entry.load_class())
    assert entry.equations == callable(getattr(type(model), "equations", None))
    path = model.save(tmp_path / f"{kind}.json")
    loaded = load_model(path)
    assert type(loaded) is type(model) and loaded.to_dict()["format_version"] == entry.schema_version
    result = evaluate(loaded, short_dataset)
    assert result.scores[0].kind == kind and np.all(np.isfinite(result.scores[0].rms))
    fmu = export_fmu(path, tmp_path / f"{kind}.fmu", timezone=short_dataset.building.timezone)
    assert validate(fmu) == []
    week, frame = _two_days(short_dataset, loaded)
    Y_fmu = _fmu_run(fmu, loaded, frame, week.season)
    Y_ref = _reference(loaded, frame, week.season)
    assert Y_fmu.shape == Y_ref.shape
    assert_allclose(Y_fmu, Y_ref, rtol=0, atol=EXACT)  # [K]


def test_builtin_kinds_and_fields():
    assert kind_names()[:4] == ["lumped", "zones", "physics", "extended"]
    assert fittable_kinds()[:3] == ["lumped", "zones", "physics"] and "extended" not in fittable_kinds()
    for k in kinds():
        cls = k.load_class()
        assert getattr(cls, "kind", None) == k.name or k.name in getattr(cls, "KINDS", ())
        assert k.fmu_slave.startswith("Hvacfmu")


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: get_kind("nonsense"), r"unknown model kind 'nonsense'; choose one of \['lumped', 'zones'"),
        (lambda: get_kind("extended").fit_function(), r"not fitted directly.*diagnos.*\['lumped'"),
        (lambda: register_kind(ModelKind("zones", "other", "x.y:Z")), r"already registered"),
        (lambda: ModelKind("bad kind", "", "x.y:Z"), r"non-empty identifier"),
        (lambda: ModelKind("k", "", "no_colon"), r"'module:attribute'"),
        (lambda: ModelKind("k", "", "nosuch.module:Cls").load_class(), r"cannot import the model class"),
    ],
)
def test_registry_errors(call, match):
    with pytest.raises(ModelError, match=match):
        call()


def test_fit_dispatches_through_registry(monkeypatch):
    """A kind registered from a test is fitted by ``hvacfmu.fitting.fit`` and offered by the CLI."""
    import sys
    import types

    from hvacfmu.cli.commands import build_parser
    from hvacfmu.fitting import fit
    from hvacfmu.models import registry

    mod = types.ModuleType("toy_kind_module")
    mod.fit_toy = lambda dataset, **options: ("toy", dataset, options)
    monkeypatch.setitem(sys.modules, "toy_kind_module", mod)
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    register_kind(ModelKind("toy", "a toy", "hvacfmu.models.linear:LinearZoneModel", fit="toy_kind_module:fit_toy"))
    assert fit("DATA", "toy", a=1) == ("toy", "DATA", {"a": 1})
    args = build_parser().parse_args(["fit", "d.csv", "-b", "b.toml", "-m", "toy", "-o", "m.json"])
    assert args.model == "toy"


def test_state_from_outputs_public_home_matches_fmu_slave():
    """``hvacfmu.models.state.state_from_outputs`` (used by MPC) gives the FMU slave's start state."""
    from hvacfmu.emulator import sdh_building
    from hvacfmu.fmu_slave import state_from_outputs as slave_version
    from hvacfmu.models.physics import PhysicsModel
    from hvacfmu.models.state import state_from_outputs

    b = sdh_building(nominal=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        model = PhysicsModel(
            building=b,
            params=dict(b.physics["physics"]["nominal"]),
            solar=True,
            gains={s: np.full((672, len(b.zone_names) + 1), 1000.0) for s in b.season_names},
        )
    assert model.q_names[-1] == "T_ground"  # the slabs face the storeys (a 1000 °C boundary: a probe only)
    y0 = np.linspace(20.0, 23.0, model.n_outputs)
    u = np.full(model.n_inputs if hasattr(model, "n_inputs") else len(model.inputs), 0.3)
    v = np.array([10.0, 14.0] + [50.0] * (len(model.disturbances) - 2))
    q = model.gains["fall"][0] if "fall" in model.gains else next(iter(model.gains.values()))[0]
    x = state_from_outputs(model, y0, u, v, q)
    assert_allclose(x, slave_version(model, y0, u, v, q), rtol=0, atol=0)
    assert_allclose(model.output(x), y0, rtol=0, atol=1e-9)  # [°C]
