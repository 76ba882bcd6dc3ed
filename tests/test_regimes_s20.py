"""The memory check's selection that does not trade seasons (option ``memory_select``, benchmarks/regimes_s20.md).

Session 19's rule keeps the candidate with the lowest week cross-validated RMS over the seasons: on the EnergyPlus
apartments it halved winter by losing summer. ``memory_select="no_season_worse"`` keeps only a candidate that is
not worse than the fit in any season by more than one standard error of the paired week difference. The records
below have the shape :func:`hvacfmu.models.memory.week_cv` returns (``season_folds``: one ``[week, sum of squared
errors, values]`` per left-out week).
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from hvacfmu.errors import FitError, HvacfmuWarning
from hvacfmu.models import memory
from hvacfmu.models.datadriven import fit_zones
from tests.test_memory_s19 import FORGETFUL, data  # noqa: F401  (the module-scoped dataset fixture)

N = 96 * 6  # values per fold: six 24-h windows of 96 steps, one zone


def _record(season_mse: dict) -> dict:
    """A week_cv-shaped record from per-season lists of per-fold mean squared errors [K²]."""
    folds, rms = {}, {}
    week = 0
    for s, mses in season_mse.items():
        folds[s] = []
        for m in mses:
            folds[s].append([week, float(m) * N, N])
            week += 1
        rms[s] = float(np.sqrt(np.mean(mses)))
    return {
        "rms": float(np.sqrt(np.mean([r**2 for r in rms.values()]))),
        "season_rms": rms,
        "season_folds": folds,
    }


#: the fit: forgets (bad in winter, where the zones float), right in summer (held by their units)
FIT = {"winter": [0.70, 0.75, 0.68, 0.72], "summer": [0.30, 0.33, 0.28, 0.31]}


def test_the_mean_rule_trades_summer_for_winter_and_the_season_rule_does_not():
    """A candidate with memory: winter 0.1 K² instead of 0.7, summer 0.6 instead of 0.3 (every week worse). The
    mean over seasons prefers it (session 19's default); the season rule keeps the fit and names summer. On main
    the season rule does not exist (fails there)."""
    cv = {
        "fit": _record(FIT),
        "slow": _record({"winter": [0.10, 0.12, 0.09, 0.11], "summer": [0.60, 0.64, 0.58, 0.62]}),
    }
    assert cv["slow"]["rms"] < cv["fit"]["rms"]
    assert memory.select_candidate(cv, "mean")[0] == "slow"
    kept, rec = memory.select_candidate(cv, "no_season_worse")
    assert kept == "fit"
    assert rec["worse_seasons"] == {"fit": [], "slow": ["summer"]}
    d = rec["season_differences"]["slow"]["summer"]
    assert d["folds"] == 4
    np.testing.assert_allclose(d["mse_difference"], 0.305, atol=1e-12)  # [K²] every week 0.30-0.31 worse
    assert 0 < d["se"] < 0.01  # the same loss each week: no noise to hide in


def test_a_candidate_within_its_noise_in_one_season_and_better_in_another_is_kept():
    """Summer 0.015 K² worse on average but better in two of four weeks (standard error 0.05 K²): not worse beyond
    noise, and much better in winter: the season rule keeps it too."""
    cv = {
        "fit": _record(FIT),
        "slow": _record({"winter": [0.10, 0.12, 0.09, 0.11], "summer": [0.24, 0.43, 0.22, 0.39]}),
    }
    kept, rec = memory.select_candidate(cv, "no_season_worse")
    d = rec["season_differences"]["slow"]["summer"]
    assert 0 < d["mse_difference"] < d["se"]
    assert kept == "slow"


def test_the_best_admissible_candidate_is_kept_and_a_one_week_season_admits_no_loss():
    """Of three candidates: one better everywhere but less than another that loses summer: the former is kept. A
    season with a single left-out week has no standard error: any loss there excludes a candidate."""
    cv = {
        "fit": _record(FIT),
        "slow": _record({"winter": [0.10, 0.12, 0.09, 0.11], "summer": [0.60, 0.64, 0.58, 0.62]}),
        "within": _record({"winter": [0.50, 0.52, 0.49, 0.51], "summer": [0.29, 0.30, 0.27, 0.30]}),
    }
    assert memory.select_candidate(cv, "mean")[0] == "slow"
    assert memory.select_candidate(cv, "no_season_worse")[0] == "within"
    assert memory.season_best(cv) == {"summer": "within", "winter": "slow"}
    one = {
        "fit": _record({"winter": FIT["winter"], "fall": [0.20]}),
        "slow": _record({"winter": [0.10, 0.12, 0.09, 0.11], "fall": [0.21]}),
    }
    kept, rec = memory.select_candidate(one, "no_season_worse")
    assert np.isnan(rec["season_differences"]["slow"]["fall"]["se"])
    assert (kept, rec["worse_seasons"]["slow"]) == ("fit", ["fall"])


def test_week_cv_records_the_folds_the_rule_pairs(data):  # noqa: F811
    """week_cv's per-season fold records add up to its season RMS, and the rule runs inside the fit: the forced
    forgetful fit of test_memory_s19 keeps a refit whose every season is better than the fit's (so both rules agree),
    and meta["memory"] names the rule and each season's best candidate."""
    _, ds = data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        model = fit_zones(ds, memory_select="no_season_worse", **FORGETFUL)
    info = model.meta["memory"]
    assert info["selection"]["rule"] == "no_season_worse"
    cv = info["week_cv"]
    for c in cv.values():
        for s, folds in c["season_folds"].items():
            f = np.array(folds, float)
            np.testing.assert_allclose(np.sqrt(f[:, 1].sum() / f[:, 2].sum()), c["season_rms"][s], rtol=1e-12)
    assert info["kept"] != "fit"
    assert info["selection"]["worse_seasons"][info["kept"]] == []
    assert set(info["season_best"]) == set(cv["fit"]["season_rms"])
    json.dumps(model.to_dict(), allow_nan=False)  # the record is saved with the model file


def test_option_memory_select_is_checked(data):  # noqa: F811
    _, ds = data
    with pytest.raises(FitError, match="memory_select"):
        fit_zones(ds, memory_select="worst")
    with pytest.raises(ValueError, match="selection rule"):
        memory.select_candidate({"fit": _record(FIT)}, "median")
