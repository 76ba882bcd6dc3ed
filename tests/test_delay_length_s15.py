"""An actuation delay's length is picked by the blocked 24-h cross-validation, not by the one-step fit (session 15).

quad4 battery case 4 (``benchmarks/diagnosis_quad4_s15.md``): a 45-min delay was found at 15 min, the one-step
fit's pick, while the cross-validation gains most at 30 min. The diagnosis now cross-validates the best one-step
variants of a delay candidate (``delay_cv_variants``) and keeps the one with the largest cross-validated gain
(``benchmarks/diagnosis_delay_length_s15.md``).
"""

from __future__ import annotations

from hvacfmu.diagnosis import selection as S
from hvacfmu.diagnosis.crossval import make_plan
from hvacfmu.diagnosis.design import Within, fit_structure, make_signals
from hvacfmu.models.causes.actuation_delay import ActuationDelay
from hvacfmu.models.extended import ExtendedModel
from tests.test_diagnosis import row_model, simulate_dataset


def _scored(variants):
    """``(sig, W, plan, candidate)``: the zone-C delay candidate of a true 3-step delay in C (random airflow,
    8 weeks), scored on the training rows with only ``variants`` (delays in steps) to choose from."""
    base = row_model()
    ds = simulate_dataset(ExtendedModel(base=base, terms=(ActuationDelay(zone="C", delay=3),)), weeks=8, seed=3)
    sig = make_signals(ds, base)
    rows = sig.rows("train")
    W = Within(sig.group, rows)
    cur = fit_structure(sig, [], rows)
    (c,) = [c for c in ActuationDelay.screen(sig, [], W, cur.resid, {}) if c.location["zone"] == "C"]
    c.variants = [ActuationDelay(zone="C", delay=d) for d in variants]
    factors = [S.ess_factor(S.lag1(cur.resid[:, z])) for z in range(sig.nz)]
    S.score_candidate(sig, W, [], [ls.rss for ls in cur.zone_ls], factors, c, S.DEFAULT_OPTIONS)
    return sig, W, make_plan(sig, 10, 96), c


def test_score_keeps_the_one_step_runners_up_of_a_delay():
    _, _, _, c = _scored([1, 2, 3, 4])
    assert c.term.delay == 3  # white airflow: the one-step fit is right here
    alts = c.alternatives
    assert all(a["opts"] == S.DEFAULT_OPTIONS for a in alts)
    assert len(alts) == S.DEFAULT_OPTIONS["delay_cv_variants"] - 1
    lrs = [c.test["lr"]] + [a["test"]["lr"] for a in alts]
    assert lrs == sorted(lrs, reverse=True)
    assert {a["term"].delay for a in alts} <= {1, 2, 4}


def test_cross_validation_picks_the_delay_length_the_one_step_fit_missed():
    """A candidate whose one-step pick is 1 step (its runner-up: the true 3 steps) ends at 3 steps after the
    cross-validation, with the 3-step variant's own test, location and history evidence."""
    sig, W, plan, c = _scored([1])
    _, _, _, c3 = _scored([3])
    assert c.term.delay == 1 and c.alternatives == []
    c.alternatives = [{"term": c3.term, "test": c3.test, "W": W, "opts": S.DEFAULT_OPTIONS}]
    S.cross_validate(sig, plan, [], c, {})
    ev = c.evidence["delay_length_cv"]
    assert ev["one_step_pick"] == 1 and ev["picked"] == 3
    assert ev["gain_percent_by_delay"]["3"] > ev["gain_percent_by_delay"]["1"]
    assert c.term.delay == 3 and c.location["delay"] == 3
    assert c.test == c3.test
    assert c.cv["gain_percent"] == ev["gain_percent_by_delay"]["3"]
    assert c.evidence["history"]["delta_bic"] == c3.evidence["history"]["delta_bic"]
