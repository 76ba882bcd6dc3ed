"""From native-resolution measurements to the model step: gap interpolation and averaging.

Conventions
-----------
- A sample is an instantaneous reading at its timestamp.
- Model-step bins are left-closed, ``[start, start + step)``, labelled by their
  start and aligned to the local clock (a 900 s step starts bins at :00, :15,
  :30, :45 local time, also across daylight-saving changes). The step must
  divide one hour.
- Temperatures, flows and irradiance are averaged over the samples of a bin;
  ``excitation`` is 1 if any sample in the bin is 1. A bin with fewer than
  ``min_coverage`` (default 50 %) of the samples expected from the column's
  native resolution is NaN: gaps stay gaps.
- A column sampled more coarsely than the step (e.g. hourly ``ghi`` in a
  1-minute file) is linearly interpolated in time to the bin midpoints between
  consecutive samples at most 1.5 native steps apart (the paper down-samples
  or interpolates "respectively"); ``excitation`` holds its last value for one
  native step.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

#: Default minimum fraction of expected samples for a bin to get a value.
MIN_COVERAGE = 0.5


def _seconds(index: pd.DatetimeIndex) -> np.ndarray:
    """Seconds since the epoch (UTC) of a tz-aware index, as float."""
    return index.as_unit("ns").asi8 / 1e9


def _median_spacing(t: np.ndarray) -> float | None:
    if len(t) < 2:
        return None
    d = np.diff(t)
    d = d[d > 0]
    return float(np.median(d)) if len(d) else None


def interpolate_gaps(frame: pd.DataFrame, limit: float, native_step: float | None = None) -> pd.DataFrame:
    """Linearly interpolate every gap of at most ``limit`` minutes, explicitly.

    A gap is a run of missing values (NaN or missing timestamps) between two
    valid samples of a column; its length is the time between those samples
    minus one native step, i.e. the missing duration. Longer gaps and gaps at
    the ends stay NaN. If the timestamps lie on a regular grid of the native
    step, missing timestamps are inserted first so that they are filled too.
    ``excitation`` is filled only where both neighbours agree.

    Parameters
    ----------
    frame : DataFrame
        Native-resolution data with a tz-aware index.
    limit : float [min]
        Longest gap to fill.
    native_step : float, optional [s]
        Sample spacing (default: the median spacing of the index).

    Returns
    -------
    DataFrame
        A new frame (possibly with inserted timestamps).
    """
    if limit is None or len(frame) < 2:
        return frame.copy()
    if limit < 0:
        raise ValueError(f"interpolate_limit must be >= 0 minutes, got {limit}")
    t = _seconds(frame.index)
    native = native_step or _median_spacing(t)
    if native is None:
        return frame.copy()
    # regularise onto the native grid when the data are on one
    ns = round(native * 1e9)
    tns = frame.index.as_unit("ns").asi8
    if ns > 0 and np.all((tns - tns[0]) % ns == 0):
        n_grid = (tns[-1] - tns[0]) // ns + 1
        if n_grid <= 10 * len(tns):
            grid = pd.DatetimeIndex((tns[0] + ns * np.arange(n_grid)).view("M8[ns]")).tz_localize("UTC")
            grid = grid.tz_convert(frame.index.tz)
            grid.name = frame.index.name
            frame = frame.reindex(grid)
            t = _seconds(frame.index)
    out = {}
    limit_s = float(limit) * 60.0
    for col in frame.columns:
        v = frame[col].to_numpy(dtype=float, copy=True)
        valid = np.isfinite(v)
        if valid.all() or not valid.any():
            out[col] = v
            continue
        pos = np.arange(len(v))
        prev = np.maximum.accumulate(np.where(valid, pos, -1))
        nxt = np.minimum.accumulate(np.where(valid, pos, len(v))[::-1])[::-1]
        fill = ~valid & (prev >= 0) & (nxt < len(v))
        p, q = prev[fill], nxt[fill]
        gap = t[q] - t[p] - native
        ok = gap <= limit_s + 1e-6
        idx = np.flatnonzero(fill)[ok]
        p, q = p[ok], q[ok]
        if col == "excitation":
            same = v[p] == v[q]
            v[idx[same]] = v[p[same]]
        else:
            w = (t[idx] - t[p]) / (t[q] - t[p])
            v[idx] = v[p] + w * (v[q] - v[p])
        out[col] = v
    return pd.DataFrame(out, index=frame.index)


def bin_grid(index: pd.DatetimeIndex, step: float):
    """Bin number of each timestamp and the local-clock-aligned grid of bin starts.

    Returns
    -------
    bins : ndarray of int64
        Bin of each timestamp, 0 for the first bin.
    grid : DatetimeIndex
        Bin starts (tz of ``index``), named ``time``.
    """
    step_ns = _step_ns(step)
    tns = index.as_unit("ns").asi8
    offset = index[0].utcoffset()
    shift = int(offset.total_seconds() * 1e9) % step_ns if offset is not None else 0
    k = (tns + shift) // step_ns
    k0 = int(k.min()) if len(k) else 0
    n = int(k.max() - k0 + 1) if len(k) else 0
    starts = (k0 + np.arange(n)) * step_ns - shift
    grid = pd.DatetimeIndex(starts.view("M8[ns]")).tz_localize("UTC").tz_convert(index.tz)
    grid.name = "time"
    return (k - k0).astype(np.int64), grid


def _step_ns(step: float) -> int:
    if not step > 0 or abs(step - round(step)) > 1e-9 or 3600 % round(step):
        raise ValueError(f"model step must be a whole number of seconds dividing one hour, got {step}")
    return round(step) * 1_000_000_000


def resample(
    frame: pd.DataFrame,
    step: float = 900.0,
    min_coverage: float = MIN_COVERAGE,
    column_steps: dict | None = None,
):
    """Average native-resolution data onto the model step.

    Parameters
    ----------
    frame : DataFrame
        Native data, tz-aware index (see :func:`hvacfmu.data.load_measurements`).
    step : float [s]
        Model step; must divide one hour.
    min_coverage : float
        Minimum fraction of the expected samples for a bin to get a value.
    column_steps : dict, optional
        Native spacing per column [s] (default: median spacing of the
        column's valid samples).

    Returns
    -------
    resampled : DataFrame
        On the grid of bin starts (left-closed bins, local-clock aligned).
    coverage : DataFrame
        Fraction of expected samples present per bin and column (capped at 1;
        1 or 0 for interpolated coarse columns).
    """
    if not 0 < min_coverage <= 1:
        raise ValueError(f"min_coverage must be in (0, 1], got {min_coverage}")
    if len(frame) == 0:
        empty = pd.DataFrame(columns=frame.columns, index=pd.DatetimeIndex([], tz=frame.index.tz, name="time"))
        return empty.astype(float), empty.astype(float)
    bins, grid = bin_grid(frame.index, step)
    n = len(grid)
    t = _seconds(frame.index)
    t_mid = _seconds(grid) + step / 2.0
    column_steps = column_steps or {}
    values, coverage = {}, {}
    for col in frame.columns:
        v = frame[col].to_numpy(dtype=float)
        valid = np.isfinite(v)
        native = column_steps.get(col) or _median_spacing(t[valid]) or _median_spacing(t) or step
        if native > step * (1 + 1e-9):
            values[col], coverage[col] = _interpolate_coarse(t[valid], v[valid], t_mid, native, col == "excitation")
            continue
        count = np.bincount(bins, weights=valid.astype(float), minlength=n)
        cov = np.minimum(count / (step / native), 1.0)
        enough = cov >= min_coverage - 1e-12
        if col == "excitation":
            anyone = np.bincount(bins, weights=(v == 1).astype(float), minlength=n) > 0
            out = np.where(anyone, 1.0, np.where(enough, 0.0, np.nan))
        else:
            total = np.bincount(bins, weights=np.where(valid, v, 0.0), minlength=n)
            with np.errstate(invalid="ignore", divide="ignore"):
                out = np.where(enough & (count > 0), total / np.maximum(count, 1.0), np.nan)
        values[col], coverage[col] = out, cov
    cols = list(frame.columns)
    # (k, n) blocks passed transposed: pandas stores them as they are, without a copy
    return (
        pd.DataFrame(np.stack([values[c] for c in cols]).T, index=grid, columns=cols, copy=False),
        pd.DataFrame(np.stack([coverage[c] for c in cols]).T, index=grid, columns=cols, copy=False),
    )


def _interpolate_coarse(t, v, t_mid, native, hold):
    """Values at ``t_mid`` from samples (t, v) spaced ``native`` apart; NaN across longer gaps."""
    n = len(t_mid)
    if len(t) == 0:
        return np.full(n, np.nan), np.zeros(n)
    j = np.searchsorted(t, t_mid, side="right") - 1  # last sample at or before
    out = np.full(n, np.nan)
    if hold:
        ok = (j >= 0) & (t_mid - t[np.clip(j, 0, None)] < native * (1 + 1e-9))
        out[ok] = v[j[ok]]
    else:
        inside = (j >= 0) & (j < len(t) - 1)
        jj = np.clip(j, 0, max(len(t) - 2, 0))
        if len(t) >= 2:
            span = t[jj + 1] - t[jj]
            ok = inside & (span <= 1.5 * native)
            w = (t_mid - t[jj]) / span
            out[ok] = v[jj[ok]] + w[ok] * (v[jj[ok] + 1] - v[jj[ok]])
        exact = (j >= 0) & (t[np.clip(j, 0, None)] == t_mid)
        out[exact] = v[j[exact]]
    return out, np.isfinite(out).astype(float)
