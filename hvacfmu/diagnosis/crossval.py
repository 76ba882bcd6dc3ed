"""Blocked cross-validation over whole weeks with a week-clustered paired test.

The training weeks are cut into at most ``n_folds`` (default 10) blocks of consecutive
whole weeks. For each block, the current structure and the structure with the candidate
term are both refitted (within least squares, :func:`~hvacfmu.diagnosis.design.fit_structure`)
on the other blocks, and both predict the block's days open loop over 24 hours from local
midnight. Only the zones the candidate acts on are simulated: every other zone's temperature
is the measured one at every step (a one-zone effect is not diluted by the other zones'
errors, and a coupling is scored on its two zones).

Per week ``w`` the RMS over its days and the affected zones before (``b_w``) and after
(``a_w``) gives the paired difference ``d_w = b_w − a_w``. Reported: the cross-validated
gain ``100 · mean(d) / mean(b)`` [%], its standard error ``100 · sd(d) / √W / mean(b)``, and
the week-clustered paired t-statistic ``mean(d) / (sd(d) / √W)``. Weeks, not rows, are
the independent units: residuals are correlated within a day and a week.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .design import Signals, Within, fit_structure, prepare_structure


@dataclasses.dataclass
class CVPlan:
    """Folds of whole training weeks and the 24-hour windows of each fold."""

    folds: list  # week numbers per fold
    fit_rows: list  # training rows (one-step) outside each fold
    within: list  # Within transform of each fold's fit rows
    starts: list  # window start rows inside each fold
    week_of_start: list
    horizon: int


def make_plan(sig: Signals, n_folds: int = 10, horizon: int = 96) -> CVPlan | None:
    """Blocks of consecutive training weeks and their midnight windows (None with < 4 training weeks)."""
    rows = sig.rows("train")
    weeks = np.unique(sig.week[rows])
    if len(weeks) < 4:
        return None
    k = min(n_folds, len(weeks))
    blocks = [b for b in np.array_split(weeks, k) if len(b)]
    idx = sig.index
    midnight = np.flatnonzero((idx.hour == 0) & (idx.minute == 0) & sig.train)
    ok_start = []
    for s in midnight:
        e = s + horizon
        if e < len(sig.Y) and sig.week[e - 1] == sig.week[s]:
            ok_start.append(s)
    ok_start = np.array(ok_start, dtype=int)
    plan = CVPlan([], [], [], [], [], horizon)
    for b in blocks:
        inb = np.isin(sig.week[rows], b)
        fr = rows[~inb]
        st = ok_start[np.isin(sig.week[ok_start], b)]
        if len(st) == 0 or len(fr) < 50:
            continue
        plan.folds.append(b)
        plan.fit_rows.append(fr)
        plan.within.append(Within(sig.group, fr))
        plan.starts.append(st)
        plan.week_of_start.append(sig.week[st])
    return plan if len(plan.folds) >= 3 else None


def day_plan(sig: Signals, starts, horizon: int) -> CVPlan:
    """One fold per window start (an active day of a calendar term): fitted on every other training row.

    A holiday acting on one training week has all its days in one block of :func:`make_plan`:
    refitted without that block, its coefficient has no day to be learned from, and the block
    test measures nothing. Here each active day is held out alone (its 24-hour window's rows
    left out of the fit), so its coefficient is learned from the other active days.
    """
    rows = sig.rows("train")
    plan = CVPlan([], [], [], [], [], horizon)
    for st in np.asarray(starts, int):
        fr = rows[(rows < st) | (rows >= st + horizon)]
        plan.folds.append(np.array([sig.week[st]]))
        plan.fit_rows.append(fr)
        plan.within.append(Within(sig.group, fr))
        plan.starts.append(np.array([st]))
        plan.week_of_start.append(np.array([sig.week[st]]))
    return plan


def disturbance_matrix(sig: Signals, model) -> np.ndarray:
    """``model.disturbances`` as columns (n, nv): from ``sig.V``, else the unused columns ``sig.extra``
    (an ``unused_input`` term's), else NaN."""
    cols = []
    for c in model.disturbances:
        if c in sig.V:
            cols.append(sig.V[c])
        elif c in sig.extra:
            cols.append(sig.extra[c])
        else:
            cols.append(np.full(len(sig.Y), np.nan))
    return np.column_stack(cols)


def _gains(sig: Signals, model, rows=None) -> np.ndarray:
    """Internal gains (n, nz) [K per step] of ``model`` at every row, or (len(rows), nz) at ``rows`` only (the
    rollouts read their windows' rows: each row's value is its own, whatever the other rows)."""
    rows = np.arange(len(sig.Y)) if rows is None else np.asarray(rows, int)
    q = np.zeros((len(rows), sig.nz))
    calendar = any(
        t.gain_adjustment(sig.index[:1], np.zeros((sig.n_tow, sig.nz)), sig.step) is not None for t in model.terms
    )
    season = sig.season[rows]
    for s in sig.seasons:
        m = season == s
        if m.any():
            ss = s if s in model.gains else next(iter(model.gains))
            # the slot table read at the rows' time of week (the calendar terms need gains_at)
            r = rows[m]
            q[m] = model.gains_at(sig.index[r], ss) if calendar else np.asarray(model.gains[ss])[sig.tow[r]]
    return q


def _window_inputs(sig: Signals, model, starts, horizon: int) -> tuple:
    """Teacher-forced states (n, nx) of ``model`` and its airflows, disturbances and gains on the windows' rows
    (``rows[w * horizon + h] = starts[w] + h``): read once per fold model by the affine map and, when that fails,
    the step-by-step rollout."""
    rows = (np.asarray(starts, int)[:, None] + np.arange(horizon)[None, :]).ravel()
    X = model.teacher_forced(sig.Y, sig.U)
    return X, sig.U[rows], disturbance_matrix(sig, model)[rows], _gains(sig, model, rows)


def zone_open_loop_rms(
    sig: Signals, model, starts: np.ndarray, zones_idx, horizon: int, inputs: tuple | None = None
) -> np.ndarray:
    """24-hour open-loop RMS (n_windows, len(zones_idx)) [K] of ``zones_idx``, other zones measured.

    Windows with a missing value are NaN.
    """
    starts = np.asarray(starts, int)
    X, U, V, Q = _window_inputs(sig, model, starts, horizon) if inputs is None else inputs
    x0 = X[starts].copy()
    # step h of every window as one contiguous (n_windows, ·) block, the layout U[k] had
    U, V, Q = (np.ascontiguousarray(a.reshape(len(starts), horizon, -1).swapaxes(0, 1)) for a in (U, V, Q))
    return _rollout_rms(sig, x0, starts, zones_idx, horizon, lambda x, k, h: model.step_state(x, U[h], V[h], Q[h]))


def _rollout_rms(sig: Signals, x, starts, zones_idx, horizon: int, advance) -> np.ndarray:
    """RMS over ``horizon`` steps (n_windows, len(zones_idx)) [K] of the states ``advance(x, k, h)`` from ``x`` at
    rows ``starts`` (``k = starts + h``), the other zones reset to their measurements each step; NaN where a value
    is missing."""
    zones_idx = list(zones_idx)
    other = [j for j in range(sig.nz) if j not in zones_idx]
    err2 = np.zeros((len(starts), len(zones_idx)))
    bad = ~np.isfinite(x).all(axis=1)
    nxt = sig.Y[starts[:, None] + 1 + np.arange(horizon)]  # (n_windows, horizon, nz): the measurements, read once
    y_other, y_zones = nxt[:, :, other], nxt[:, :, zones_idx]
    for h in range(horizon):
        x = advance(x, starts + h, h)
        if other:
            x[:, other] = y_other[:, h]
        e = x[:, zones_idx] - y_zones[:, h]
        bad |= ~np.isfinite(e).all(axis=1)
        err2 += e**2  # a window with a non-finite error is NaN below, whatever its sum
    out = np.sqrt(err2 / horizon)
    out[bad] = np.nan
    return out


def fold_fits(sig: Signals, plan: CVPlan, terms, zones_idx=None) -> list:
    """The structure with ``terms`` refitted on each fold's fit rows (list of ExtendedModel).

    ``zones_idx``: fit only the equations of these zones (and the zones coupled to them): the
    others are measured in :func:`zone_open_loop_rms`, so their coefficients are not needed.
    """
    prepared = prepare_structure(sig, terms)  # the columns are the same in every fold: built once
    return [
        fit_structure(sig, terms, rows, within=W, only_zones=zones_idx, prepared=prepared).model
        for rows, W in zip(plan.fit_rows, plan.within)
    ]


def fold_scores(sig: Signals, plan: CVPlan, models: list, zones_idx) -> list:
    """Per fold, the window RMS (n_windows, nz_affected) of each fold model.

    Every fold's windows are simulated together through the model's one-step affine map
    (:func:`affine_steps`); a fold whose model is not affine in its state (a delayed airflow
    feeding a bilinear or switched term) is simulated step by step by :func:`zone_open_loop_rms`.
    """
    out: list = [None] * len(models)
    maps = []
    for f, (m, st) in enumerate(zip(models, plan.starts)):
        inputs = _window_inputs(sig, m, st, plan.horizon)
        aff = affine_steps(sig, m, st, plan.horizon, inputs)
        if aff is None:
            out[f] = zone_open_loop_rms(sig, m, st, zones_idx, plan.horizon, inputs)
        else:
            maps.append((f, st, aff))
    if maps:
        rms = _simulate_affine(sig, maps, zones_idx, plan.horizon)
        for (f, _, _), r in zip(maps, rms):
            out[f] = r
    return out


def affine_steps(sig: Signals, model, starts: np.ndarray, horizon: int, inputs: tuple | None = None):
    """The one-step map ``x⁺ = M_k x + c_k`` of ``model`` on each row of the windows, or None.

    Returns ``(M, c, x0)`` with ``M`` (n_windows, horizon, nx, nx), ``c`` (n_windows, horizon, nx)
    and the teacher-forced start states ``x0`` (n_windows, nx). ``M`` and ``c`` are read from
    ``step_state`` at ``x = 0`` and at the unit vectors, all rows at once; the map is checked
    against ``step_state`` at the teacher-forced states of the same rows and None is returned
    when it differs by more than 1e-9 (relative): the model is not affine in its state there.
    """
    starts = np.asarray(starts, int)
    rows = (starts[:, None] + np.arange(horizon)[None, :]).ravel()
    X, U, V, Q = _window_inputs(sig, model, starts, horizon) if inputs is None else inputs
    nx = X.shape[1]
    P = np.zeros((nx + 1, len(rows), nx))
    for j in range(nx):
        P[j + 1, :, j] = 1.0
    with np.errstate(invalid="ignore", over="ignore"):
        F = model.step_state(P, U, V, Q)
        c = F[0]
        M = np.moveaxis(F[1:] - c[None], 0, -1)  # M[k, i, j] = d x⁺_i / d x_j
        xs = X[rows]
        ref = model.step_state(xs, U, V, Q)
        rec = c + np.einsum("kij,kj->ki", M, xs)
    ok = np.isfinite(ref)
    if not np.array_equal(ok, np.isfinite(rec)):
        return None
    if ok.any() and np.max(np.abs(rec[ok] - ref[ok]) / (1.0 + np.abs(ref[ok]))) > 1e-9:
        return None
    n = len(starts)
    return M.reshape(n, horizon, nx, nx), c.reshape(n, horizon, nx), X[starts]


def _simulate_affine(sig: Signals, maps: list, zones_idx, horizon: int) -> list:
    """24-hour RMS of ``zones_idx`` for every fold's windows at once (other zones measured)."""
    M = np.concatenate([a[0] for _, _, a in maps])
    c = np.concatenate([a[1] for _, _, a in maps])
    x = np.concatenate([a[2] for _, _, a in maps])
    starts = np.concatenate([st for _, st, _ in maps])
    rms = _rollout_rms(
        sig, x, starts, zones_idx, horizon, lambda x, k, h: np.einsum("wij,wj->wi", M[:, h], x) + c[:, h]
    )
    return np.split(rms, np.cumsum([len(st) for _, st, _ in maps])[:-1])


def paired_test(plan: CVPlan, before: list, after: list) -> dict:
    """Week-clustered paired comparison of window RMS lists (see the module docstring)."""
    b_w, a_w = [], []
    for wk, rb, ra in zip(plan.week_of_start, before, after):
        ok = np.isfinite(rb).all(axis=1) & np.isfinite(ra).all(axis=1)
        for w in np.unique(wk[ok]):
            m = ok & (wk == w)
            b_w.append(float(np.mean(rb[m])))
            a_w.append(float(np.mean(ra[m])))
    b_w, a_w = np.array(b_w), np.array(a_w)
    n = len(b_w)
    if n < 3:
        return {"n_weeks": n, "gain_percent": None, "se_percent": None, "t": None}
    d = b_w - a_w
    mb = float(b_w.mean())
    sd = float(d.std(ddof=1))
    se = sd / np.sqrt(n)
    t = float(d.mean() / se) if se > 0 else (np.inf if d.mean() > 0 else 0.0)
    return {
        "n_weeks": int(n),
        "n_folds": len(plan.folds),
        "before": mb,
        "after": float(a_w.mean()),
        "gain_abs": float(d.mean()),
        "gain_percent": 100.0 * float(d.mean()) / mb if mb > 0 else 0.0,
        "se_percent": float(100.0 * se / mb) if mb > 0 else None,
        "t": t,
        "weeks_improved": float(np.mean(d > 0)),
    }


def gate_failures(r: dict, opts: dict, min_gain_percent: float | None = None) -> dict:
    """The conditions of the acceptance rule that the paired test ``r`` fails (empty: it passes).

    One rule for every candidate the diagnosis cross-validates (the forward selection's and the held setpoints'):
    gain ≥ ``min_gain_percent`` (default ``opts["cv_min_gain_percent"]``; a coupling passes
    ``opts["coupling_min_gain_percent"]``), absolute gain ≥ ``opts["min_gain_abs"]`` [K] (a percentage of a zone
    predicted within a few hundredths of a kelvin is no evidence), and week-clustered paired t ≥
    ``opts["cv_min_t"]``. ``r``: a :func:`paired_test` or :func:`paired_test_days` result. Returns
    ``{option name: why}``; a test without a gain (fewer than 3 weeks or days scored) fails as ``"gain"``.
    """
    need = opts["cv_min_gain_percent"] if min_gain_percent is None else min_gain_percent
    if r.get("gain_percent") is None:
        return {"gain": r.get("reason") or "no cross-validated gain (fewer than 3 weeks or days scored)"}
    out = {}
    if not r["gain_percent"] >= need:  # written so that NaN fails
        out["cv_min_gain_percent"] = f"gain {r['gain_percent']:.2f} % under {need:g} %"
    if not r["gain_abs"] >= opts["min_gain_abs"]:
        out["min_gain_abs"] = (
            f"absolute gain {r['gain_abs']:.4f} K under the floor min_gain_abs {opts['min_gain_abs']:g} K"
        )
    if not r["t"] >= opts["cv_min_t"]:
        out["cv_min_t"] = f"paired t {r['t']:.2f} under cv_min_t {opts['cv_min_t']:g}"
    return out


def passes_gate(r: dict, opts: dict, min_gain_percent: float | None = None) -> bool:
    """Whether the paired test ``r`` passes the acceptance rule (:func:`gate_failures` empty)."""
    return not gate_failures(r, opts, min_gain_percent)


def paired_test_days(plan: CVPlan, before: list, after: list, active: list) -> dict:
    """Paired comparison over the days a calendar term acts on (each 24-hour window one unit).

    A term that only changes a few dated days (a holiday) changes nothing on the other
    weeks: the week-clustered test over every week would dilute its gain by the share of
    weeks it acts on. Here the units are its active windows (``active``: per fold, a bool
    per window), gain ``100 · mean(d) / mean(b)`` over them, ``t = mean(d) / (sd(d) / √n)``.
    """
    b, a, folds = [], [], set()
    for f, (rb, ra, act) in enumerate(zip(before, after, active)):
        ok = np.isfinite(rb).all(axis=1) & np.isfinite(ra).all(axis=1) & act
        b += list(rb[ok].mean(axis=1))
        a += list(ra[ok].mean(axis=1))
        if ok.any():
            folds.add(f)
    b_d, a_d = np.array(b), np.array(a)
    n = len(b_d)
    if n < 3:
        return {"n_days": n, "gain_percent": None, "se_percent": None, "t": None, "unit": "active day"}
    d = b_d - a_d
    mb = float(b_d.mean())
    se = float(d.std(ddof=1)) / np.sqrt(n)
    return {
        "unit": "active day",
        "n_days": int(n),
        "n_folds_active": len(folds),
        "n_folds": len(plan.folds),
        "before": mb,
        "after": float(a_d.mean()),
        "gain_abs": float(d.mean()),
        "gain_percent": 100.0 * float(d.mean()) / mb if mb > 0 else 0.0,
        "se_percent": float(100.0 * se / mb) if mb > 0 else None,
        "t": float(d.mean() / se) if se > 0 else (np.inf if d.mean() > 0 else 0.0),
        "days_improved": float(np.mean(d > 0)),
    }


__all__ = [
    "CVPlan",
    "affine_steps",
    "day_plan",
    "fold_fits",
    "fold_scores",
    "gate_failures",
    "make_plan",
    "paired_test",
    "paired_test_days",
    "passes_gate",
    "zone_open_loop_rms",
]
