"""The diagnosis's terms on a given base model's dynamics: the extended model to control with.

:func:`~hvacfmu.diagnosis.diagnose` scores and fits its terms jointly with a one-step
least-squares refit of the base structure. On closed-loop data that refit has a one-step
airflow response an order of magnitude below the building's (measured on the emulator's
plant: −0.09 … −0.15 K per step per kg/s against −1.3 … −1.6 for the plant and −0.43 …
−0.63 for the fitted Model A), because the airflow follows the zone temperature; its
steady-state gain is of the right order, so it forecasts well open loop, but an MPC that
trusts its first steps commands bang-bang moves (README "Control gain of the diagnosis").

:func:`terms_on_base` keeps the base model's state, input and disturbance matrices
``A, B, C`` as they are and re-estimates only the diagnosed terms' coefficients and the
internal-gain profiles (the same within-slot least squares as the diagnosis, with the base
prediction as a fixed offset). With ``terms=()`` it gives the matching base: the same gain
profile estimate without terms, so that base → extended compares the terms alone.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import FitError
from ..models.causes.signals import Within, coupling_ratios, effective_inputs
from ..models.extended import ExtendedModel
from .design import _gains_from_fit, base_linear, bounded_ls, coupled_blocks, make_signals, term_features, zone_design


def _fixed_prediction(sig, base, U_eff) -> np.ndarray:
    """``A y + B u + C v`` of the base model at every row (without internal gains) [°C]."""
    V = np.column_stack([sig.V[c] for c in base.disturbances]) if base.disturbances else np.zeros((len(sig.Y), 0))
    return sig.Y @ base.A.T + U_eff @ base.B.T + V @ base.C.T


def _term_columns(sig, terms, U_eff, feats, z):
    """Names, columns, bounds and owning term of zone ``z``'s term regressors."""
    D = zone_design(sig, z, terms, U_eff, feats)
    keep = [k for k, own in enumerate(D.owner) if own >= 0]
    return (
        [D.names[k] for k in keep],
        D.X[:, keep],
        D.lower[keep],
        D.upper[keep],
        [D.owner[k] for k in keep],
    )


def _kept_values(sig, term) -> dict:
    """The design coefficients (feature name -> value) of a term whose fitted coefficients are kept."""
    if term.cause == "zone_coupling":
        ra, _ = coupling_ratios(sig, sig.zones.index(term.zone_a), sig.zones.index(term.zone_b))
        return {"k": term.coef_ab / ra}
    if hasattr(term, "coef"):
        return {"coef": term.coef}
    raise FitError(f"terms_on_base: cannot keep the coefficients of a {term.cause} term; refit it instead")


def _solve(sig, terms, keep, keys, X, y, lo, hi, dof_extra):
    """(θ, 1-σ) of the block's least squares, with the kept terms' coefficients fixed at their values."""
    pinned = {j: _kept_values(sig, terms[own])[nm] for j, (own, nm) in enumerate(keys) if terms[own].cause in keep}
    if not pinned:
        ls = bounded_ls(X, y, lo, hi, dof_extra=dof_extra)
        return ls.theta, np.sqrt(np.maximum(np.diag(ls.cov), 0.0))
    free = [j for j in range(len(keys)) if j not in pinned]
    theta, sd = np.zeros(len(keys)), np.zeros(len(keys))
    for j, v in pinned.items():
        theta[j] = v
        y = y - X[:, j] * v
    if free:
        ls = bounded_ls(X[:, free], y, [lo[j] for j in free], [hi[j] for j in free], dof_extra=dof_extra)
        theta[free] = ls.theta
        sd[free] = np.sqrt(np.maximum(np.diag(ls.cov), 0.0))
    return theta, sd


def terms_on_base(dataset, base, terms=(), meta=None, keep=()) -> ExtendedModel:
    """The base model (``A, B, C`` kept) with ``terms`` refitted on it, and its gain profiles re-estimated.

    Parameters
    ----------
    dataset : hvacfmu.data.Dataset
        The data the diagnosis ran on (its training weeks are used).
    base : LinearZoneModel or ExtendedModel
        Model A in the airflow form (an extended model: its base).
    terms : sequence of Term
        The diagnosis's terms (e.g. ``report.model.terms``); their structural parameters
        (zone, facade, delay, slow-mass rate ...) are kept, their coefficients refitted.
    meta : dict, optional
    keep : sequence of str
        Causes whose terms keep the coefficients they come with (e.g. the diagnosis's
        ``zone_coupling`` conductance) instead of being refitted; the other terms and the gain
        profiles are fitted around them.

    Returns
    -------
    ExtendedModel
    """
    base = base_linear(base)
    sig = make_signals(dataset, base)
    rows = sig.rows("train")
    if len(rows) < 50:
        raise FitError(f"only {len(rows)} usable one-step rows in the training weeks; need at least 50")
    W = Within(sig.group, rows)
    terms = list(terms)
    U_eff = effective_inputs(sig, terms)
    feats = [term_features(sig, t, U_eff) for t in terms]
    fixed = _fixed_prediction(sig, base, U_eff)
    target = np.vstack([sig.Y[1:], np.full((1, sig.nz), np.nan)]) - fixed
    yhat = np.zeros_like(target)
    coefs = [dict() for _ in terms]
    stds = [dict() for _ in terms]
    for block in coupled_blocks(sig, terms):
        cols = {z: _term_columns(sig, terms, U_eff, feats, z) for z in block}
        keys, lo, hi = [], [], []
        for z in block:
            for nm, own, lw, up in zip(cols[z][0], cols[z][4], cols[z][2], cols[z][3]):
                if (own, nm) not in keys:
                    keys += [(own, nm)]
                    lo.append(lw)
                    hi.append(up)
        if not keys:
            continue
        n = len(W.rows)
        X = np.zeros((n * len(block), len(keys)))
        y = np.concatenate([W(target[:, z]) for z in block])
        for i, z in enumerate(block):
            Xw = W(cols[z][1])
            for j, (nm, own) in enumerate(zip(cols[z][0], cols[z][4])):
                X[i * n : (i + 1) * n, keys.index((own, nm))] = Xw[:, j]
        theta, sd = _solve(sig, terms, keep, keys, X, y, lo, hi, W.n_groups * len(block))
        for (own, nm), th, s in zip(keys, theta, sd):
            coefs[own][nm], stds[own][nm] = float(th), float(s)
        for z in block:
            th = np.array([theta[keys.index((own, nm))] for nm, own in zip(cols[z][0], cols[z][4])])
            with np.errstate(invalid="ignore"):
                yhat[:, z] = cols[z][1] @ th
    gains = _gains_from_fit(sig, rows, target - yhat, W)
    new_base = dataclasses.replace(
        base,
        gains=gains,
        meta={**{k: v for k, v in base.meta.items() if k != "uncertainty"}, "refit": "gains on the base's A, B, C"},
    )
    new_terms = tuple(t if t.cause in keep else t.with_fit(sig, coefs[i], stds[i]) for i, t in enumerate(terms))
    return ExtendedModel(base=new_base, terms=new_terms, meta=dict(meta or {}))
