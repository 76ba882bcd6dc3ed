"""The base kinds keep memory where the data have it (hvacfmu.models.memory, benchmarks/memory_s19.md).

Data are simulated by the known six-zone delivered-heat model of test_delivered_heat (diagonal of A 0.84-0.88 per
15 min: time constants of 1.4-2 h) and read back through hvacfmu.data.prepare; six weeks keep the module fast.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from hvacfmu.building import building_from_dict
from hvacfmu.errors import FitError, HvacfmuWarning
from hvacfmu.models import datadriven, memory
from hvacfmu.models.datadriven import fit_zones
from tests.test_datadriven import simulate_frame, six_zone_building_dict, write_dataset
from tests.test_delivered_heat import delivered_truth


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    building = building_from_dict(six_zone_building_dict())
    truth = delivered_truth(building)
    frame = simulate_frame(truth, building, weeks=6, seed=5)
    return truth, write_dataset(tmp_path_factory.mktemp("memory"), frame, six_zone_building_dict())


def _fit(ds, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return fit_zones(ds, **kw)


#: a one-step fit forced to forget: the prior of the diagonal of A pinned at 0.05 (a time constant of 5 min at a
#: 15-min step, as the apartments' fit ends), no open-loop refinement
FORGETFUL = {"open_loop": False, "mu_a": 0.05, "prior_sd_a": 1e-4}


def test_a_fit_that_forgets_gets_the_memory_of_the_data_back(data):
    """The fit's diagonal of A is pinned at 0.05; the week cross-validation prefers the within one-step refit (or its
    cross-fitted refinement), whose diagonal is the truth's. On main the model kept a = 0.05 (fails there)."""
    truth, ds = data
    model = _fit(ds, **FORGETFUL)
    np.testing.assert_allclose(np.diag(model.A), np.diag(truth.A), rtol=0, atol=0.04)  # [-]
    info = model.meta["memory"]
    assert info["checked"] is True
    assert info["slowest_time_constant_steps"] < memory.SHORT_MEMORY_STEPS  # the forced fit's own
    assert info["kept"] in ("within_one_step", "within_cross_fitted")
    cv = info["week_cv"]
    assert cv[info["kept"]]["rms"] < 0.5 * cv["fit"]["rms"]
    assert memory.slowest_steps(model) > 4.0
    np.testing.assert_allclose(model.beta, truth.beta, rtol=0.25, atol=0)
    # option memory=False: main's behaviour, the forced fit kept as it is
    same = _fit(ds, memory=False, **FORGETFUL)
    assert np.all(np.diag(same.A) < 0.07)
    assert memory.slowest_steps(same) < memory.SHORT_MEMORY_STEPS
    assert (same.meta["memory"]["checked"], same.meta["memory"]["reason"]) == (False, "option memory=False")


def test_a_fit_with_memory_is_left_alone(data):
    """The default fit of these data keeps its memory (time constants over one step): nothing is refitted, the model
    is the one memory=False gives (guard: passes on main)."""
    _, ds = data
    model = _fit(ds, open_loop=False)
    assert model.meta["memory"]["checked"] is False
    assert model.meta["memory"]["slowest_time_constant_steps"] >= memory.SHORT_MEMORY_STEPS
    ref = _fit(ds, open_loop=False, memory=False)
    np.testing.assert_array_equal(model.A, ref.A)
    np.testing.assert_array_equal(model.beta, ref.beta)


def test_week_cross_validation_scores_every_week_with_the_profiles_of_the_others(data):
    """week_cv leaves each training week out of the gain profiles: the truth, whose gains are the same every week,
    scores near its noise; a copy whose profiles hold one week's own errors is no better for it out of sample,
    while on its training windows (the in-sample criterion of the refinement) it would be."""
    truth, ds = data
    prep = datadriven._Prepared(ds, datadriven._options({}))
    true = memory.gains_on_training(truth, prep)
    cv = memory.week_cv(true, prep)
    assert cv["weeks"] == len({w.number for w in ds.weeks if w.train})
    assert cv["unscored"] == 0 and cv["windows"] >= 20
    assert cv["rms"] < 0.1  # [K]: process noise 0.01 K per step over 96 steps
    # memoryless: its profiles are the training weeks' time-of-week means, which out of sample cost it the level
    forgetful = memory.gains_on_training(dataclasses.replace(true, A=np.diag(np.full(6, 0.05))), prep)
    assert memory.week_cv(forgetful, prep)["rms"] > 2 * cv["rms"]


def test_option_memory_is_checked(data):
    _, ds = data
    with pytest.raises(FitError, match="option memory must be 'auto', True or False"):
        _fit(ds, memory="yes")


def test_the_verdict_says_when_the_memory_check_kept_a_forgetful_fit():
    """A model that still forgets after the check: the short-memory line says the week cross-validation kept it, with
    the scores (fails on main: the line did not know of the check)."""
    import types

    from hvacfmu.evaluation import verdict as V

    meta = {
        "plausibility": {"time_constants_h": [0.14, 0.1]},
        "memory": {
            "checked": True,
            "kept": "fit",
            "week_cv": {"fit": {"rms": 0.63}, "within_one_step": {"rms": 0.67}, "slow_cross_fitted": {"rms": 0.64}},
        },
    }
    (line,) = V._short_memory(types.SimpleNamespace(meta=meta, step=900.0))
    assert "the fit's memory check kept it: blocked week cross-validation on the training weeks (fit 0.63 K, " in line
    assert "slow_cross_fitted 0.64 K)" in line
    meta["memory"]["kept"] = "within_one_step"  # not the fit: nothing said about the check
    (line,) = V._short_memory(types.SimpleNamespace(meta=meta, step=900.0))
    assert "memory check" not in line


def test_no_season_with_two_training_weeks_is_said_not_guessed(data):
    """With one training week per season there is nothing to cross-validate: the fit is kept and the record says why
    (the EnergyPlus 2004 medium office export, one training week per season, scored every candidate NaN)."""
    _, ds = data
    model = _fit(ds, memory=False, **FORGETFUL)
    prep = datadriven._Prepared(ds, datadriven._options({}))
    prep.train_weeks = {s: w[:1] for s, w in prep.train_weeks.items()}
    kept, info = memory.keep_memory(model, prep, {"memory": "auto"})
    assert kept is model
    assert info["checked"] is False and info["reason"].startswith("no season has two training weeks")
