"""Held setpoints: the zones a local thermostat holds, tested after the forward selection.

A ``held_setpoint`` term (:mod:`hvacfmu.models.causes.held_setpoint`) limits a zone's simulated temperature to the
band its training measurements never cross (a heating setpoint it never falls below, a cooling setpoint it never
exceeds, or the setpoint a running unit stops at). It has no one-step regressor, so the forward selection cannot
score it by a likelihood ratio; it is tested here, on the selected structure, by the selection's own blocked
cross-validation. Per zone:

- the band is learned on each fold's fit rows only;
- at an unconditional edge (``lower``/``upper``: a heater or cooler the data do not meter), the zone's equation is
  also refitted without the rows whose next temperature sits at the edge (there the unmetered heat enters the zone:
  its free equation is not observed, and least squares would fold that heat into the zone's coefficients, a model
  that no longer reaches the edge). At a conditional edge (a running unit's setpoint, ``cooling_floor`` /
  ``heating_ceiling``) the unit's airflow is measured and its rows identify its effect: the fit is kept, and the
  running unit may also *hold* its setpoint exactly (``hold``: an ideal thermostat with spare capacity, wrong in
  the steps a unit runs short of capacity). Of the variants (kept, censored, hold) the one with the largest
  cross-validated gain is kept (a zone held 95 % of the time leaves too few free rows to refit);
- the fold's structure without the term and the fit with it predict the fold's 24-hour windows open loop (the other
  zones measured), and the week-clustered paired test must pass the selection's acceptance rule
  (:func:`~hvacfmu.diagnosis.crossval.gate_failures`: ``cv_min_gain_percent``, the absolute floor ``min_gain_abs``
  and ``cv_min_t``).

An accepted zone gets the term learned on every training row and, when the censored fit was kept, its censored
equation (its rows of ``A``, ``B``, ``C``, its internal-gain column and the coefficients of the terms that act on it alone). A
zone in a coupled block (a ``zone_coupling``) keeps its equation.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..models.causes.base import Candidate
from ..models.causes.held_setpoint import HeldSetpoint
from ..models.causes.reheat import zone_boxes
from .crossval import fold_fits, fold_scores, gate_failures, make_plan, paired_test
from .design import coupled_blocks, fit_structure


def own_supply(sig, zi: int) -> str:
    """The supply-air column of zone ``zi``'s own unit (``T_supply_<ahu>``) when all its boxes have one and the data
    measure it, else ``T_supply`` (the airflow-weighted supply of every unit). A running unit's mode is read from its
    own supply air: in a building of split units one flat heats while its neighbour cools, and the weighted mean of
    their supplies says neither (the EnergyPlus mid-rise apartments, ``benchmarks/apartments_s16.md``)."""
    cols = {sig.supply_of.get(v, "T_supply") for v in zone_boxes(sig.base, sig.zones[zi])}
    c = cols.pop() if len(cols) == 1 else "T_supply"
    return c if c in sig.extra else "T_supply"


def _learn(sig, zi: int, rows):
    c = own_supply(sig, zi)
    Ts = sig.extra[c] if c != "T_supply" else sig.V.get("T_supply")
    return HeldSetpoint.learn(sig.zones[zi], sig.Y[:, zi], sig.U[:, zi], Ts, rows, float(sig.u_min[zi]), supply=c)


def _hold(model):
    """``model`` with its last term (the fold's held_setpoint) holding a running unit's setpoint exactly."""
    t = model.terms[-1]
    if not isinstance(t, HeldSetpoint) or (t.cooling_floor is None and t.heating_ceiling is None):
        return model
    return model.with_terms(list(model.terms[:-1]) + [dataclasses.replace(t, hold=True)])


def _censored(sig, zi: int, term, rows) -> np.ndarray:
    """``rows`` without those whose next temperature of zone ``zi`` sits at ``term``'s edges."""
    return np.setdiff1d(rows, term.held_rows(sig.Y[:, zi], rows))


def _splice(model, censored, zi: int):
    """``model`` with zone ``zi``'s equation (base rows, gain column, its own terms) taken from ``censored``."""
    b, c = model.base, censored.base
    A, B, C = b.A.copy(), b.B.copy(), b.C.copy()
    A[zi], B[zi], C[zi] = c.A[zi], c.B[zi], c.C[zi]
    gains = {}
    for s, g in b.gains.items():
        g = np.array(g, float)
        if s in c.gains:
            g[:, zi] = np.asarray(c.gains[s], float)[:, zi]
        gains[s] = g
    base = dataclasses.replace(b, A=A, B=B, C=C, gains=gains)
    z = b.outputs[zi]
    terms = [tc if t.affected(()) == (z,) else t for t, tc in zip(model.terms, censored.terms)]
    return model.with_terms(terms, base=base)


def held_setpoints(sig, model, opts: dict) -> tuple:
    """``(model with the accepted terms, candidates)`` for every zone whose training data show a held edge.

    ``model``: the selected :class:`~hvacfmu.models.extended.ExtendedModel`; candidates are :class:`Candidate`
    with status ``"found"`` or ``"no held-out gain"`` (``cv``: the paired test; ``evidence``: the edges and their
    pile-up and crossing shares on the training rows).
    """
    rows = sig.rows("train")
    have = {t.zone for t in model.terms if isinstance(t, HeldSetpoint)}
    found = {}
    for zi, z in enumerate(sig.zones):
        if z in have:
            continue
        term, ev = _learn(sig, zi, rows)
        if term is not None:
            found[zi] = (term, ev)
    if not found:  # no zone meets the evidence rule: no plan, no fit, no cross-validation
        return model, []
    plan = make_plan(sig, opts.get("cv_folds", 10), opts["horizon"])
    cands = []
    if plan is None:
        for term, ev in found.values():
            cands.append(Candidate(HeldSetpoint.cause, term.location(), [term], 0, "untestable",
                                   "fewer than 4 training weeks: no cross-validation", ev, term=term))  # fmt: skip
        return model, cands
    terms = list(model.terms)
    folds = fold_fits(sig, plan, terms, sorted(found))  # only the equations of the zones with an edge are simulated
    alone = {blk[0] for blk in coupled_blocks(sig, terms) if len(blk) == 1}
    final = model
    for zi, (term, ev) in found.items():
        before = fold_scores(sig, plan, folds, [zi])
        # the limiter on the fold's structure; at an unconditional edge also on the censored refit of the zone
        plain, censored = [], []
        for f, m in enumerate(folds):
            t_f, _ = _learn(sig, zi, plan.fit_rows[f])
            plain.append(m if t_f is None else m.with_terms(list(m.terms) + [t_f]))
            if zi in alone and t_f is not None and (t_f.lower is not None or t_f.upper is not None):
                m = fit_structure(sig, terms, _censored(sig, zi, t_f, plan.fit_rows[f]), only_zones=[zi]).model
                censored.append(m.with_terms(list(m.terms) + [t_f]))
            else:
                censored.append(plain[-1])
        tests = {"kept": paired_test(plan, before, fold_scores(sig, plan, plain, [zi]))}
        if any(c is not p for c, p in zip(censored, plain)):
            tests["censored"] = paired_test(plan, before, fold_scores(sig, plan, censored, [zi]))
        if term.cooling_floor is not None or term.heating_ceiling is not None:
            holding = [_hold(m) for m in plain]
            tests["hold"] = paired_test(plan, before, fold_scores(sig, plan, holding, [zi]))
        variant = max(
            tests, key=lambda k: -np.inf if tests[k].get("gain_percent") is None else tests[k]["gain_percent"]
        )
        cv = tests[variant]
        censor = variant == "censored"
        if variant == "hold":
            term = dataclasses.replace(term, hold=True)
        short = gate_failures(cv, opts)
        ok = not short
        edges = ", ".join(f"{k} {v:g} °C" for k, v in term.coefficients().items() if k != "u_on")
        ev = {**ev, "censored_fit": censor, "variant": variant}
        ev["cv_gain_percent_by_variant"] = {k: t.get("gain_percent") for k, t in tests.items()}
        c = Candidate(
            HeldSetpoint.cause,
            term.location(),
            [term],
            0,
            "found" if ok else "no held-out gain",
            (f"held edge ({edges}) crossed by the open-loop prediction; limiting it gains {cv['gain_percent']:.1f} % "
             f"(paired t {cv['t']:.1f})") if ok else "limiting the prediction to the held band gains too little "
            "in the cross-validation: " + "; ".join(short.values()),
            ev,
            test={"open_loop_only": True},
            term=term,
        )  # fmt: skip
        c.cv = cv
        cands.append(c)
        if ok:
            if censor and (term.lower is not None or term.upper is not None):
                final = _splice(
                    final, fit_structure(sig, terms, _censored(sig, zi, term, rows), only_zones=[zi]).model, zi
                )
            final = final.with_terms(list(final.terms) + [term])
    return final, cands
