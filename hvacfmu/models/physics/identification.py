"""Identification of Model B (section IV.B of Zhou, Hu & Tomlin).

Step 1 (weekend training data, ``f_IG^v = 0``): the five physical parameters
``U_win, gamma_IW, gamma_EW, gamma_floor, gamma_ceil`` and the constant gains
``f_IG^c`` (one per zone) minimise the summed squared simulation error of the
zone temperatures over weekend-day segments of every season (eq. physics_opt).
Each segment starts from an estimate of the full state (walls are not
measured): a filter over the preceding warm-up window (by default the
gain-injection limit of the Kalman filter, see ``segment_observer``), plus the
amplitudes of the few slowest modes fitted on the segment itself (a
deterministic smoother of the part of the state a one-day warm-up cannot
see; without it the slow-mode errors bias the parameters). Positivity: the
physical parameters are optimised in logarithms, ``f_IG^c >= 0`` by
non-negative least squares. Because the simulated output is affine in
``f_IG^c`` (for given parameters), ``f_IG^c`` is eliminated by variable
projection: every residual evaluation simulates the segments once per zone
plus once, as one batch, and solves a small NNLS problem; ``least_squares``
then works on the five log-parameters only.

Step 2: ``f_IG,m,w^v(k)`` by ordinary least squares from
``(C B_IG) f = y(k+1) - y~(k+1)`` with ``y~`` the one-step prediction
(eq. ig(k-1)) for every training week, averaged per season and time of week
(eq. fixed_ig). The state ``x(k)`` carried from step to step is the prediction
plus the estimated gains' effect, ``x~(k) + B_IG f(k-1)``, which puts the zone
air at the measured temperatures and lets the walls follow physically. With
``gain_days="workdays"`` Monday to Friday share one daily profile (the mean of
every training workday of the season), Saturday and Sunday keep their own;
with ``"shrunk"`` each workday's profile is shrunk toward that Monday-Friday
profile by a random-effects weight from the training weeks' scatter
(``"week"`` is the paper's profile per time of week); with ``"auto"``, the
default since session 8, the one of the three with the lowest 24-h open-loop
RMS in blocked cross-validation over the training weeks (module :mod:`.gaincv`).

Uncertainty: the covariance ``s^2 (J^T J)^{-1}`` of all parameters from the
Jacobian at the optimum, with the residual variance inflated by
``(1 + rho) / (1 - rho)`` for the lag-1 autocorrelation ``rho`` of the
residuals (simulation errors are strongly autocorrelated; without it the
standard errors are far too small). A parameter is flagged as not
identifiable when its relative standard deviation exceeds 100 %, when it
loads on a near-singular direction of the scaled Jacobian, or when it ends at
a bound.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
import warnings

import numpy as np
import pandas as pd
import scipy.optimize as so

from ...calendars import holiday_slots
from ...errors import FitError, HvacfmuWarning
from ...progress import Progress
from ...threads import one_blas_thread
from ...timeutil import n_time_of_week, time_of_week
from ..heat import inlet_columns
from ..plausibility import check_physics
from .geometry import PARAM_NAMES, parse_physics
from .model import PhysicsModel, fill_signals, kalman_gain

log = logging.getLogger(__name__)


class _Segments:
    """Weekend-day segments with their warm-up windows, as arrays.

    y (B, nw+ns+1, nz), u (B, nw+ns, n_vav), v (B, nw+ns, nv), q0 (B, nw+ns, nq)
    (zero gains, ground temperature column if any); rows ``nw+1 ..`` are fitted.
    """

    def __init__(self, y, u, v, q0, nw, seasons, starts):
        self.y, self.u, self.v, self.q0 = y, u, v, q0
        self.nw = nw
        self.seasons = seasons
        self.starts = starts
        self.mask = np.isfinite(y[:, nw + 1 :])

    @property
    def n(self):
        return self.y.shape[0]


def _row_of(index: pd.DatetimeIndex, ts, step) -> int | None:
    """Row of timestamp ``ts`` in a regular ``index`` (None if absent)."""
    i = int(index.searchsorted(ts))
    if i < len(index) and index[i] == ts:
        return i
    return None


def _regular(index, r0, n, step) -> bool:
    return r0 >= 0 and r0 + n < len(index) and (index[r0 + n] - index[r0]).total_seconds() == n * step


def _weekend_segments(dataset, model, nw, ns, max_segments):
    frame = dataset.frame
    index = frame.index
    step = dataset.step
    y_all = model.measured_outputs(frame)
    u_all, v_all = model.signals(frame)
    nz = len(model.outputs)
    starts, seasons = [], []
    names = [*model.inputs, *model.disturbances]
    broken = np.zeros(len(names), dtype=int)  # weekend days each input column breaks (a gap in the segment)
    n_days = 0
    for week in dataset.weeks:
        if not week.train:
            continue
        for day in range(7):
            t0 = pd.Timestamp(week.start) + pd.DateOffset(days=day)  # calendar days (DST-safe)
            if t0.day_of_week < 5:
                continue
            r = _row_of(index, t0, step)
            if r is None or not _regular(index, r - nw, nw + ns, step):
                continue
            seg = slice(r, r + ns)
            n_days += 1
            gaps = np.concatenate([np.isnan(u_all[seg]).any(axis=0), np.isnan(v_all[seg]).any(axis=0)])
            if gaps.any():
                broken += gaps
                continue
            if np.isfinite(y_all[r + 1 : r + ns + 1]).mean() < 0.5 or np.isnan(y_all[r]).all():
                continue
            starts.append(r)
            seasons.append(week.season)
    if not starts:
        worst = [(names[j], int(broken[j])) for j in np.argsort(-broken, kind="stable") if broken[j]][:5]
        culprits = (
            "; the input columns with a gap in most of the "
            f"{n_days} weekend days: " + ", ".join(f"{c} ({n})" for c, n in worst) + ": fill their short gaps "
            "(--interpolate-gaps MINUTES), fix the export, or fit a model that needs no whole days (zones, lumped)"
            if worst
            else ""
        )
        raise FitError(
            "no usable weekend segment in the training weeks (need complete airflows and disturbances over "
            f"{ns} steps after a {nw}-step warm-up on Saturdays/Sundays){culprits}"
        )
    starts = np.asarray(starts)
    seasons = np.asarray(seasons)
    if max_segments and len(starts) > max_segments:
        keep = np.unique(np.round(np.linspace(0, len(starts) - 1, int(max_segments))).astype(int))
        starts, seasons = starts[keep], seasons[keep]
    rows = starts[:, None] + np.arange(-nw, ns + 1)[None, :]
    y = y_all[rows]
    u = u_all[rows[:, :-1]]
    v = v_all[rows[:, :-1]]
    for b in range(len(starts)):
        u[b] = fill_signals(u[b], 0.0)
        v[b] = fill_signals(v[b], np.nanmean(y[b]))
    q0 = np.zeros(u.shape[:2] + (len(model.q_names),))
    if len(model.q_names) > nz:
        q0[..., nz] = model._spec.ground_temperature
    return _Segments(y, u, v, q0, nw, seasons, starts)


def _simulate_segments(template, theta, step, segs, K, free_modes=0):
    """Outputs of every segment for zero gains, for 1 W in each zone and for unit slow modes.

    Returns ``Y0`` (B, ns, nz), ``S`` (nz, B, ns, nz) [K/W] and ``Phi``
    (k, B, ns, nz) [K/K] such that the simulated outputs for constant gains
    ``f`` and initial-state corrections ``delta`` (B, k) along the ``k``
    slowest modes are ``Y0 + sum_j f_j S[j] + sum_i delta[:, i] Phi[i]``.
    """
    net = template.build(np.exp(theta))
    disc = net.discretize(step)
    nz = template.n_zones
    nw = segs.nw
    with np.errstate(all="ignore"):
        ymean = np.nanmean(segs.y[:, : nw + 1], axis=1)
    ymean = np.where(np.isnan(ymean), np.nanmean(ymean), ymean)
    T_out = segs.v[:, :nw, 0].mean(axis=1) if nw else segs.v[:, 0, 0]
    x0 = net.wall_steady_state(ymean, T_out, segs.q0[:, 0])
    y0 = segs.y[:, 0]
    x0[:, :nz] = np.where(np.isnan(y0), ymean, y0)
    z0 = x0 @ disc.W.T
    # copies: 0 = no zone gains, j = 1 W in zone j-1
    ncopy = nz + 1
    qc = np.zeros((ncopy, 1, 1, segs.q0.shape[-1]))
    qc[np.arange(1, ncopy), 0, 0, np.arange(nz)] = 1.0
    q = segs.q0[None] + qc
    m = segs.u @ disc.zone_vav.T
    mt = disc.inlet_flux(segs.u, segs.v)
    if isinstance(K, str) and K == "gain_injection":
        Kz = disc.Pq[:, :nz] @ np.linalg.inv(disc.Vz @ disc.Pq[:, :nz])
    else:
        Kz = disc.W @ K
    Y, *_ = disc.run(z0[None], m[None], segs.v[None], q, y=segs.y[None], Kz=Kz, n_correct=nw + 1, mt=mt[None])
    Yf = Y[:, :, nw + 1 :]
    Phi = None
    if free_modes:
        # free response of the (airflow-dependent) homogeneous system to each slow mode, from the segment start
        lam = net.modal[0]
        slow = np.argsort(-lam)[: int(free_modes)]
        scale = 1.0 / np.abs(disc.V[:, slow]).max(axis=0)  # 1 K peak temperature per mode
        zf = np.zeros((len(slow), 1, disc.n_states))
        zf[np.arange(len(slow)), 0, slow] = scale
        ms = m[None, :, nw:]
        vs = np.zeros((1, 1) + segs.v.shape[1:])[:, :, nw:]
        qs = np.zeros((1, 1, ms.shape[2], segs.q0.shape[-1]))
        Yh, *_ = disc.run(zf, ms, vs, qs)
        Phi = Yh[:, :, 1:]
    return Yf[0], Yf[1:] - Yf[0][None], Phi


class _LinearPart:
    """Linear parameters of step 1 for fixed physical parameters.

    Constant gains ``f >= 0`` shared by all segments (NNLS) and, per segment,
    free amplitudes of the slowest modes of the initial state (eliminated by
    projection, i.e. a deterministic smoother of the initial state's slow
    part on the segment's own data).
    """

    def __init__(self, Y0, S, Phi, segs):
        self.segs = segs
        mask = segs.mask
        target = segs.y[:, segs.nw + 1 :] - Y0
        self.bases = []
        t_parts, a_parts = [], []
        for b in range(segs.n):
            mb = mask[b]
            t = target[b][mb]
            A = S[:, b][:, mb].T
            if Phi is not None and t.size > Phi.shape[0]:
                Q, _ = np.linalg.qr(Phi[:, b][:, mb].T)
                t = t - Q @ (Q.T @ t)
                A = A - Q @ (Q.T @ A)
                self.bases.append(Q)
            else:
                self.bases.append(None)
            t_parts.append(t)
            a_parts.append(A)
        self.t = np.concatenate(t_parts)
        self.A = np.concatenate(a_parts)
        self.n_free = 0 if Phi is None else Phi.shape[0] * segs.n

    def solve(self):
        """``f`` (nz,) [W] and the projected residual vector."""
        Qm, R = np.linalg.qr(self.A)
        f, _ = so.nnls(R, Qm.T @ self.t)
        return f, self.residual(f)

    def residual(self, f):
        return self.A @ f - self.t


def _solve_gains(Y0, S, Phi, segs):
    """NNLS estimate of the constant gains f (nz,) [W] and the (projected) residuals."""
    return _LinearPart(Y0, S, Phi, segs).solve()


def _lag1(res_blocks):
    """Pooled lag-1 autocorrelation of residual series (B, n, nz) with NaN gaps."""
    r = res_blocks
    a, b = r[:, 1:], r[:, :-1]
    ok = np.isfinite(a) & np.isfinite(b)
    den = np.sum(np.where(np.isfinite(r), r, 0.0) ** 2)
    if den == 0:
        return 0.0
    return float(np.clip(np.sum(np.where(ok, a * b, 0.0)) / den, 0.0, 0.99))


def fit_physics(
    dataset,
    *,
    progress: bool = True,
    solar: bool | None = None,
    max_layer_thickness: float | None = None,
    furniture_capacity: float | None = None,
    internal_mass: float | None = None,
    segment_hours: float = 24.0,
    warmup_hours: float = 48.0,
    max_segments: int | None = 24,
    kalman: dict | None = None,
    kalman_rounds: int = 1,
    bound_factor: float = 30.0,
    max_nfev: int = 15,
    initial: dict | None = None,
    free_modes: int = 3,
    segment_observer: str = "gain_injection",
    gain_days: str | None = None,
) -> PhysicsModel:
    """Identify Model B on ``dataset``'s training weeks (two steps, see the module docstring).

    Parameters
    ----------
    dataset : hvacfmu.data.Dataset
        Its building must carry the physics tables.
    progress : bool
        Show a progress bar over residual evaluations.
    solar : bool or None
        Model solar gains through the windows (needs facade irradiance in the
        data). None (default): when the dataset has facade irradiance. (The
        paper left solar gains out as negligible for SDH; the emulated floor's
        are not.)
    max_layer_thickness : float [m], optional
        Node splitting of massive layers (default: building file, else 0.025 m).
    furniture_capacity, internal_mass : float [J/(K m2)], optional
        Override the building file's values.
    segment_hours, warmup_hours : float [h]
        Length of each simulated weekend segment and of the Kalman warm-up before it.
    max_segments : int or None
        Use at most this many weekend segments (evenly spread over the
        training weeks, so every season keeps its share); None: all.
    kalman : dict, optional
        State-estimator settings (see :attr:`PhysicsModel.kalman_gain`):
        ``observer`` ("gain_injection" or "kalman"), ``q_air``, ``q_mass``,
        ``r`` [K], ``warmup_steps`` (default from ``warmup_hours``).
    kalman_rounds : int
        Times the optimisation is repeated with the filter gain recomputed
        at the current estimate (1: gain of the nominal model only).
    bound_factor : float
        Physical parameters are kept within nominal / factor .. nominal * factor.
    max_nfev : int
        Maximum iterations (residual evaluations not counting the
        finite-difference Jacobian) per round of ``least_squares``.
    initial : dict, optional
        Initial parameter values (default: the building file's ``[physics].nominal``).
    segment_observer : {"gain_injection", "kalman"}
        State estimator over each segment's warm-up in step 1. Default: the
        gain-injection limit of the Kalman filter (see
        :attr:`PhysicsModel.kalman_gain`). Step 1 has no time-varying gains
        yet, and the warm-up (Friday) holds occupancy gains; a Kalman filter
        with wall process noise lets the walls absorb them, which biased
        ``f_IG^c`` by +40-60 % on synthetic data, while gain injection charges
        them to the zones' gains as the model structure says. (The fitted
        model's ``initial_state`` uses its own ``kalman.observer``.)
    free_modes : int
        Number of slowest modes of each segment's initial state estimated from
        the segment itself on top of the Kalman filter's estimate (0: filter only).
        The slow wall modes are barely observable over a warm-up of a day; left
        to the filter, their errors bias the parameters.
    gain_days : {"week", "workdays", "shrunk", "auto"} or None
        Day types of step 2's seasonal gain profile; None (default): the
        building file's ``[physics].gain_days``, else ``"auto"``. ``"week"``: the
        paper's profile per time of week (eq. fixed_ig), each slot the mean of
        the few training weeks of the season, so one unusual day (a holiday, a
        change of occupancy level) weighs a third of its weekday with three
        training weeks, and a weekday's own pattern (Monday's recovery from
        the weekend) is kept. ``"workdays"``: Monday to Friday share one daily
        profile [W] averaged over every training workday of the season,
        Saturday and Sunday have their own. ``"shrunk"``: each workday's own
        profile shrunk toward that Monday-Friday profile, by a weight per
        weekday and zone from the training weeks' scatter (a random-effects
        estimate, see :func:`_shrunk_workdays`): a weekday that differs
        consistently keeps its pattern, one unusual day is pooled. Measured
        (README "Where physics loses"): both options beat the time-of-week
        mean in every zone of the BMS exports where ``"week"`` loses in two,
        but both lose a zone-season cell of the 16-week reheat data (fall E,
        -3.3 % and -2.2 %: one test week whose random day levels sat near the
        training Wednesdays' and Fridays' means), so neither is the default.
        ``"auto"``: the one of the three with the lowest 24-h open-loop RMS in
        blocked cross-validation over the training weeks (whole weeks held out,
        test weeks never used; :func:`.gaincv.choose_gain_days`, about a second),
        recorded in ``meta["gains"]["auto"]`` (``chosen``, ``cv_rms``, ...). It
        chose ``"workdays"`` or ``"shrunk"`` on every emulated data set of
        ``benchmarks/bench_gain_days.py`` and so loses the same reheat cell, but
        the pooled profiles had the lower RMS in 10 of 10 seven-week winter
        exports never used before (``benchmarks/short_winter_s8.md``): the
        default since session 8 (README, Model B).

    Returns
    -------
    PhysicsModel
        With ``meta["estimates"]`` (value, std, relative std, flags per
        parameter) and ``meta["unidentifiable"]``.

    References
    ----------
    D. Zhou, Q. Hu, C. J. Tomlin, "Model comparison of a data-driven and a
    physical model for simulating HVAC systems", eqs. (physics_opt),
    (ig(k-1)), (fixed_ig).
    """
    with one_blas_thread():
        return _fit_physics(
            dataset,
            progress=progress,
            solar=solar,
            max_layer_thickness=max_layer_thickness,
            furniture_capacity=furniture_capacity,
            internal_mass=internal_mass,
            segment_hours=segment_hours,
            warmup_hours=warmup_hours,
            max_segments=max_segments,
            kalman=kalman,
            kalman_rounds=kalman_rounds,
            bound_factor=bound_factor,
            max_nfev=max_nfev,
            initial=initial,
            free_modes=free_modes,
            segment_observer=segment_observer,
            gain_days=gain_days,
        )


def refit_gains(model: PhysicsModel, dataset, gain_days: str) -> PhysicsModel:
    """``model`` with step 2 (the seasonal gain profile) redone on ``dataset`` with other day types.

    Step 1's parameters and constant gains ``f_IG^c`` are kept, so the result is what
    :func:`fit_physics` gives with ``gain_days`` on the same data (step 1 does not depend on it),
    in seconds instead of a refit.

    Parameters
    ----------
    model : PhysicsModel
        A model fitted by :func:`fit_physics` (it carries ``f_IG^c`` and the filter warm-up).
    dataset : hvacfmu.data.Dataset
        The data it was fitted on (its training weeks give the profile).
    gain_days : {"week", "workdays", "shrunk", "auto"}
        See :func:`fit_physics` (``"auto"``: the cross-validated choice, step 1 kept).

    Returns
    -------
    PhysicsModel
        With the new ``gains`` [W], ``meta["gains"]``, ``meta["fit_options"]["gain_days"]`` and
        ``meta["plausibility"]``.
    """
    problems = _gain_days_problems(gain_days)
    if model.f_ig_const is None or "warmup_steps" not in model.meta:
        problems.append("the model was not fitted by fit_physics (no f_IG^c or warm-up in its meta): fit it first")
    if float(dataset.step) != float(model.step) or tuple(dataset.building.zone_names) != tuple(model.outputs):
        problems.append(
            f"the data (step {float(dataset.step):g} s, zones {list(dataset.building.zone_names)}) are not the "
            f"model's (step {model.step:g} s, zones {list(model.outputs)}): use the dataset the model was fitted on"
        )
    if problems:
        from ...errors import problems_message

        raise FitError(problems_message("refit_gains: cannot redo step 2", problems))
    f_c = np.asarray(model.f_ig_const, dtype=float)
    with one_blas_thread():
        gains, info = _seasonal_gains(dataset, model, f_c, int(model.meta["warmup_steps"]), gain_days)
    meta = {**model.meta, "gains": info, "fit_options": {**model.meta.get("fit_options", {}), "gain_days": gain_days}}
    out = dataclasses.replace(model, gains=gains, meta=meta, holidays=dataset.holidays.dates)
    meta["plausibility"] = check_physics(out)
    return out


def _fit_physics(
    dataset,
    *,
    progress,
    solar,
    max_layer_thickness,
    furniture_capacity,
    internal_mass,
    segment_hours,
    warmup_hours,
    max_segments,
    kalman,
    kalman_rounds,
    bound_factor,
    max_nfev,
    initial,
    free_modes,
    segment_observer,
    gain_days,
):
    t_start = time.perf_counter()
    step = float(dataset.step)
    building = dataset.building
    gain_days = _gain_days(building, gain_days)
    _check_fit_options(segment_observer, free_modes, segment_hours, warmup_hours, bound_factor, gain_days)
    options = {
        k: v
        for k, v in (
            ("max_layer_thickness", max_layer_thickness),
            ("furniture_capacity", furniture_capacity),
            ("internal_mass", internal_mass),
        )
        if v is not None
    }
    solar, inlets, notes, nominal, start, zero_gains, model = _fit_setup(
        dataset, solar, options, kalman, warmup_hours, initial
    )
    template = model._template

    nw = int(model.options["kalman"]["warmup_steps"])
    ns = int(round(segment_hours * 3600 / step))
    segs = _weekend_segments(dataset, model, nw, ns, max_segments)
    log.info("Model B step 1: %d weekend segments of %d steps, %d states", segs.n, ns, model.n_states)

    bounds = (
        np.log(template.params_vector(nominal) / bound_factor),
        np.log(template.params_vector(nominal) * bound_factor),
    )
    theta0 = np.clip(np.log(template.params_vector(start)), bounds[0] + 1e-9, bounds[1] - 1e-9)
    theta, K, results, nfev, f_c, r = _step1(
        model, segs, theta0, bounds, progress, segment_observer, kalman_rounds, free_modes, max_nfev
    )
    params = dict(zip(PARAM_NAMES, map(float, np.exp(theta))))

    # --- uncertainty ------------------------------------------------------------
    estimates, unident, jac_info = _uncertainty(
        template, theta, f_c, step, segs, K, bounds[0], bounds[1], building.zone_names, free_modes
    )
    rms = float(np.sqrt(np.mean(r**2)))

    # --- step 2: seasonal time-of-week gains, meta record ------------------------------
    settings = dict(
        segment_hours=segment_hours,
        warmup_hours=warmup_hours,
        max_segments=max_segments,
        free_modes=int(free_modes),
        segment_observer=segment_observer,
        bound_factor=bound_factor,
        max_nfev=max_nfev,
        solar=bool(solar),
        gain_days=gain_days,
    )
    record = dict(nominal=nominal, initial=start, estimates=estimates, unident=unident, jac_info=jac_info, rms=rms)
    record.update(segs=segs, ns=ns, nw=nw, results=results, nfev=nfev, n_states=model.n_states, notes=notes)
    record["inlets"] = dict(zip(building.vav_names, inlets))
    return _fit_finish(dataset, model, params, zero_gains, f_c, inlets, solar, t_start, settings, record)


def _step1(model, segs, theta0, bounds, progress, observer, kalman_rounds, free_modes, max_nfev):
    """Step 1: the log-parameters ``theta`` on the weekend segments, then the constant gains ``f_c`` [W].

    Returns ``(theta, K, results, nfev, f_c, r)``: the Kalman gain of the last round, the rounds'
    results, the residual evaluations and the weekend residuals [K] at the optimum.
    """
    theta, K, results, nfev = _optimise(
        model, segs, theta0, bounds, progress, observer, kalman_rounds, free_modes, max_nfev
    )
    Y0, S, Phi = _simulate_segments(model._template, theta, float(model.step), segs, K, free_modes)
    f_c, r = _solve_gains(Y0, S, Phi, segs)
    return theta, K, results, nfev, f_c, r


def _fit_setup(dataset, solar, options, kalman, warmup_hours, initial):
    """The model to optimise: the solar choice checked, training inlets, nominal and start parameters, zero gains.

    Returns ``(solar, inlets, notes, nominal, start, zero_gains, model)``.
    """
    building = dataset.building
    if solar is None:
        solar = bool(getattr(dataset, "has_solar", False))
    if solar and not getattr(dataset, "has_solar", False):
        raise FitError("solar=True needs facade irradiance (I_N..I_W) in the data; this dataset has none")
    inlets, notes = _training_inputs(dataset, options, kalman, warmup_hours)
    spec = parse_physics(building, **{k: v for k, v in options.items() if k != "kalman"})
    nominal = dict(spec.nominal)
    start = dict(nominal)
    if initial:
        start.update(initial)
    zero_gains = _zero_gains(dataset, spec)
    step = float(dataset.step)
    model = PhysicsModel(building, start, zero_gains, step=step, solar=solar, options=options, inlets=inlets)
    if solar:
        missing = [c for c in model.disturbances if c not in dataset.frame.columns]
        if missing:
            raise FitError(f"solar=True but the data lack {missing}")
    return solar, inlets, notes, nominal, start, zero_gains, model


def _fit_finish(dataset, model, params, zero_gains, f_c, inlets, solar, t_start, settings, record):
    """Step 2 (seasonal time-of-week gains) and the final model with its meta record and plausibility check."""
    building, step = dataset.building, float(dataset.step)
    fitted = PhysicsModel(
        building, params, zero_gains, step=step, solar=solar, options=model.options, f_ig_const=f_c, inlets=inlets
    )
    gains, gain_info = _seasonal_gains(dataset, fitted, f_c, record["nw"], settings["gain_days"])
    meta = _fit_meta(dataset, t_start, settings, gain_info=gain_info, **record)
    final = PhysicsModel(
        building,
        params,
        gains,
        step=step,
        solar=solar,
        options=fitted.options,
        f_ig_const=f_c,
        meta=meta,
        inlets=inlets,
        holidays=dataset.holidays.dates,
    )
    meta["plausibility"] = check_physics(final)
    meta["fit_seconds"] = round(time.perf_counter() - t_start, 2)
    log.info("Model B identified in %.1f s, weekend RMS %.3f K", meta["fit_seconds"], record["rms"])
    return final


def _fit_meta(
    dataset,
    t_start,
    fit_options: dict,
    *,
    nominal,
    initial,
    estimates,
    unident,
    jac_info,
    rms,
    segs,
    ns,
    nw,
    results,
    nfev,
    gain_info,
    n_states,
    inlets,
    notes,
) -> dict:
    """The ``meta`` record of a fitted physics model (method, options, estimates, optimiser, gains)."""
    res = results[-1]
    return {
        "fitted": pd.Timestamp.now(tz="UTC").isoformat(),
        "fit_seconds": round(time.perf_counter() - t_start, 2),
        "data": {"source": str(getattr(dataset, "source", "")), "sha256": getattr(dataset, "sha256", None)},
        "method": "Zhou, Hu & Tomlin sec. IV.B: weekend simulation-error fit (log-parameters, variable "
        "projection for f_IG^c >= 0), segment initial states from a filter over the warm-up plus "
        "fitted slowest modes; f_IG^v by one-step OLS (gain injection) averaged per season",
        "fit_options": fit_options,
        "nominal": nominal,
        "initial": initial,
        "estimates": estimates,
        "unidentifiable": unident,
        "jacobian": jac_info,
        "fit_rms": rms,
        "n_segments": int(segs.n),
        "segment_steps": ns,
        "warmup_steps": nw,
        "segments_per_season": {s: int(np.sum(segs.seasons == s)) for s in np.unique(segs.seasons)},
        "optimizer": {
            "status": int(res.status),
            "message": str(res.message),
            "nfev": int(nfev),
            "rounds": len(results),
            "cost": float(res.cost),
        },
        "gains": gain_info,
        "n_states": n_states,
        "inlets": inlets,
        "inlet_notes": notes,
    }


#: Step 2's gain profiles: the paper's per time of week, one Mon-Fri profile, or each workday's profile shrunk
#: toward the Mon-Fri one.
GAIN_PROFILES = ("week", "workdays", "shrunk")
#: Values of ``gain_days``: a profile of :data:`GAIN_PROFILES`, or ``"auto"`` (the one with the lowest blocked
#: cross-validated 24-h open-loop RMS over the training weeks, :func:`.gaincv.choose_gain_days`).
GAIN_DAYS = (*GAIN_PROFILES, "auto")


def _one_of() -> str:
    """``'week', 'workdays', 'shrunk' or 'auto'``: the values of :data:`GAIN_DAYS` for messages."""
    names = [repr(g) for g in GAIN_DAYS]
    return ", ".join(names[:-1]) + " or " + names[-1]


def _gain_days_problems(gain_days) -> list[str]:
    """The refusal of a ``gain_days`` argument outside :data:`GAIN_DAYS` (empty when it is one of them)."""
    return [] if gain_days in GAIN_DAYS else [f"gain_days must be {_one_of()}, got {gain_days!r}"]


def _gain_days(building, gain_days: str | None) -> str:
    """Step 2's day types: the argument, else the building file's ``[physics].gain_days``, else ``"auto"``."""
    if gain_days is not None:
        return gain_days
    value = ((building.physics or {}).get("physics") or {}).get("gain_days", "auto")
    if value not in GAIN_DAYS:
        where = f" of {building.source}" if getattr(building, "source", None) else ""
        raise FitError(f"[physics].gain_days{where} must be {_one_of()}, got {value!r}: fix the building file")
    return value


def _check_fit_options(segment_observer, free_modes, segment_hours, warmup_hours, bound_factor, gain_days) -> None:
    """Refuse impossible options of :func:`fit_physics`, all problems at once."""
    problems = []
    if segment_observer not in ("gain_injection", "kalman"):
        problems.append(f"segment_observer must be 'gain_injection' or 'kalman', got {segment_observer!r}")
    if int(free_modes) < 0:
        problems.append(f"free_modes must be >= 0, got {free_modes}")
    if not segment_hours > 0 or warmup_hours < 0:
        problems.append(f"need segment_hours > 0 and warmup_hours >= 0, got {segment_hours}, {warmup_hours}")
    if not bound_factor > 1:
        problems.append(f"bound_factor must be > 1, got {bound_factor}")
    problems += _gain_days_problems(gain_days)
    if problems:
        from ...errors import problems_message

        raise FitError(problems_message("fit_physics: bad options", problems))


def _training_inputs(dataset, options: dict, kalman, warmup_hours) -> tuple:
    """Inlet temperature columns of the boxes on the training rows, and the filter options (set in ``options``).

    Returns ``(inlets, notes)``; ``options["kalman"]`` gets the mean training airflow per zone and the
    warm-up length unless given.
    """
    frame, building = dataset.frame, dataset.building
    train_rows = np.zeros(len(frame), dtype=bool)
    for w in dataset.weeks:
        if w.train:
            train_rows |= (frame.index >= w.start) & (frame.index < w.end)
    if not train_rows.any():
        raise FitError("the dataset has no training weeks")
    inlets, notes = inlet_columns(building, frame, rows=train_rows)
    for note in notes:
        warnings.warn(note, HvacfmuWarning, stacklevel=3)
    m_zone = frame[[f"m_{v}" for v in building.vav_names]].to_numpy(float)[train_rows] @ building.zone_vav_matrix().T
    airflow = np.nan_to_num(np.nanmean(m_zone, axis=0), nan=0.0)
    kal = dict(kalman or {})
    kal.setdefault("airflow", airflow.tolist())
    if "warmup_steps" not in kal:
        kal["warmup_steps"] = int(round(warmup_hours * 3600 / float(dataset.step)))
    options["kalman"] = kal
    return inlets, notes


def _zero_gains(dataset, spec) -> dict:
    """season -> zero time-of-week gain table (the ground column at the ground temperature)."""
    nz = len(spec.zones)
    nq = nz + (1 if spec.has_ground else 0)
    n_tow = n_time_of_week(float(dataset.step))
    zero_gains = {}
    for s in dict.fromkeys(w.season for w in dataset.weeks):
        zero_gains[s] = np.zeros((n_tow, nq))
        if spec.has_ground:
            zero_gains[s][:, nz] = spec.ground_temperature
    return zero_gains


def _optimise(model, segs, theta0, bounds, progress, observer, kalman_rounds, free_modes, max_nfev) -> tuple:
    """Step 1: bounded least squares of the weekend simulation error over the log-parameters.

    Returns ``(theta, K, results, nfev)``: the optimum, the segment observer used last, the
    ``least_squares`` result of every round and the number of residual evaluations.
    """
    template, step = model._template, model.step
    bar = Progress(total=None, desc="Model B step 1", unit="eval", enabled=progress)
    state = {"K": "gain_injection" if observer == "gain_injection" else model.kalman_gain, "nfev": 0}

    def residuals(theta):
        Y0, S, Phi = _simulate_segments(template, theta, step, segs, state["K"], free_modes)
        _, r = _solve_gains(Y0, S, Phi, segs)
        state["nfev"] += 1
        if bar is not None:
            bar.update(1)
        return r

    theta = theta0
    results = []
    n_rounds = max(1, int(kalman_rounds)) if observer == "kalman" else 1
    for rnd in range(n_rounds):
        if rnd > 0 and observer == "kalman":
            net = template.build(np.exp(theta))
            k = model.options["kalman"]
            state["K"] = kalman_gain(net.discretize(step), k["airflow"], k["q_air"], k["q_mass"], k["r"])
        res = so.least_squares(
            residuals,
            theta,
            bounds=bounds,
            method="trf",
            x_scale=1.0,
            diff_step=1e-5,
            max_nfev=max_nfev,
            xtol=1e-4,
            ftol=1e-6,
        )
        theta = res.x
        results.append(res)
    if bar is not None:
        bar.close()
    return theta, state["K"], results, state["nfev"]


def _uncertainty(template, theta, f_c, step, segs, K, lo, hi, zones, free_modes):
    """Standard deviations and identifiability flags of all parameters at the optimum."""
    lin = _LinearPart(*_simulate_segments(template, theta, step, segs, K, free_modes), segs)
    r = lin.residual(f_c)
    cols = []
    h = 1e-4
    for p in range(len(theta)):
        th = theta.copy()
        th[p] += h
        linp = _LinearPart(*_simulate_segments(template, th, step, segs, K, free_modes), segs)
        cols.append((linp.residual(f_c) - r) / h)
    J = np.column_stack(cols + [lin.A])
    r0 = np.full(segs.mask.shape, np.nan)
    r0[segs.mask] = r
    names = list(PARAM_NAMES) + [f"f_ig_const_{z}" for z in zones]
    n, p = J.shape
    rho = _lag1(r0)
    s2 = float(r @ r) / max(n - p - lin.n_free, 1) * (1 + rho) / (1 - rho)
    cov = s2 * np.linalg.pinv(J.T @ J)
    std = np.sqrt(np.clip(np.diag(cov), 0, None))
    values = np.r_[np.exp(theta), f_c]
    colnorm = np.linalg.norm(J, axis=0)
    colnorm[colnorm == 0] = 1.0
    Jn = J / colnorm
    _, sv, Vt = np.linalg.svd(Jn, full_matrices=False)
    weak = sv < 1e-3 * sv[0]
    estimates, unident = {}, []
    for i, name in enumerate(names):
        flags = []
        if i < len(theta):
            rel = float(np.expm1(std[i])) if std[i] < 50 else math.inf
            at_bound = theta[i] <= lo[i] + 1e-6 or theta[i] >= hi[i] - 1e-6
            e = {
                "value": float(values[i]),
                "rel_std": rel if math.isfinite(rel) else None,
                "std": float(values[i] * rel) if math.isfinite(rel) else None,
            }
        else:
            rel = float(std[i] / abs(values[i])) if values[i] > 0 else math.inf
            at_bound = values[i] <= 0.0
            e = {
                "value": float(values[i]),
                "std": float(std[i]) if np.isfinite(std[i]) else None,
                "rel_std": rel if math.isfinite(rel) else None,
            }
        if colnorm[i] == 1.0 and not np.any(J[:, i]):
            flags.append("no influence on the fitted outputs")
        if rel > 1.0:
            flags.append("relative std > 100 %")
        if at_bound:
            flags.append("at bound")
        if np.any(weak & (np.abs(Vt[:, i]) > 0.3)):
            flags.append("near-singular direction")
        e["flags"] = flags
        estimates[name] = e
        if flags:
            unident.append(name)
    with np.errstate(all="ignore"):
        corr = np.nan_to_num(cov / np.outer(std, std), nan=0.0, posinf=0.0, neginf=0.0)
    info = {
        "names": names,
        "scaled_singular_values": (sv / sv[0]).tolist(),
        "residual_lag1_autocorrelation": rho,
        "correlation": np.round(corr, 4).tolist(),
        "note": "std from s^2 (J^T J)^-1 with s^2 inflated by (1+rho)/(1-rho); physical parameters in logs",
    }
    return estimates, unident, info


def _seasonal_gains(dataset, model, f_c, nw, gain_days):
    """Step 2: f_IG,m^v(k) per season by one-step OLS on the filtered states, averaged over training weeks
    (per time of week, or per day type: see :func:`_profile_of`; ``"auto"``: the day types chosen by
    blocked cross-validation over the training weeks, :func:`.gaincv.choose_gain_days`)."""
    auto = None
    if gain_days == "auto":
        from .gaincv import choose_gain_days

        auto = choose_gain_days(dataset, model, f_c, nw)
        gain_days = auto["chosen"]
    profiles = _week_profiles(dataset, model, f_c, nw)
    out, info = _gains_of_profiles(dataset, model, f_c, profiles, gain_days)
    if auto is not None:
        info["auto"] = auto
    return out, info


def _week_profiles(dataset, model, f_c, nw, frame=None) -> list:
    """Step 2's one-step gains of every training week: a list of ``(week, profile (n_tow, nz) [W])``,
    NaN where not estimated. ``frame`` (default the dataset's) gives the measurements."""
    frame = dataset.frame if frame is None else frame
    index = frame.index
    step = float(dataset.step)
    n_tow = n_time_of_week(step)
    disc = model.discrete
    nz = len(model.outputs)
    y_all = model.measured_outputs(frame)
    u_all, v_all = model.signals(frame)
    q_all = np.zeros((len(frame), len(model.q_names)))
    q_all[:, :nz] = f_c
    if len(model.q_names) > nz:
        q_all[:, nz] = model._spec.ground_temperature
    CB = disc.Vz @ disc.Pq[:, :nz]  # C B_IG (nz, nz) [K/W]
    CB_inv = np.linalg.inv(CB)
    # "gain injection": every step the zone gains that make the one-step prediction hit the measured
    # temperatures are added (x(k) = x~(k) + B_IG f(k-1), the paper's eq. ig(k-1)); walls follow physically.
    # (A Kalman correction here would let the walls soak up part of persistent gains.)
    Kz = disc.Pq[:, :nz] @ CB_inv
    out = []
    for week in dataset.weeks:
        if not week.train:
            continue
        r0 = _row_of(index, pd.Timestamp(week.start), step)
        if r0 is None:
            continue
        w = min(nw, r0)
        n = min(n_tow + 1, len(frame) - r0)  # rows of the week plus the first row after it
        rows = np.arange(r0 - w, r0 + n)
        if len(rows) < 2:
            continue
        y = y_all[rows]
        u = fill_signals(u_all[rows[:-1]], 0.0)
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a week without any measured zone: NaN gains
            v = fill_signals(v_all[rows[:-1]], np.nanmean(y))
            ymean = np.nanmean(y[: w + 1], axis=0)
            ymean = np.where(np.isnan(ymean), np.nanmean(y), ymean)
        q = q_all[rows[:-1]]
        x0 = disc.network.wall_steady_state(ymean[None], v[: max(w, 1), 0].mean()[None], q[:1])[0]
        x0[:nz] = np.where(np.isnan(y[0]), ymean, y[0])
        m = u @ disc.zone_vav.T
        _, _, Yp, _ = disc.run(
            x0 @ disc.W.T, m, v, q, y=y, Kz=Kz, n_correct=len(rows), record_pred=True, mt=disc.inlet_flux(u, v)
        )
        innov = y[w + 1 :] - Yp[w + 1 :]  # rows r0+1 .. : innovation of y(k+1) -> f(k)
        # bad inputs give meaningless innovations
        bad = np.isnan(u_all[rows[w:-1]]).any(axis=1) | np.isnan(v_all[rows[w:-1]]).any(axis=1)
        fv = innov @ CB_inv.T
        fv[bad] = np.nan
        # a holiday is not an ordinary weekday: left out of the profile (the model reads Sunday's on it)
        fv[holiday_slots(index[rows[w:-1]], step, dataset.holidays.dates)[0]] = np.nan
        slots = time_of_week(index[rows[w:-1]], step)
        prof = np.full((n_tow, nz), np.nan)
        prof[slots] = fv
        out.append((week, prof))
    return out


def _gains_of_profiles(dataset, model, f_c, profiles, gain_days):
    """The seasonal gain profiles ``{season: (n_tow, nq)}`` [W] and their record from the training weeks'
    one-step gains ``profiles`` (:func:`_week_profiles`) with day types ``gain_days`` (not ``"auto"``)."""
    nz = len(model.outputs)
    per_season: dict[str, list] = {}
    for week, prof in profiles:
        per_season.setdefault(week.season, []).append(prof)
    gains, info = {}, {"weeks_per_season": {}, "filled_slots": {}, "day_types": gain_days}
    season_names = list(dict.fromkeys(w.season for w in dataset.weeks))
    for s, profs in per_season.items():
        record: dict = {}
        mean = _profile_of(np.stack(profs), gain_days, record=record)
        if record:
            info.setdefault("shrinkage_weight", {})[s] = record["shrinkage_weight"]
        filled = int(np.isnan(mean).any(axis=1).sum())
        mean = _fill_circular(mean)
        info["weeks_per_season"][s] = len(profs)
        info["filled_slots"][s] = filled
        gains[s] = mean
    if not gains:
        raise FitError("step 2: no training week could be filtered to estimate internal gains")
    for s in season_names:
        if s not in gains:
            gains[s] = np.mean([g for g in gains.values()], axis=0)
            info.setdefault("borrowed", []).append(s)
    out = {}
    for s, fv in gains.items():
        g = np.zeros((fv.shape[0], len(model.q_names)))
        g[:, :nz] = f_c[None, :] + fv
        if len(model.q_names) > nz:
            g[:, nz] = model._spec.ground_temperature
        out[s] = g
    return out, info


def _profile_of(profs, gain_days, record=None):
    """Mean (n_tow, nz) gain profile [W] of a season from the training weeks' profiles (n_weeks, n_tow, nz).

    ``"week"``: per time-of-week slot over the weeks. ``"workdays"``: Monday to Friday get one daily
    profile, the mean over the weeks and the five days of each slot of the day. ``"shrunk"``: each
    workday's own profile shrunk toward that Monday-Friday profile by :func:`_shrunk_workdays`.
    Saturday and Sunday stay per slot. All-NaN slots stay NaN (filled by the caller). ``record``
    (a dict), if given, receives the shrinkage weights (``"shrunk"`` only).
    """
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN slots: filled by the caller
        mean = np.nanmean(profs, axis=0)
        if gain_days in ("workdays", "shrunk"):
            if profs.shape[1] % 7:
                raise FitError(
                    f"step 2: gain_days={gain_days!r} needs a model step that divides a day; the week has "
                    f"{profs.shape[1]} steps; use gain_days='week' or resample the data"
                )
            per_day = profs.shape[1] // 7  # slots of a day; slot 0 is Monday 00:00
            days = profs[:, : 5 * per_day].reshape(profs.shape[0], 5, per_day, profs.shape[2])
            if gain_days == "workdays":
                work = np.tile(np.nanmean(days, axis=(0, 1)), (5, 1, 1))
            else:
                work, weight = _shrunk_workdays(days)
                if record is not None:
                    record["shrinkage_weight"] = np.round(weight, 3).tolist()
            mean[: 5 * per_day] = work.reshape(5 * per_day, -1)
    return mean


def _shrunk_workdays(days):
    """Each workday's profile shrunk toward the Monday-Friday profile by a random-effects estimate.

    Parameters
    ----------
    days : array (n_weeks, 5, per_day, nz) [W]
        The training weeks' one-step gains of Monday..Friday, NaN where not estimated.

    Returns
    -------
    profile : array (5, per_day, nz) [W]
        ``pooled + w_dz (mean_dz - pooled)`` with ``mean_dz`` the mean over the weeks of weekday ``d``,
        ``pooled`` the mean over every training workday (the ``"workdays"`` profile).
    weight : array (5, nz) [-]
        ``w_dz = max(0, 1 - (4/5) s2_dz / V_dz)``: ``V_dz`` the mean square of ``mean_dz - pooled`` over
        the slots of the day, ``s2_dz`` the mean over the slots of the squared standard error of
        ``mean_dz`` (the between-week variance of the slot over its number of weeks; the factor 4/5
        because the pooled mean holds the day too). A weekday whose profile differs from the others by
        more than its own week-to-week scatter explains keeps it (``w`` near 1, Monday's recovery from
        the weekend); one unusual day in a training week raises the scatter and is pooled (``w`` near
        0). With fewer than two training weeks the scatter is unknown and every workday is pooled.
    """
    pooled = np.nanmean(days, axis=(0, 1))  # (per_day, nz)
    own = np.nanmean(days, axis=0)  # (5, per_day, nz)
    count = np.isfinite(days).sum(axis=0)  # weeks per slot
    diff = np.where(np.isfinite(own), own - pooled, 0.0)
    spread = np.nanmean(diff**2, axis=1)  # V (5, nz)
    var = np.nanvar(days, axis=0, ddof=1) / np.maximum(count, 1)
    noise = np.nanmean(np.where(count >= 2, var, np.nan), axis=1)  # s2 (5, nz)
    with np.errstate(all="ignore"):
        weight = 1.0 - (4.0 / 5.0) * noise / spread
    weight = np.clip(np.nan_to_num(weight, nan=0.0, posinf=0.0, neginf=0.0), 0.0, 1.0)
    if days.shape[0] < 2:
        weight[:] = 0.0
    return pooled[None] + weight[:, None, :] * diff, weight


def _fill_circular(prof):
    """Fill NaN slots of a (n_tow, nz) profile by circular linear interpolation (0 if a zone has no data)."""
    out = prof.copy()
    n = prof.shape[0]
    x = np.arange(n)
    for j in range(prof.shape[1]):
        ok = np.isfinite(prof[:, j])
        if not ok.any():
            out[:, j] = 0.0
        elif not ok.all():
            out[~ok, j] = np.interp(x[~ok], x[ok], prof[ok, j], period=n)
    return out
