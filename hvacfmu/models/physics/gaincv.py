"""``gain_days = "auto"``: step 2's day types chosen by blocked cross-validation over the training weeks.

Step 1 (the physical parameters and ``f_IG^c``) does not depend on the gain profile, so the choice
among :data:`~.identification.GAIN_PROFILES` (``"week"``, ``"workdays"``, ``"shrunk"``) is made on
step 2 alone. Blocks are whole training weeks: for every training week ``h`` of a season with at
least two training weeks, each candidate's seasonal profile is rebuilt from the one-step gains of the
season's *other* training weeks, and the 24-h open-loop prediction of every local midnight of ``h``
is scored exactly as the evaluation scores a test window (:mod:`hvacfmu.data.windows`):
inputs filled across gaps of at most 2 h, the start shifted up to 1 h to the first step with every
zone measured, a window skipped when an output is measured in under 75 % of its steps or an input
gap is longer; the initial state from the model's filter over the preceding warm-up with the fold's
gains; the RMS of each window and zone over the measured steps. (One deviation: a window needs the
full filter warm-up, so the first two days of the data are not scored.) The score of a candidate
is the mean of those RMS values over the windows and zones [K]: the evaluation's own measure, on
training weeks the candidate's profile did not see. The lowest score wins; a tie goes to the
earlier candidate in :data:`GAIN_PROFILES` order.

No test week is used: the measurements of the test weeks are blanked (NaN) before anything is
computed, so neither the training weeks' one-step gains (whose filter warm-up may reach into a
preceding test week) nor a window's initial state (48 h before midnight) nor its last step (the
first row of the next week) can see them.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
import pandas as pd

from ...calendars import gain_slots
from ...data.windows import FILL_INPUTS_H, MIN_OUTPUT_SHARE, fill_inputs, plan_windows, window_starts
from .model import gains_for_rows

#: Open-loop horizon of a window [h]
HORIZON_H = 24.0


def choose_gain_days(dataset, model, f_c, nw) -> dict:
    """The day types of step 2 with the lowest blocked-CV 24-h open-loop RMS over the training weeks.

    Parameters
    ----------
    dataset : hvacfmu.data.Dataset
    model : PhysicsModel
        Step 1's model (its gains are not used).
    f_c : array (nz,) [W]
        Step 1's constant gains.
    nw : int
        Filter warm-up [steps] of step 2 and of the windows' initial states.

    Returns
    -------
    dict
        ``chosen`` (one of :data:`GAIN_PROFILES`), ``cv_rms`` {candidate: K}, ``cv_rms_by_zone``
        {candidate: {zone: K}}, ``folds`` (held-out training weeks with a scored window),
        ``windows``, ``score`` (what was scored) and ``seconds``; ``note`` when no window could be
        scored (then ``chosen`` is ``"week"``, the paper's profile).
    """
    from .identification import GAIN_PROFILES, _gains_of_profiles, _week_profiles

    t0 = time.perf_counter()
    frame = _without_test_weeks(dataset)
    profiles = _week_profiles(dataset, model, f_c, nw, frame=frame)
    step = float(dataset.step)
    filled = fill_inputs(frame, dataset.building.zone_names, step, FILL_INPUTS_H, MIN_OUTPUT_SHARE)
    Y = model.measured_outputs(frame)
    u, v = (np.asarray(a, float) for a in model.signals(filled.frame))
    windows = _cv_windows(frame.index, profiles, Y, u, v, nw, step)
    record: dict = {
        "score": "mean 24-h open-loop RMS over the windows and zones of each held-out training week [K] "
        "(blocked CV: whole training weeks, profile from the season's other training weeks; test weeks unused)",
        "folds": len({w for w, _ in windows}),
        "windows": len(windows),
    }
    if not windows:
        record.update(chosen="week", cv_rms={}, cv_rms_by_zone={})
        record["note"] = "no training week could be held out (a season needs two training weeks): kept 'week'"
        record["seconds"] = round(time.perf_counter() - t0, 2)
        return record
    folds = sorted({w for w, _ in windows})
    by_zone = {}
    for g in GAIN_PROFILES:
        fold_gains = {
            h: _gains_of_profiles(dataset, model, f_c, [(w, p) for w, p in profiles if w.number != h], g)[0]
            for h in folds
        }
        by_zone[g] = _window_rms(model, dataset, frame.index, windows, fold_gains, nw, (Y, u, v)).mean(axis=0)
    cv = {g: float(np.mean(r)) for g, r in by_zone.items()}
    record["chosen"] = min(GAIN_PROFILES, key=lambda g: (cv[g], GAIN_PROFILES.index(g)))
    record["cv_rms"] = {g: round(v, 5) for g, v in cv.items()}
    record["cv_rms_by_zone"] = {g: dict(zip(model.outputs, np.round(r, 5).tolist())) for g, r in by_zone.items()}
    record["seconds"] = round(time.perf_counter() - t0, 2)
    return record


def _without_test_weeks(dataset) -> pd.DataFrame:
    """The dataset's frame with every value of the test weeks' rows blanked (NaN)."""
    frame = dataset.frame.copy()
    index = frame.index
    blank = np.zeros(len(frame), bool)
    for w in dataset.weeks:
        if not w.train:
            blank |= (index >= w.start) & (index < w.end)
    frame.loc[blank, :] = np.nan
    return frame


def _cv_windows(index, profiles, Y, u, v, nw, step) -> list:
    """``(week number, start row)`` of every scored window of the training weeks that can be held out (their
    season keeps another training week with one-step gains), under the evaluation's rules
    (:func:`hvacfmu.data.windows.plan_windows`) and after a full filter warm-up of ``nw`` steps."""
    per_season: dict = {}
    for w, _ in profiles:
        per_season[w.season] = per_season.get(w.season, 0) + 1
    seasons = {s: True for s, count in per_season.items() if count >= 2}
    starts = window_starts([w for w, _ in profiles])
    N = int(round(HORIZON_H * 3600.0 / step))
    plan = plan_windows(starts, index, Y, u, v, N, seasons, FILL_INPUTS_H, MIN_OUTPUT_SHARE, step)
    return [(w.number, k) for w, k in plan.kept if k >= nw]


def _q_rows(model, gains, index, season=None, holidays=()) -> np.ndarray:
    """``q`` (n, nq) at ``index`` from ``gains``: ``season``'s profile, or (None) each row's calendar season;
    ``holidays`` read Sunday's."""
    if season is None:
        return gains_for_rows(gains, model.building, float(model.step), index, holidays)
    prof = np.asarray(gains[season])
    return prof[gain_slots(index, float(model.step), holidays) % prof.shape[0]]


def _window_rms(model, dataset, index, windows, fold_gains, nw, signals) -> np.ndarray:
    """RMS (W, nz) [K] of the 24-h open-loop windows, each with its held-out week's fold gains; ``signals``:
    the measured outputs and the gap-filled inputs and disturbances ``(Y, u, v)``."""
    step = float(model.step)
    N = int(round(HORIZON_H * 3600.0 / step))
    season = {w.number: w.season for w in dataset.weeks}
    Y, u, v = signals
    k0s = np.array([k for _, k in windows])
    warm = k0s[:, None] + np.arange(-nw, 1)[None, :]  # (W, nw+1) rows of the filter warm-up
    rng = k0s[:, None] + np.arange(N)[None, :]  # (W, N) rows k0..k0+N-1
    q_warm = np.empty(warm[:, :-1].shape + (len(model.q_names),))
    q_sim = np.empty(rng.shape + (len(model.q_names),))
    for i, (h, _) in enumerate(windows):
        q_warm[i] = _q_rows(model, fold_gains[h], index[warm[i, :-1]], holidays=dataset.holidays.dates)
        q_sim[i] = _q_rows(model, fold_gains[h], index[rng[i]], season[h], dataset.holidays.dates)
    x0 = model._filter_windows(Y[warm], u[warm[:, :-1]], v[warm[:, :-1]], q_warm)
    _, Yp = model.simulate(x0, u[rng], v[rng], q_sim)
    meas, pred = Y[rng + 1], np.asarray(Yp)[:, 1:, :]
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        rms = np.sqrt(np.nanmean((meas - pred) ** 2, axis=1))
    rms[~np.isfinite(rms) | ~np.all(np.isfinite(pred), axis=1)] = np.inf  # a diverging candidate must lose
    return rms
