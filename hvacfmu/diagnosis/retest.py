"""Wind infiltration re-tested after the held setpoints (option ``wind_retest``; off by default).

The forward selection cross-validates a ``wind_infiltration`` candidate against fold models *without* the
held-setpoint limiters (they are learned after the selection, :mod:`hvacfmu.diagnosis.held`). In a zone whose unit
holds it at a setpoint for much of the year, the wind term's open-loop effect is then judged mostly on windows where
the real zone is held and the fold model is not: the EnergyPlus mid-rise apartments' S1/S2 flats float only in the
coldest weeks, where the wind × ΔT regressor has t 14 on one step, and the year-round cross-validation rejects it
(``benchmarks/apartments_s17.md``). Here, after the held stage, every wind candidate the selection did not accept
(significant on its screen: cross-validated and rejected, left out for the load checks, or not tried) in a zone
with an accepted held term is cross-validated again, both fold models carrying that zone's held term (learned on
the fold's fit rows, the variant the held stage kept), by the selection's own acceptance rule
(:func:`~hvacfmu.diagnosis.crossval.gate_failures`):

- ``wind_retest="year"``: the paired week-clustered test over every window (as the selection);
- ``wind_retest="floating"``: also, when that fails, the same test over the *floating* windows only (the zone's
  unit runs in at most :data:`FLOATING_SHARE` of the window's steps: the regime where a leak is not compensated by a
  thermostat, declared before any score is read), provided the other windows do not get significantly worse
  (their paired t above ``-cv_min_t``). The term itself is the year-round ``wind_infiltration``: a leak acts all
  year, and while the unit runs the held term holds the zone.

An accepted term must also leave the jointly refitted model passing the load checks (as in the selection); the
pipeline then refits the selected structure with it and runs the held stage again on that structure. Measured on the
apartments (``benchmarks/apartments_s18.md``): nothing passes there, so the option stays off.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..models.causes.held_setpoint import HeldSetpoint, running_threshold
from ..models.causes.internal_gain_schedule import InternalGainSchedule
from ..models.causes.wind_infiltration import WIND_COLUMN, WindInfiltration
from ..models.loadcheck import model_problems
from .crossval import fold_fits, fold_scores, gate_failures, make_plan, paired_test
from .held import _learn

#: A window is *floating* when the zone's unit runs (airflow above its running threshold) in at most this share of
#: its steps.
FLOATING_SHARE = 0.1
#: ``wind_retest`` values.
MODES = (False, "year", "floating")
#: Selection statuses of a candidate significant on its screen but not accepted.
RETESTED_STATUSES = ("no cross-validated gain", "rejected", "not tested")


def floating_windows(sig, zi: int, plan) -> list:
    """Per fold, a bool per window: the zone's unit runs in at most :data:`FLOATING_SHARE` of the window's steps."""
    rows = sig.rows("train")
    u = sig.U[:, zi]
    q99 = float(np.nanpercentile(u[rows], 99)) if rows.size else 0.0
    run = np.nan_to_num(u, nan=0.0) > running_threshold(q99, float(sig.u_min[zi]))
    cum = np.concatenate([[0], np.cumsum(run)])
    return [(cum[st + plan.horizon] - cum[st]) / plan.horizon <= FLOATING_SHARE for st in plan.starts]


def _subset_test(plan, before: list, after: list, keep: list) -> dict:
    """:func:`paired_test` over the windows ``keep`` (per fold, a bool per window) only."""
    sub = dataclasses.replace(plan, week_of_start=[w[k] for w, k in zip(plan.week_of_start, keep)])
    return paired_test(sub, [b[k] for b, k in zip(before, keep)], [a[k] for a, k in zip(after, keep)])


def _with_held(sig, plan, models: list, zi: int, held: HeldSetpoint) -> list:
    """Each fold model with zone ``zi``'s held term learned on the fold's fit rows (the held stage's variant)."""
    out = []
    for f, m in enumerate(models):
        t_f, _ = _learn(sig, zi, plan.fit_rows[f])
        out.append(m if t_f is None else m.with_terms(list(m.terms) + [dataclasses.replace(t_f, hold=held.hold)]))
    return out


def _fmt(r: dict) -> str:
    if r.get("gain_percent") is None:
        return f"no gain ({r.get('n_weeks', 0)} weeks)"
    return f"{r['gain_percent']:+.2f} % (t {r['t']:.2f}, {r['n_weeks']} weeks)"


def wind_after_held(sig, model, held_cands: list, candidates: list, opts: dict, refit) -> tuple:
    """``(accepted candidates, notes)``: the selection's unaccepted wind candidates re-tested after the held stage.

    ``model``: the model after the held stage (selected terms and held terms); ``held_cands``: the held stage's
    candidates; ``candidates``: the selection's other candidates (the wind ones are updated in place: status
    ``"found"`` when accepted, ``evidence["retest_after_held"]`` always); ``refit(terms)``: the selected structure
    refitted on the training rows with ``terms`` (for the load checks). Does nothing unless ``opts["wind_retest"]``.
    """
    mode = opts.get("wind_retest", False)
    if mode not in MODES:
        raise ValueError(f"wind_retest must be one of {MODES}, got {mode!r}")
    if not mode or WIND_COLUMN not in sig.extra:
        return [], []
    held = {t.zone: t for t in model.terms if isinstance(t, HeldSetpoint)}
    censored = {c.location.get("zone") for c in held_cands if c.status == "found" and c.evidence.get("censored_fit")}
    selected = [t for t in model.terms if not isinstance(t, HeldSetpoint)]
    have = {t.zone for t in selected if isinstance(t, WindInfiltration)}
    todo = [
        c
        for c in candidates
        if c.cause == WindInfiltration.cause
        and c.status in RETESTED_STATUSES
        and c.location["zone"] in held
        and c.location["zone"] not in have | censored
    ]
    notes: list = []
    if not todo:
        return [], notes
    if any(isinstance(t, InternalGainSchedule) for t in selected):
        notes.append("wind_retest: not run (the selection holds a calendar term, whose profiles the refit would move)")
        return [], notes
    plan = make_plan(sig, opts.get("cv_folds", 10), opts["horizon"])
    if plan is None:
        return [], notes
    accepted: list = []
    for c in todo:
        z = c.location["zone"]
        zi = sig.zones.index(z)
        before = fold_scores(sig, plan, _with_held(sig, plan, fold_fits(sig, plan, selected, [zi]), zi, held[z]), [zi])
        with_w = fold_fits(sig, plan, selected + [WindInfiltration(zone=z)], [zi])
        after = fold_scores(sig, plan, _with_held(sig, plan, with_w, zi, held[z]), [zi])
        tests = {"year": paired_test(plan, before, after)}
        variant = "year" if not gate_failures(tests["year"], opts) else None
        if variant is None and mode == "floating":
            fl = floating_windows(sig, zi, plan)
            tests["floating"] = _subset_test(plan, before, after, fl)
            tests["not_floating"] = _subset_test(plan, before, after, [~k for k in fl])
            other_t = tests["not_floating"].get("t")
            if not gate_failures(tests["floating"], opts) and (other_t is None or other_t > -opts["cv_min_t"]):
                variant = "floating"
        ev = {"tests": tests, "variant": variant, "selection_status": c.status, "selection_cv": c.cv}
        c.evidence["retest_after_held"] = ev
        said = "; ".join(f"{k} windows {_fmt(r)}" for k, r in tests.items())
        if variant is None:
            c.reason = f"{c.reason}; re-tested after the held stage (fold models with {z}'s held term): {said}"
            continue
        fitted = refit(selected + [a.term for a in accepted] + [WindInfiltration(zone=z)])
        bad = model_problems(fitted)
        if bad:
            c.reason = (
                f"{c.reason}; re-tested after the held stage: {said}, but with it the refitted model fails the load "
                f"checks ({'; '.join(bad)})"
            )
            continue
        c.term = next(t for t in fitted.terms if isinstance(t, WindInfiltration) and t.zone == z)
        c.status, c.cv = "found", tests[variant]
        c.reason = (
            f"rejected by the selection ({ev['selection_status']}), found when re-tested after the held stage with "
            f"{z}'s held term in the fold models: {said} (accepted on the {variant} windows)"
        )
        accepted.append(c)
    return accepted, notes


__all__ = ["FLOATING_SHARE", "floating_windows", "wind_after_held"]
