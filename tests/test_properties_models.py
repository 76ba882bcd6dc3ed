"""Property-based tests (issue 17 p.2, p.5): mutated model files load as a plausible model or are refused clearly.

A valid model file of each kind (lumped, zones, extended with four terms; physics in the slow tier,
its load alone takes seconds) is mutated: wrong types, missing and extra keys, NaN/inf, wrong shapes,
scaled coefficients, truncated text, schema versions, another kind. Every load either raises a
:class:`~hvacfmu.errors.HvacfmuError` whose message names the file, or returns a model that
(checked here independently of the loader) is stable and simulates two measured days to finite
temperatures. A model for other zones than the data is refused naming both zone lists.

Deterministic: Hypothesis runs derandomized (``HVACFMU_HYPOTHESIS_EXAMPLES=500`` explores randomly).
"""

from __future__ import annotations

import copy
import json
import os
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hvacfmu.errors import HvacfmuError, HvacfmuWarning, ModelError
from hvacfmu.models import load_model

EXPLORE = int(os.environ.get("HVACFMU_HYPOTHESIS_EXAMPLES", "0"))


def _settings(n):
    return settings(
        derandomize=not EXPLORE,
        max_examples=EXPLORE or n,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    )


@pytest.fixture(scope="module")
def short_dataset(short_paths):
    from hvacfmu.data import prepare

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(short_paths.measurements, short_paths.building)


@pytest.fixture(scope="module")
def model_files(short_dataset):
    """JSON mappings of a valid model of each fast kind, fitted on the 8-week emulator data."""
    from hvacfmu.fitting import fit
    from hvacfmu.models.extended import ActuationDelay, ExtendedModel, SolarGain, ThermalMass, ZoneCoupling

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        lumped = fit(short_dataset, "lumped", progress=False)
        zones = fit(short_dataset, "zones", progress=False)
    terms = (
        SolarGain(zone="S", facade="S", coef=2e-4),
        ThermalMass(zone="C", alpha=0.02, beta=0.05),
        ZoneCoupling(zone_a="NW", zone_b="C", coef_ab=0.01, coef_ba=0.01),
        ActuationDelay(zone="W", delay=2),
    )
    extended = ExtendedModel(base=zones, terms=terms)
    return {m.kind: json.loads(json.dumps(m.to_dict())) for m in (lumped, zones, extended)}


@pytest.fixture(scope="module")
def physics_file(short_paths):
    """A physics model of the emulated floor at its nominal parameters (no fit: fast to make)."""
    from hvacfmu.building import load_building
    from hvacfmu.models.physics import PhysicsModel

    b = load_building(short_paths.building)
    gains = np.full((672, 7), 800.0)  # [W] six zones, then the slabs' boundary (the storeys) [°C]
    gains[:, 6] = b.physics["physics"]["ground_temperature"]
    model = PhysicsModel(b, b.physics["physics"]["nominal"], {"fall": gains})
    return json.loads(json.dumps(model.to_dict()))


# --------------------------------------------------------------------------- mutations
VALUES = [True, None, "x", "1", [], {}, 0, -1, 0.5, 1e308, float("nan"), float("inf"), [[1.0]], {"a": 1}]


def key_paths(d, prefix=()):
    """Paths to every value (first and last element of each list) in a JSON mapping."""
    out = [prefix] if prefix else []
    if isinstance(d, dict):
        for k, v in d.items():
            out += key_paths(v, prefix + (k,))
    elif isinstance(d, list) and d:
        for i in sorted({0, len(d) - 1}):
            out += key_paths(d[i], prefix + (i,))
    return out


def _at(d, path):
    for k in path:
        d = d[k]
    return d


@st.composite
def mutations(draw, files):
    """(kind, mutated JSON text, description) for one of ``files``."""
    kind = draw(st.sampled_from(sorted(files)))
    d = copy.deepcopy(files[kind])
    paths = [p for p in key_paths(d) if p[0] != "meta"]
    how = draw(st.sampled_from(["value", "delete", "extra", "shape", "nonfinite", "scale", "version", "truncate"]))
    path = draw(st.sampled_from(paths))
    parent, key = _at(d, path[:-1]), path[-1]
    if how == "value":
        parent[key] = draw(st.sampled_from(VALUES))
    elif how == "delete":
        del parent[key]
    elif how == "extra":
        (parent if isinstance(parent, dict) else d)["unexpected_key"] = draw(st.sampled_from([1, "x", None]))
    elif how == "shape" and isinstance(parent[key], list) and parent[key]:
        if draw(st.booleans()):
            parent[key].append(copy.deepcopy(parent[key][-1]))
        else:
            parent[key].pop()
    elif how in ("nonfinite", "scale") and isinstance(parent[key], (int, float)) and not isinstance(parent[key], bool):
        factor = [float("nan"), float("inf"), -float("inf")] if how == "nonfinite" else [-1.0, 0.0, 10.0, 1e3, 1e6]
        parent[key] = parent[key] * draw(st.sampled_from(factor))
    elif how == "version":
        d["format_version"] = draw(st.sampled_from([0, 2, 99, "1", 1.5, True, None, [1]]))
    text = json.dumps(d)  # NaN/Infinity written as JSON extensions, as a careless tool would
    if how == "truncate":
        text = text[: draw(st.integers(0, len(text) - 1))]
    return Mutated(kind, how, path, text)


class Mutated(tuple):
    """(kind, how, path, text) of one mutated file; the repr leaves out the text (Hypothesis prints it)."""

    def __new__(cls, kind, how, path, text):
        return super().__new__(cls, (kind, how, path, text))

    def __repr__(self):
        return f"Mutated(kind={self[0]!r}, how={self[1]!r}, path={self[2]!r}, {len(self[3])} characters)"


# --------------------------------------------------------------------------- the property
def assert_usable(model, frame):
    """Independent of the loader: stable, and two measured days simulate to finite temperatures."""
    if model.kind in ("lumped", "zones", "extended"):
        base = model.base if model.kind == "extended" else model
        assert np.max(np.abs(np.linalg.eigvals(base.A))) < 1.0
        if model.kind == "extended":
            assert np.max(np.abs(np.linalg.eigvals(model.equations().A))) < 1.0
    day = frame.iloc[96 * 14 : 96 * 16]
    u, v = model.signals(day)
    q = model.gains_at(day.index, next(iter(model.gains)))
    _, Y = model.simulate(model.initial_state(day, 0), u, v, q)
    assert np.all(np.isfinite(Y)), "a loaded model simulated non-finite temperatures"


def load_or_refuse(tmp_path, text, frame):
    path = tmp_path / "model.json"
    path.write_text(text, encoding="utf-8")
    try:
        model = load_model(path)
    except HvacfmuError as exc:
        assert isinstance(exc, ModelError)
        assert str(path) in str(exc), f"the message does not name the file: {exc}"
        return "refused"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        try:
            assert_usable(model, frame)
        except ModelError as exc:  # a valid model of other zones or boxes: refused where it meets the data
            assert "Model zones:" in str(exc) and "data zones:" in str(exc), str(exc)
            return "refused with the data"
    return "ok"


def test_unmutated_model_files_load(tmp_path, model_files, short_dataset):
    for d in model_files.values():
        assert load_or_refuse(tmp_path, json.dumps(d), short_dataset.frame) == "ok"


class Inputs:
    """The valid files and the data, with a short repr for Hypothesis' falsifying examples."""

    def __init__(self, files, frame):
        self.files, self.frame = files, frame

    def __repr__(self):
        return f"Inputs({sorted(self.files)})"


@pytest.fixture(scope="module")
def fast_inputs(model_files, short_dataset):
    return Inputs(model_files, short_dataset.frame)


@pytest.fixture(scope="module")
def physics_inputs(physics_file, short_dataset):
    return Inputs({"physics": physics_file}, short_dataset.frame)


@_settings(40)
@given(data=st.data())
def test_mutated_model_files_load_plausibly_or_are_refused(tmp_path_factory, fast_inputs, data):
    text = data.draw(mutations(fast_inputs.files), label="mutation")[3]
    load_or_refuse(tmp_path_factory.mktemp("m"), text, fast_inputs.frame)


@pytest.mark.slow
@_settings(25)
@given(data=st.data())
def test_mutated_physics_model_files_load_plausibly_or_are_refused(tmp_path_factory, physics_inputs, data):
    text = data.draw(mutations(physics_inputs.files), label="mutation")[3]
    load_or_refuse(tmp_path_factory.mktemp("p"), text, physics_inputs.frame)


# --------------------------------------------------------------------------- named cases
def _edit(d, path, value):
    d = copy.deepcopy(d)
    _at(d, path[:-1])[path[-1]] = value
    return d


def _scaled_A(d, rho):
    d = copy.deepcopy(d)
    d["A"] = (np.asarray(d["A"]) * rho / np.max(np.abs(np.linalg.eigvals(d["A"])))).tolist()
    return d


@pytest.mark.parametrize(
    "kind, edit, message",
    [
        ("zones", lambda d: _scaled_A(d, 1.02), "spectral radius of A is 1.02"),
        ("zones", lambda d: _edit(d, ("A", 0, 1), -0.05), r"coupling A\[NW, W\] = -0.05 < 0"),
        ("lumped", lambda d: _edit(d, ("B", 0, 0), 0.3), "airflow warms zone"),
        ("lumped", lambda d: _edit(d, ("gains", "fall", 5, 0), 500.0), r"gains\['fall'\].*above 50 K per step"),
        ("zones", lambda d: _edit(d, ("A",), [[0.5]]), r"A has shape \(1, 1\), expected \(6, 6\)"),
        ("zones", lambda d: _edit(d, ("step",), True), "'step' must be a finite number, got True"),
        ("zones", lambda d: _edit(d, ("format_version",), 9), "format_version 9 is newer"),
        ("zones", lambda d: {k: v for k, v in d.items() if k != "B"}, "missing keys"),
        ("lumped", lambda d: _edit(d, ("output_weights", 0, 0), 1e308), "output_weights: each row must hold shares"),
        ("zones", lambda d: _edit(d, ("input_map", 0, 0), 3.0), "input_map: every VAV box must feed exactly one"),
        ("zones", lambda d: _edit(d, ("C", 0, 0), 1e6), "coefficients too large: the steady state of state 0"),
        ("extended", lambda d: _edit(d, ("terms", 0, "coef"), 1e300), "coefficients too large"),
        ("extended", lambda d: _edit(d, ("terms", 1, "beta"), 40.0), "spectral radius of the extended model"),
        ("extended", lambda d: _edit(d, ("terms", 0, "zone"), "Lobby"), "Lobby"),
        ("extended", lambda d: _edit(d, ("terms", 3, "delay"), -2), "delay"),
    ],
    ids=lambda x: x if isinstance(x, str) and " " not in x and "\\" not in x else None,
)
def test_implausible_model_files_are_refused_with_the_reason(tmp_path, model_files, kind, edit, message):
    path = tmp_path / "model.json"
    path.write_text(json.dumps(edit(model_files[kind])), encoding="utf-8")
    with pytest.raises(ModelError, match=message) as info:
        load_model(path)
    assert str(path) in str(info.value)


def test_extended_base_airflow_may_warm_only_where_a_supply_air_term_cools(tmp_path, model_files):
    """Until session 13 the diagnosis fitted a zone's base airflow coefficient free of sign when a
    ``supply_air_bilinear`` term carried the supply air's cooling there (B + coef (T_supply - T_zone): B read as
    the delivered air's offset); files saved then must still load (an emulated core9 floor's diagnosis wrote
    B = 0.337 that its export refused).
    Elsewhere a warming airflow stays refused, naming the zone."""
    d = copy.deepcopy(model_files["extended"])
    base = d["base"]
    i = base["outputs"].index("S")
    j = int(np.argmax(np.abs(base["B"][i])))
    base["B"][i][j] = 0.3
    path = tmp_path / "warm.json"
    path.write_text(json.dumps(d), encoding="utf-8")
    with pytest.raises(ModelError, match="airflow warms zone S"):
        load_model(path)
    d["terms"].append({"cause": "supply_air_bilinear", "zone": "S", "coef": 0.05})
    path.write_text(json.dumps(d), encoding="utf-8")
    model = load_model(path)
    assert model.base.B[i, j] == 0.3
    d["terms"][-1]["zone"] = "E"  # the term in another zone does not free S
    path.write_text(json.dumps(d), encoding="utf-8")
    with pytest.raises(ModelError, match="airflow warms zone S"):
        load_model(path)


def test_model_for_other_zones_is_refused_with_both_zone_lists(tmp_path, model_files, short_dataset):
    """Issue 17 p.5: a model file made for another building meets these data."""
    from hvacfmu.evaluation import evaluate

    d = copy.deepcopy(model_files["zones"])
    other = ["X1", "X2", "X3", "X4", "X5", "X6"]
    d["outputs"] = d["measured_zones"] = other
    path = tmp_path / "other.json"
    path.write_text(json.dumps(d), encoding="utf-8")
    model = load_model(path)  # a valid model of another building
    for call in (lambda: model.measured_outputs(short_dataset.frame), lambda: evaluate(model, short_dataset)):
        with pytest.raises(ModelError) as info:
            call()
        msg = str(info.value)
        assert "Model zones: ['X1'" in msg and "data zones: ['NW'" in msg, msg
