"""``gain_days = "auto"``: step 2's day types chosen by blocked cross-validation over the training weeks.

Step 1 (the physical parameters and ``f_IG^c``) does not depend on the gain profile, so the choice
among :data:`~.identification.GAIN_PROFILES` (``"week"``, ``"workdays"``, ``"shrunk"``) is made on
step 2 alone. Blocks are whole training weeks: for every training week ``h`` of a season with at
least two training weeks, each candidate's seasonal profile is rebuilt from the one-step gains of the
season's *other* training weeks, and the 24-h open-loop prediction of every local midnight of ``h``
is scored exactly as the evaluation scores a test window (:mod:`hvacfmu.evaluation.windows`):
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

from ...data.resample import interpolate_gaps
from ...timeutil import time_of_week

#: Inputs are filled across gaps of at most this many hours, as by the evaluation [h]
FILL_INPUTS_H = 2.0
#: A window is scored only when every zone is measured in at least this share of its steps [-]
MIN_OUTPUT_SHARE = 0.75
#: Latest start of a window whose zone temperatures are not all measured at midnight [h]
START_SHIFT_MAX_H = 1.0
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
    windows = _cv_windows(dataset, model, frame, profiles, nw)
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
        by_zone[g] = _window_rms(model, dataset, frame, windows, fold_gains, nw).mean(axis=0)
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


def _midnights(week) -> list:
    """Every local midnight of ``week`` (DST-safe, as the evaluation's windows)."""
    tz = week.start.tz
    day0 = week.start.tz_localize(None)
    out = []
    for d in range(7):
        t = (day0 + pd.Timedelta(days=d)).tz_localize(tz, nonexistent="shift_forward", ambiguous=False)
        if t < week.end:
            out.append(t)
    return out


def _cv_windows(dataset, model, frame, profiles, nw) -> list:
    """``(week number, start row)`` of every scored window of the training weeks that can be held out
    (their season keeps another training week with one-step gains), under the evaluation's rules."""
    step = float(dataset.step)
    index = frame.index
    n, N = len(frame), int(round(HORIZON_H * 3600.0 / step))
    shift_max = int(round(START_SHIFT_MAX_H * 3600.0 / step))
    per_season: dict = {}
    for w, _ in profiles:
        per_season[w.season] = per_season.get(w.season, 0) + 1
    Y = model.measured_outputs(frame)
    u, v = _filled_signals(model, frame, step)
    y_ok = np.isfinite(Y)
    row_ok = y_ok.all(axis=1)
    obs = np.r_[np.zeros((1, Y.shape[1]), np.int64), np.cumsum(y_ok, axis=0)]
    bad_in = np.r_[0, np.cumsum(~(np.all(np.isfinite(u), axis=1) & np.all(np.isfinite(v), axis=1)))]
    out = []
    for week, _ in profiles:
        if per_season[week.season] < 2:
            continue
        for t in _midnights(week):
            k0 = index.get_indexer([t])[0]
            ok = np.flatnonzero(row_ok[k0 : k0 + shift_max + 1]) if k0 >= 0 else []
            if not len(ok):
                continue
            k = k0 + int(ok[0])
            if k < nw or k + N >= n or np.any(obs[k + N + 1] - obs[k + 1] < MIN_OUTPUT_SHARE * N):
                continue
            if bad_in[k + N] - bad_in[k]:
                continue
            out.append((week.number, k))
    return out


def _filled_signals(model, frame, step):
    """The model's inputs and disturbances (n, .) with gaps of at most :data:`FILL_INPUTS_H` interpolated."""
    u, v = model.signals(frame)
    cols = list(model.inputs) + list(model.disturbances)
    raw = pd.DataFrame(np.c_[u, v], index=frame.index, columns=range(len(cols)))
    if not raw.isna().to_numpy().any():
        return np.asarray(u, float), np.asarray(v, float)
    filled = interpolate_gaps(raw, FILL_INPUTS_H * 60.0, native_step=step).reindex(frame.index).to_numpy(float)
    return filled[:, : u.shape[1]], filled[:, u.shape[1] :]


def _q_rows(model, gains, index, season=None) -> np.ndarray:
    """``q`` (n, nq) at ``index`` from ``gains``: ``season``'s profile, or (None) each row's calendar season
    as :meth:`PhysicsModel.gains_for_rows` (the mean profile for a season without one)."""
    slots = time_of_week(index, float(model.step))
    if season is not None:
        prof = np.asarray(gains[season])
        return prof[slots % prof.shape[0]]
    md = index.month.to_numpy() * 100 + index.day.to_numpy()
    out = np.empty((len(index), len(model.q_names)))
    mean = np.mean([np.asarray(g) for g in gains.values()], axis=0)
    for key in np.unique(md):
        s = model.building.season_of(pd.Timestamp(2001, key // 100, key % 100))
        prof = np.asarray(gains[s]) if s in gains else mean
        rows = md == key
        out[rows] = prof[slots[rows] % prof.shape[0]]
    return out


def _window_rms(model, dataset, frame, windows, fold_gains, nw) -> np.ndarray:
    """RMS (W, nz) [K] of the 24-h open-loop windows, each with its held-out week's fold gains."""
    step = float(model.step)
    N = int(round(HORIZON_H * 3600.0 / step))
    index = frame.index
    season = {w.number: w.season for w in dataset.weeks}
    Y = model.measured_outputs(frame)
    u, v = _filled_signals(model, frame, step)
    k0s = np.array([k for _, k in windows])
    warm = k0s[:, None] + np.arange(-nw, 1)[None, :]  # (W, nw+1) rows of the filter warm-up
    rng = k0s[:, None] + np.arange(N)[None, :]  # (W, N) rows k0..k0+N-1
    q_warm = np.empty(warm[:, :-1].shape + (len(model.q_names),))
    q_sim = np.empty(rng.shape + (len(model.q_names),))
    for i, (h, _) in enumerate(windows):
        q_warm[i] = _q_rows(model, fold_gains[h], index[warm[i, :-1]])
        q_sim[i] = _q_rows(model, fold_gains[h], index[rng[i]], season[h])
    x0 = model._filter_windows(Y[warm], u[warm[:, :-1]], v[warm[:, :-1]], q_warm)
    _, Yp = model.simulate(x0, u[rng], v[rng], q_sim)
    meas, pred = Y[rng + 1], np.asarray(Yp)[:, 1:, :]
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        rms = np.sqrt(np.nanmean((meas - pred) ** 2, axis=1))
    rms[~np.isfinite(rms) | ~np.all(np.isfinite(pred), axis=1)] = np.inf  # a diverging candidate must lose
    return rms
