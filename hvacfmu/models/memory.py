"""Keep a fitted Model A's memory where the data have it: a within one-step refit, chosen by week cross-validation.

Why
---
On closed-loop data whose zones float for weeks (the EnergyPlus mid-rise apartments, ``benchmarks/
apartments_s18.md``), the paper's one-step fit on LOESS-de-smoothed series has ``a`` = 0.0001 (the bandwidth on its
grid's lower edge: the de-smoothed increments are the thermostat loop), and the open-loop refinement
(:mod:`hvacfmu.models.openloop`) leaves time constants of 4-8 min at a 15-min step. Its criterion is the error of
24-h simulations on the training weeks *with the gain profiles estimated on those same weeks*: a memoryless model
is then the training weeks' own time-of-week mean, which fits them well in-sample (a profile of 672 slots per
season from a few weeks) and predicts a new week no better than the time-of-week mean. Such a model lost to
persistence in 20 of the 32 flat-seasons, while the diagnosis's one-step base on the raw series (the gain profile
eliminated by the within transformation, :mod:`hvacfmu.diagnosis.design`) keeps ``a`` of 0.70-0.95 per step.

What
----
When a fitted model keeps no memory (slowest time constant shorter than :data:`SHORT_MEMORY_STEPS` model steps),
the same structure is refitted by one-step least squares on the raw series, each regressor and the target
within-transformed by season and time-of-week slot over the training rows (the fixed-effects estimator: the gain
profile is a free value per slot, so it cannot take what the state explains; no LOESS bandwidth to choose), under
the fit's bounds (``0 < a_ii < 1``, ``0 <= a_ij <= a_ii``, row sums below one, the drive's sign, ``c >= 0``).
That refit, and the same refit with every zone's own coefficient held at the memory of :data:`SLOW_START_H`, start
an open-loop refinement (:mod:`hvacfmu.models.openloop`) whose windows are simulated with *cross-fitted* gain
profiles (each window's from the other training weeks). The candidates (the fit, the within refit, the two
refinements) are compared by blocked week cross-validation on the training weeks only (:func:`week_cv`): each
training week in turn is left out of the gain profiles, and the 24-h open-loop windows starting in it are simulated
with the profiles of the other weeks of the season. The candidate with the lowest cross-validated RMS (every season
weighs alike) is kept (option ``memory_select="mean"``, session 19's rule); ``memory_select="no_season_worse"`` keeps
only a candidate not worse than the fit in any season beyond one standard error of the paired week difference
(:func:`select_candidate`: a candidate that wins the floating winter by losing the thermostat-held summer is not
kept; ``benchmarks/regimes_s20.md``); ``memory_select="season"`` keeps per season the candidate the cross-validation
ranks first in that season (:func:`season_sets`, the default since session 21): a
:class:`~hvacfmu.models.linear.SeasonalZoneModel` with one coefficient set per season when the seasons pick
different candidates (``benchmarks/seasons_s21.md``).
``meta["memory"]`` records every score, the rule's verdicts and each season's best candidate. The held-out test
weeks are never read.

The coefficients themselves are not refitted per fold (the refinement's cost, run once per week, would be that of
the whole fit times the number of weeks): they are few (two per zone plus the weather's), against 672 gain values
per season and zone, which are what an in-sample criterion overfits.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .heat import delivered_heat

#: Slowest time constant of a fitted model, in model steps, under which it keeps no memory of its state: every step
#: forgets more than 63 % of it (the apartments' zones model: 0.3-0.6 steps; the emulator's fitted zones and lumped
#: models, which beat persistence, 1.4-2.9 steps at 15 min).
SHORT_MEMORY_STEPS = 1.0

#: Time constant [h] of the second start of the cross-fitted refinement: every zone's own coefficient held at
#: ``exp(-step / SLOW_START_H)`` (0.951 at 15 min) in a within one-step refit of the rest. The refinement has
#: several local optima on closed-loop data; a start with the memory of a building's mass reaches one the
#: one-step start does not (the apartments' winter, ``benchmarks/memory_s19.md``).
SLOW_START_H = 5.0


def slowest_steps(model) -> float:
    """The slowest time constant of ``model.A`` in model steps (``inf`` for an integrator)."""
    from .plausibility import time_constants_h

    tau = time_constants_h(model.A, model.step)
    return float(tau[0]) * 3600.0 / float(model.step) if tau.size else float("nan")


def week_ids(prep) -> np.ndarray:
    """Week number of every row of the fit's grid (-1 outside the dataset's weeks)."""
    wk = np.full(len(prep.index), -1, dtype=np.int64)
    for w in prep.dataset.weeks:
        wk[(prep.index >= w.start) & (prep.index < w.end)] = int(w.number)
    return wk


@dataclasses.dataclass
class _Arrays:
    """The measured outputs, the (filled) inputs, the one-step training rows and the 24-h window starts."""

    Y: np.ndarray
    u: np.ndarray
    v: np.ndarray
    rows: np.ndarray
    starts: np.ndarray


def _arrays(model, prep, horizon) -> _Arrays:
    from .openloop import _filled_signals, training_windows

    Y = np.asarray(model.measured_outputs(prep.frame), float)
    u_raw, v_raw = (np.asarray(a, float) for a in model.signals(prep.frame))
    uv_ok = np.all(np.isfinite(u_raw), axis=1) & np.all(np.isfinite(v_raw), axis=1)
    u, v = _filled_signals(model, prep)
    inputs_ok = np.all(np.isfinite(u), axis=1) & np.all(np.isfinite(v), axis=1)
    starts = training_windows(prep, horizon, inputs_ok=inputs_ok)
    y_ok = np.all(np.isfinite(Y), axis=1)
    rows = np.flatnonzero(prep.train[:-1] & prep.train[1:] & uv_ok[:-1] & y_ok[:-1] & y_ok[1:] & prep.gain_ok[:-1])
    return _Arrays(Y, np.nan_to_num(u), np.nan_to_num(v), rows, starts)


def _profiles(model, prep, qr, rows, keep):
    """Season -> gain profile (n_slots, nx) from the one-step residuals ``qr`` of ``rows[keep]`` (eq. qig_estimation)."""
    from .datadriven import estimate_gains

    out = {}
    for s in model.gains:
        sel = keep & (prep.season[rows] == s)
        if sel.any():
            out[s], _ = estimate_gains(qr[sel], prep.slots[rows][sel], prep.n_slots)
    return out


def _residuals(model, arr: _Arrays) -> np.ndarray:
    r = arr.rows
    return arr.Y[r + 1] - model.step_state(arr.Y[r], arr.u[r], arr.v[r], np.zeros((r.size, arr.Y.shape[1])))


def gains_on_training(model, prep, horizon: int = 96):
    """``model`` with its gain profiles re-estimated from its one-step residuals on the measured training rows."""
    arr = _arrays(model, prep, horizon)
    gains = _profiles(model, prep, _residuals(model, arr), arr.rows, np.ones(arr.rows.size, bool))
    return dataclasses.replace(model, gains={**model.gains, **gains})


def week_cv(model, prep, horizon: int = 96, arrays: _Arrays | None = None) -> dict:
    """Blocked week cross-validation of ``model``'s ``horizon``-step open-loop RMS on the training weeks.

    For every training week holding a window start, the gain profiles are estimated (eq. qig_estimation, the
    model's coefficients fixed) from the one-step residuals of the other training weeks, and the windows starting
    in that week are simulated open loop from the measured state with them. Windows whose season has no other
    training week are not scored.

    Parameters
    ----------
    model : hvacfmu.models.linear.LinearZoneModel
    prep : hvacfmu.models.datadriven._Prepared
        The fit's arrays (training weeks, seasons, time-of-week slots).
    horizon : int [steps]

    Returns
    -------
    dict
        ``rms`` [K] (root of the mean over seasons of each season's mean squared error), ``season_rms`` [K],
        ``persistence_season_rms`` [K] (persistence on the same windows), ``windows`` (scored), ``unscored``
        (windows whose season has a single training week), ``weeks`` (folds), ``season_folds`` (season -> one
        ``[week, sum of squared errors [K²], values]`` per fold: what :func:`season_differences` pairs).
    """
    arr = _arrays(model, prep, horizon) if arrays is None else arrays
    wk = week_ids(prep)
    qr = _residuals(model, arr)
    row_wk = wk[arr.rows]
    nx = arr.Y.shape[1]
    sse: dict = {}
    cnt: dict = {}
    pse: dict = {}
    fold_rec: dict = {}
    unscored, folds = 0, 0
    for w in np.unique(wk[arr.starts]):
        st = arr.starts[wk[arr.starts] == w]
        prof = _profiles(model, prep, qr, arr.rows, row_wk != w)
        season0 = prep.season[st]
        ok = np.array([s in prof for s in season0])
        unscored += int(np.sum(~ok))
        st, season0 = st[ok], season0[ok]
        if st.size == 0:
            continue
        folds += 1
        rng = st[:, None] + np.arange(horizon)[None, :]
        q = np.zeros(rng.shape + (nx,))
        for s in set(season0):
            sel = season0 == s
            q[sel] = prof[s][prep.slots[rng[sel]] % len(prof[s])]
        x = arr.Y[st]
        X = np.empty(rng.shape + (nx,))
        for k in range(horizon):
            kk = rng[:, k]
            x = model.step_state(x, arr.u[kk], arr.v[kk], q[:, k])
            X[:, k] = x
        err = arr.Y[rng + 1] - X
        per = arr.Y[rng + 1] - arr.Y[st][:, None, :]
        for s in set(season0):
            e = err[season0 == s]
            se_w, n_w = float(np.nansum(e**2)), int(np.sum(np.isfinite(e)))
            sse[s] = sse.get(s, 0.0) + se_w
            cnt[s] = cnt.get(s, 0) + n_w
            pse[s] = pse.get(s, 0.0) + float(np.nansum(per[season0 == s] ** 2))
            fold_rec.setdefault(str(s), []).append([int(w), se_w, n_w])
    season_rms = {s: float(np.sqrt(sse[s] / cnt[s])) for s in sse if cnt[s] > 0}
    persistence = {s: float(np.sqrt(pse[s] / cnt[s])) for s in season_rms}
    rms = float(np.sqrt(np.mean([r**2 for r in season_rms.values()]))) if season_rms else float("nan")
    n_win = int(sum(np.sum(prep.season[arr.starts] == s) for s in season_rms)) if season_rms else 0
    return {
        "rms": rms,
        "season_rms": season_rms,
        "persistence_season_rms": persistence,
        "windows": n_win,
        "unscored": unscored,
        "weeks": folds,
        "season_folds": fold_rec,
    }


#: Rules of option ``memory_select`` by which :func:`keep_memory` keeps one of its candidates (:func:`select_candidate`).
SELECT_RULES = ("mean", "no_season_worse", "season")


def season_differences(cv: dict, ref: str = "fit") -> dict:
    """Per candidate and season: its week cross-validated mean squared error minus ``ref``'s, paired by fold.

    ``cv``: candidate name -> :func:`week_cv` record (with ``season_folds``). For a season with folds (left-out
    weeks) ``w`` holding ``n_w`` values and per-fold mean squared errors ``e_w`` (the candidate's) and ``r_w``
    (``ref``'s), the difference is ``D = sum n_w d_w / sum n_w`` with ``d_w = e_w - r_w`` [K²] (the season's MSE difference when
    both score the same values) and its standard error the weeks-as-clusters one,
    ``sqrt(k / (k - 1) * sum n_w² (d_w - D)²) / sum n_w`` over the ``k`` folds (NaN for a season with one fold).

    Returns
    -------
    dict
        name -> season -> ``{"mse_difference", "se", "folds", "rms", "rms_ref"}``.
    """
    base = {s: {int(w): (e, n) for w, e, n in f} for s, f in (cv[ref].get("season_folds") or {}).items()}
    out: dict = {}
    for name, c in cv.items():
        per: dict = {}
        for s, folds in (c.get("season_folds") or {}).items():
            b = base.get(s, {})
            pairs = [
                (e / n - b[int(w)][0] / b[int(w)][1], n)
                for w, e, n in folds
                if int(w) in b and n > 0 and b[int(w)][1] > 0
            ]
            if not pairs:
                continue
            d = np.array([p[0] for p in pairs])
            n = np.array([p[1] for p in pairs], float)
            D = float(np.sum(n * d) / np.sum(n))
            k = d.size
            se = float(np.sqrt(k / (k - 1) * np.sum(n**2 * (d - D) ** 2)) / np.sum(n)) if k > 1 else float("nan")
            per[s] = {
                "mse_difference": D,
                "se": se,
                "folds": int(k),
                "rms": c["season_rms"].get(s),
                "rms_ref": cv[ref]["season_rms"].get(s),
            }
        out[name] = per
    return out


def select_candidate(cv: dict, rule: str = "mean", ref: str = "fit") -> tuple[str, dict]:
    """The candidate :func:`keep_memory` keeps, by ``rule``, from the week cross-validation records ``cv``.

    ``"mean"`` (session 19): the lowest ``rms`` (every season weighs alike), whatever it costs in one season.
    ``"no_season_worse"``: the lowest ``rms`` among ``ref`` and the candidates that are not worse than ``ref`` in
    any season it scores by more than one standard error of the paired difference (:func:`season_differences`; in a
    season with one fold, not worse at all): a candidate that wins winter by losing summer is not kept. ``ref`` if
    no candidate scored.

    Returns the name kept and the record: per candidate the seasons in which it is worse beyond noise.
    """
    if rule not in SELECT_RULES:
        raise ValueError(f"memory selection rule must be one of {SELECT_RULES}, got {rule!r}")
    finite = {name: c["rms"] for name, c in cv.items() if np.isfinite(c["rms"])}
    rec: dict = {"rule": rule}
    if not finite:
        return ref, rec
    if rule in ("mean", "season"):  # "season": the year's pick, for seasons the cross-validation did not score
        return min(finite, key=lambda k: finite[k]), rec
    diffs = season_differences(cv, ref)
    seasons = set((cv[ref].get("season_folds") or {}).keys())
    worse: dict = {}
    for name in finite:
        if name == ref:
            worse[name] = []
            continue
        per = diffs.get(name, {})
        bad = []
        for s in sorted(seasons):
            r = per.get(s)
            if r is None:
                bad.append(s)  # a season the reference scores and the candidate does not
                continue
            limit = r["se"] if np.isfinite(r["se"]) else 0.0
            if r["mse_difference"] > limit:
                bad.append(s)
        worse[name] = bad
    admissible = {name: v for name, v in finite.items() if not worse[name]}
    kept = min(admissible, key=lambda k: admissible[k]) if admissible else ref
    rec.update(worse_seasons=worse, season_differences=diffs)
    return kept, rec


def season_best(cv: dict) -> dict:
    """Season -> the candidate with the lowest week cross-validated RMS in it: the sets rule ``"season"`` keeps
    (:func:`season_sets`, ``benchmarks/regimes_s20.md``, ``benchmarks/seasons_s21.md``)."""
    seasons = {s for c in cv.values() for s in c.get("season_rms", {})}
    out = {}
    for s in sorted(seasons):
        sc = {n: c["season_rms"][s] for n, c in cv.items() if np.isfinite(c.get("season_rms", {}).get(s, np.nan))}
        if sc:
            out[s] = min(sc, key=lambda k: sc[k])
    return out


def season_sets(candidates: dict, best: dict, year: str):
    """The model rule ``memory_select="season"`` keeps: per season of the fit's gain profiles the candidate the
    week cross-validation ranks first there (``best``, :func:`season_best`), ``year`` (the ``"mean"`` rule's pick)
    in a season it did not score. One set when every season picks the same candidate (an ordinary
    :class:`~hvacfmu.models.linear.LinearZoneModel`), else a :class:`~hvacfmu.models.linear.SeasonalZoneModel`
    whose season's set is that candidate's coefficients and gain profile. Returns ``(model, season -> candidate)``.
    """
    from .linear import SeasonalZoneModel

    seasons = list(candidates[year].gains)
    pick = {s: best.get(s, year) if best.get(s) in candidates else year for s in seasons}
    names = set(pick.values())
    if len(names) == 1:
        return candidates[names.pop()], pick
    return SeasonalZoneModel(sets={s: candidates[pick[s]] for s in seasons}, meta=dict(candidates[year].meta)), pick


def _vcols(prep, model, i) -> list:
    """Disturbance columns of state ``i``'s equation: the fit's structure (``hvacfmu.models.datadriven``)."""
    n_temps = 1 if prep.delivered else 2
    if model.kind == "lumped":
        return list(range(len(prep.v_names)))
    orient = prep.building.zones[i].orientations
    return list(range(n_temps)) + [k for k, vn in enumerate(prep.v_names) if k >= n_temps and vn[2:] in orient]


def within_refit(model, prep, stability_margin: float = 1e-3, horizon: int = 96, a_own: float | None = None):
    """``model``'s structure refitted by one-step least squares on the raw series, within-transformed by season and
    time-of-week slot over the training rows (the fixed-effects estimator of :mod:`hvacfmu.diagnosis.design`), under
    the fit's bounds; gains re-estimated from the new coefficients' one-step residuals. ``a_own``: every zone's own
    coefficient held at this value (the others fitted given it). ``None`` if a zone's problem has no solution."""
    from .datadriven import A_EPS, bayes_cls
    from .openloop import _adjacent_mask

    arr = _arrays(model, prep, horizon)
    r = arr.rows
    nx = model.A.shape[0]
    Y, u, v = arr.Y, arr.u, arr.v
    delivered = model.beta is not None
    if delivered:
        drive = delivered_heat(u, v[:, model._inlet_idx], Y[:, model._box_state]) @ np.asarray(model.heat_map, float).T
    else:
        drive = u[:, :nx]
    adj = _adjacent_mask(model, prep.building) if model.kind == "zones" else np.zeros((nx, nx), bool)
    _, season_id = np.unique(prep.season[r].astype(str), return_inverse=True)
    _, ginv = np.unique(season_id * prep.n_slots + prep.slots[r], return_inverse=True)
    counts = np.bincount(ginv).astype(float)

    def within(M):
        M = np.atleast_2d(M.T).T
        means = np.stack([np.bincount(ginv, weights=M[:, j]) / counts for j in range(M.shape[1])], axis=1)
        return M - means[ginv]

    A = np.zeros((nx, nx))
    d = np.zeros(nx)
    C = np.zeros_like(model.C)
    lo_d, hi_d = (0.0, np.inf) if delivered else (-np.inf, 0.0)
    for i in range(nx):
        nb = list(np.flatnonzero(adj[i]))
        vc = _vcols(prep, model, i)
        Z = np.column_stack([Y[r, i], Y[r][:, nb], drive[r, i], v[r][:, vc]])
        y = Y[r + 1, i]
        Zw, yw = within(Z), within(y[:, None])[:, 0]
        na = 1 + len(nb)
        p = Z.shape[1]
        lb = np.r_[A_EPS if a_own is None else a_own, np.zeros(na - 1), lo_d, np.zeros(len(vc))]
        ub = np.r_[1 - A_EPS if a_own is None else a_own, np.ones(na - 1), hi_d, np.full(len(vc), np.inf)]
        G = np.zeros((na, p))
        G[0, :na] = 1.0
        G[np.arange(1, na), np.arange(1, na)] = 1.0
        G[1:, 0] = -1.0
        h = np.r_[1.0 - stability_margin, np.zeros(na - 1)]
        res = bayes_cls(Zw, yw, lb=lb, ub=ub, G=G, h=h)
        if not res.found:
            return None
        th = res.theta
        A[i, i] = th[0]
        A[i, nb] = th[1:na]
        d[i] = th[na]
        C[i, vc] = th[na + 1 :]
    kw: dict = {"A": A, "C": C}
    if delivered:
        kw["beta"] = d
    else:
        B = model.B.copy()
        B[np.arange(nx), np.arange(nx)] = d
        kw["B"] = B
    new = dataclasses.replace(model, **kw)
    gains = _profiles(new, prep, _residuals(new, arr), r, np.ones(r.size, bool))
    return dataclasses.replace(new, gains={**model.gains, **gains})


def memory_candidates(model, alt, prep, opts, horizon: int = 96) -> tuple[dict, dict, float]:
    """The candidates :func:`keep_memory` compares: the fit ``model``, its within one-step refit ``alt``, and the
    cross-fitted open-loop refinements started from ``alt`` and from the refit with own coefficients at
    ``exp(-step / SLOW_START_H)``. Returns ``(name -> model, the refinements' records, that own coefficient)``."""
    from .openloop import refine_open_loop

    candidates = {"fit": model, "within_one_step": alt}
    weeks = week_ids(prep)
    refinements: dict = {}
    a_slow = float(np.exp(-float(model.step) / (SLOW_START_H * 3600.0)))
    slow = within_refit(model, prep, float(opts.get("stability_margin", 1e-3)), horizon, a_own=a_slow)
    for name, start in (("within_cross_fitted", alt), ("slow_cross_fitted", slow)):
        if start is None:
            refinements[name] = {"used": False, "reason": "the within one-step refit found no solution"}
            continue
        refined, rinfo = refine_open_loop(start, prep, horizon, weeks=weeks)
        refinements[name] = {k: rinfo.get(k) for k in ("used", "reason", "rms_before", "rms_after", "nfev")}
        if rinfo.get("used"):
            candidates[name] = refined
    return candidates, refinements, a_slow


def keep_memory(model, prep, opts, horizon: int = 96):
    """The fitted ``model`` or its within one-step refit, whichever predicts the left-out training weeks better.

    Run when option ``memory`` is ``"auto"`` and the model's slowest time constant is shorter than
    :data:`SHORT_MEMORY_STEPS` steps, or when it is ``True``; see the module docstring. Returns the model kept and
    the record for ``meta["memory"]``.
    """
    form = opts.get("memory", "auto")
    steps = slowest_steps(model)
    info: dict = {"slowest_time_constant_steps": steps, "threshold_steps": SHORT_MEMORY_STEPS}
    if form is False:
        return model, {**info, "checked": False, "reason": "option memory=False"}
    if form == "auto" and not steps < SHORT_MEMORY_STEPS:
        return model, {
            **info,
            "checked": False,
            "reason": f"slowest time constant {steps:.2f} steps >= {SHORT_MEMORY_STEPS:g}",
        }
    if not any(len(set(w)) >= 2 for w in prep.train_weeks.values()):
        return model, {
            **info,
            "checked": False,
            "reason": "no season has two training weeks: a left-out week has no other week's gain profile "
            "(nothing to cross-validate)",
        }
    alt = within_refit(model, prep, float(opts.get("stability_margin", 1e-3)), horizon)
    if alt is None:
        return model, {**info, "checked": False, "reason": "the within one-step refit found no solution"}
    candidates, refinements, a_slow = memory_candidates(model, alt, prep, opts, horizon)
    arr = _arrays(model, prep, horizon)  # the candidates share the fit's inputs and outputs: one set of arrays
    cv = {name: week_cv(m, prep, horizon, arrays=arr) for name, m in candidates.items()}
    rule = str(opts.get("memory_select", "season"))
    kept, selection = select_candidate(cv, rule)
    best = season_best(cv)
    chosen = candidates[kept]
    if rule == "season":
        chosen, pick = season_sets(candidates, best, kept)
        selection.update(season_sets=pick, year_pick=kept, seasonal=bool(getattr(chosen, "seasonal", False)))
        if not chosen.seasonal:
            kept = next(iter(pick.values()))
    info.update(
        selection=selection,
        season_best=best,
        checked=True,
        why="option memory=True"
        if form is True
        else f"slowest time constant {steps:.2f} steps < {SHORT_MEMORY_STEPS:g}",
        week_cv=cv,
        cross_fitted_refinements=refinements,
        slow_start_a=a_slow,
        candidates={
            name: {"A_diag": np.diag(m.A).tolist(), "slowest_time_constant_steps": slowest_steps(m)}
            for name, m in candidates.items()
        },
        kept=kept if not chosen.seasonal else "per season: " + ", ".join(f"{s} {c}" for s, c in pick.items()),
    )
    return chosen, info


__all__ = [
    "SELECT_RULES",
    "SHORT_MEMORY_STEPS",
    "gains_on_training",
    "keep_memory",
    "memory_candidates",
    "season_best",
    "season_differences",
    "season_sets",
    "select_candidate",
    "slowest_steps",
    "week_cv",
    "within_refit",
]
