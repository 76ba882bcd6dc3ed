"""The evaluation protocol: 24-hour open-loop RMS on held-out weeks, baselines, results, plots, CLI."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from test_datadriven import (
    simulate_frame,
    six_zone_building_dict,
    true_lumped_model,
    true_zone_model,
    write_dataset,
)

from hvacfmu.building import building_from_dict
from hvacfmu.errors import DataError, HvacfmuWarning
from hvacfmu.evaluation import BASELINES, evaluate, week_trajectory, window_rms
from hvacfmu.models.base import ZoneModel
from hvacfmu.models.datadriven import fit_zones
from hvacfmu.models.linear import LinearZoneModel


@pytest.fixture(scope="module")
def building():
    return building_from_dict(six_zone_building_dict())


@pytest.fixture(scope="module")
def truth(building):
    return true_zone_model(building)


@pytest.fixture(scope="module")
def data(tmp_path_factory, building, truth):
    """Eleven weeks (fall and winter) simulated from the true model; one day with a gap."""
    frame = simulate_frame(truth, building, weeks=11, start="2025-10-20", seed=11)
    frame.iloc[3 * 672 + 200 : 3 * 672 + 210, frame.columns.get_loc("T_NW")] = np.nan
    return write_dataset(tmp_path_factory.mktemp("eval"), frame, six_zone_building_dict(), "eval")


class AugmentedModel(ZoneModel):
    """A wrapped LinearZoneModel with an extra hidden state (a decaying offset).

    Uses a different state than outputs, so evaluation must go through
    initial_state / simulate / output rather than assume x == y.
    """

    kind = "augmented"

    def __init__(self, inner: LinearZoneModel):
        self.inner = inner
        self.step = inner.step
        self.outputs = inner.outputs
        self.inputs = inner.inputs
        self.disturbances = inner.disturbances
        self.gains = inner.gains

    @property
    def n_states(self):
        return self.inner.n_states + 1

    def measured_outputs(self, frame):
        return self.inner.measured_outputs(frame)

    def signals(self, frame):
        return self.inner.signals(frame)

    def initial_state(self, frame, k0):
        return np.r_[self.inner.initial_state(frame, k0), 0.0]

    def step_state(self, x, u, v, q):
        nx = self.inner.n_states
        inner = self.inner.step_state(x[..., :nx], u, v, q)
        return np.concatenate([inner, 0.5 * x[..., nx:]], axis=-1)

    def output(self, x):
        return np.asarray(x)[..., : self.inner.n_states] + np.asarray(x)[..., self.inner.n_states :]

    def to_dict(self):
        return {"kind": "augmented", "format_version": 1}

    @classmethod
    def from_dict(cls, d):
        raise NotImplementedError


def test_window_rms_is_eq_rms():
    meas = np.array([[[1.0, 2.0], [3.0, 4.0]]])
    pred = np.array([[[1.0, 1.0], [1.0, 4.0]]])
    assert_allclose(window_rms(meas, pred), [[np.sqrt(4.0 / 2), np.sqrt(1.0 / 2)]], rtol=0, atol=1e-15)


def test_truth_scores_at_noise_floor(data, truth):
    res = evaluate(truth, data)
    sc = res.scores[0]
    tab = res.table()
    assert list(tab.columns) == [*truth.outputs, "mean"]
    seasons = {w.season for w in data.test_weeks()}
    assert set(tab.index) == seasons | {"all"}
    # open-loop error of the true model: accumulated process noise (sd 0.01 K per step, a ~ 0.9)
    # plus measurement noise 0.005 K: a few hundredths
    assert tab.loc["all", "mean"] < 0.05
    for b in BASELINES:
        assert np.all(res.table(which=b).loc["all", list(truth.outputs)] > 3 * tab.loc["all", list(truth.outputs)])
    # seven windows per test week, minus the one with the gap
    n_test = len(data.test_weeks())
    assert len(sc.starts) + sum(sc.skipped.values()) == 7 * n_test
    assert all(t.hour == 0 and t.minute == 0 for t in sc.starts)


def test_output_gap_is_scored_on_the_observed_steps_only(data, truth):
    """The 2.5-h gap in T_NW no longer skips its window: NW is scored on its 86 measured steps, the others on 96."""
    gap_day = data.frame.index[3 * 672 + 200].normalize()
    week = next(w for w in data.weeks if w.start <= gap_day < w.end)
    weeks = tuple(dataclasses.replace(w, train=w.number != week.number) for w in data.weeks)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)  # the other seasons now have no test week
        sc = evaluate(truth, dataclasses.replace(data, weeks=weeks)).scores[0]
    i = sc.starts.index(gap_day)
    assert sc.observed[i].sum(axis=0).tolist() == [86, 96, 96, 96, 96, 96]
    assert sum(sc.skipped.values()) == 0 and len(sc.starts) == 7


def test_only_the_interface_is_used(data, truth):
    """A model whose state is not its output scores as its wrapped model (the extra state is zero)."""
    res = evaluate([truth, AugmentedModel(truth)], data, names=["linear", "augmented"])
    assert_allclose(res.score("augmented").rms, res.score("linear").rms, rtol=0, atol=1e-12)
    text = res.format_table()
    assert "baselines as above" in text  # same outputs, same windows: printed once


def test_lumped_baselines_on_the_floor_output(data, building):
    lumped = true_lumped_model(building)
    res = evaluate(lumped, data)
    sc = res.scores[0]
    assert sc.outputs == ("floor",)
    floor = data.frame[[f"T_{z}" for z in building.zone_names]].to_numpy() @ building.area_weights()
    k0 = data.frame.index.get_indexer([sc.starts[0]])[0]
    expected = np.sqrt(np.mean((floor[k0 + 1 : k0 + 97] - floor[k0]) ** 2))
    assert_allclose(sc.baselines["persistence"][0, 0], expected, rtol=0, atol=1e-12)


def test_result_outputs(data, truth, tmp_path):
    res = evaluate(truth, data)
    text = res.format_table()
    for word in ("persistence", "time-of-week mean", "NW", "mean", "windows"):
        assert word in text
    d = json.loads(res.save_json(tmp_path / "r.json").read_text())
    m = d["models"][0]
    assert m["kind"] == "zones" and m["outputs"] == list(truth.outputs)
    assert_allclose(m["table"]["all"]["mean"], res.table().loc["all", "mean"], rtol=0, atol=1e-12)
    assert set(m["baselines"]) == set(BASELINES)
    assert len(m["windows"]) == len(res.scores[0].starts)
    df = res.to_pandas()
    assert len(df) == len(res.scores[0].starts) * len(truth.outputs)
    assert_allclose(
        df.groupby("output")["rms"].mean()[list(truth.outputs)].to_numpy(),
        res.table().loc["all", list(truth.outputs)].to_numpy(float),
        rtol=0,
        atol=1e-12,
    )
    files = res.plot(tmp_path / "plots", dataset=data)
    assert len(files) == 2 and all(f.exists() and f.stat().st_size > 10_000 for f in files)


def test_week_trajectory(data, truth):
    week = data.test_weeks()[0]
    tr = week_trajectory(truth, data, week)
    assert tr.predicted.shape == tr.measured.shape == (672, 6)
    assert_allclose(tr.predicted[0], tr.measured[0], rtol=0, atol=1e-12)
    # seven days open loop from the true model: drift stays at the noise level
    assert np.all(tr.rms() < 0.1)
    assert list(tr.to_pandas().columns[:2]) == ["measured_NW", "measured_W"]
    with pytest.raises(DataError, match="no week number 99"):
        week_trajectory(truth, data, 99)


def test_season_without_test_week_and_no_test_weeks(data, truth):
    weeks = tuple(dataclasses.replace(w, train=True) if w.season == "winter" else w for w in data.weeks)
    with pytest.warns(HvacfmuWarning, match="season winter has no test week"):
        res = evaluate(truth, dataclasses.replace(data, weeks=weeks))
    assert "winter" not in res.table().index
    all_train = tuple(dataclasses.replace(w, train=True) for w in data.weeks)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        with pytest.raises(DataError, match="no test week"):
            evaluate(truth, dataclasses.replace(data, weeks=all_train))


def test_model_without_season_profile(data, truth):
    partial = dataclasses.replace(truth, gains={"fall": truth.gains["fall"]})
    with pytest.warns(HvacfmuWarning, match="no internal-gain profile for season winter"):
        res = evaluate(partial, data)
    assert res.scores[0].skipped["no internal-gain profile for season"] > 0
    assert set(res.scores[0].seasons) == {"fall"}


@pytest.mark.parametrize(
    "kwargs, exc, message",
    [
        ({"horizon": 0}, ValueError, "horizon must be at least one step"),
        ({"names": ["a", "b"]}, ValueError, "one per model"),
    ],
)
def test_bad_arguments(data, truth, kwargs, exc, message):
    with pytest.raises(exc, match=message):
        evaluate(truth, data, **kwargs)


@pytest.mark.slow  # over 15 s: keeps the not-slow tier under 3 min
def test_cli_fit_and_evaluate(data, tmp_path):
    src = data.source
    bpath = tmp_path / "b.toml"
    data.building.save(bpath)
    model = tmp_path / "m.json"
    run = lambda *a: subprocess.run([sys.executable, "-m", "hvacfmu.cli", *a], capture_output=True, text=True)  # noqa: E731
    r = run("-q", "fit", src, "--building", str(bpath), "--model", "zones", "-o", str(model))
    assert r.returncode == 0, r.stderr
    assert "spectral radius" in r.stdout
    lumped = tmp_path / "l.json"
    r = run("-q", "fit", src, "--building", str(bpath), "--model", "lumped", "-o", str(lumped))
    assert r.returncode == 0, r.stderr
    out = tmp_path / "r.json"
    r = run(
        "evaluate",
        src,
        "--building",
        str(bpath),
        "--model",
        str(model),
        "--model",
        str(lumped),
        "--json",
        str(out),
        "--plots",
        str(tmp_path / "plots"),
    )
    assert r.returncode == 0, r.stderr
    assert "time-of-week mean" in r.stdout and "== lumped" in r.stdout and "== zones" in r.stdout
    # the verdict opens the output and the JSON
    assert r.stdout.splitlines()[0].startswith("zones: beats persistence in 6/6 zones"), r.stdout[:400]
    assert r.stdout.splitlines()[1].startswith("lumped: beats persistence in 1/1 zones"), r.stdout[:400]
    saved = json.loads(out.read_text())
    assert list(saved)[0] == "verdict" and len(saved["verdict"]["zones"]) == 7
    assert [m["kind"] for m in saved["models"]] == ["zones", "lumped"]
    assert len(list((tmp_path / "plots").glob("*.png"))) == 3
    r = run("evaluate", src, "--building", str(bpath), "--model", str(tmp_path / "missing.json"))
    assert r.returncode == 2 and "does not exist" in r.stderr


# ----------------------------------------------------------------------------- emulated datasets
@pytest.fixture(
    scope="module",
    params=["winter", pytest.param("default", marks=pytest.mark.slow)],
)
def emulated(request):
    """(dataset, result of Model A against the baselines): four weeks across the winter/spring boundary
    (``winter_dataset``, two seasons), and in the slow tier the emulator's default 51 weeks (all four seasons;
    its generation and preparation alone cost about 20 CPU-s on an empty cache)."""
    ds = request.getfixturevalue(f"{request.param}_dataset")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        model = fit_zones(ds)
    return ds, evaluate(model, ds)


def test_emulated_dataset_table_all_seasons(emulated):
    ds, result = emulated
    tab = result.table()
    assert len(ds.seasons) >= 2
    assert set(ds.seasons) <= set(tab.index)
    assert not tab.isna().any().any()


def test_emulated_dataset_every_zone_beats_both_baselines(emulated):
    """Over all test windows, each zone's RMS is below persistence and the time-of-week mean."""
    ds, result = emulated
    zones = list(ds.building.zone_names)
    model = result.table().loc["all", zones]
    for b in BASELINES:
        base = result.table(which=b).loc["all", zones]
        assert np.all(model.to_numpy(float) < base.to_numpy(float)), (b, model, base)


def test_trajectory_week_must_exist(winter_dataset):
    from hvacfmu.errors import DataError
    from hvacfmu.evaluation import _choose_week

    assert _choose_week(winter_dataset, 3).number == 3
    with pytest.raises(DataError, match="no week 999 in the dataset"):
        _choose_week(winter_dataset, 999)
