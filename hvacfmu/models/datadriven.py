"""Identification of Model A, the data-driven semiparametric model (paper section III).

    x(k+1) = A x(k) + B u(k) + C v(k) + q_IG(k) + eps(k)

The internal gains ``q_IG`` are unknown. Taking conditional expectations given
time and subtracting removes them (eq. (subtract)):

    x(k+1) - x^(k+1) = A (x(k) - x^(k)) + B (u(k) - u^(k)) + C (v(k) - v^(k)) + eps(k)

where ``x^``, ``u^``, ``v^`` are LOESS smooths of the measured series against
time. ``A``, ``B``, ``C`` follow from Bayesian constrained least squares on the
de-smoothed series of all seasons jointly (eq. (data_opt)); ``q_IG`` per
season is the time-of-week average of ``x^(k+1) - (A x^(k) + B u^(k) + C v^(k))``
over that season's training weeks (eq. (qig_estimation)).

Choices beyond the paper
------------------------
- One common LOESS bandwidth for all series of a fit (pooled k-fold CV; the
  per-series CV curves are kept). The subtraction step is exact only when x, u
  and v are smoothed alike; per-series bandwidths bias b (see ``fit_lumped``).
  ``common_bandwidth=False`` restores per-series bandwidths.
- Cross-validation holds out 2-h blocks: with single points held out, CV on an
  autocorrelated temperature always picks the smallest window, which leaves
  mostly measurement noise in the de-smoothed series and attenuates a [3]_.
- The prior of b (eq. (excitation_equation)) is fitted with a constant term.
- The data term is weighted by the residual variance of the fit without
  priors, so prior standard deviations are in the coefficients' own units.

Layers
------
1. Pure functions on numpy arrays: :func:`loess_smooth`, :func:`cv_bandwidth`,
   :func:`bayes_cls`, :func:`excitation_prior_b`, :func:`estimate_gains`.
2. :func:`fit_lumped` and :func:`fit_zones`, which pull arrays from a
   :class:`hvacfmu.data.Dataset` and return a
   :class:`~hvacfmu.models.linear.LinearZoneModel`.

References
----------
.. [1] D. Zhou, Q. Hu, C. J. Tomlin, "Model comparison of a data-driven and a
   physical model for simulating HVAC systems", section III.
.. [2] A. Aswani, N. Master, J. Taneja, D. Culler, C. Tomlin, "Reducing
   transient and steady state electricity consumption in HVAC using
   learning-based model-predictive control", Proc. IEEE 100(1), 2012.
.. [3] J. Opsomer, Y. Wang, Y. Yang, "Nonparametric regression with correlated
   errors", Statistical Science 16(2), 2001 (cross-validation picks too small
   bandwidths under autocorrelation; blocked folds counter this).
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import hashlib
import logging
import time
import warnings
from typing import Any

import numpy as np
import scipy.fft
import scipy.sparse

from ..calendars import holiday_slots
from ..data.idle import UNIT_OFF_FRACTION, unit_off_bounds
from ..errors import DataError, FitError, HvacfmuWarning, problems_message
from ..timeutil import n_time_of_week
from .heat import air_handler_off_share, delivered_heat, inlet_columns

log = logging.getLogger(__name__)

#: Default bandwidth grid: half-widths of the tricube window [h].
DEFAULT_BANDWIDTHS_H = (2.0, 3.0, 4.0, 6.0, 8.0, 12.0)

#: Strict bounds 0 < a < 1 are imposed as eps <= a <= 1 - eps.
A_EPS = 1e-4


# =============================================================================
# layer 1: LOESS smoothing on a regular grid
# =============================================================================
def tricube(r):
    """Tricube weight ``(1 - |r|^3)^3`` for ``|r| < 1``, else 0."""
    r = np.abs(np.asarray(r, dtype=float))
    return np.where(r < 1.0, (1.0 - r**3) ** 3, 0.0)


def _grid_step(t) -> float:
    """Spacing of a regular time grid ``t``; raises ValueError if irregular."""
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise ValueError("t must be a 1-D array with at least two points")
    dt = np.diff(t)
    step = float(np.median(dt))
    if step <= 0 or np.max(np.abs(dt - step)) > 1e-6 * step:
        raise ValueError(
            "loess_smooth needs a regular time grid (constant spacing, NaN where data are missing); "
            f"got spacings from {dt.min()} to {dt.max()}"
        )
    return step


class _Convolver:
    """Centred 'same'-size convolutions along axis 0 by FFT, reusing transforms.

    The forward transforms of the data are computed once; each kernel then costs
    one multiplication and one inverse transform.
    """

    def __init__(self, columns: np.ndarray, max_half_width: int):
        self.n = columns.shape[0]
        self.nfft = scipy.fft.next_fast_len(self.n + max_half_width + 1, real=True)
        self.F = scipy.fft.rfft(columns, n=self.nfft, axis=0)

    def __call__(self, kernel: np.ndarray, cols=slice(None)) -> np.ndarray:
        r = (kernel.size - 1) // 2
        k = np.zeros(self.nfft)
        k[: r + 1] = kernel[r:]  # offsets 0..r
        if r:
            k[-r:] = kernel[:r]  # offsets -r..-1 wrap to the end
        out = scipy.fft.irfft(self.F[:, cols] * scipy.fft.rfft(k)[:, None], n=self.nfft, axis=0)
        return out[: self.n]


def _kernels(h: float):
    """Offsets d, tricube weights w for half-width h [steps] (odd length)."""
    r = max(int(np.floor(h)), 1)
    d = np.arange(-r, r + 1, dtype=float)
    return d, tricube(d / h)


def _local_linear_weights(S0, S1, S2):
    """Coefficients (c0, c1) with estimate = c0 T0 + c1 T1; NaN where there is no support.

    Local linear regression: ``[S0 S1; S1 S2] [alpha; beta] = [T0; T1]``, the
    estimate is ``alpha = (S2 T0 - S1 T1) / det``. Where the local design is
    degenerate (a single point in the window) it falls back to the local mean
    ``T0 / S0``.
    """
    det = S0 * S2 - S1 * S1
    good = det > 1e-8 * np.maximum(S0 * S2, 1e-300)
    with np.errstate(invalid="ignore", divide="ignore"):
        c0 = np.where(good, S2 / det, 1.0 / S0)
        c1 = np.where(good, -S1 / det, 0.0)
    c0[~(S0 > 1e-9)] = np.nan
    return c0, c1


def loess_smooth(t, y, bandwidth):
    """Local linear regression with tricube weights (LOESS, degree 1, no robustness iterations).

    The estimate at every grid point ``t_i`` is the intercept of the weighted
    least-squares line through the observations ``(t_j, y_j)`` with weights
    ``tricube((t_j - t_i) / bandwidth)``. Missing observations (NaN) get weight
    zero, so the smoother is NaN-aware: windows next to a gap use only the data
    on one side (local linear regression has no boundary bias to first order),
    and points farther than ``bandwidth`` from any observation are NaN.

    Implementation: on a regular grid the five weighted moment sums
    ``sum w``, ``sum w d``, ``sum w d^2``, ``sum w y``, ``sum w d y`` are
    convolutions of the data and of the missing-data mask with fixed kernels,
    computed by FFT in O(n log n) — about a millisecond for a year of
    15-minute data, for any bandwidth. This is exact (not an interpolated
    approximation like statsmodels' ``delta``), uses a fixed bandwidth in time
    units (statsmodels' ``frac`` is a nearest-neighbour span, which silently
    reaches across gaps), and lets cross-validation reuse the data's Fourier
    transforms for every candidate bandwidth.

    Parameters
    ----------
    t : array (n,) [s]
        Regular time grid (constant spacing; NaN in ``y`` where data are missing).
    y : array (n,) or (n, m)
        Series to smooth; columns are smoothed independently.
    bandwidth : float [s]
        Half-width of the tricube window (weights vanish at ``|t_j - t_i| >= bandwidth``).
        Must be at least two grid steps.

    Returns
    -------
    array, same shape as ``y``
        Smoothed series.

    References
    ----------
    W. S. Cleveland, "Robust locally weighted regression and smoothing
    scatterplots", JASA 74(368), 1979.
    """
    step = _grid_step(t)
    y = np.asarray(y, dtype=float)
    if y.shape[0] != np.asarray(t).shape[0]:
        raise ValueError(f"t has {np.asarray(t).shape[0]} points but y has {y.shape[0]} rows")
    h = float(bandwidth) / step
    if not h >= 2.0:
        raise ValueError(f"bandwidth {bandwidth} s is less than two grid steps ({2 * step} s)")
    Y = y.reshape(y.shape[0], -1)
    out = _smooth_columns(Y, np.isfinite(Y), h)
    return out.reshape(y.shape)


def _smooth_columns(Y, M, h):
    """Smooth columns of Y (NaN where ~M) with half-width h [steps]."""
    d, w = _kernels(h)
    center = np.array([np.mean(Y[M[:, j], j]) if M[:, j].any() else 0.0 for j in range(Y.shape[1])])
    conv_y = _Convolver(np.where(M, Y - center, 0.0), d.size // 2)
    conv_m = _Convolver(M.astype(float), d.size // 2)
    c0, c1 = _local_linear_weights(conv_m(w), conv_m(-d * w), conv_m(d * d * w))
    return c0 * conv_y(w) + c1 * conv_y(-d * w) + center


@dataclasses.dataclass(frozen=True)
class CvResult:
    """Result of :func:`cv_bandwidth`.

    Attributes
    ----------
    bandwidth : array (m,) [s]
        Chosen bandwidth per series (minimiser of the CV score).
    grid : array (k,) [s]
        Candidate bandwidths.
    scores : array (k, m)
        Mean squared prediction error on held-out points, per candidate and series
        (in the series' unit squared; inf where held-out points could not be predicted).
    """

    bandwidth: np.ndarray
    grid: np.ndarray
    scores: np.ndarray


def cv_bandwidth(t, y, bandwidths, *, folds=5, block=4, seed=0) -> CvResult:
    """Choose the LOESS bandwidth of each series by blocked k-fold cross-validation.

    The rows are cut into consecutive blocks of ``block`` points, and the blocks
    are dealt at random into ``folds`` folds. For each fold and candidate
    bandwidth the series is smoothed without that fold and the squared error on
    the held-out points is summed. Holding out blocks rather than single points
    keeps autocorrelated noise from pulling the choice towards too small
    bandwidths [3]_.

    Parameters
    ----------
    t : array (n,) [s]
        Regular time grid.
    y : array (n,) or (n, m)
        Series (NaN where missing).
    bandwidths : sequence of float [s]
        Candidate half-widths, each at least ``block`` grid steps.
    folds : int
        Number of folds k (>= 2).
    block : int
        Length of a held-out block [grid steps].
    seed : int
        Seed of the block-to-fold assignment.

    Returns
    -------
    CvResult
    """
    step = _grid_step(t)
    Y = np.asarray(y, dtype=float).reshape(np.asarray(y).shape[0], -1)
    grid = np.asarray(sorted(float(b) for b in bandwidths))
    if grid.size == 0:
        raise ValueError("no candidate bandwidths")
    if folds < 2:
        raise ValueError(f"need at least 2 folds, got {folds}")
    if grid[0] / step < max(2, block):
        raise ValueError(
            f"smallest candidate bandwidth {grid[0]} s is below max(2, block={block}) grid steps of {step} s"
        )
    n, m = Y.shape
    rng = np.random.default_rng(seed)
    n_blocks = -(-n // block)
    # interleaved blocks (random offset): held-out blocks of one fold never touch
    fold = np.repeat((np.arange(n_blocks) + int(rng.integers(folds))) % folds, block)[:n]
    M = np.isfinite(Y)
    # columns: (series j, fold f) -> j * folds + f, series j without fold f
    keep = np.stack([fold != f for f in range(folds)], axis=1)  # (n, folds)
    Mrep = (M[:, :, None] & keep[:, None, :]).reshape(n, m * folds)
    center = np.array([np.mean(Y[M[:, j], j]) if M[:, j].any() else 0.0 for j in range(m)])
    Yc = np.where(M, Y - center, 0.0)
    Yrep = np.where(Mrep, np.repeat(Yc, folds, axis=1), 0.0)
    rmax = int(np.ceil(grid[-1] / step)) + 1
    conv_y = _Convolver(Yrep, rmax)
    # masks are often identical across series: transform each distinct one once
    packed = np.packbits(Mrep, axis=0).T.copy()
    _, first, inverse = np.unique(
        packed.view(np.dtype((np.void, packed.shape[1]))).ravel(), return_index=True, return_inverse=True
    )
    inverse = inverse.ravel()
    conv_m = _Convolver(Mrep[:, first].astype(float), rmax)
    held = ~keep  # (n, folds)
    test = M[:, :, None] & held[:, None, :]
    cnt = test.sum(axis=(0, 2))
    scores = np.empty((grid.size, m))
    for i, bw in enumerate(grid):
        h = bw / step
        d, w = _kernels(h)
        c0, c1 = _local_linear_weights(conv_m(w), conv_m(-d * w), conv_m(d * d * w))
        pred = c0[:, inverse] * conv_y(w)
        pred += c1[:, inverse] * conv_y(-d * w)
        err = pred.reshape(n, m, folds)
        err -= Yc[:, :, None]
        ok = test & np.isfinite(err)
        err[~ok] = 0.0
        sse = np.einsum("ijk,ijk->j", err, err)
        cnt_ok = ok.sum(axis=(0, 2))
        with np.errstate(invalid="ignore", divide="ignore"):
            sc = sse / cnt_ok
        sc[(cnt_ok < 0.99 * cnt) | (cnt == 0)] = np.inf
        scores[i] = sc
    best = grid[np.argmin(np.where(np.isfinite(scores), scores, np.inf), axis=0)]
    return CvResult(bandwidth=best, grid=grid, scores=scores)


def pooled_bandwidth(scores, grid):
    """One bandwidth for several series: minimiser of the summed relative CV scores.

    Each series' CV curve is divided by its own minimum, so series in
    different units weigh equally; the common bandwidth minimises the sum.

    Parameters
    ----------
    scores : array (k, m)
        CV scores of m series on k candidate bandwidths (from :func:`cv_bandwidth`).
    grid : array (k,)
        Candidate bandwidths.

    Returns
    -------
    float
        The chosen candidate.
    """
    scores = np.asarray(scores, float)
    finite = np.isfinite(scores)
    best = np.min(np.where(finite, scores, np.inf), axis=0)
    usable = np.isfinite(best) & (best > 0)
    if not usable.any():
        return float(np.asarray(grid)[0])
    rel = np.where(finite[:, usable], scores[:, usable] / best[usable], np.inf)
    return float(np.asarray(grid)[int(np.argmin(rel.sum(axis=1)))])


# =============================================================================
# layer 1: Bayesian constrained least squares
# =============================================================================
@dataclasses.dataclass(frozen=True)
class BayesClsResult:
    """Result of :func:`bayes_cls` (qpsolvers-style: check ``found``).

    Attributes
    ----------
    theta : array (p,) or None
        Posterior mode under the constraints (None if the solver failed).
    cov : array (p, p) or None
        Posterior covariance of the unconstrained Gaussian problem,
        ``(Z^T Z / sigma2 + Sigma^-1)^-1`` — a guide to the uncertainty,
        not exact for coefficients at an active constraint.
    sigma2 : float
        Noise variance used to weight the data term.
    found : bool
    n : int
        Number of data rows.
    rss : float
        Residual sum of squares at ``theta``.
    problem : dict
        The QP (P, q, G, h, lb, ub) in scaled variables, kept for replay when not found.
    """

    theta: np.ndarray | None
    cov: np.ndarray | None
    sigma2: float
    found: bool
    n: int
    rss: float
    problem: dict


def bound_rows(lo, hi) -> tuple[list, list]:
    """The finite bounds ``lo <= x <= hi`` as inequality rows ``g @ x <= h`` (``+e_j`` for an upper bound, then
    ``-e_j`` for a lower one, variable by variable): lists of rows and right-hand sides for a QP solver that must
    not see infinite bounds."""
    rows, h = [], []
    eye = np.eye(len(lo))
    for j in range(len(lo)):
        if np.isfinite(hi[j]):
            rows.append(eye[j])
            h.append(hi[j])
        if np.isfinite(lo[j]):
            rows.append(-eye[j])
            h.append(-lo[j])
    return rows, h


def bayes_cls(Z, y, *, lb=None, ub=None, G=None, h=None, prior_mean=None, prior_sd=None, sigma2=None):
    """Bayesian constrained least squares (eq. (data_opt) of [1]_) as a QP solved by Clarabel.

    Minimises

        ||y - Z theta||^2 / sigma2 + sum_i ((theta_i - mu_i) / s_i)^2

    subject to ``lb <= theta <= ub`` and ``G theta <= h``. Coefficients with an
    infinite (or NaN) prior standard deviation ``s_i`` have a flat prior. With
    ``sigma2`` the noise variance, the objective is twice the negative log
    posterior of a linear-Gaussian model, so the prior standard deviations are
    in the coefficients' own units.

    Parameters
    ----------
    Z : array (n, p)
        Regressors.
    y : array (n,)
        Targets.
    lb, ub : array (p,), optional
        Bounds (``-inf`` / ``inf`` for none).
    G, h : arrays (r, p), (r,), optional
        Linear inequality constraints.
    prior_mean, prior_sd : arrays (p,), optional
        Gaussian prior; omitted means flat.
    sigma2 : float, optional
        Noise variance; default: residual variance of the constrained fit
        without priors (computed first).

    Returns
    -------
    BayesClsResult
    """
    import qpsolvers

    Z = np.asarray(Z, dtype=float)
    y = np.asarray(y, dtype=float)
    n, p = Z.shape
    lb = np.full(p, -np.inf) if lb is None else np.asarray(lb, dtype=float)
    ub = np.full(p, np.inf) if ub is None else np.asarray(ub, dtype=float)
    mu = np.zeros(p) if prior_mean is None else np.asarray(prior_mean, dtype=float)
    sd = np.full(p, np.inf) if prior_sd is None else np.asarray(prior_sd, dtype=float)
    prec = np.where(np.isfinite(sd) & (sd > 0), 1.0 / np.where(sd > 0, sd, 1.0) ** 2, 0.0)
    if sigma2 is None:
        if np.any(prec > 0):
            first = bayes_cls(Z, y, lb=lb, ub=ub, G=G, h=h)
            sigma2 = first.sigma2
        else:
            sigma2 = 1.0
    sigma2 = float(sigma2) if np.isfinite(sigma2) and sigma2 > 0 else 1.0
    # scale the variables: theta = s * phi, with s the regressor RMS
    s = np.sqrt(np.mean(Z * Z, axis=0))
    s = np.where(s > 0, 1.0 / np.where(s > 0, s, 1.0), 1.0)
    Zs = Z * s
    P = Zs.T @ Zs / sigma2 + np.diag(prec * s * s)
    q = -(Zs.T @ y) / sigma2 - prec * mu * s
    norm = max(np.max(np.abs(np.diag(P))), 1e-300)
    P, q = P / norm, q / norm
    lbs, ubs = lb / s, ub / s
    Gs = None if G is None else np.asarray(G, dtype=float) * s
    hs = None if h is None else np.asarray(h, dtype=float)
    problem = {"P": P, "q": q, "G": Gs, "h": hs, "lb": lbs, "ub": ubs, "scale": s}
    # finite bounds become inequality rows (qpsolvers would pass infinite ones on to Clarabel)
    rows_G, rows_h = bound_rows(lbs, ubs)
    if Gs is not None:
        rows_G += list(np.atleast_2d(Gs))
        rows_h += list(np.atleast_1d(hs))
    kw = {}
    if not rows_G:  # unconstrained: the normal equations
        phi = np.linalg.lstsq(0.5 * (P + P.T), -q, rcond=None)[0]
    else:
        kw.update(G=scipy.sparse.csc_matrix(np.array(rows_G)), h=np.array(rows_h, dtype=float))
        try:
            phi = qpsolvers.solve_qp(scipy.sparse.csc_matrix(0.5 * (P + P.T)), q, solver="clarabel", **kw)
        except Exception as exc:  # noqa: BLE001 - any solver failure is reported as found=False
            log.warning("bayes_cls: clarabel failed: %s", exc)
            phi = None
    if phi is None or not np.all(np.isfinite(phi)):
        return BayesClsResult(None, None, sigma2, False, n, float("nan"), problem)
    theta = phi * s
    r = y - Z @ theta
    rss = float(r @ r)
    H = Z.T @ Z / sigma2 + np.diag(prec)
    try:
        cov = np.linalg.inv(H)
    except np.linalg.LinAlgError:
        cov = np.linalg.pinv(H)
    if not np.any(prec > 0):
        sigma2 = rss / max(n - p, 1)
        cov = cov * sigma2  # flat prior: classical LS covariance with the fitted noise variance
    return BayesClsResult(theta, cov, sigma2, True, n, rss, problem)


def excitation_prior_b(dx, u):
    """Prior mean of b from excitation experiments, eq. (excitation_equation) of [1]_.

    During forced-response experiments the airflow dominates the temperature
    change, ``dx = x(k+1) - x(k) = b u(k)``. The slope is fitted by least squares
    with a constant, which absorbs the slowly varying remainder
    ``(a - 1) x + c^T v + q_IG`` over the experiments.

    Parameters
    ----------
    dx : array (n,) [K per step]
        Temperature increments during excitation.
    u : array (n,) [kg/s]
        Airflow at the start of each increment.

    Returns
    -------
    float [K per step per kg/s]
        NaN if the airflow does not vary.
    """
    dx, u = np.asarray(dx, float), np.asarray(u, float)
    ok = np.isfinite(dx) & np.isfinite(u)
    dx, u = dx[ok], u[ok]
    if dx.size < 3:
        return float("nan")
    uc = u - u.mean()
    var = float(uc @ uc)
    if var <= 1e-12 * max(float(u @ u), 1e-300):
        return float("nan")
    return float(uc @ (dx - dx.mean()) / var)


# =============================================================================
# layer 1: internal gains
# =============================================================================
def estimate_gains(q_rows, slots, n_slots):
    """Time-of-week profile of internal gains, eq. (qig_estimation) of [1]_.

    Averages the per-row estimates ``q_rows`` over all rows sharing a
    time-of-week slot (i.e. over the training weeks of a season). Slots without
    any estimate are filled by linear interpolation around the (circular) week.

    Parameters
    ----------
    q_rows : array (n, nq) [K per step]
        ``x^(k+1) - (A x^(k) + B u^(k) + C v^(k))`` at rows with valid data.
    slots : array (n,) of int
        Time-of-week slot of each row.
    n_slots : int
        Slots per week (672 at 15 minutes).

    Returns
    -------
    profile : array (n_slots, nq)
    coverage : float
        Fraction of slots with at least one estimate (before filling).
    """
    q_rows = np.asarray(q_rows, dtype=float)
    # no row at all (a season whose training rows all miss a value): an empty (0, nq) table, coverage 0 below
    q_rows = (
        q_rows.reshape(len(slots), -1) if q_rows.size else q_rows.reshape(0, q_rows.shape[-1] if q_rows.ndim else 1)
    )
    slots = np.asarray(slots, dtype=np.int64)
    nq = q_rows.shape[1]
    prof = np.full((n_slots, nq), np.nan)
    ok_rows = np.all(np.isfinite(q_rows), axis=1)
    cnt = np.bincount(slots[ok_rows], minlength=n_slots)
    for j in range(nq):
        sums = np.bincount(slots[ok_rows], weights=q_rows[ok_rows, j], minlength=n_slots)
        with np.errstate(invalid="ignore", divide="ignore"):
            prof[:, j] = np.where(cnt > 0, sums / np.maximum(cnt, 1), np.nan)
    have = cnt > 0
    coverage = float(have.mean())
    if not have.any():
        return prof, 0.0
    if not have.all():
        idx = np.arange(n_slots)
        known = idx[have]
        for j in range(nq):
            prof[~have, j] = np.interp(idx[~have], known, prof[have, j], period=n_slots)
    return prof, coverage


# =============================================================================
# layer 2: fitting on a Dataset
# =============================================================================
#: Default options of fit_lumped / fit_zones (documented there).
DEFAULTS: dict[str, Any] = {
    "bandwidths": DEFAULT_BANDWIDTHS_H,
    "bandwidth": None,
    "cv_folds": 5,
    "cv_block": 8,
    "common_bandwidth": True,
    "seed": 0,
    "prior_sd_a": 0.05,
    "prior_rel_sd_b": 0.5,
    "mu_a": None,
    "mu_b": None,
    "prior_sd_a_offdiag": 0.02,
    "mu_a_offdiag": 0.005,
    "stability_margin": 1e-3,
    "use_solar": True,
    "min_rows": 200,
    "min_season_coverage": 0.5,
    "heat": "auto",
    "plausibility": True,
    "open_loop": "auto",
    "open_loop_couplings": False,
    "memory": "auto",
    "memory_select": "season",
}

#: With option heat="auto", the delivered-heat form is used when an air handler is off in more than this share
#: of the training steps (its supply temperature is then an idle node temperature).
OFF_SHARE_DELIVERED = 0.05


def _options(opts: dict) -> dict:
    opts = dict(opts)
    opts.pop("progress", None)
    unknown = sorted(set(opts) - set(DEFAULTS))
    if unknown:
        raise TypeError(f"unknown fit option(s) {unknown}; known: {sorted(DEFAULTS)}")
    out = dict(DEFAULTS)
    out.update(opts)
    if out["open_loop"] not in ("auto", True, False):
        raise FitError(f"option open_loop must be 'auto', True or False, got {out['open_loop']!r}")
    if out["memory"] not in ("auto", True, False):
        raise FitError(f"option memory must be 'auto', True or False, got {out['memory']!r}")
    from .memory import SELECT_RULES

    if out["memory_select"] not in SELECT_RULES:
        raise FitError(
            f"option memory_select must be {' or '.join(repr(r) for r in SELECT_RULES)}, got {out['memory_select']!r}"
        )
    if not isinstance(out["open_loop_couplings"], bool):
        raise FitError(f"option open_loop_couplings must be True or False, got {out['open_loop_couplings']!r}")
    return out


def _jsonable(x):
    """Convert numpy values (and NaN/inf) to JSON-safe Python values."""
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        x = float(x)
        return x if np.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


class _Prepared:
    """Arrays pulled once from a Dataset: series on the regular grid, row masks and the boxes' drive.

    The *drive* is what the boxes do to the zones: their airflow [kg/s] in the
    paper's airflow form, the heat their air delivers ``m c_p (T_in - x)`` [kW]
    in the delivered-heat form (see :mod:`hvacfmu.models.heat`).
    """

    def __init__(self, dataset, opts):
        self.dataset = dataset
        self.building = b = dataset.building
        self.step = float(dataset.step)
        self.frame = frame = _regular_frame(dataset.frame, self.step)
        self.index = frame.index
        n = len(frame)
        self.t = np.arange(n) * self.step
        self.T = frame[[f"T_{z}" for z in b.zone_names]].to_numpy(float)
        self.m = frame[[f"m_{v}" for v in b.vav_names]].to_numpy(float)
        self.exc = frame["excitation"].to_numpy(float) == 1.0 if "excitation" in frame.columns else np.zeros(n, bool)
        self._split_weeks(dataset)
        self.warnings: list[str] = []  # fit warnings (the dataset keeps its own)
        self.min_cov = float(opts["min_season_coverage"])
        self._choose_heat_form(opts)
        orient = []
        self.solar = bool(dataset.has_solar) and bool(opts["use_solar"])
        if self.solar:
            orient = [o for o in ("N", "E", "S", "W") if any(o in z.orientations for z in b.zones)]
            orient = [o for o in orient if f"I_{o}" in frame.columns]
        temps = ("T_out",) if self.delivered else ("T_out", "T_supply")
        self.v_names = temps + tuple(f"I_{o}" for o in orient)
        self.V = frame[list(self.v_names)].to_numpy(float)

    def _split_weeks(self, dataset):
        n = len(self.index)
        train = np.zeros(n, bool)
        season = np.full(n, None, dtype=object)
        self.train_weeks = {}
        for w in dataset.weeks:
            sel = (self.index >= w.start) & (self.index < w.end)
            season[sel] = w.season
            if w.train:
                train |= sel
                self.train_weeks.setdefault(w.season, []).append(w.number)
        self.train = train
        self.season = season
        # the slot each row's gains are read at (a holiday weekday: Sunday's), and the rows that estimate
        # a profile (not holidays: hvacfmu.data.holidays)
        on, self.slots = holiday_slots(self.index, self.step, dataset.holidays.dates)
        self.gain_ok = ~on
        self.n_slots = n_time_of_week(self.step)
        if not train.any():
            raise FitError("the dataset has no training weeks; need at least one full week of data")

    def _choose_heat_form(self, opts):
        """Airflow or delivered-heat form (option ``heat``); inlet column per box."""
        b = self.building
        self.inlets, notes = inlet_columns(b, self.frame, rows=self.train)
        for note in notes:
            self.warn(note)
        # an air handler is off by the one unit-off rule (hvacfmu.data.idle.unit_off_bounds, as diagnose's idle
        # supply rule, the FMUs and the co-simulation's schedule): every box below half its minimum airflow
        bounds = unit_off_bounds(b)
        self.off_share = air_handler_off_share(b, self.m, self.train, [bounds[f"m_{v}"] for v in b.vav_names])
        has_td = [c for c in self.inlets if c.startswith("Td_")]
        form = opts["heat"]
        if form not in ("auto", "airflow", "delivered"):
            raise FitError(f"option heat must be 'auto', 'airflow' or 'delivered', got {form!r}")
        if form == "auto":
            if has_td:
                form, why = "delivered", f"discharge air temperatures measured ({len(has_td)} of {len(b.vavs)} boxes)"
            elif self.off_share > OFF_SHARE_DELIVERED:
                form, why = (
                    "delivered",
                    (
                        f"an air handler is off (every box at or below {100 * UNIT_OFF_FRACTION:g} % of its minimum airflow) in "
                        f"{100 * self.off_share:.0f} % of the training steps"
                    ),
                )
            else:
                form, why = "airflow", "no discharge air temperatures; air handlers always run"
        else:
            why = "option heat"
        if form == "airflow" and has_td:
            self.warn(f"heat='airflow' ignores the measured discharge air temperatures {has_td}")
        if form == "airflow" and self.off_share > OFF_SHARE_DELIVERED:
            self.warn(
                f"heat='airflow': the supply temperature enters linearly although an air handler is off in "
                f"{100 * self.off_share:.0f} % of the training steps (its idle node temperature is "
                "meaningless); heat='delivered' avoids this"
            )
        self.delivered = form == "delivered"
        self.heat_form = {
            "form": form,
            "reason": why,
            "inlets": dict(zip(b.vav_names, self.inlets)),
            "air_handler_off_share": self.off_share,
        }
        self.Tin = self.frame[list(self.inlets)].to_numpy(float)

    def box_heat(self, T_box):
        """Heat delivered by each box [kW] with the zone temperature ``T_box`` (n, n_vav) it sees; 0 at zero flow."""
        Q = delivered_heat(self.m, self.Tin, T_box)
        return np.where(self.m == 0.0, 0.0, Q)

    def zone_drive(self):
        """What each zone's boxes do (n, n_zones): summed airflow [kg/s] or delivered heat [kW]."""
        zvm = self.building.zone_vav_matrix()
        if not self.delivered:
            return self.m @ zvm.T
        box_zone = np.argmax(zvm, axis=0)
        return self.box_heat(self.T[:, box_zone]) @ zvm.T

    def floor_drive(self, x_floor):
        """What all boxes do to the floor (n,): total airflow [kg/s] or delivered heat [kW]."""
        if not self.delivered:
            return self.m.sum(axis=1)
        return self.box_heat(np.repeat(x_floor[:, None], self.m.shape[1], axis=1)).sum(axis=1)

    @property
    def drive_label(self) -> str:
        """Prefix of the drive series in smoothing metadata: ``m`` (airflow) or ``Q`` (delivered heat)."""
        return "Q" if self.delivered else "m"

    @property
    def drive_bounds(self):
        """Bounds of the drive coefficient: airflow cools (b <= 0), delivered heat warms (beta >= 0)."""
        return (0.0, np.inf) if self.delivered else (-np.inf, 0.0)

    def warn(self, msg):
        self.warnings.append(msg)
        warnings.warn(msg, HvacfmuWarning, stacklevel=4)

    def check_constant(self, names, X, what):
        """Problems for series that are constant (or absent) over the training rows."""
        problems = []
        for j, name in enumerate(names):
            x = X[self.train, j]
            x = x[np.isfinite(x)]
            if x.size < 2:
                why = [w for w in getattr(self.dataset, "warnings", []) or [] if f"'T_{name}'" in w]
                problems.append(
                    f"{what} {name}: no data in the training weeks"
                    + (f" (the data layer said: {why[0]})" if why else "")
                )
            elif np.ptp(x) < 1e-6:
                problems.append(
                    f"{what} {name}: constant at {x[0]:g} over all training weeks (stuck sensor?); "
                    "its dynamics cannot be identified"
                )
        return problems


def _regular_frame(frame, step):
    """``frame`` on a regular grid of ``step`` seconds (the smoother needs one); rows added as NaN."""
    import pandas as pd

    idx = frame.index
    if len(idx) < 3:
        raise DataError("dataset has fewer than three rows; nothing to fit")
    full = pd.date_range(idx[0], idx[-1], freq=pd.Timedelta(seconds=step))
    if len(full) != len(idx) or not full.equals(idx):
        frame = frame.reindex(full)
    return frame


def _smooth_series(prep: _Prepared, names, X, opts):
    """LOESS smooths of the columns of X on training rows; bandwidths by CV unless given."""
    Xt = np.where(prep.train[:, None], X, np.nan)
    fixed = opts["bandwidth"]
    curves = {}
    if fixed is not None:
        if isinstance(fixed, dict):
            missing = [nm for nm in names if nm not in fixed]
            if missing:
                raise FitError(f"option bandwidth: no bandwidth [h] given for series {missing}")
            bws = np.array([float(fixed[nm]) * 3600.0 for nm in names])
        else:
            bws = np.full(len(names), float(fixed) * 3600.0)
        grid = np.unique(bws)
    else:
        cv, grid = _cv_extending(prep, Xt, opts)
        bws = cv.bandwidth
        for j, nm in enumerate(names):
            curves[nm] = cv.scores[:, j]
        if opts["common_bandwidth"]:
            bws = np.full(len(names), pooled_bandwidth(cv.scores, grid))
        _warn_grid_edge(prep, names, bws, grid)
    hat = np.full_like(Xt, np.nan)
    for bw in np.unique(bws):
        cols = np.flatnonzero(bws == bw)
        hat[:, cols] = loess_smooth(prep.t, Xt[:, cols], bw)
    info = {
        "bandwidth_h": {nm: float(bws[j]) / 3600.0 for j, nm in enumerate(names)},
        "cv_grid_h": (np.asarray(grid) / 3600.0).tolist(),
        "cv_scores": {nm: curves[nm] for nm in curves},
    }
    return hat, info


#: The CV grid is extended upwards (by factors of 1.5) up to this half-width [h] when its top candidate wins.
MAX_BANDWIDTH_H = 48.0


def _cv_extending(prep: _Prepared, Xt, opts):
    """Blocked CV on the option's grid, extended upwards while the pooled choice sits on its top edge."""
    grid_h = sorted(float(g) for g in opts["bandwidths"])
    kw = {"folds": int(opts["cv_folds"]), "block": int(opts["cv_block"]), "seed": int(opts["seed"])}
    while True:
        cv = cv_bandwidth(prep.t, Xt, np.asarray(grid_h) * 3600.0, **kw)
        top = pooled_bandwidth(cv.scores, cv.grid) if opts["common_bandwidth"] else float(np.max(cv.bandwidth))
        if len(grid_h) < 2 or top < cv.grid[-1] or grid_h[-1] * 1.5 > MAX_BANDWIDTH_H:
            return cv, cv.grid
        grid_h.append(grid_h[-1] * 1.5)
        log.info("CV chose the largest candidate bandwidth; grid extended to %.1f h", grid_h[-1])


def _warn_grid_edge(prep: _Prepared, names, bws, grid):
    """Warn (naming series and bandwidth) when CV chose a bandwidth on the edge of its grid.

    At the lower edge the smoother follows nearly every wiggle of the series:
    on closed-loop data the de-smoothed temperature is mostly the thermostat
    loop's fast response and the identified dynamics describe the loop, not the
    building. The lower edge cannot go below the CV block length.
    """
    if len(grid) < 2:
        return
    for edge, label in ((grid[0], "lower"), (grid[-1], "upper")):
        at = [nm for nm, bw in zip(names, bws) if bw == edge]
        if not at:
            continue
        # the lumped and the six-zone fit both warn: say which series, so the two are told apart
        what = (
            f"every series ({', '.join(names)})"
            if len(at) == len(names) and len(names) <= 6
            else f"all {len(names)} series ({', '.join(names[:3])}, ...)"
            if len(at) == len(names)
            else ", ".join(at)
        )
        hint = (
            "(it cannot go lower than the CV block, option cv_block): the de-smoothed series may be dominated "
            "by fast variations such as a thermostat loop; see the identifiability check, or fix option "
            "bandwidth to compare"
            if label == "lower"
            else f"(extended up to {MAX_BANDWIDTH_H:g} h); the series vary little within a day"
        )
        prep.warn(
            f"LOESS bandwidth {edge / 3600:g} h chosen by cross-validation for {what} is on the "
            f"{label} edge of its grid ({', '.join(f'{g / 3600:g}' for g in grid)} h) {hint}"
        )


def _regression_rows(prep: _Prepared, *arrays_at_k, next_ok):
    """Rows k usable for the regression: training at k and k+1, all values finite."""
    n = len(prep.t)
    ok = np.zeros(n, bool)
    ok[:-1] = prep.train[:-1] & prep.train[1:] & next_ok[1:]
    for a in arrays_at_k:
        ok[:-1] &= np.all(np.isfinite(a[:-1].reshape(n - 1, -1)), axis=1)
    return np.flatnonzero(ok)


def _provenance(prep: _Prepared, opts, t0, kind):
    b = prep.building
    bsha = b.sha256 or hashlib.sha256(b.to_toml().encode("utf-8")).hexdigest()
    from .. import __version__

    return {
        "method": "Model A: LOESS de-smoothing + Bayesian constrained least squares (Zhou, Hu, Tomlin, sec. III)",
        "kind": kind,
        "hvacfmu_version": __version__,
        "data_source": str(getattr(prep.dataset, "source", "")),
        "data_sha256": getattr(prep.dataset, "sha256", None),
        "building": b.name,
        "building_sha256": bsha,
        "options": {k: (list(v) if isinstance(v, tuple) else v) for k, v in opts.items()},
        "fit_time": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "fit_seconds": round(time.perf_counter() - t0, 3),
        "train_weeks": prep.train_weeks,
        "solar": prep.solar,
        "timezone": b.timezone,
        "holidays": {
            "source": prep.dataset.holidays.source,
            "country": prep.dataset.holidays.country,
            "in_data": prep.dataset.holidays.in_data,
        },
    }


def _missing_in_season(prep: _Prepared, season: str) -> str:
    """`` (T_x has no value in 100 % of them, ...)``: zone temperatures missing in most training rows of a season."""
    sel = (prep.season == season) & prep.train
    if not sel.any():
        return ""
    share = np.mean(~np.isfinite(prep.T[sel]), axis=0)
    names = [f"T_{z} has no value in {100 * share[j]:.0f} %" for j, z in enumerate(prep.building.zone_names)]
    worst = [names[j] for j in np.argsort(-share) if share[j] >= 0.5]
    return f" ({', '.join(worst)} of them)" if worst else ""


def _gains_by_season(prep: _Prepared, q_rows, rows, nq):
    """Season -> (672, nq) profile from per-row gain estimates; warns about thin seasons."""
    gains, coverage = {}, {}
    seasons_in_data = [s for s in prep.building.season_names if s in prep.train_weeks]
    absent = []
    for s in prep.building.season_names:
        if s not in prep.train_weeks:
            if any(w.season == s for w in prep.dataset.weeks):
                prep.warn(
                    f"season {s}: no training weeks (only test weeks); the model has no internal-gain "
                    f"profile for {s} and cannot predict in it"
                )
            else:
                absent.append(s)
            continue
        sel = (prep.season[rows] == s) & prep.gain_ok[rows]
        prof, cov = estimate_gains(q_rows[sel], prep.slots[rows][sel], prep.n_slots)
        if cov == 0.0:
            prep.warn(
                f"season {s}: no usable rows (missing data) in its training weeks{_missing_in_season(prep, s)}; "
                "no internal-gain profile"
            )
            continue
        if cov < prep.min_cov:
            prep.warn(
                f"season {s}: usable training data cover only {100 * cov:.0f} % of the week's "
                f"{prep.n_slots} time-of-week slots; the rest of its internal-gain profile is interpolated"
            )
        gains[s] = prof
        coverage[s] = cov
    if not gains:
        raise FitError(
            "no season has usable training data for the internal gains "
            f"(seasons with training weeks: {seasons_in_data or 'none'})"
        )
    if absent:
        log.info("the data cover no week of season(s) %s: no internal-gain profile for them", absent)
        coverage.update({s: 0.0 for s in absent})
    return gains, coverage


def _lumped_stage(prep: _Prepared, opts, smooth_cache=None):
    """Smooth, fit without and with priors for the lumped model. Returns a dict of results."""
    w = prep.building.area_weights()
    x = prep.T @ w
    u = prep.floor_drive(x)
    names = ["x_floor", prep.drive_label + "_total"] + list(prep.v_names)
    X = np.column_stack([x, u, prep.V])
    if smooth_cache is not None and all(nm in smooth_cache["names"] for nm in names):
        cols = [smooth_cache["names"].index(nm) for nm in names]
        hat, sinfo = smooth_cache["hat"][:, cols], smooth_cache["info"]
    else:
        hat, sinfo = _smooth_series(prep, names, X, opts)
    D = X - hat
    rows = _regression_rows(prep, D, next_ok=np.isfinite(D[:, 0]))
    if rows.size < int(opts["min_rows"]):
        raise FitError(
            f"only {rows.size} usable 15-minute transitions in the training weeks (need >= {opts['min_rows']}); "
            "too little data (or too many gaps) to identify the model (the floor temperature needs "
            "every zone's temperature at the same time)"
        )
    nv = len(prep.v_names)
    Z, y = D[rows], D[rows + 1, 0]
    lo, hi = prep.drive_bounds
    lb = np.r_[A_EPS, lo, np.zeros(nv)]
    ub = np.r_[1 - A_EPS, hi, np.full(nv, np.inf)]
    free = bayes_cls(Z, y, lb=lb, ub=ub)
    if not free.found:
        raise FitError("the constrained least-squares fit without priors failed (Clarabel found no solution)")
    a0, b0 = free.theta[0], free.theta[1]
    prior_src = {}
    mu_b = _prior_drive(prep, opts, x, u, b0, prior_src)
    mu_a = opts["mu_a"]
    prior_src["mu_a"] = "option"
    if mu_a is None:
        mu_a, prior_src["mu_a"] = a0, "fit without priors"
    sd_a = float(opts["prior_sd_a"])
    sd_b = float(opts["prior_rel_sd_b"]) * max(abs(mu_b), 1e-6)
    mu = np.r_[mu_a, mu_b, np.zeros(nv)]
    sd = np.r_[sd_a, sd_b, np.full(nv, np.inf)]
    post = bayes_cls(Z, y, lb=lb, ub=ub, prior_mean=mu, prior_sd=sd, sigma2=free.rss / max(free.n - free.theta.size, 1))
    if not post.found:
        raise FitError("the Bayesian constrained least-squares fit failed (Clarabel found no solution)")
    return {
        "x": x,
        "u": u,
        "X": X,
        "hat": hat,
        "rows": rows,
        "free": free,
        "post": post,
        "mu_a": float(mu_a),
        "mu_b": float(mu_b),
        "sd_a": sd_a,
        "sd_b": sd_b,
        "prior_src": prior_src,
        "smooth": sinfo,
        "weights": w,
    }


def _prior_drive(prep: _Prepared, opts, x, u, b0, prior_src) -> float:
    """Prior mean of the drive coefficient (b or beta): option, excitation experiments, else the free fit.

    Eq. (excitation_equation) of [1]_: during forced-response experiments
    ``dx = b u`` (airflow form) or ``dx = beta Q`` (delivered heat).
    """
    if opts["mu_b"] is not None:
        prior_src["mu_b"] = "option"
        return float(opts["mu_b"])
    ex = np.flatnonzero(prep.train[:-1] & prep.train[1:] & prep.exc[:-1])
    sign = "positive" if prep.delivered else "negative"
    if ex.size == 0:
        prep.warn(
            "no excitation periods (column 'excitation' == 1) in the training weeks: the prior mean of b "
            "falls back to the constrained least-squares estimate without priors, so the prior adds no "
            "information about the airflow response"
        )
        prior_src["mu_b"] = "fallback: fit without priors (no excitation periods)"
        return float(b0)
    mu_b = excitation_prior_b(x[ex + 1] - x[ex], u[ex])
    if np.isfinite(mu_b) and (mu_b > 0 if prep.delivered else mu_b < 0):
        prior_src["mu_b"] = f"excitation experiments ({ex.size} steps)"
        return float(mu_b)
    prep.warn(
        f"excitation experiments give a non-{sign} or undefined effect of the boxes (b = {mu_b:.4g}); "
        "the prior mean of b falls back to the fit without priors"
    )
    prior_src["mu_b"] = f"fallback: fit without priors (excitation estimate not {sign})"
    return float(b0)


def fit_lumped(dataset, **options):
    """Identify the lumped Model A: the whole floor as one zone.

    x = area-weighted mean zone temperature [°C]; the boxes' drive ``u`` is the
    total airflow [kg/s] (airflow form, v = [T_out, T_supply (°C), I_N, I_E,
    I_S, I_W (W/m², only if the dataset has solar data)]) or the total heat
    their air delivers ``sum_b m_b c_p (T_in,b - x)`` [kW] (delivered-heat
    form, v without T_supply); ``x(k+1) = a x(k) + b u(k) + c^T v(k) + q_IG(k)``.

    Parameters
    ----------
    dataset : hvacfmu.data.Dataset
        Only its training weeks are used.
    heat : {"auto", "airflow", "delivered"}
        Form of the boxes' effect (default "auto": delivered heat when the data
        have discharge air temperatures ``Td_<vav>`` or an air handler is off in
        more than 5 % of the training steps, else the paper's airflow form).
    bandwidths : sequence of float [h]
        LOESS half-width candidates for cross-validation (default 2 .. 12 h;
        extended upwards up to 48 h while the largest one wins; a choice on an
        edge of the grid is warned about).
    bandwidth : float or dict name -> float [h], optional
        Fixed bandwidth(s) instead of cross-validation.
    cv_folds : int
        k of the k-fold cross-validation (default 5).
    cv_block : int
        Held-out block length [steps] of the cross-validation (default 8 = 2 h,
        about the time constant of a zone's air temperature, so the smoother
        cannot interpolate the dynamic response from the neighbouring samples).
    common_bandwidth : bool
        Smooth every series with one bandwidth, the minimiser of the summed
        relative CV curves (default True). The de-smoothed equation (subtract)
        is exact only if ``x``, ``u`` and ``v`` go through the same linear
        smoother: with a different bandwidth for ``x`` than for ``u``, the
        residual contains ``b (S_x u - S_u u)``, which biases the estimates
        (in simulation tests, per-series bandwidths gave b = -0.030 instead of
        the true -0.050, common ones -0.0499). False uses each series' own CV
        bandwidth, as the paper states.
    seed : int
        Seed of the fold assignment.
    prior_sd_a : float
        Prior standard deviation of a (default 0.05).
    prior_rel_sd_b : float
        Prior standard deviation of b relative to ``|mu_b|`` (default 0.5).
    mu_a, mu_b : float, optional
        Prior means; default as in the paper: ``mu_a`` from the fit without
        priors, ``mu_b`` from ``dx = b u`` during excitation experiments.
    use_solar : bool
        Include facade irradiance in v when the dataset has solar data (default True).
    min_rows : int
        Minimum number of usable transitions (default 200).
    min_season_coverage : float
        Warn if a season's usable data cover fewer time-of-week slots (default 0.5).
    plausibility : bool
        Check the fitted model (:mod:`hvacfmu.models.plausibility`) and refuse an
        implausible one (default True).
    open_loop : {"auto", True, False}
        After the paper's one-step fit, re-fit the diagonal of A, the drive
        coefficient(s) and the non-zero entries of C for 24-hour open-loop
        prediction on the training weeks, with the gain profiles re-estimated
        alongside (:mod:`hvacfmu.models.openloop`). On closed-loop data the
        one-step fit identifies the thermostat loop's fast mode; this keeps
        the building's slow one. Default "auto": when the training weeks
        have no excitation periods (closed-loop data only; with excitation
        experiments the airflow form keeps the paper's estimate, it recovers
        the parameters better), and always in the delivered-heat form: there
        the zones are driven by the boxes' reheat loops whatever the airflow
        experiments do (on the emulator's reheat-dual BMS export, 10 weeks,
        seeds 0 and 1, the refinement takes the 24-h RMS of the lumped model
        from 0.178/0.247 to 0.117/0.140 K and of the six-zone model from
        0.135-0.437 to 0.099-0.228 K per zone, below the time-of-week mean in
        every zone). ``meta["open_loop"]`` says whether and why, with the one-step
        values and the training errors before and after.
    open_loop_couplings : bool
        Six-zone model only: the open-loop refinement also re-fits the couplings of adjacent zones
        (the off-diagonal entries of A; the one-step fit learns them from the thermostat loop), keeping
        every row of A non-negative with sum below one. Default False. Measured (session 8, zones
        model, 24-h RMS on the held-out weeks of a year of EnergyPlus data): it lowers the perimeter
        zones' errors by up to 40 % (medium office 0.46-0.60 -> 0.30-0.53 K, stand-alone retail
        Back_Space 0.49 -> 0.30 K; small office Core_ZN in winter 0.65 -> 0.37 K, persistence 0.37 K)
        but raises the core zones' in summer (medium office 0.17 -> 0.21 K, Chicago 0.28 -> 0.33 K,
        against time-of-week means of 0.21 and 0.26 K), and is neutral on the emulator's reheat exports;
        so it is not the default.
    progress : bool
        Accepted for the CLI; the fit is fast and shows no bar.

    Returns
    -------
    LinearZoneModel
        ``kind="lumped"``, outputs ``("floor",)``; ``meta`` holds provenance,
        bandwidths, CV curves, priors, coefficient uncertainties and the heat form.

    Raises
    ------
    FitError
        Too little data, constant temperatures, no season with usable data, or
        an implausible fitted model.

    References
    ----------
    .. [1] Zhou, Hu, Tomlin, section III-A.
    """
    t0 = time.perf_counter()
    opts = _options(options)
    prep = _Prepared(dataset, opts)
    b = prep.building
    problems = prep.check_constant(b.zone_names, prep.T, "zone temperature")
    if problems:
        raise FitError(problems_message("Cannot fit the lumped model", problems))
    if np.ptp(np.nan_to_num(prep.m[prep.train].sum(axis=1))) < 1e-9:
        prep.warn("the total airflow is constant over the training weeks: b is determined by its prior only")
    st = _lumped_stage(prep, opts)
    theta = st["post"].theta
    a, bb, c = theta[0], theta[1], theta[2:]
    hat = st["hat"]
    rows = _regression_rows(prep, hat, next_ok=np.isfinite(hat[:, 0]))
    qr = hat[rows + 1, 0] - (a * hat[rows, 0] + bb * hat[rows, 1] + hat[rows, 2:] @ c)
    gains, coverage = _gains_by_season(prep, qr[:, None], rows, 1)
    sd = np.sqrt(np.maximum(np.diag(st["post"].cov), 0.0))
    names = ["a", "b"] + [f"c[{v}]" for v in prep.v_names]
    meta = _provenance(prep, opts, t0, "lumped")
    meta.update(
        {
            "smoothing": st["smooth"],
            "priors": {
                "mu_a": st["mu_a"],
                "sd_a": st["sd_a"],
                "mu_b": st["mu_b"],
                "sd_b": st["sd_b"],
                "source": st["prior_src"],
            },
            "fit_without_priors": dict(zip(names, st["free"].theta.tolist())),
            "coef": dict(zip(names, theta.tolist())),
            "coef_sd": dict(zip(names, sd.tolist())),
            "coef_sd_note": "posterior sd of the unconstrained Gaussian problem; ignores residual autocorrelation",
            "residual_sd": float(np.sqrt(st["post"].sigma2)),
            "n_transitions": int(st["rows"].size),
            "gain_coverage": coverage,
        }
    )
    return _finish(
        prep,
        opts,
        "lumped",
        np.array([[a]]),
        np.array([bb]),
        c.reshape(1, -1),
        gains,
        meta,
        weights=st["weights"][None, :],
    )


def fit_zones(dataset, **options):
    """Identify the six-zone (multi-zone) Model A.

    x, u in R^nz: zone temperatures [°C] and what each zone's boxes do — their
    summed airflow [kg/s] (airflow form) or the heat their air delivers
    ``sum_b m_b c_p (T_in,b - x_i)`` [kW] (delivered-heat form, see
    :func:`fit_lumped` option ``heat``); ``x(k+1) = A x(k) + B u(k) + C v(k) + q_IG(k)`` with

    - ``A`` sparse by adjacency (diagonal + ``building.adjacency_pairs()``),
      elementwise non-negative with row sums ``<= 1 - stability_margin`` and
      every coupling at most the zone's own coefficient (``a_ij <= a_ii``: over a
      step shorter than the zone's time constant ``A ≈ I − Δt C⁻¹K`` has
      ``a_ij = Δt k_ij / C_i`` below ``a_ii``; without it, one-step least squares
      may put a zone's memory on a mirror-twin neighbour whose temperature is
      nearly collinear with its own, ``a_ii = 0``, giving negative eigenvalues). A
      non-negative matrix with all row sums below one has
      ``rho(A) <= ||A||_inf < 1``, so every identified model is stable; the
      sign follows from Newton's law of cooling (a warmer neighbour warms the
      zone), and the row-sum bound is the discrete form of the zone losing heat
      to its surroundings.
    - ``B`` diagonal, ``<= 0`` for airflow (``beta >= 0`` for delivered heat).
    - ``C >= 0``, sparse: T_out (and T_supply in the airflow form) for every
      zone, plus the irradiance of the orientations of each zone's exterior facades.

    Priors as in the paper (sec. III-B): the lumped priors scaled by thermal
    mass — ``mu_B,ii = mu_b / s_i`` with ``s_i`` the zone's volume share (the
    same airflow cools a smaller air mass faster), ``mu_A,ii = mu_a`` (losses
    and capacity both scale with zone size, so the decay per step is unchanged
    to first order), off-diagonal means ``mu_a_offdiag`` (near zero).

    Parameters
    ----------
    dataset : hvacfmu.data.Dataset
    prior_sd_a_offdiag : float
        Prior standard deviation of the off-diagonal entries of A (default 0.02).
    mu_a_offdiag : float
        Prior mean of the off-diagonal entries of A (default 0.005).
    stability_margin : float
        Row sums of A are at most ``1 - stability_margin`` (default 1e-3).
    **options
        As for :func:`fit_lumped` (``prior_sd_a`` and ``prior_rel_sd_b`` apply to
        the diagonals of A and B).

    Returns
    -------
    LinearZoneModel
        ``kind="zones"``.

    References
    ----------
    .. [1] Zhou, Hu, Tomlin, section III-B.
    """
    t0 = time.perf_counter()
    opts = _options(options)
    prep = _Prepared(dataset, opts)
    U = _zone_drive_checked(prep)
    hat, sinfo, D, cache = _zone_smooth(prep, U, opts)
    layout = _zone_layout(prep, D, opts)
    lump = _lumped_stage(prep, opts, smooth_cache=cache)
    fits = [_fit_one_zone(prep, opts, D, layout[i], lump, i) for i in range(len(layout))]
    A, drive, C, coef_sd = _zone_coefficients(prep, layout, fits)
    nz, nv = A.shape[0], C.shape[1]
    Xh, Uh, Vh = hat[:, :nz], hat[:, nz : 2 * nz], hat[:, 2 * nz : 2 * nz + nv]
    rows = _regression_rows(prep, Xh, Uh, Vh, next_ok=np.all(np.isfinite(Xh), axis=1))
    qr = Xh[rows + 1] - (Xh[rows] @ A.T + Uh[rows] * drive + Vh[rows] @ C.T)
    gains, coverage = _gains_by_season(prep, qr, rows, nz)
    zn = prep.building.zone_names
    meta = _provenance(prep, opts, t0, "zones")
    meta.update(
        {
            "smoothing": sinfo,
            "priors": {
                "lumped": {
                    "mu_a": lump["mu_a"],
                    "mu_b": lump["mu_b"],
                    "sd_a": lump["sd_a"],
                    "sd_b": lump["sd_b"],
                    "source": lump["prior_src"],
                },
                "zones": {z: f["prior"] for z, f in zip(zn, fits)},
            },
            "fit_without_priors": {z: f["free"].theta.tolist() for z, f in zip(zn, fits)},
            "coef_sd": coef_sd,
            "coef_sd_note": "posterior sd of the unconstrained Gaussian problem; ignores residual autocorrelation",
            "residual_sd": {z: float(np.sqrt(f["post"].sigma2)) for z, f in zip(zn, fits)},
            "spectral_radius_A": float(np.max(np.abs(np.linalg.eigvals(A)))),
            "n_transitions": {z: int(lay["rows"].size) for z, lay in zip(zn, layout)},
            "gain_coverage": coverage,
        }
    )
    return _finish(prep, opts, "zones", A, drive, C, gains, meta, weights=np.eye(nz))


def _zone_drive_checked(prep: _Prepared):
    """Each zone's drive (n, nz); FitError for constant zone temperatures, warnings for constant drives."""
    zn = prep.building.zone_names
    problems = prep.check_constant(zn, prep.T, "zone temperature")
    if problems:
        raise FitError(problems_message("Cannot fit the zone model", problems))
    U = prep.zone_drive()
    for j, z in enumerate(zn):
        uz = U[prep.train, j]
        uz = uz[np.isfinite(uz)]
        if uz.size and np.ptp(uz) < 1e-9:
            what = "delivered heat" if prep.delivered else "airflow"
            prep.warn(f"zone {z}: its {what} is constant over the training weeks; B[{z}] is set by its prior only")
    return U


def _zone_smooth(prep: _Prepared, U, opts):
    """Smooth every zone series and the lumped series (for the priors) once; returns hat, info, D, cache."""
    b = prep.building
    zn = b.zone_names
    x_floor = prep.T @ b.area_weights()
    d = prep.drive_label
    names = [f"T_{z}" for z in zn] + [f"{d}_{z}" for z in zn] + list(prep.v_names) + ["x_floor", f"{d}_total"]
    X = np.column_stack([prep.T, U, prep.V, x_floor, prep.floor_drive(x_floor)])
    hat, sinfo = _smooth_series(prep, names, X, opts)
    return hat, sinfo, X - hat, {"names": names, "hat": hat, "info": sinfo}


def _zone_layout(prep: _Prepared, D, opts):
    """Per zone: state columns (itself + neighbours), disturbance columns, regressors, usable rows."""
    b = prep.building
    zn = b.zone_names
    nz = len(zn)
    adj = {z: set() for z in zn}
    for p, q in b.adjacency_pairs():
        adj[p].add(q)
        adj[q].add(p)
    n_temps = 1 if prep.delivered else 2
    layout, problems = [], []
    for i, z in enumerate(zn):
        nbrs = [j for j, other in enumerate(zn) if other in adj[z]]
        vcols = list(range(n_temps)) + [
            k for k, vn in enumerate(prep.v_names) if k >= n_temps and vn[2:] in b.zones[i].orientations
        ]
        xcols = [i] + nbrs
        Z = np.column_stack([D[:, xcols], D[:, nz + i], D[:, 2 * nz + np.array(vcols, int)]])
        rows = _regression_rows(prep, Z, next_ok=np.isfinite(D[:, i]))
        if rows.size < int(opts["min_rows"]):
            problems.append(
                f"zone {z}: only {rows.size} usable transitions in the training weeks (need >= {opts['min_rows']}); "
                "too little data (or too many gaps) to identify its dynamics"
            )
        layout.append({"xcols": xcols, "vcols": vcols, "Z": Z, "rows": rows})
    if problems:
        raise FitError(problems_message("Cannot fit the zone model", problems))
    return layout


def _fit_one_zone(prep: _Prepared, opts, D, lay, lump, i):
    """Constrained LS without priors, then the Bayesian fit of zone ``i``'s row of A, B, C."""
    z = prep.building.zone_names[i]
    xcols, vcols, rows = lay["xcols"], lay["vcols"], lay["rows"]
    Zi, yi = lay["Z"][rows], D[rows + 1, i]
    p, na = Zi.shape[1], len(xcols)
    lo, hi = prep.drive_bounds
    lb = np.r_[A_EPS, np.zeros(na - 1), lo, np.zeros(len(vcols))]
    ub = np.r_[1 - A_EPS, np.ones(na - 1), hi, np.full(len(vcols), np.inf)]
    # row sum below one (stability), and every coupling at most the zone's own coefficient (a_ij <= a_ii: a
    # zone's memory is its own, see hvacfmu.diagnosis.design.dominance_pairs for the RC-physics reason)
    G = np.zeros((na, p))
    G[0, :na] = 1.0
    G[np.arange(1, na), np.arange(1, na)] = 1.0
    G[1:, 0] = -1.0
    h = np.r_[1.0 - float(opts["stability_margin"]), np.zeros(na - 1)]
    free = bayes_cls(Zi, yi, lb=lb, ub=ub, G=G, h=h)
    if not free.found:
        raise FitError(f"zone {z}: the constrained least-squares fit without priors failed (Clarabel)")
    vols = np.array([zz.volume for zz in prep.building.zones], float)
    share = vols[i] / vols.sum()
    sd_a, sd_off, mu_off = (float(opts[k]) for k in ("prior_sd_a", "prior_sd_a_offdiag", "mu_a_offdiag"))
    mu_bi = lump["mu_b"] / share
    sd_bi = float(opts["prior_rel_sd_b"]) * max(abs(mu_bi), 1e-6)
    mu = np.r_[lump["mu_a"], np.full(na - 1, mu_off), mu_bi, np.zeros(len(vcols))]
    sd = np.r_[sd_a, np.full(na - 1, sd_off), sd_bi, np.full(len(vcols), np.inf)]
    post = bayes_cls(Zi, yi, lb=lb, ub=ub, G=G, h=h, prior_mean=mu, prior_sd=sd, sigma2=free.rss / max(free.n - p, 1))
    if not post.found:
        raise FitError(f"zone {z}: the Bayesian constrained least-squares fit failed (Clarabel)")
    prior = {
        "mu_A_diag": lump["mu_a"],
        "sd_A_diag": sd_a,
        "mu_A_offdiag": mu_off,
        "sd_A_offdiag": sd_off,
        "mu_B": mu_bi,
        "sd_B": sd_bi,
        "volume_share": share,
    }
    return {"free": free, "post": post, "prior": prior}


def _zone_coefficients(prep: _Prepared, layout, fits):
    """A (nz, nz), drive coefficients (nz,), C (nz, nv) and their posterior sd from the per-zone fits."""
    nz, nv = len(layout), len(prep.v_names)
    A, A_sd = np.zeros((nz, nz)), np.zeros((nz, nz))
    drive, drive_sd = np.zeros(nz), np.zeros(nz)
    C, C_sd = np.zeros((nz, nv)), np.zeros((nz, nv))
    for i, (lay, f) in enumerate(zip(layout, fits)):
        th, sdv = f["post"].theta, np.sqrt(np.maximum(np.diag(f["post"].cov), 0.0))
        na = len(lay["xcols"])
        A[i, lay["xcols"]], A_sd[i, lay["xcols"]] = th[:na], sdv[:na]
        drive[i], drive_sd[i] = th[na], sdv[na]
        C[i, lay["vcols"]], C_sd[i, lay["vcols"]] = th[na + 1 :], sdv[na + 1 :]
    key = "beta" if prep.delivered else "B"
    return A, drive, C, {"A": A_sd, key: drive_sd if prep.delivered else np.diag(drive_sd), "C": C_sd}


def _finish(prep: _Prepared, opts, kind, A, drive, C, gains, meta, weights):
    """The LinearZoneModel of either form, checked for plausibility (option ``plausibility``)."""
    from .linear import LinearZoneModel
    from .plausibility import check_fitted

    b = prep.building
    nx = A.shape[0]
    heat_map = np.ones((1, len(b.vavs))) if kind == "lumped" else b.zone_vav_matrix()
    meta["heat"] = prep.heat_form
    meta["warnings"] = prep.warnings
    common = {
        "kind": kind,
        "step": prep.step,
        "outputs": ("floor",) if kind == "lumped" else b.zone_names,
        "measured_zones": b.zone_names,
        "output_weights": weights,
        "vavs": b.vav_names,
        "A": A,
        "gains": gains,
        "holidays": prep.dataset.holidays.dates,
    }
    if not prep.delivered:
        model = LinearZoneModel(
            input_map=heat_map, disturbances=prep.v_names, B=np.diag(drive), C=C, meta=_jsonable(meta), **common
        )
    else:
        extra = tuple(dict.fromkeys(c for c in prep.inlets if c not in prep.v_names))
        C = np.concatenate([C, np.zeros((nx, len(extra)))], axis=1)
        model = LinearZoneModel(
            input_map=np.eye(len(b.vavs)),
            disturbances=prep.v_names + extra,
            B=np.zeros((nx, len(b.vavs))),
            C=C,
            beta=drive,
            inlets=prep.inlets,
            heat_map=heat_map,
            meta=_jsonable(meta),
            **common,
        )
    model = _refined(prep, opts, model)
    model = _memory_kept(prep, opts, model)
    if opts["plausibility"]:
        model = check_fitted(model, prep.dataset, warn=prep.warn)
    return model


def _refined(prep: _Prepared, opts, model):
    """The model re-fitted for 24-h open-loop prediction (option ``open_loop``, :mod:`.openloop`); meta records it."""
    import dataclasses

    from .openloop import refine_open_loop

    form = opts["open_loop"]
    excited = bool(np.any(prep.exc & prep.train))
    delivered = getattr(model, "heat", "airflow") == "delivered"
    if form is False or (form == "auto" and excited and not delivered):
        why = "option open_loop=False" if form is False else "excitation periods in the training weeks"
        return dataclasses.replace(model, meta=_jsonable({**model.meta, "open_loop": {"used": False, "reason": why}}))
    t0 = time.perf_counter()
    couplings = opts["open_loop_couplings"] and model.kind == "zones"  # a bool (checked by _options)
    new, info = refine_open_loop(model, prep, couplings=couplings, max_nfev=100 if couplings else 60)
    info["couplings"] = couplings
    info["seconds"] = round(time.perf_counter() - t0, 3)  # not in fit_seconds, which times the one-step fit
    info["why"] = (
        "option open_loop=True"
        if form is True
        else "closed-loop data: no excitation periods"
        if not excited
        else "delivered heat: the boxes' reheat loops drive the zones (closed loop) also in the weeks "
        "with airflow experiments"
    )
    info["one_step"] = {
        "A_diag": np.diag(model.A),
        "drive": model.beta if model.beta is not None else np.diag(model.B),
        "C": model.C,
    }
    return dataclasses.replace(new, meta=_jsonable({**model.meta, "open_loop": info}))


def _memory_kept(prep: _Prepared, opts, model):
    """The model, or its within one-step refit when it keeps no memory and that predicts left-out weeks better
    (option ``memory``, :mod:`.memory`); ``meta["memory"]`` records it."""
    from .memory import keep_memory

    t0 = time.perf_counter()
    new, info = keep_memory(model, prep, opts)
    info["seconds"] = round(time.perf_counter() - t0, 3)
    return dataclasses.replace(new, meta=_jsonable({**model.meta, "memory": info}))


__all__ = [
    "BayesClsResult",
    "CvResult",
    "bayes_cls",
    "cv_bandwidth",
    "estimate_gains",
    "excitation_prior_b",
    "fit_lumped",
    "fit_zones",
    "loess_smooth",
    "tricube",
]
