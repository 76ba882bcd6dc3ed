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

import numpy as np

#: Open-loop horizon of the refinement criterion [steps] (24 h at 15 minutes).
HORIZON_STEPS = 96


def training_windows(prep, horizon: int):
    """Start rows of the training windows: every midnight whose window has complete training data.

    Parameters
    ----------
    prep : hvacfmu.models.datadriven._Prepared
        Arrays of the fit (regular grid, training mask).
    horizon : int [steps]

    Returns
    -------
    array of int
        Row indices into ``prep.frame``.
    """
    idx = prep.index
    n = len(idx)
    ok = prep.train & np.all(np.isfinite(prep.T), axis=1)
    bad = np.r_[0, np.cumsum(~ok)]
    mid = np.flatnonzero((idx.hour == 0) & (idx.minute == 0))
    mid = mid[mid + horizon + 1 <= n]
    return mid[bad[mid + horizon + 1] - bad[mid] == 0]


class _Problem:
    """Simulation of a LinearZoneModel's windows with free parameters theta (diag A, drive, C entries)."""

    def __init__(self, model, prep, starts, horizon):
        self.model, self.prep, self.horizon = model, prep, horizon
        frame = prep.frame
        self.Y = np.asarray(model.measured_outputs(frame), float)
        u, v = (np.asarray(a, float) for a in model.signals(frame))
        self.u, self.v = np.nan_to_num(u), np.nan_to_num(v)
        self.uv_ok = np.all(np.isfinite(u), axis=1) & np.all(np.isfinite(v), axis=1)
        self.rng = starts[:, None] + np.arange(horizon)[None, :]
        self.seasons = prep.season
        # every season weighs alike, however many training days it has (the goal is every season)
        ws = self.seasons[starts]
        count = {s: int(np.sum(ws == s)) for s in set(ws)}
        self.weight = np.array([1.0 / np.sqrt(count[s]) for s in ws])[:, None, None]
        self.slots = prep.slots
        nx = model.A.shape[0]
        self.delivered = model.beta is not None
        drive = model.beta if self.delivered else np.diag(model.B)
        self.cmask = model.C != 0.0
        self.theta0 = np.r_[np.diag(model.A), drive, model.C[self.cmask]]
        off = np.abs(model.A).sum(axis=1) - np.abs(np.diag(model.A))
        a_hi = np.maximum(1.0 - 1e-3 - off, 2e-4)
        d_lo, d_hi = (np.zeros(nx), np.full(nx, np.inf)) if self.delivered else (np.full(nx, -np.inf), np.zeros(nx))
        nc = int(self.cmask.sum())
        self.lb = np.r_[np.full(nx, 1e-4), d_lo, np.zeros(nc)]
        self.ub = np.r_[a_hi, d_hi, np.full(nc, np.inf)]
        self.theta0 = np.clip(self.theta0, self.lb, np.where(np.isfinite(self.ub), self.ub - 1e-9, self.ub))
        rows = np.flatnonzero(
            prep.train[:-1]
            & prep.train[1:]
            & self.uv_ok[:-1]
            & np.all(np.isfinite(self.Y[:-1]), axis=1)
            & np.all(np.isfinite(self.Y[1:]), axis=1)
        )
        self.rows = rows

    def with_theta(self, theta, gains=None):
        """A copy of the model with parameters ``theta`` (and the given or re-estimated gains)."""
        import dataclasses

        m = self.model
        nx = m.A.shape[0]
        A = m.A.copy()
        A[np.diag_indices(nx)] = theta[:nx]
        C = m.C.copy()
        C[self.cmask] = theta[2 * nx :]
        kw = {"A": A, "C": C}
        if self.delivered:
            kw["beta"] = theta[nx : 2 * nx].copy()
        else:
            kw["B"] = np.diag(theta[nx : 2 * nx])
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
            sel = self.seasons[r] == s
            if sel.any():
                gains[s], _ = estimate_gains(qr[sel], self.slots[r][sel], self.prep.n_slots)
            else:
                gains[s] = prof
        return gains

    def residuals(self, theta):
        """Open-loop errors of every training window [K], flattened."""
        model = self.with_theta(theta)
        rng = self.rng
        q = np.zeros(rng.shape + (self.Y.shape[1],))
        for s, prof in model.gains.items():
            sel = self.seasons[rng[:, 0]] == s
            q[sel] = np.asarray(prof)[self.slots[rng[sel]] % len(prof)]
        _, Yp = model.simulate(self.Y[rng[:, 0]], self.u[rng], self.v[rng], q)
        err = (self.Y[rng + 1] - Yp[:, 1:, :]) * self.weight
        return np.nan_to_num(err, nan=0.0, posinf=1e3, neginf=-1e3).ravel()


def refine_open_loop(model, prep, horizon: int = HORIZON_STEPS, max_nfev: int = 60):
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

    starts = training_windows(prep, horizon)
    if starts.size < 7:
        return model, {
            "used": False,
            "reason": f"only {starts.size} complete training days",
            "windows": int(starts.size),
        }
    pb = _Problem(model, prep, starts, horizon)
    r0 = pb.residuals(pb.theta0)
    sol = least_squares(
        pb.residuals, pb.theta0, bounds=(pb.lb, pb.ub), x_scale="jac", max_nfev=max_nfev, diff_step=1e-4
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
