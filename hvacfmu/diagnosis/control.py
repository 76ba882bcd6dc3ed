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

Where the data measure the boxes' discharge air (``Td_<vav>``: every reheat building), the
diagnosis's base (Model A in the airflow form) does not see the reheat that holds the zones: on
fleet sweep s10's b000 (reheat-dual, airflow at its minimum 71-80 % of the time, reheat on 39 %)
its one-step coefficients are a ≈ 0.45-0.49 and B −0.28 … −0.78 K per step per kg/s, a first-step
reheat gain of 0.04-0.10 K per kW against the plant's 0.31, and an MPC on it cycles between full
reheat at minimum airflow and maximum airflow every other step (8.70 K·h in two days, 41 reversals
in R2). :func:`terms_on_base` therefore refits the terms by default (``heat="auto"``) on the
delivered-heat twin of that base (the same fit options, ``heat="delivered"``: each box acts through
``m c_p (Td - T_zone)``), as ``fit --model zones`` does on such data; the terms' regressors still come
from the airflow base's signals. Supply-air bilinear and reheat terms are dropped (the twin's boxes carry
that heat); an actuation delay acts on the zone airflow, which that form does not have: the airflow base is
kept then, with a warning.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from ..errors import DataError, FitError, HvacfmuWarning
from ..models.causes.reheat import reheat_column
from ..models.causes.signals import Within, coupling_ratios, effective_inputs
from ..models.extended import ExtendedModel
from .design import _gains_from_fit, base_linear, bounded_ls, coupled_blocks, make_signals, term_features, zone_design

#: causes whose terms act on Model A's zone airflow input (a delayed airflow): a delivered-heat base has one
#: airflow per box acting at once, and no such input
AIRFLOW_CAUSES = ("actuation_delay",)
#: causes whose heat the delivered-heat base carries through its boxes' ``m c_p (T_in - x)`` (the supply air's
#: ``u (T_supply - x)``, the reheat read from the discharge air or switched at minimum airflow)
CARRIED_CAUSES = ("supply_air_bilinear", "reheat")


def _acts_on_airflow(term) -> bool:
    return term.cause in AIRFLOW_CAUSES


#: causes whose terms keep the diagnosis's coefficients where the refit on the base zeroes them (session 19)
KEEP_ZEROED = ("zone_coupling",)


def _fixed_prediction(sig, base, U_eff, dataset=None) -> np.ndarray:
    """The base model's step at every row without internal gains [°C]: ``A y + B u + C v`` (airflow form),
    plus ``beta Σ m c_p (T_in - y)`` of the boxes (delivered-heat form, read from ``dataset``'s frame)."""
    if getattr(base, "beta", None) is not None:
        u, v = base.signals(dataset.frame)
        return base.step_state(sig.Y, u, v, 0.0)
    V = np.column_stack([sig.V[c] for c in base.disturbances]) if base.disturbances else np.zeros((len(sig.Y), 0))
    return sig.Y @ base.A.T + U_eff @ base.B.T + V @ base.C.T


def delivered_twin(dataset, base, terms=()):
    """``(twin, terms, notes, fit_notes)``: the delivered-heat twin of the airflow-form ``base``, the terms it
    carries, what was decided (to warn of) and the twin fit's own warnings (recorded, as the base fit's are).

    ``twin`` is ``None`` (the airflow base stays) when the data measure no discharge air ``Td_<vav>`` of the
    base's boxes, when the base is not an airflow-form Model A, or when a term acts on the zone airflow
    (:data:`AIRFLOW_CAUSES`: a delayed airflow); ``notes`` say why. The twin is fitted with the base's own fit
    options (``meta["options"]``) and ``heat="delivered"``. Terms whose heat the twin carries through its
    boxes' ``m c_p (T_in - x)`` are dropped (:data:`CARRIED_CAUSES`: supply air times airflow, reheat; and an
    unused-input term on a column the twin reads as a box inlet).
    """
    base = base.base if isinstance(base, ExtendedModel) else base
    frame = dataset.frame
    vavs = tuple(getattr(base, "vavs", ()))
    td = [f"Td_{v}" for v in vavs if f"Td_{v}" in frame.columns]
    if getattr(base, "beta", None) is not None or getattr(base, "kind", "") != "zones" or not td:
        return None, tuple(terms), [], []
    on_airflow = [t for t in terms if _acts_on_airflow(t)]
    if on_airflow:
        names = ", ".join(f"{t.cause} in {getattr(t, 'zone', '?')}" for t in on_airflow)
        return (
            None,
            tuple(terms),
            [
                f"the control model stays on the airflow-form base although the data measure the discharge air "
                f"({len(td)} of {len(vavs)} boxes): the term(s) {names} act on the zone airflow, which the "
                "delivered-heat form does not have; its reheat gain comes from the airflow gain and may be far "
                "below the building's (README 'Control gain of the diagnosis')"
            ],
            [],
        )
    from ..fitting import fit

    opts = dict((base.meta or {}).get("options") or {})
    opts.update(heat="delivered")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            twin = fit(dataset, "zones", progress=False, **opts)
        except (FitError, DataError) as e:
            return (
                None,
                tuple(terms),
                [
                    f"the control model stays on the airflow-form base: its delivered-heat form could not be fitted ({e})"
                ],
                [],
            )
    fit_notes = [f"delivered-heat base fit: {w.message}" for w in caught if issubclass(w.category, HvacfmuWarning)]
    if tuple(twin.outputs) != tuple(base.outputs):
        raise FitError(
            f"terms_on_base: the delivered-heat twin has outputs {list(twin.outputs)}, the base "
            f"{list(base.outputs)}; pass heat='airflow' to keep the airflow base"
        )
    inlets = set(twin.inlets)
    kept, dropped = [], []
    for t in terms:
        carried = t.cause in CARRIED_CAUSES or (t.cause == "unused_input" and getattr(t, "column", None) in inlets)
        (dropped if carried else kept).append(t)
    notes = [
        f"the control model is built on the delivered-heat form of the base (each box acts through "
        f"m c_p (Td - T_zone); the discharge air is measured at {len(td)} of {len(vavs)} boxes): the airflow form "
        "does not see the reheat that holds the zones (on reheat buildings its first-step airflow and reheat gains "
        "were measured far below the plant's: README 'Control gain of the diagnosis')"
    ]
    if dropped:
        notes.append(
            "dropped from the control model, the delivered-heat base carries their heat through its boxes: "
            + ", ".join(
                f"{t.cause} in {t.zone}"
                + (
                    f" ({getattr(t, 'column', None) or reheat_column(t.zone)})"
                    if t.cause != "supply_air_bilinear"
                    else ""
                )
                for t in dropped
            )
        )
    return twin, tuple(kept), notes, fit_notes


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


def _solve(sig, terms, kept, keys, X, y, lo, hi, dof_extra):
    """(θ, 1-σ) of the block's least squares, with the kept terms' (indices ``kept``) coefficients fixed."""
    pinned = {j: _kept_values(sig, terms[own])[nm] for j, (own, nm) in enumerate(keys) if own in kept}
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


def terms_on_base(dataset, base, terms=(), meta=None, keep=(), heat="auto", keep_zeroed=KEEP_ZEROED) -> ExtendedModel:
    """The base model (``A, B, C`` kept) with ``terms`` refitted on it, and its gain profiles re-estimated.

    Parameters
    ----------
    dataset : hvacfmu.data.Dataset
        The data the diagnosis ran on (its training weeks are used).
    base : LinearZoneModel or ExtendedModel
        Model A in the airflow form (an extended model: its base).
    heat : {"auto", "airflow"}
        ``"auto"``: where the data measure the boxes' discharge air, the terms go on the base's
        delivered-heat twin (:func:`delivered_twin`; a warning says so, ``meta["control_base"]`` records
        it); ``"airflow"``: always on ``base`` as given.
    terms : sequence of Term
        The diagnosis's terms (e.g. ``report.model.terms``); their structural parameters
        (zone, facade, delay, slow-mass rate ...) are kept, their coefficients refitted.
    meta : dict, optional
    keep : sequence of str
        Causes whose terms keep the coefficients they come with (e.g. the diagnosis's
        ``zone_coupling`` conductance) instead of being refitted; the other terms and the gain
        profiles are fitted around them.
    keep_zeroed : sequence of str
        Causes whose terms keep the coefficients they come with **when the refit sets every coefficient of
        the term to 0** (default :data:`KEEP_ZEROED`: ``("zone_coupling",)``, the diagnosis's coupling
        conductance; a warning names each such term); ``()`` lets the refit drop them (a warning names them).

    Returns
    -------
    ExtendedModel
    """
    if heat not in ("auto", "airflow"):
        raise FitError(f"terms_on_base: heat must be 'auto' or 'airflow', got {heat!r}")
    base = base_linear(base)
    sig = make_signals(dataset, base)
    meta = dict(meta or {})
    dyn = base  # the model whose dynamics the terms are refitted on
    if heat == "auto":
        twin, terms, notes, fit_notes = delivered_twin(dataset, base, terms)
        for note in notes:
            warnings.warn(note, HvacfmuWarning, stacklevel=2)
        if twin is not None:
            dyn = twin
        meta["control_base"] = {"heat": dyn.heat, "notes": notes + fit_notes}
    # a term without a matrix form (``Term.matrix_form`` False: ``held_setpoint``, a limiter standing for an
    # unmetered thermostat, whose heat a controller must not be told is free) cannot be controlled with: left out,
    # said
    no_form = [t for t in terms if not getattr(t, "matrix_form", True)]
    if no_form:
        note = (
            "the control model leaves out "
            + ", ".join(f"{t.cause} in {', '.join(t.zones())}" for t in no_form)
            + ": the term has no matrix form (ModelEquations) the MPC (or a native FMU) can use; the MPC controls "
            "without it (the diagnosis's extended model keeps it: evaluate it, or export it as a Python FMU)"
        )
        warnings.warn(note, HvacfmuWarning, stacklevel=2)
        meta.setdefault("control_base", {}).setdefault("notes", []).append(note)
        meta["left_out"] = [t.to_dict() for t in no_form]
    terms = [t for t in terms if getattr(t, "matrix_form", True)]
    U_eff = effective_inputs(sig, terms)
    feats = [term_features(sig, t, U_eff) for t in terms]
    fixed = _fixed_prediction(sig, dyn, U_eff, dataset)
    target = np.vstack([sig.Y[1:], np.full((1, sig.nz), np.nan)]) - fixed
    rows = sig.rows("train")
    rows = rows[np.isfinite(target[rows]).all(axis=1)]  # a delivered-heat base: discharge air measured too
    if len(rows) < 50:
        raise FitError(f"only {len(rows)} usable one-step rows in the training weeks; need at least 50")
    W = Within(sig.group, rows)
    kept = {i for i, t in enumerate(terms) if t.cause in keep}
    coefs, stds, yhat = _refit(sig, terms, kept, U_eff, feats, target, W)
    zeroed = zeroed_terms(terms, coefs, keep)
    # a term of a ``keep_zeroed`` cause that the refit drops keeps the coefficients it comes with (when it has any),
    # the others refitted around it: session 19 (``benchmarks/control_front_s19.md``) measured the MPC with a quad4
    # coupling's diagnosed conductance kept against the refit's zero on comfort-against-energy fronts
    restored = [
        i
        for i, t in enumerate(terms)
        if any(t is z for z in zeroed) and t.cause in keep_zeroed and any(v != 0.0 for v in t.coefficients().values())
    ]
    if restored:
        kept |= set(restored)
        coefs, stds, yhat = _refit(sig, terms, kept, U_eff, feats, target, W)
    gains = _gains_from_fit(sig, rows, target - yhat, W)
    new_base = dataclasses.replace(
        dyn,
        gains=gains,
        meta={**{k: v for k, v in dyn.meta.items() if k != "uncertainty"}, "refit": "gains on the base's A, B, C"},
    )
    new_terms = tuple(t if i in kept else t.with_fit(sig, coefs[i], stds[i]) for i, t in enumerate(terms))
    # not silent: a term the diagnosis accepted that the refit on the control base drops (every coefficient at 0) is
    # named, whether the control model keeps the diagnosis's coefficients (``keep_zeroed``) or controls without it
    # (session 17: a quad4 coupling found at t 5.3 was refitted to 0, ``benchmarks/control_gain_coupling_s17.md``)
    notes = []
    back = [terms[i] for i in restored]
    dropped = [t for t in zeroed if not any(t is b for b in back)]
    if back:
        notes.append(
            "the control model's refit on the base sets "
            + ", ".join(f"{t.cause} in {', '.join(t.zones())}" for t in back)
            + " to 0 (every coefficient at its bound); the control model keeps the diagnosis's coefficients "
            "instead, the other terms refitted around them (keep_zeroed=() drops "
            + ("it" if len(back) == 1 else "them")
            + ")"
        )
    if dropped:
        notes.append(
            "the control model's refit on the base sets "
            + ", ".join(f"{t.cause} in {', '.join(t.zones())}" for t in dropped)
            + " to 0 (every coefficient at its bound): the MPC controls without "
            + ("it" if len(dropped) == 1 else "them")
            + "; keep=("
            + ", ".join(sorted({repr(t.cause) for t in dropped}))
            + ",) keeps the coefficients the terms come with instead"
        )
    for note in notes:
        warnings.warn(note, HvacfmuWarning, stacklevel=2)
        meta.setdefault("control_base", {}).setdefault("notes", []).append(note)
    if zeroed:
        meta["zeroed"] = [{**t.to_dict(), "kept": any(t is b for b in back)} for t in zeroed]
    return ExtendedModel(base=new_base, terms=new_terms, meta=meta)


def _refit(sig, terms, kept, U_eff, feats, target, W):
    """(coefficients, their 1-σ, the terms' one-step prediction) of every coupled block's least squares, with the
    terms of indices ``kept`` at the coefficients they come with."""
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
        theta, sd = _solve(sig, terms, kept, keys, X, y, lo, hi, W.n_groups * len(block))
        for (own, nm), th, s in zip(keys, theta, sd):
            coefs[own][nm], stds[own][nm] = float(th), float(s)
        for z in block:
            th = np.array([theta[keys.index((own, nm))] for nm, own in zip(cols[z][0], cols[z][4])])
            with np.errstate(invalid="ignore"):
                yhat[:, z] = cols[z][1] @ th
    return coefs, stds, yhat


def zeroed_terms(terms, coefs, keep=()) -> list:
    """The refitted terms (cause not in ``keep``) whose every refitted coefficient (``coefs[i]``: name -> value) is 0."""
    return [t for t, c in zip(terms, coefs) if t.cause not in keep and c and all(v == 0.0 for v in c.values())]
