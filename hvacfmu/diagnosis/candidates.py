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
    for c in out:
        _mark_column_taken(sig, terms, c)
    return out


def shared_sources(sig: Signals, a, b) -> list:
    """Measured columns two terms both bring into one zone's equation (:meth:`Term.sources`), sorted; [] when
    they act on different zones or read different columns."""
    if not set(a.zones()) & set(b.zones()):
        return []
    return sorted(a.sources(sig) & b.sources(sig))


def _mark_column_taken(sig: Signals, terms, c) -> None:
    """A candidate that would read, at a zone, a column an accepted term already reads there is not tested.

    Its gain is the gain that term already took (the same discharge heat named ``reheat`` and again
    ``unused_input Td_<vav>``): one measured column, one cause. The rival of the round that accepted
    the term was scored then (``hvacfmu.diagnosis.selection``); here it is named with the reason.
    """
    if not c.variants or c.status != "not tested":
        return
    for t in terms:
        shared = [shared_sources(sig, v, t) for v in c.variants]
        if all(shared):
            c.status = "no evidence"
            c.reason = (
                f"reads {', '.join(shared[0])}, which the accepted {t.cause} at {t.location()} already brings into "
                f"the zone's equation: one measured column is named by one cause"
            )
            c.evidence["column_taken_by"] = {"cause": t.cause, "location": t.location(), "columns": shared[0]}
            return


_params = term_params

__all__ = [
    "Candidate",
    "apparent_gains",
    "day_departures",
    "dst_profile_lag",
    "generate",
    "shared_sources",
    "shifted_clock_profiles",
]
