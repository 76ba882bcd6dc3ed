"""Open-loop (output-error) refinement of a fitted Model A: its coefficients re-fitted for 24-hour prediction.

Why
---
Model A's coefficients come from one-step regressions on LOESS-de-smoothed
series (:mod:`hvacfmu.models.datadriven`). On closed-loop data, such as a
thermostat-controlled building that floats with its air handler off at night,
the de-smoothed one-step increments are dominated by the fast exchange of the
zone air with its surroundings and by the thermostat loop: the fitted ``a`` is
the fast mode (0.3-0.6 per 15 min on the EnergyPlus medium office, issue 13),
the slow mode of the building's mass is left to the time-of-week gain profile,
and a 24-hour open-loop prediction forgets its initial temperature within an
hour and becomes a time-of-week mean. In a week whose level differs from the
training weeks (the winter test week of the EnergyPlus office, 2 K warmer at
night), the model then loses to persistence.

What
----
The structure of the model stays the paper's: ``x(k+1) = A x(k) + B u(k) + C v(k)
+ q_IG(k)`` (or the delivered-heat form). Starting from the fitted values, the
diagonal of ``A``, the drive coefficients (``B_ii`` or ``beta_i``) and the
non-zero entries of ``C`` are re-estimated by minimising the squared error of
24-hour open-loop simulations over the training weeks (output-error
identification, e.g. L. Ljung, *System Identification*, 2nd ed., sec. 7.3:
the prediction-error criterion for the horizon the model is used on), under the
fit's sign and stability constraints. For every candidate the internal-gain
profile of each season is re-estimated by eq. (qig_estimation) from the
one-step residuals ``x(k+1) - (A x(k) + B u(k) + C v(k))`` of the measured
series, so that ``q_IG`` cannot absorb what the coefficients explain and the
coefficients are judged together with the gains they imply.
"""

from __future__ import annotations

import functools

import numpy as np

from .heat import CP_AIR

#: Open-loop horizon of the refinement criterion [steps] (24 h at 15 minutes).
HORIZON_STEPS = 96


def training_windows(prep, horizon: int, inputs_ok=None):
    """Start rows of the training windows: every midnight of the training weeks with a day of data to learn from.

    Days with every zone temperature measured in every step come first (clean targets). When they are fewer than
    7 or than half of the days the evaluation's coverage rules would score (a real export's scattered missing
    cells: one blank zone reading cost a whole day), the windows follow those rules instead
    (:mod:`hvacfmu.data.windows`): the zone temperatures measured at the start, each zone measured in at least
    :data:`~hvacfmu.data.windows.MIN_OUTPUT_SHARE` of the steps (errors count measured steps only). Either way
    every row lies in the training weeks and no input is missing after the short gaps are filled (``inputs_ok``).

    Parameters
    ----------
    prep : hvacfmu.models.datadriven._Prepared
        Arrays of the fit (regular grid, training mask).
    horizon : int [steps]
    inputs_ok : array of bool, optional
        Rows whose model inputs are known (after :func:`_filled_signals`); default: every row.

    Returns
    -------
    array of int
        Row indices into ``prep.frame``.
    """
    from ..data.windows import MIN_OUTPUT_SHARE

    idx = prep.index
    n = len(idx)
    y_ok = np.isfinite(prep.T)
    usable = prep.train & (np.ones(n, bool) if inputs_ok is None else np.asarray(inputs_ok, bool))
    mid = np.flatnonzero((idx.hour == 0) & (idx.minute == 0))
    mid = mid[mid + horizon + 1 <= n]
    bad = np.r_[0, np.cumsum(~(usable & y_ok.all(axis=1)))]
    complete = mid[bad[mid + horizon + 1] - bad[mid] == 0]
    bad = np.r_[0, np.cumsum(~usable)]
    obs = np.r_[np.zeros((1, y_ok.shape[1]), np.int64), np.cumsum(y_ok, axis=0)]
    measured = np.all(obs[mid + horizon + 1] - obs[mid + 1] >= MIN_OUTPUT_SHARE * horizon, axis=1)
    covered = mid[(bad[mid + horizon + 1] - bad[mid] == 0) & y_ok[mid].all(axis=1) & measured]
    return complete if complete.size >= max(7, covered.size / 2) else covered


def _filled_signals(model, prep):
    """The model's inputs and disturbances with gaps up to :data:`~hvacfmu.data.windows.FILL_INPUTS_H` filled.

    As the evaluation fills them for its simulations (:func:`hvacfmu.data.windows.fill_inputs`); zone
    temperatures are never filled.
    """
    from ..data.windows import FILL_INPUTS_H, fill_inputs

    filled = fill_inputs(prep.frame, prep.building.zone_names, prep.step, FILL_INPUTS_H).frame
    return tuple(np.asarray(a, float) for a in model.signals(filled))


class _Problem:
    """Open-loop simulation of a LinearZoneModel's windows with free parameters theta, and its exact Jacobian.

    theta = (diag A, drive, non-zero entries of C, off-diagonal entries of A between adjacent zones when
    ``couplings``). Every parameter acts on one state row ``i_p`` through a feature ``phi_p(x, u, v)``:
    ``x_i`` (diag A), ``x_j`` (A_ij), ``v_c`` (C_ic), the delivered heat ``H_i - M_i x_i`` (beta_i;
    ``H_i = sum_b m_b c_p T_in,b``, ``M_i = sum_b m_b c_p`` over the boxes of state i) or the zone airflow
    ``u_i`` (B_ii), so one step is ``x+ = F x + G u + sum_p theta_p phi_p e_(i_p) + q`` with the entries
    that are not free in ``F``, ``G``. The gain profile ``q`` re-estimated for theta (eq. qig_estimation:
    the per-slot mean of the one-step residuals of the training rows) is then affine in theta,
    ``q = q0 - sum_p theta_p q_p``, so it costs one product per candidate, and the sensitivities
    ``S = dx/dtheta`` follow ``S+ = J S + E`` with ``J = dx+/dx``: the Jacobian of the window errors is exact
    (no finite differences) and costs about one simulation.
    """

    def __init__(self, model, prep, starts, horizon, couplings=False, filled=None, weeks=None):
        self.model, self.prep, self.horizon = model, prep, horizon
        # cross-fitted gains: each window simulated with the profiles of the other training weeks (``weeks``: the
        # week number of every row), so a profile is never judged on the week it was estimated from
        self.weeks = weeks
        self.window_week = None if weeks is None else np.asarray(weeks)[starts]
        frame = prep.frame
        self.Y = np.asarray(model.measured_outputs(frame), float)
        u, v = (np.asarray(a, float) for a in model.signals(frame))
        self.uv_ok = np.all(np.isfinite(u), axis=1) & np.all(np.isfinite(v), axis=1)  # measured: the gain rows
        # the simulation's inputs, short gaps filled as in the evaluation (``filled``: already computed)
        u, v = _filled_signals(model, prep) if filled is None else filled
        self.u, self.v = np.nan_to_num(u), np.nan_to_num(v)
        self.rng = starts[:, None] + np.arange(horizon)[None, :]
        self.seasons = prep.season
        # every season weighs alike, however many training days it has (the goal is every season)
        ws = self.seasons[starts]
        count = {s: int(np.sum(ws == s)) for s in set(ws)}
        self.weight = np.array([1.0 / np.sqrt(count[s]) for s in ws])[:, None, None]
        self.slots = prep.slots
        nx = model.A.shape[0]
        self.nx = nx
        self.delivered = model.beta is not None
        drive = model.beta if self.delivered else np.diag(model.B)
        self.cmask = model.C != 0.0
        self.omask = _adjacent_mask(model, prep.building) if couplings else np.zeros((nx, nx), bool)
        ci, cc = np.nonzero(self.cmask)
        oi, oj = np.nonzero(self.omask)
        self.c_col, self.o_col = cc, oj
        self.row = np.r_[np.arange(nx), np.arange(nx), ci, oi].astype(np.int64)  # state row of each parameter
        self.n_par = self.row.size
        self.onehot = (self.row[None, :] == np.arange(nx)[:, None]).astype(float)  # (nx, P): parameter p on row i_p
        self.c0, self.o0 = 2 * nx, 2 * nx + ci.size  # where the C entries and the couplings start in theta
        self.is_a = np.zeros(self.n_par, bool)  # entries of A: the diagonal and the couplings
        self.is_a[:nx] = self.is_a[self.o0 :] = True
        self.theta0 = np.r_[np.diag(model.A), drive, model.C[self.cmask], model.A[self.omask]]
        free_a = np.eye(nx, dtype=bool) | self.omask
        self.A_fixed = np.where(free_a, 0.0, model.A)
        self.B_fixed = model.B.copy()
        if not self.delivered:
            self.B_fixed[np.arange(nx), np.arange(nx)] = 0.0
        self.row_limit = 1.0 - 1e-3 - np.abs(self.A_fixed).sum(axis=1)  # what the fixed entries leave of a row
        a_hi = np.maximum(self.row_limit, 2e-4)
        d_lo, d_hi = (np.zeros(nx), np.full(nx, np.inf)) if self.delivered else (np.full(nx, -np.inf), np.zeros(nx))
        nc, no = ci.size, oi.size
        # a_ii >= every fixed coupling of its row (the one-step fit's a_ij <= a_ii, kept by the refinement)
        a_lo = np.minimum(np.maximum(np.abs(self.A_fixed).max(axis=1), 1e-4), a_hi - 1e-6)
        self.lb = np.r_[a_lo, d_lo, np.zeros(nc), np.zeros(no)]
        self.ub = np.r_[a_hi, d_hi, np.full(nc, np.inf), np.ones(no)]
        self.theta0 = np.clip(self.theta0, self.lb, np.where(np.isfinite(self.ub), self.ub - 1e-9, self.ub))
        rows = np.flatnonzero(
            prep.train[:-1]
            & prep.train[1:]
            & self.uv_ok[:-1]
            & np.all(np.isfinite(self.Y[:-1]), axis=1)
            & np.all(np.isfinite(self.Y[1:]), axis=1)
        )
        self.rows = rows
        if self.delivered:
            hm = np.asarray(model.heat_map, float)
            cp = CP_AIR / 1000.0
            self.M = (self.u * cp) @ hm.T  # (n, nx) [kW/K]
            self.H = (self.u * cp * self.v[:, model._inlet_idx]) @ hm.T  # (n, nx) [kW]
        self._gain_parts()

    # --- the one-step map, linear in theta --------------------------------------------------------------------
    def _features(self, x, k):
        """phi (..., P) at states x (..., nx) and rows k (...)."""
        drive = self.H[k] - self.M[k] * x if self.delivered else self.u[k][..., : self.nx]
        return np.concatenate([x, drive, self.v[k][..., self.c_col], x[..., self.o_col]], axis=-1)

    def _fixed(self, x, k):
        """The part of x+ that no parameter moves: the fixed entries of A and B."""
        return x @ self.A_fixed.T + self.u[k] @ self.B_fixed.T

    def _scatter(self, phi_theta):
        """sum_p phi_p theta_p e_(i_p): (..., P) -> (..., nx)."""
        return phi_theta @ self.onehot.T

    def _gain_parts(self):
        """Per season: q0 (n_slots, nx) and q_p (n_slots, P) with gains(theta) = q0 - q_p theta on rows i_p."""
        from .datadriven import estimate_gains

        r = self.rows
        y0, y1 = self.Y[r], self.Y[r + 1]
        base = y1 - self._fixed(y0, r)
        phi = self._features(y0, r)
        both = np.c_[base, phi]

        def parts(keep):
            q0, qp = {}, {}
            for s in self.model.gains:
                sel = keep & (self.seasons[r] == s) & self.prep.gain_ok[r]
                if sel.any():
                    est, _ = estimate_gains(both[sel], self.slots[r][sel], self.prep.n_slots)
                    q0[s], qp[s] = est[:, : self.nx], est[:, self.nx :]
            return q0, qp

        self.q0, self.qp = parts(np.ones(r.size, bool))
        for s, prof in self.model.gains.items():
            if s not in self.q0:
                self.q0[s], self.qp[s] = np.asarray(prof, float), np.zeros((len(prof), self.n_par))
        self.cross = None
        if self.weeks is not None:  # week -> (q0, qp) without that week (a season with no other week: all weeks')
            row_week = np.asarray(self.weeks)[r]
            self.cross = {}
            for w in np.unique(self.window_week):
                q0, qp = parts(row_week != w)
                self.cross[w] = ({**self.q0, **q0}, {**self.qp, **qp})

    def gains_of(self, theta, q0=None, qp=None):
        """Season -> gains profile (n_slots, nx) for theta (the linear form of :meth:`gains_for`); ``q0``, ``qp``:
        another estimate's parts (a left-out week's cross-fitted ones), default this problem's."""
        q0, qp = (self.q0, self.qp) if q0 is None else (q0, qp)
        return {s: q0[s] - self._scatter(qp[s] * theta) for s in q0}

    # --- model and errors -------------------------------------------------------------------------------------
    def with_theta(self, theta, gains=None):
        """A copy of the model with parameters ``theta`` (and the given or re-estimated gains)."""
        import dataclasses

        m = self.model
        nx = self.nx
        A = m.A.copy()
        A[np.diag_indices(nx)] = theta[:nx]
        C = m.C.copy()
        C[self.cmask] = theta[self.c0 : self.o0]
        A[self.omask] = theta[self.o0 :]
        kw = {"A": A, "C": C}
        if self.delivered:
            kw["beta"] = theta[nx : 2 * nx].copy()
        else:
            B = m.B.copy()
            B[np.arange(nx), np.arange(nx)] = theta[nx : 2 * nx]
            kw["B"] = B
        new = dataclasses.replace(m, **kw)
        if gains is None:
            gains = self.gains_for(new)
        return dataclasses.replace(new, gains=gains)

    def gains_for(self, model):
        """Season -> time-of-week gains profile, eq. (qig_estimation) on the measured one-step residuals."""
        from .datadriven import estimate_gains

        r = self.rows
        zero = np.zeros((r.size, self.Y.shape[1]))
        qr = self.Y[r + 1] - model.step_state(self.Y[r], self.u[r], self.v[r], zero)
        gains = {}
        for s, prof in self.model.gains.items():
            sel = (self.seasons[r] == s) & self.prep.gain_ok[r]
            if sel.any():
                gains[s], _ = estimate_gains(qr[sel], self.slots[r][sel], self.prep.n_slots)
            else:
                gains[s] = prof
        return gains

    def _simulate(self, theta, jac=None):
        """States x(1..H) of every window (W, H, nx); with ``jac`` (W, H, nx, P), fills it with -w dx/dtheta."""
        rng, nx, P = self.rng, self.nx, self.n_par
        W, Hn = rng.shape
        gains = self._window_gains(theta)
        sensitivities = jac is not None
        qp = self._window_qp if sensitivities else None
        A_full = self.A_fixed.copy()
        A_full[np.diag_indices(nx)] += theta[:nx]
        A_full[self.omask] += theta[self.o0 :]
        beta = theta[nx : 2 * nx]
        x = self.Y[rng[:, 0]]
        X = np.empty((W, Hn, nx))
        S = np.zeros((W, nx, P)) if sensitivities else None
        for k in range(Hn):
            kk = rng[:, k]
            phi = self._features(x, kk)
            xn = self._fixed(x, kk) + self._scatter(phi * theta) + gains[:, k]
            if sensitivities:  # S+ = (A - diag(beta M)) S + (phi - dq/dtheta) on each parameter's row
                Sn = np.matmul(A_full, S)
                if self.delivered:
                    Sn -= (beta * self.M[kk])[:, :, None] * S
                S = Sn + (phi - qp[:, k])[:, None, :] * self.onehot[None]
                np.multiply(S, -self.weight, out=jac[:, k])  # weight (W, 1, 1)
            x = xn
            X[:, k] = x
        return X

    def _at_windows(self, profiles, width, windows=None):
        """Season profiles (n_slots, width) gathered at every window step (W, H, width), each window in its start's
        season (zeros where the season has none); only the ``windows`` (a mask) when given."""
        out = np.zeros(self.rng.shape + (width,))
        season0 = self.seasons[self.rng[:, 0]]
        for s, prof in profiles.items():
            sel = season0 == s
            if windows is not None:
                sel &= windows
            if sel.any():
                out[sel] = prof[self.slots[self.rng[sel]] % len(prof)]
        return out

    def _window_gains(self, theta):
        """Gains at every window step (W, H, nx) for theta."""
        if self.cross is None:
            return self._at_windows(self.gains_of(theta), self.nx)
        out = np.zeros(self.rng.shape + (self.nx,))
        for w, (q0, qp) in self.cross.items():
            sel = self.window_week == w
            out[sel] = self._at_windows(self.gains_of(theta, q0, qp), self.nx, sel)[sel]
        return out

    @functools.cached_property
    def _window_qp(self):
        """d gains / d theta_p at every window step (W, H, P) on row i_p (it does not depend on theta)."""
        if self.cross is None:
            return self._at_windows(self.qp, self.n_par)
        out = np.zeros(self.rng.shape + (self.n_par,))
        for w, (_, qp) in self.cross.items():
            sel = self.window_week == w
            out[sel] = self._at_windows(qp, self.n_par, sel)[sel]
        return out

    def _penalty(self, theta):
        """Stability: each row of |A| sums below 1 (hinge; only with free couplings; the entries are >= 0)."""
        rowsum = self.onehot[:, self.is_a] @ theta[self.is_a]
        return 1e3 * np.maximum(rowsum - self.row_limit, 0.0)

    def residuals(self, theta):
        """Open-loop errors of every training window [K] (flattened), then the stability hinge when couplings."""
        X = self._simulate(theta)
        err = (self.Y[self.rng + 1] - X) * self.weight
        err = np.nan_to_num(err, nan=0.0, posinf=1e3, neginf=-1e3).ravel()
        return np.r_[err, self._penalty(theta)] if self.omask.any() else err

    def jacobian(self, theta):
        """d residuals / d theta, exact (sensitivity recursion)."""
        Jm = np.empty(self.rng.shape + (self.nx, self.n_par))
        self._simulate(theta, jac=Jm)
        Jm = Jm.reshape(-1, self.n_par)
        if not self.omask.any():
            return Jm
        excess = self._penalty(theta) > 0
        Jp = 1e3 * self.onehot * (self.is_a[None, :] & excess[:, None])
        return np.vstack([Jm, Jp])


def _adjacent_mask(model, building):
    """(nx, nx) True where two states are adjacent zones of ``building`` (never the diagonal)."""
    nx = model.A.shape[0]
    mask = np.zeros((nx, nx), bool)
    names = {z: i for i, z in enumerate(model.outputs)}
    for a, b in building.adjacency_pairs():
        if a in names and b in names:
            mask[names[a], names[b]] = mask[names[b], names[a]] = True
    return mask


def refine_open_loop(
    model, prep, horizon: int = HORIZON_STEPS, max_nfev: int = 60, couplings: bool = False, weeks=None
):
    """Re-fit ``model``'s coefficients for open-loop prediction over ``horizon`` steps (see module docstring).

    Parameters
    ----------
    model : hvacfmu.models.linear.LinearZoneModel
        The model from the paper's one-step fit (the starting point).
    prep : hvacfmu.models.datadriven._Prepared
        The fit's arrays (training weeks, seasons, time-of-week slots).
    horizon : int [steps]
        Length of the simulated windows (default 96 = 24 h at 15 minutes).
    max_nfev : int
        Function-evaluation budget of the trust-region solver.
    weeks : array of int, optional
        Week number of every row: the gain profiles of each window are then estimated without its week
        (cross-fitted, :mod:`hvacfmu.models.memory`); the returned model's are from every training week.

    Returns
    -------
    model : LinearZoneModel
        The refined model (or the input one when there are too few windows or
        the refinement does not lower the training error).
    info : dict
        ``windows``, ``rms_before`` and ``rms_after`` [K] on the training
        windows (each season weighted alike), ``used`` and the reason when not used.
    """
    from scipy.optimize import least_squares

    filled = u, v = _filled_signals(model, prep)
    starts = training_windows(prep, horizon, inputs_ok=np.all(np.isfinite(u), axis=1) & np.all(np.isfinite(v), axis=1))
    if starts.size < 7:
        return model, {
            "used": False,
            "reason": f"only {starts.size} complete training days",
            "windows": int(starts.size),
        }
    pb = _Problem(model, prep, starts, horizon, couplings=couplings, filled=filled, weeks=weeks)
    r0 = pb.residuals(pb.theta0)
    sol = least_squares(
        pb.residuals, pb.theta0, jac=pb.jacobian, bounds=(pb.lb, pb.ub), x_scale="jac", max_nfev=max_nfev
    )
    w2 = np.broadcast_to(pb.weight**2, (starts.size, horizon, pb.Y.shape[1])).ravel()
    rms0 = float(np.sqrt(np.sum(r0**2) / np.sum(w2)))
    rms1 = float(np.sqrt(np.sum(sol.fun**2) / np.sum(w2)))
    info = {
        "windows": int(starts.size),
        "horizon_steps": int(horizon),
        "rms_before": rms0,
        "rms_after": rms1,
        "nfev": int(sol.nfev),
    }
    if not rms1 < rms0:
        info.update(used=False, reason="no improvement of the training windows' open-loop error")
        return model, info
    info["used"] = True
    return pb.with_theta(sol.x), info


__all__ = ["HORIZON_STEPS", "refine_open_loop", "training_windows"]
