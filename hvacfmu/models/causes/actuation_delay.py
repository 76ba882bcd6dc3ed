"""Cause ``actuation_delay``: a zone's airflow acts ``delay`` steps late.

Term: ``u_z(k)`` is replaced by ``u_z(k − delay)`` everywhere in the model; the last
``delay`` airflows are hidden states. Screen: one candidate per zone, delays 1 ..
:func:`~hvacfmu.models.causes.signals.max_delay` (one hour); evidence: cross-correlation of the residual
with the airflow by lag, past (``u(k − lag)``) and future (``u(k + lag)``, what a feedback
loop produces: the controller answers the temperature error), and the best past lag.

Feedback is not delay. In closed loop the airflow a controller set ``d`` steps ago is a function
of the zone's temperature then, so ``u(k − d)`` can stand in for the zone's own past temperature
(a fast mass, the air node of a detailed simulation, a controller holding a setpoint) that the
first-order equation lacks, and "explain" the zone without acting late (EnergyPlus's VAV boxes, which
have no actuator delay: Denver Core, ``benchmarks/diagnosis_energyplus_s12.md``). A real delay acts
through the airflow whatever set it, so its gain survives when the zone's own temperatures of the last
:data:`HISTORY_S` (``T_z(k − 1) … T_z(k − L)``, :func:`temperature_history`) are added, free, to both
equations. The diagnosis (``hvacfmu.diagnosis.selection.delay_given_history``) refits the zone's
equation with and without the delay on that history and requires the same ΔBIC margin as the screen
(``evidence["history"]``). Measured at the base structure (``benchmarks/bench_diagnosis_delay_evidence.py``,
``benchmarks/diagnosis_energyplus_s12.md``): the battery's seven injected delays score ΔBIC 1 021–3 117
given the history (plain 677–1 954); the 99 emulator zones without a delay −1 489 … −51 (plain all
negative); the 60 EnergyPlus zones −115 … 6.6, while 37 of them pass the plain screen (up to 628).

A loop that cycles at twice the data's step is not a delay either. At that period the airflow's cycle
flips sign from one step to the next, ``u(k − 1) − ū ≈ −(u(k) − ū)``, so a delay by an odd number of steps
can fit the cycle's sampled phase (the airflow at the sampling instant against the heat of the whole step)
and survive the history test (ell5 cold1, zone S: one box whose PI loop cycles every 30 min in 15-min data;
ΔBIC 125 given the history, no delay in the truth; ``benchmarks/delayguard_s17.md``). A real delay acts on
the airflow's slower moves as well, so it must also hold with the airflow low-passed by
:func:`lowpass_airflow` (the centred ``[1, 2, 1] / 4`` filter: zero gain at a period of two steps, no phase
shift) in both equations (``evidence["history_lowpass"]``, same margin). Measured at the base structure: the
quad4 and default battery's true delays 265 … 1 897 (LR, not deflated), S −31.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from ...errors import ModelError
from .base import Candidate, EquationParts, StepContext, Term, corr, zone_of
from .signals import MAX_DELAY_S, max_delay, shifted

#: Own-temperature history a delay must explain the zone beyond [s]: the longest delay tested (one hour).
HISTORY_S = MAX_DELAY_S


def history_lags(step: float) -> int:
    """Number of past temperatures in :func:`temperature_history` at model step ``step`` [s] (:data:`HISTORY_S`)."""
    return max(1, int(round(HISTORY_S / float(step))))


def temperature_history(y: np.ndarray, step: float) -> np.ndarray:
    """The zone's own past temperatures ``y(k − 1) … y(k − L)`` (n, L) [°C], L = :func:`history_lags` (NaN before the data)."""
    y = np.asarray(y, dtype=float)
    return np.column_stack([shifted(y, j) for j in range(1, history_lags(step) + 1)])


def lowpass_airflow(u: np.ndarray) -> np.ndarray:
    """``(u(k − 1) + 2 u(k) + u(k + 1)) / 4`` (n,) [kg/s]: the airflow without a cycle of period two steps.

    Centred, so no phase shift (a one-sided mean would itself be half a step of delay); where a neighbour
    is missing (the ends, gaps) it stands in with ``u(k)``. It reads ``u(k + 1)``, which a controller sets
    from ``T(k + 1)``: that favours the equation without the delay, so the test it serves is conservative
    for a delay.
    """
    u = np.asarray(u, dtype=float)
    prv, nxt = shifted(u, 1), np.r_[u[1:], np.nan]
    prv = np.where(np.isfinite(prv), prv, u)
    nxt = np.where(np.isfinite(nxt), nxt, u)
    return 0.25 * (prv + 2.0 * u + nxt)


@dataclasses.dataclass(frozen=True)
class ActuationDelay(Term):
    """The airflow of ``zone`` acts ``delay`` steps late."""

    cause: ClassVar[str] = "actuation_delay"
    description: ClassVar[str] = "airflow acting late (zone, delay in steps)"
    zone: str = ""
    delay: int = 1

    def zones(self):
        return (self.zone,)

    def location(self):
        return {"zone": self.zone, "delay": int(self.delay)}

    @classmethod
    def from_dict(cls, d, zone_names, problems, std):
        what = f"extension term {cls.cause}"
        dl = d.get("delay")
        if not (isinstance(dl, int) and 1 <= dl <= 96):
            problems.append(f"{what}: delay must be an integer number of steps in 1..96, got {dl!r}")
            dl = 1
        return cls(zone=zone_of(d, "zone", zone_names, what, problems), delay=dl, std=std)

    def delayed_input(self):
        return (self.zone, int(self.delay))

    def n_hidden(self):
        return int(self.delay)

    def hidden_names(self):
        return [f"u_{self.zone}_lag{self.delay - j}" for j in range(self.delay)]

    def hidden_history(self, Y, U, zi):
        u = U[:, zi[self.zone]]
        return np.column_stack([shifted(u, self.delay - j) for j in range(self.delay)])

    def with_fit(self, sig, coefs, stds):
        return self

    def shift_input(self, c: StepContext) -> None:
        """Replace the zone's airflow by the oldest buffered one and push the current one."""
        zi, n, off = c.zi[self.zone], int(self.delay), c.off
        buf = c.x[..., off : off + n]
        c.u_eff[..., zi] = buf[..., 0]
        c.x_new[..., off : off + n - 1] = buf[..., 1:]
        c.x_new[..., off + n - 1] = c.u[..., zi]

    def add_equations(self, e: EquationParts) -> None:
        zi, n, off = e.zi[self.zone], int(self.delay), e.off
        if np.any(e.Bxu[zi]) or np.any(e.Bvu[zi]):
            raise ModelError(
                f"actuation_delay in zone {self.zone!r} of a model bilinear in that airflow (delivered "
                "heat): the delayed airflow times the state is quadratic, no bilinear equations"
            )
        for j in range(n - 1):
            e.A[off + j, off + j + 1] = 1.0
        e.Bu[off + n - 1, zi] = 1.0
        # the airflow acts through the oldest buffered value
        e.A[:, off] += e.Bu[:, zi] * (np.arange(e.A.shape[0]) < len(e.zi))
        e.Bu[: len(e.zi), zi] = 0.0
        e.u_state[zi] = off

    @classmethod
    def screen(cls, sig, terms, W, resid, options):
        have = {t.zone for t in terms if isinstance(t, ActuationDelay)}
        out = []
        for zi, z in enumerate(sig.zones):
            if z in have:
                continue
            ev = delay_evidence(sig, W, resid[:, zi], sig.U[:, zi])
            out.append(
                Candidate(
                    cls.cause,
                    {"zone": z},
                    [cls(zone=z, delay=d) for d in range(1, max_delay(sig.step) + 1)],
                    0,
                    evidence=ev,
                )
            )
        return out


def delay_evidence(sig, W, r, u) -> dict:
    """Cross-correlation of the residual with past and future airflow, by lag [steps]."""
    fill = float(np.nanmean(u))
    past, future = {}, {}
    for lag in range(max_delay(sig.step) + 3):
        past[str(lag)] = corr(r, W(np.nan_to_num(shifted(u, lag), nan=fill)))
        if lag:
            fu = np.full(len(u), np.nan)
            fu[:-lag] = u[lag:]
            future[str(lag)] = corr(r, W(np.nan_to_num(fu, nan=fill)))
    best = max((k for k in past if k != "0" and np.isfinite(past[k])), key=lambda k: abs(past[k]), default=None)
    return {
        "xcorr_resid_airflow_by_lag": past,
        "xcorr_resid_future_airflow_by_lag": future,
        "best_past_lag": None if best is None else int(best),
    }
