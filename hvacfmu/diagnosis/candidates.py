"""Candidate generation: every registered cause screens the data (:mod:`hvacfmu.models.causes`).

Each cause module's ``screen`` returns its candidates (extension terms at named locations)
with evidence computed from the current model's one-step residuals on the training rows.
The confirmation (cross-validation, likelihood-ratio test, held-out gain) is in
:mod:`hvacfmu.diagnosis.selection`.
"""

from __future__ import annotations

from ..models.causes import causes
from ..models.causes.base import Candidate, term_params
from ..models.causes.internal_gain_schedule import (
    apparent_gains,
    day_departures,
    dst_profile_lag,
    shifted_clock_profiles,
)
from ..models.causes.signals import Signals, Within


def generate(sig: Signals, terms, W: Within, resid, options: dict) -> list:
    """All candidates of every registered cause not yet in ``terms``, each with its evidence.

    Parameters
    ----------
    sig : Signals
    terms : list of Term
        The current extension terms.
    W : Within
        Within transform over the training rows.
    resid : array (len(W.rows), nz) [K]
        Current one-step within residuals on ``W.rows``.
    options : dict
        Diagnosis options (``_resid_all``: one-step residuals of every row, NaN outside the training rows).
    """
    out = []
    for cls in causes():
        out += cls.screen(sig, terms, W, resid, options)
    return out


_params = term_params

__all__ = ["Candidate", "apparent_gains", "day_departures", "dst_profile_lag", "generate", "shifted_clock_profiles"]
