"""Residuals of a model and where they are large: one-step and 24-hour open-loop, by zone.

Pure functions on numpy arrays (plus the model's own simulation for the open-loop
windows). Whiteness is judged with the sample autocorrelation function, Bartlett's
cumulated periodogram (Kolmogorov–Smirnov bounds) and the Ljung–Box test of
statsmodels; an "unexplained" structure is located by the dominant periodogram
peak.

References
----------
H. Madsen, *Time Series Analysis*, Chapman & Hall/CRC, 2008, sections 6.3 (ACF,
cumulated periodogram) and 6.3.3 (Ljung–Box / portmanteau tests).
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pandas as pd

#: Kolmogorov–Smirnov coefficient of the cumulated-periodogram bound at 1 % (Madsen 2008, Table 6.2).
KS_99 = 1.63
#: A residual is "practically" non-white only if its cumulated periodogram departs from the
#: white-noise line by more than this (share of variance), besides being significant.
MIN_CPGRAM_DEPARTURE = 0.10


# ----------------------------------------------------------------------------
# residual series
# ----------------------------------------------------------------------------
def open_loop_residuals(model, frame: pd.DataFrame, starts, seasons, horizon: int = 96):
    """24-hour open-loop residuals from each window start.

    Parameters
    ----------
    model : ZoneModel
    frame : DataFrame
    starts : array of int
        Start rows k0 (state: measured outputs at k0 and, for extended models, hidden states
        along the measured history, ``teacher_forced_states``; else ``model.initial_state``).
    seasons : sequence of str
        Season of each start (internal-gain profile).
    horizon : int [steps]

    Returns
    -------
    array (n, ny) [K]
        Measured minus predicted at rows k0+1 .. k0+horizon of each window (NaN elsewhere
        and where data are missing).
    """
    n = len(frame)
    Y = np.asarray(model.measured_outputs(frame), float)
    u, v = (np.asarray(a, float) for a in model.signals(frame))
    out = np.full((n, Y.shape[1]), np.nan)
    keep, x0, qs = [], [], []
    idx = frame.index
    # hidden states along the measured history (one pass), gains once per season: not per window
    if hasattr(model, "teacher_forced_states"):
        X = np.asarray(model.teacher_forced_states(frame), float)
    else:  # a state per measured output: the measured outputs are the state
        X = Y if getattr(model, "n_states", -1) == Y.shape[1] else None
    q_by_season = {s: np.asarray(model.gains_at(idx, s), float) for s in set(seasons) if s in model.gains}
    for k0, s in zip(starts, seasons):
        if k0 + horizon >= n or s not in model.gains:
            continue
        r = np.arange(k0, k0 + horizon)
        if not (np.isfinite(u[r]).all() and np.isfinite(v[r]).all()):
            continue
        if X is not None and np.isfinite(X[k0]).all():
            x = X[k0]
        else:
            x = np.asarray(model.initial_state(frame, int(k0)), float)
        if not np.isfinite(x).all():
            continue
        keep.append(r)
        x0.append(x)
        qs.append(q_by_season[s][r])
    if not keep:
        return out
    R = np.stack(keep)
    _, Yp = model.simulate(np.stack(x0), u[R], v[R], np.stack(qs))
    out[R + 1] = Y[R + 1] - Yp[:, 1:, :]
    return out


def day_starts(index: pd.DatetimeIndex, week: np.ndarray, season: np.ndarray):
    """Rows at local midnight inside a week, with their seasons."""
    idx = pd.DatetimeIndex(index)
    mid = (idx.hour == 0) & (idx.minute == 0) & (week >= 0)
    k = np.flatnonzero(mid)
    return k, [season[i] for i in k]


# ----------------------------------------------------------------------------
# whiteness
# ----------------------------------------------------------------------------
def acf(r: np.ndarray, nlags: int = 96) -> np.ndarray:
    """NaN-aware sample autocorrelation ``ρ(0..nlags)`` of one series (pairs of valid values)."""
    r = np.asarray(r, float)
    ok = np.isfinite(r)
    if ok.sum() < 3:
        return np.full(nlags + 1, np.nan)
    x = np.where(ok, r - r[ok].mean(), 0.0)
    c0 = (x * x).sum() / ok.sum()
    out = np.empty(nlags + 1)
    for k in range(nlags + 1):
        if k >= len(x):
            out[k] = np.nan
            continue
        m = ok[k:] & ok[: len(x) - k]
        out[k] = (x[k:] * x[: len(x) - k])[m].sum() / max(m.sum(), 1) / c0 if c0 > 0 else np.nan
    return out


def _segments(r: np.ndarray) -> np.ndarray:
    """Valid values of a series with gaps removed (consecutive segments joined)."""
    r = np.asarray(r, float)
    return r[np.isfinite(r)]


def cumulated_periodogram(r: np.ndarray, max_period: float | None = None):
    """Bartlett's cumulated periodogram of the valid values of ``r``.

    Parameters
    ----------
    r : array
        Residuals (NaN-gaps are dropped and the segments joined).
    max_period : float, optional [steps]
        Look for the peak only among periods up to this (e.g. 8 days: seasonal drifts
        are not a "where").

    Returns
    -------
    freq : array [cycles per step]
    C : array
        Normalised cumulated periodogram (0..1).
    bound : float
        1 % Kolmogorov–Smirnov half-width around the white-noise line.
    peak_period : float [steps]
        Period of the largest periodogram ordinate (within ``max_period``).
    peak_share : float
        Share of the variance in that ordinate.
    """
    x = _segments(r)
    x = x - x.mean() if len(x) else x
    n = len(x)
    if n < 16:
        return np.zeros(0), np.zeros(0), np.nan, np.nan, np.nan
    P = np.abs(np.fft.rfft(x)) ** 2
    P = P[1:]
    freq = np.fft.rfftfreq(n)[1:]
    tot = P.sum()
    C = np.cumsum(P) / tot if tot > 0 else np.zeros_like(P)
    q = len(P)
    bound = KS_99 / np.sqrt(q)
    ok = np.ones(len(P), bool) if max_period is None else (1.0 / freq) <= max_period
    if not ok.any():
        ok[:] = True
    j = int(np.flatnonzero(ok)[np.argmax(P[ok])])
    return freq, C, float(bound), float(1.0 / freq[j]), float(P[j] / tot) if tot > 0 else np.nan


def whiteness(r: np.ndarray, step: float, nlags: int = 96) -> dict:
    """Whiteness tests of one residual series.

    Returns
    -------
    dict with ``n``, ``acf_lag1``, ``acf_max`` (largest |ρ| at lags 1..nlags) and its lag,
    ``acf_bound`` (95 % ±1.96/√n), ``ljung_box`` {``lags``, ``stat``, ``p_value``}
    (statsmodels), ``cpgram_departure`` (max distance to the white-noise line),
    ``cpgram_bound`` (1 % KS), ``peak_period_h`` (dominant period up to 8 days),
    ``peak_share``, and ``white``
    (True unless both significant and practically relevant: departure > bound and
    > :data:`MIN_CPGRAM_DEPARTURE`).
    """
    from statsmodels.tsa.stattools import acf as sm_acf

    x = _segments(r)
    n = len(x)
    out = {"n": int(n)}
    if n < 32:
        out.update(white=None, reason="too few residuals")
        return out
    rho = acf(r, nlags)
    k = 1 + int(np.nanargmax(np.abs(rho[1:])))
    lags = int(min(nlags, n // 4))
    # Ljung-Box Q (statsmodels, FFT autocorrelation: O(n log n) for a year of 15-min data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)  # statsmodels' future AcfResult notice
        _, q, p = sm_acf(x, nlags=lags, fft=True, qstat=True)[:3]
    freq, C, bound, period, share = cumulated_periodogram(r, max_period=8 * 86400.0 / step)
    dep = float(np.max(np.abs(C - np.arange(1, len(C) + 1) / len(C)))) if len(C) else np.nan
    out.update(
        acf_lag1=float(rho[1]),
        acf_max=float(rho[k]),
        acf_max_lag=k,
        acf_bound=float(1.96 / np.sqrt(n)),
        ljung_box={"lags": lags, "stat": float(q[-1]), "p_value": float(p[-1])},
        cpgram_departure=dep,
        cpgram_bound=bound,
        peak_period_h=float(period * step / 3600.0),
        peak_share=share,
        white=bool(not (dep > bound and dep > MIN_CPGRAM_DEPARTURE)),
    )
    return out


# ----------------------------------------------------------------------------
# where the errors are large
# ----------------------------------------------------------------------------
@dataclasses.dataclass
class Context:
    """Conditioning variables per row, for breakdowns."""

    index: pd.DatetimeIndex
    season: np.ndarray
    airflow_regime: np.ndarray  # (n, nz) "min" | "mid" | "max"
    T_out_band: np.ndarray  # (n,) labels
    sky: np.ndarray  # (n,) "night" | "sunny" | "cloudy" | "n/a"


def make_context(sig) -> Context:
    """Conditioning variables from the diagnosis signals."""
    n = len(sig.index)
    reg = np.full((n, sig.nz), "mid", dtype=object)
    for z in range(sig.nz):
        u = sig.U[:, z]
        umax = np.nanquantile(u, 0.98) if np.isfinite(u).any() else np.inf
        reg[u <= sig.u_min[z] * 1.05 + 1e-6, z] = "min"
        reg[u >= 0.9 * umax, z] = "max"
        reg[~np.isfinite(u), z] = "n/a"
    T = sig.V["T_out"]
    edges = [-np.inf, 8.0, 12.0, 16.0, 20.0, np.inf]
    labels = ["<8 °C", "8–12 °C", "12–16 °C", "16–20 °C", "≥20 °C"]
    band = np.full(n, "n/a", dtype=object)
    for lo, hi, lab in zip(edges[:-1], edges[1:], labels):
        band[(T >= lo) & (T < hi)] = lab
    sky = np.full(n, "n/a", dtype=object)
    if sig.has_solar:
        tot = sum(sig.V[f"I_{o}"] for o in "NESW")
        day = tot > 40.0
        sky[~day] = "night"
        if day.any():
            # clearness proxy: irradiance relative to the maximum at the same hour of day in a ±10-day window
            ser = pd.Series(tot, index=sig.index)
            ref = ser.groupby(sig.index.hour).transform(lambda s: s.rolling(20 * 96, min_periods=1, center=True).max())
            clear = (tot / np.maximum(ref.to_numpy(), 1.0)) > 0.7
            sky[day & clear] = "sunny"
            sky[day & ~clear] = "cloudy"
    return Context(sig.index, sig.season, reg, band, sky)


def breakdown(resid: np.ndarray, ctx: Context, zones, mask=None) -> dict:
    """Mean and RMS of residuals [K] by zone and by season, hour of day, weekday/weekend,
    airflow regime, outdoor-temperature band and sky (sunny/cloudy/night).

    Returns a JSON-ready nested mapping ``{by: {label: {zone: {"mean", "rms", "n"}}}}``.
    """
    resid = np.asarray(resid, float)
    n = len(resid)
    mask = np.ones(n, bool) if mask is None else np.asarray(mask, bool)
    idx = ctx.index
    keys = {
        "season": ctx.season,
        "hour": np.asarray(idx.hour),
        "day_type": np.where(np.asarray(idx.day_of_week) < 5, "weekday", "weekend"),
        "T_out_band": ctx.T_out_band,
        "sky": ctx.sky,
    }
    out = {}
    for by, lab in keys.items():
        tab = {}
        for v in pd.unique(lab[mask]):
            m = mask & (lab == v)
            tab[str(v)] = {z: _stats(resid[m, j]) for j, z in enumerate(zones)}
        out[by] = dict(sorted(tab.items(), key=lambda kv: _sort_key(kv[0])))
    tab = {}
    for j, z in enumerate(zones):
        for v in ("min", "mid", "max"):
            m = mask & (ctx.airflow_regime[:, j] == v)
            tab.setdefault(v, {})[z] = _stats(resid[m, j])
    out["airflow_regime"] = tab
    out["zone"] = {z: _stats(resid[mask, j]) for j, z in enumerate(zones)}
    return out


def _sort_key(s):
    try:
        return (0, float(s))
    except ValueError:
        return (1, s)


def _stats(x) -> dict:
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return {"mean": None, "rms": None, "n": 0}
    return {"mean": float(x.mean()), "rms": float(np.sqrt(np.mean(x * x))), "n": int(len(x))}


def largest_errors(tables: dict, zones, top: int = 5) -> list:
    """The ``top`` cells (by, label, zone) with the largest |mean| open-loop error, for the text report."""
    cells = []
    for by, tab in tables.items():
        if by == "zone":
            continue
        for lab, per_zone in tab.items():
            for z in zones:
                s = per_zone.get(z, {})
                if s.get("n", 0) >= 50 and s.get("mean") is not None:
                    cells.append({"by": by, "label": lab, "zone": z, "mean": s["mean"], "rms": s["rms"], "n": s["n"]})
    cells.sort(key=lambda c: -abs(c["mean"]))
    return cells[:top]
