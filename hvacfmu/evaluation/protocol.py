"""The evaluation protocol every model is judged by: 24-hour open-loop RMS on held-out weeks.

On each held-out test week, an open-loop prediction of ``horizon`` steps (96 =
24 h at 15 minutes) starts at every local midnight from
``model.initial_state(frame, k0)``, driven by the measured inputs ``u``,
disturbances ``v`` and the season's internal-gain profile. Each window gets the
RMS error of eq. (RMS) of the paper,

    RMS = ( 1/N sum_{k=1..N} (y_measured(k) - y_predicted(k))^2 )^(1/2),

per output; RMS values are averaged by output and season (the paper's Table I).

Windows with gaps are scored, not skipped, under the stated rules of :mod:`.windows`: inputs
are filled for the simulation across gaps of at most ``fill_inputs_h`` hours (default 2 h), the
zone temperatures must be measured at the start (or within the first hour), errors count only
the steps whose output was measured, and a window is skipped (counted, with its reason and
season) when an output is measured in under ``min_output_share`` (75 %) of its steps or an
input gap is longer than the limit.

Two baselines are scored on exactly the same windows, outputs and steps (the same mask):

- ``persistence``: the output at the window's start held for 24 h;
- ``time-of-week mean``: the mean measured output of the season's training
  weeks at the same time of week.

Only the :class:`~hvacfmu.models.base.ZoneModel` interface is used
(``measured_outputs``, ``signals``, ``gains_at``, ``initial_state``,
``simulate``), so every model kind plugs in unchanged.

References
----------
D. Zhou, Q. Hu, C. J. Tomlin, "Model comparison of a data-driven and a physical
model for simulating HVAC systems", eq. (RMS), Table I and section V-A.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from ..errors import DataError, HvacfmuWarning, problems_message
from ..models.base import building_mismatch, season_model
from ..models.loadcheck import require_box_drive
from ..timeutil import n_time_of_week, time_of_week
from .result import BASELINES, EvaluationResult, ModelScore
from .verdict import make_verdict
from .windows import FILL_INPUTS_H, MIN_OUTPUT_SHARE, fill_inputs, plan_windows, skip_reasons, window_starts


# =============================================================================
# layer 1: arrays
# =============================================================================
def window_rms(measured, predicted, observed=None):
    """RMS error per window and output, eq. (RMS), over the observed steps.

    Parameters
    ----------
    measured, predicted : arrays (W, N, ny) [°C]
        Values at steps k = 1..N of each window.
    observed : array of bool (W, N, ny), optional
        Steps that count (default: where ``measured`` is finite). With every step observed
        this is exactly ``sqrt(mean(e**2))``.

    Returns
    -------
    array (W, ny) [K]
        NaN for an output without an observed step in a window.
    """
    measured, predicted = np.asarray(measured, float), np.asarray(predicted, float)
    obs = np.isfinite(measured) if observed is None else np.asarray(observed, bool)
    e = np.where(obs, measured - predicted, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(np.sum(e * e, axis=-2) / obs.sum(axis=-2))


def time_of_week_profile(y, slots, n_slots):
    """Mean of ``y`` (n, ny) per time-of-week slot; empty slots interpolated around the week.

    Returns
    -------
    profile : array (n_slots, ny)
    coverage : float
        Fraction of slots with data before filling (0 means the profile is all NaN).
    """
    from ..models.datadriven import estimate_gains

    return estimate_gains(y, slots, n_slots)


# =============================================================================
# layer 2: the protocol
# =============================================================================
def evaluate(
    model_or_models,
    dataset,
    horizon: int = 96,
    names=None,
    fill_inputs_h: float = FILL_INPUTS_H,
    min_output_share: float = MIN_OUTPUT_SHARE,
) -> EvaluationResult:
    """Score models by 24-hour open-loop prediction RMS on the held-out test weeks, verdict first.

    Parameters
    ----------
    model_or_models : ZoneModel or sequence of ZoneModel
    dataset : hvacfmu.data.Dataset
        Its test weeks are evaluated; its training weeks feed the
        time-of-week-mean baseline.
    horizon : int
        Prediction horizon N [steps] (96 = 24 h at 15 minutes).
    names : sequence of str, optional
        Labels of the models (default: ``meta["name"]`` or the kind, made unique).
    fill_inputs_h : float [h]
        Longest gap of an input (airflow, ``Td``, ``T_supply``, weather) filled by linear
        interpolation in time for the simulation (default 2 h; 0 fills nothing). Zone
        temperatures are never filled.
    min_output_share : float [-]
        A window is scored only when every output is measured in at least this share of its
        steps (default 0.75); errors count only those steps.

    Returns
    -------
    EvaluationResult
        With ``.verdict``: per zone against both baselines, ASHRAE Guideline 14 hourly
        NMBE and CV(RMSE), and the likely causes when a model loses to persistence.

    Raises
    ------
    DataError
        If no window of any model could be evaluated (every reason listed).

    Warns
    -----
    HvacfmuWarning
        For seasons without a test week and models that cannot predict a season.
    """
    models = _check_models(model_or_models, dataset, horizon)
    names = _model_names(models, names)
    b = dataset.building
    filled = fill_inputs(
        dataset.frame, b.zone_names, float(dataset.step), float(fill_inputs_h), float(min_output_share)
    )
    notes = _season_notes(dataset)
    for name, model in zip(names, models):
        require_box_drive(model, b, f"model {name!r}")
        for note in building_mismatch(model, b)[1]:
            warnings.warn(note, HvacfmuWarning, stacklevel=2)
            notes.append(note)
    test_weeks = dataset.test_weeks()
    if not test_weeks:
        raise DataError("the dataset has no test week: nothing to evaluate (need at least two weeks in a season)")
    starts = window_starts(test_weeks)
    scores = []
    failures = []
    for model, name in zip(models, names):
        sc, more = _score_model(model, name, dataset, starts, int(horizon), filled)
        notes += more
        scores.append(sc)
        if not sc.starts:
            failures.append(f"{name}: " + (", ".join(f"{v} {k}" for k, v in sc.skipped.items() if v) or "no windows"))
    if len(failures) == len(scores):
        raise DataError(problems_message("No test window could be evaluated", failures))
    return EvaluationResult(
        scores=scores,
        horizon=int(horizon),
        step=float(dataset.step),
        season_order=tuple(b.season_names),
        notes=notes,
        data_sha256=getattr(dataset, "sha256", None),
        models=models,
        verdict=make_verdict(scores, models, dataset),
    )


def _check_models(model_or_models, dataset, horizon):
    """The models as a list, checked: ZoneModel instances on the dataset's step, a positive horizon."""
    from ..models.base import ZoneModel

    models = list(model_or_models) if isinstance(model_or_models, (list, tuple)) else [model_or_models]
    if not models:
        raise ValueError("no model to evaluate")
    for m in models:
        if not isinstance(m, ZoneModel):
            raise TypeError(f"expected ZoneModel instances, got {type(m).__name__}")
    if int(horizon) < 1:
        raise ValueError(f"horizon must be at least one step, got {int(horizon)}")
    step = float(dataset.step)
    for m in models:
        if abs(float(m.step) - step) > 1e-9:
            raise DataError(
                f"model step {m.step} s differs from the dataset step {step} s; prepare the data with --step {m.step:g}"
            )
    return models


def _season_notes(dataset):
    """Notes (also warned) for seasons with data but no test week."""
    notes = []
    seasons_with_data = [s for s in dataset.building.season_names if any(w.season == s for w in dataset.weeks)]
    test_weeks = dataset.test_weeks()
    for s in seasons_with_data:
        if not any(w.season == s for w in test_weeks):
            notes.append(f"season {s} has no test week (too few weeks); it is not evaluated")
    for n in notes:
        warnings.warn(n, HvacfmuWarning, stacklevel=3)
    return notes


def _simulate_windows(model, final, rng, x0, u, v, idx) -> np.ndarray:
    """Open-loop outputs (W, N+1, ny) of the windows ``final`` (rows ``rng``), each run by
    ``model.for_season(its week's season)``: one batch per season (a model with one coefficient set per season
    runs each window with its season's set; any other model is the same model in every batch)."""
    seasons = np.array([w.season for w, _ in final], dtype=object)
    Yp = None
    for s in dict.fromkeys(seasons):
        sel = np.flatnonzero(seasons == s)
        m = season_model(model, s)
        q = np.stack([np.asarray(m.gains_at(idx[rng[i]], s), float) for i in sel])
        _, Ys = m.simulate(x0[sel], u[rng[sel]], v[rng[sel]], q)
        Ys = np.asarray(Ys, float)
        if Yp is None:
            Yp = np.empty((len(final),) + Ys.shape[1:])
        Yp[sel] = Ys
    assert Yp is not None  # final holds at least one window (the caller's W > 0)
    return Yp


def _score_model(model, name, dataset, starts, horizon, filled):
    """Open-loop windows of one model: RMS, baselines, hourly statistics and residuals, all on the
    steps whose output was measured (see :mod:`.windows`)."""
    frame = dataset.frame
    idx = frame.index
    N = horizon
    Y = measured_outputs(model, frame)
    u, v = (np.asarray(a, float) for a in model.signals(filled.frame))
    ny = Y.shape[1]
    notes: list = []
    plan = plan_windows(
        starts, idx, Y, u, v, N, getattr(model, "gains", {}), filled.limit_h, filled.min_output_share, dataset.step
    )
    final, x0 = _initial_states(model, filled.frame, plan, filled)
    _no_profile_notes(plan, name, notes)
    W = len(final)
    rms = np.empty((W, ny))
    base = {b: np.full((W, ny), np.nan) for b in BASELINES}
    hourly, residuals, observed, filled_share = None, None, np.zeros((0, N, ny), bool), np.zeros(0)
    if W:
        k0s = np.array([k for _, k in final])
        rng = k0s[:, None] + np.arange(N)[None, :]  # (W, N) rows k0..k0+N-1
        Yp = _simulate_windows(model, final, rng, np.stack(x0), u, v, idx)
        meas, pred = Y[rng + 1], np.asarray(Yp)[:, 1:, :]  # (W, N, ny) at k = 1..N
        observed = np.isfinite(meas)
        rms = window_rms(meas, pred, observed)
        rms[~np.isfinite(rms) | ~np.all(np.isfinite(pred), axis=1)] = np.inf  # a diverging model must show
        base["persistence"] = window_rms(meas, np.broadcast_to(Y[k0s][:, None, :], meas.shape), observed)
        base["time-of-week mean"] = _tow_baseline(dataset, Y, final, rng, observed, notes, name)
        hourly = hourly_statistics(meas, pred, float(dataset.step), observed)
        residuals = pd.DataFrame(
            (meas - pred).reshape(W * N, ny), index=idx[(rng + 1).ravel()], columns=list(model.outputs)
        )
        filled_share = _filled_input_share(model, frame, filled.frame, rng)
    skipped = plan.counts(skip_reasons(filled.limit_h, filled.min_output_share))
    total_skipped = sum(skipped.values())
    if total_skipped:
        notes.append(
            f"{name}: {total_skipped} of {len(starts)} windows skipped ("
            + ", ".join(f"{v} {k}" for k, v in skipped.items() if v)
            + ")"
        )
    sc = ModelScore(
        name=name,
        kind=str(getattr(model, "kind", type(model).__name__)),
        outputs=tuple(model.outputs),
        starts=[idx[k] for _, k in final],
        seasons=[w.season for w, _ in final],
        weeks=[w.number for w, _ in final],
        rms=rms,
        baselines=base,
        skipped=skipped,
        hourly=hourly,
        residuals=residuals,
        observed=observed,
        filled_inputs=filled_share,
        skipped_windows=[(t, w.season, why) for w, t, why in plan.skipped],
        rules=filled.rules(),
    )
    return sc, notes


def measured_outputs(model, frame) -> np.ndarray:
    """The model's measured outputs (n, ny) [°C], missing only where a zone they weigh is missing.

    Outputs that are weighted sums of zone temperatures (Model A's ``output_weights`` over
    ``measured_zones``, also under an extended model's ``base``) are computed so that one zone's
    gap leaves the outputs that do not weigh it measured (a plain matrix product would spread
    the NaN to every output). Other kinds answer through ``model.measured_outputs``.
    """
    Y = np.asarray(model.measured_outputs(frame), float)
    base = getattr(model, "base", model)
    W = getattr(base, "output_weights", None)
    zones = getattr(base, "measured_zones", None)
    if W is None or zones is None or np.all(np.isfinite(Y)):
        return Y
    W = np.asarray(W, float)
    X = frame[[f"T_{z}" for z in zones]].to_numpy(dtype=float)
    if W.shape != (Y.shape[1], X.shape[1]):
        return Y
    missing = (~np.isfinite(X)).astype(float) @ (W != 0).T > 0
    return np.where(missing, np.nan, np.nan_to_num(X, nan=0.0) @ W.T)


def _initial_states(model, frame, plan, filled):
    """Initial states of the planned windows from the input-filled frame; a non-finite one skips its window."""
    x0, final = [], []
    reason = skip_reasons(filled.limit_h, filled.min_output_share)[-1]
    for w, k in plan.kept:
        x = np.asarray(model.initial_state(frame, k), float)
        if not np.all(np.isfinite(x)):
            plan.skipped.append((w, frame.index[k], reason))
            continue
        x0.append(x)
        final.append((w, k))
    return final, x0


def _no_profile_notes(plan, name, notes):
    reason = "no internal-gain profile for season"
    for s in sorted({w.season for w, _, why in plan.skipped if why == reason}):
        msg = f"{name}: no internal-gain profile for season {s} (no training data in it); its test windows are skipped"
        notes.append(msg)
        warnings.warn(msg, HvacfmuWarning, stacklevel=4)


def _filled_input_share(model, frame, filled_frame, rng) -> np.ndarray:
    """Share of each window's steps (W,) at which an input or disturbance of the model was filled."""
    if filled_frame is frame:
        return np.zeros(len(rng))
    u0, v0 = (np.asarray(a, float) for a in model.signals(frame))
    filled = ~(np.all(np.isfinite(u0), axis=1) & np.all(np.isfinite(v0), axis=1))  # finite after filling (plan)
    return filled[rng].mean(axis=1)


def hourly_statistics(measured, predicted, step, observed=None):
    """Sums over hourly means of the windows, for ASHRAE Guideline 14 NMBE and CV(RMSE).

    Parameters
    ----------
    measured, predicted : arrays (W, N, ny) [°C]
        Values at steps 1..N of each window.
    step : float [s]
        Model step; steps are averaged to whole hours (a trailing partial hour is dropped;
        steps of an hour or more are used as they are).
    observed : array of bool (W, N, ny), optional
        Steps that count (default: where ``measured`` is finite). An hour's means are taken
        over its observed steps; an hour without one is left out.

    Returns
    -------
    dict
        ``n`` (ny,) (hours per output), ``sum_error`` (ny,) [K·h], ``sum_sq_error`` (ny,) [K²·h],
        ``sum_measured`` (ny,) [°C·h]; errors are measured minus predicted.
    """
    measured, predicted = np.asarray(measured, float), np.asarray(predicted, float)
    obs = np.isfinite(measured) if observed is None else np.asarray(observed, bool)
    W, N, ny = measured.shape
    per_hour = max(1, int(round(3600.0 / step)))
    H = N // per_hour
    if H == 0:
        per_hour, H = 1, N

    def hours(a):
        return a[:, : H * per_hour].reshape(W, H, per_hour, ny)

    count = hours(obs).sum(axis=2).reshape(W * H, ny)
    has = count > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        m = hours(np.where(obs, measured, 0.0)).sum(axis=2).reshape(W * H, ny) / count
        p = hours(np.where(obs, predicted, 0.0)).sum(axis=2).reshape(W * H, ny) / count
    e = np.where(has, m - p, 0.0)
    return {
        "n": has.sum(axis=0),
        "sum_error": e.sum(axis=0),
        "sum_sq_error": (e * e).sum(axis=0),
        "sum_measured": np.where(has, m, 0.0).sum(axis=0),
    }


def _tow_baseline(dataset, Y, final, rng, observed, notes, name):
    """RMS of the seasonal time-of-week mean of the training weeks, on the given windows and observed steps."""
    idx = dataset.frame.index
    step = float(dataset.step)
    n_slots = n_time_of_week(step)
    slots = time_of_week(idx, step)
    week_of_row = np.full(len(idx), -1)
    train_season = np.full(len(idx), None, dtype=object)
    for w in dataset.weeks:
        a, e = idx.searchsorted(w.start), idx.searchsorted(w.end)
        week_of_row[a:e] = w.number
        if w.train:
            train_season[a:e] = w.season
    profiles = {}
    out = np.full((len(final), Y.shape[1]), np.nan)
    for i, ((w, _), r) in enumerate(zip(final, rng)):
        s = w.season
        if s not in profiles:
            sel = train_season == s
            prof, cov = time_of_week_profile(Y[sel], slots[sel], n_slots) if sel.any() else (None, 0.0)
            if cov == 0.0:
                prof = None
                notes.append(f"{name}: season {s} has no training data, so no time-of-week-mean baseline")
            profiles[s] = prof
        prof = profiles[s]
        if prof is not None:
            out[i] = window_rms(Y[r + 1][None], prof[slots[r + 1]][None], observed[i][None])[0]
    return out


# =============================================================================
# helpers
# =============================================================================
def _model_names(models, names):
    if names is not None:
        names = [str(n) for n in names]
        if len(names) != len(models) or len(set(names)) != len(names):
            raise ValueError("names must be unique, one per model")
        return names
    out = []
    for m in models:
        base = str((getattr(m, "meta", None) or {}).get("name") or getattr(m, "kind", type(m).__name__))
        nm, i = base, 2
        while nm in out:
            nm, i = f"{base}-{i}", i + 1
        out.append(nm)
    return out
