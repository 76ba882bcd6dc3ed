"""What every diagnosis cause plugin implements: its model term and its candidates.

A cause is one module of :mod:`hvacfmu.models.causes` holding

- a :class:`Term` subclass — the model term: JSON (``to_dict``/``from_dict``), the
  regressors its coefficients multiply in the least-squares refit (``features``), the fitted
  copy (``with_fit``), its contribution to one step of the model (``contribute``), its hidden
  states, and its part of the matrix form (``add_equations``, :mod:`hvacfmu.models.equations`);
- a screen (``Term.screen``): the candidates of this cause at every location the data allow,
  each with evidence computed from the current one-step residuals of the training rows.

The selection loop of :mod:`hvacfmu.diagnosis` iterates the registry
(:func:`hvacfmu.models.causes.causes`); nothing in this package imports the diagnosis.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from ...errors import ModelError


def num(d, key, what, problems, default=None):
    """``float(d[key])`` or NaN, appending a message to ``problems`` when missing or not finite."""
    if key not in d:
        if default is not None:
            return default
        problems.append(f"{what}: missing {key!r}")
        return np.nan
    try:
        x = float(d[key])
    except (TypeError, ValueError):
        problems.append(f"{what}: {key!r} must be a number, got {d[key]!r}")
        return np.nan
    if not np.isfinite(x):
        problems.append(f"{what}: {key!r} must be finite, got {x}")
    return x


def zone_of(d, key, zone_names, what, problems):
    """The zone named by ``d[key]``, checked against the model's zones."""
    z = d.get(key)
    if z not in zone_names:
        problems.append(f"{what}: {key} {z!r} is not a zone of the model {list(zone_names)}")
    return z


def corr(a, b) -> float:
    """Pearson correlation over the rows where both are finite (NaN with fewer than 10)."""
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < 10:
        return float("nan")
    a, b = a[ok] - a[ok].mean(), b[ok] - b[ok].mean()
    d = np.sqrt((a @ a) * (b @ b))
    return float(a @ b / d) if d > 0 else float("nan")


def cond_mean(r, mask) -> dict:
    """Mean of ``r`` where ``mask`` holds, with the row count."""
    mask = np.asarray(mask, bool)
    n = int(mask.sum())
    return {"mean": float(np.mean(r[mask])) if n else None, "n": n}


@dataclasses.dataclass
class StepContext:
    """What a term's :meth:`Term.contribute` reads and writes during one model step.

    ``T`` (…, nz) zone temperatures at k, ``x`` the full state, ``u_eff`` airflows after
    delays [kg/s], ``v`` disturbances in the model's order, ``Tn`` next zone temperatures
    (written in place), ``x_new`` next full state (hidden parts written in place), ``zi`` and
    ``vi`` name -> index maps, ``off`` the term's first hidden state.
    """

    x: np.ndarray
    T: np.ndarray
    u: np.ndarray
    u_eff: np.ndarray
    v: np.ndarray
    Tn: np.ndarray
    x_new: np.ndarray
    zi: dict
    vi: dict
    off: int = 0


@dataclasses.dataclass
class EquationParts:
    """Mutable matrices of an extended model's :class:`~hvacfmu.models.equations.ModelEquations`.

    Terms add their part in place: ``A`` (nx, nx), ``Bu`` (nx, nu), ``Bv`` (nx, nv), ``Bxu`` and
    ``Bvu`` lists of nu matrices, ``Bxv`` and ``Bvv`` lists of nv matrices (products with a
    disturbance: ``v_j (Bxv_j x + Bvv_j v)``), ``switches`` a list; ``zi``/``vi`` name -> index,
    ``u_state`` maps a zone index to the state that holds its delayed airflow (when delayed).
    """

    A: np.ndarray
    Bu: np.ndarray
    Bv: np.ndarray
    Bxu: list
    Bvu: list
    switches: list
    zi: dict
    vi: dict
    u_state: dict
    off: int = 0
    Bxv: list = dataclasses.field(default_factory=list)
    Bvv: list = dataclasses.field(default_factory=list)


@dataclasses.dataclass(frozen=True)
class Term:
    """One extension term of :class:`~hvacfmu.models.extended.ExtendedModel` (see the module docstring).

    ``cause`` is the registered cause id; ``std`` holds 1-sigma uncertainties of the fitted
    coefficients (same keys as the coefficients, JSON-ready). Subclasses are frozen dataclasses.
    """

    cause: ClassVar[str] = ""
    #: one-line description for the README and ``--help``
    description: ClassVar[str] = ""
    #: False when the term has no ``ModelEquations`` form (:meth:`add_equations` refuses): no native FMU, no MPC;
    #: the diagnosis's control model leaves it out (:func:`hvacfmu.diagnosis.control.terms_on_base`). Every
    #: registered cause but ``held_setpoint`` (a limiter) has one (``wind_infiltration`` through ``Bxv``/``Bvv``).
    matrix_form: ClassVar[bool] = True
    #: True for a catch-all cause that names a measured column, not a mechanism (``unused_input``): when a
    #: cause-specific term reads the same column and the cross-validation cannot tell them apart, the specific
    #: one is named (:meth:`sources`, ``hvacfmu.diagnosis.selection``)
    generic: ClassVar[bool] = False
    #: True for a term that limits the next zone temperature (``held_setpoint``): its :meth:`contribute` runs after
    #: every other term's
    limiter: ClassVar[bool] = False
    #: True for a term that depends on the date (holidays, a daylight-saving shift, a sensor offset from a date on):
    #: it acts through :meth:`gain_adjustment`, has no time-invariant matrix form, and its FMU reads the calendar
    calendar: ClassVar[bool] = False
    #: searched hyper-parameters charged in the information criterion for one candidate
    std: dict = dataclasses.field(default_factory=dict, compare=False)

    # --- identity -------------------------------------------------------------------
    def columns(self) -> tuple:
        """Frame columns this term reads as disturbances (beyond the base model's)."""
        return ()

    def sources(self, sig) -> frozenset:
        """Measured frame columns whose information the term's regressor brings into the model.

        Beyond what every zone equation reads (zone temperatures, airflows, ``T_out``): a derived
        column is named by the measured columns it is built from (the reheat heat ``Qrh_<zone>`` by
        its boxes' ``Td_<vav>``; the mean ``T_supply`` by the units' ``T_supply_<ahu>``). Two terms of
        different causes at one zone whose sources overlap compete for one gain: the diagnosis names
        the one the evidence favours and reports the other as its rival, and does not name the same
        column again under another cause (``sig``: :class:`~hvacfmu.models.causes.signals.Signals`).
        Default: none.
        """
        return frozenset()

    def zones(self) -> tuple:
        """Zones the term acts on (its location)."""
        raise NotImplementedError

    def affected(self, zones: tuple) -> tuple:
        """Zones whose equations change (default: :meth:`zones`)."""
        return self.zones()

    def location(self) -> dict:
        """JSON-ready location (zones, facade, pair, delay ...)."""
        raise NotImplementedError

    def coefficients(self) -> dict:
        """Fitted coefficients (name -> float or mapping)."""
        return {}

    def to_dict(self) -> dict:
        d = {"cause": self.cause}
        d.update(self.location())
        d.update(self.coefficients())
        if self.std:
            d["std"] = dict(self.std)
        return d

    @classmethod
    def from_dict(cls, d: dict, zone_names: tuple, problems: list, std: dict) -> Term:
        """Rebuild the term from its JSON mapping, appending problems to ``problems``."""
        raise NotImplementedError

    # --- hidden states --------------------------------------------------------------
    def n_hidden(self) -> int:
        return 0

    def hidden_names(self) -> list:
        return []

    def hidden_history(self, Y: np.ndarray, U: np.ndarray, zi: dict) -> np.ndarray | None:
        """Hidden states (n, n_hidden) along measured outputs ``Y`` and airflows ``U`` (teacher forcing)."""
        return None

    def delayed_input(self) -> tuple | None:
        """``(zone, delay)`` when the term delays a zone's airflow (then it implements ``shift_input``)."""
        return None

    def shift_input(self, c: StepContext) -> None:
        """Replace ``c.u_eff`` of the delayed zone and update the buffer in ``c.x_new`` (delay terms)."""

    def derive(self, frame, base) -> dict:
        """Disturbance columns the term derives from other frame columns ``{name: array}`` (default none)."""
        return {}

    # --- regression -------------------------------------------------------------------
    def features(self, sig, U_eff: np.ndarray) -> list:
        """Regressors of the refit: list of ``(zone index, name, array (n,), lower, upper)``.

        The term adds Σ coef · feature to the zone's equation; ``sig`` is a
        :class:`~hvacfmu.models.causes.signals.Signals`.
        """
        return []

    def with_fit(self, sig, coefs: dict, stds: dict) -> Term:
        """The term with the fitted coefficients (``coefs``/``stds`` keyed by feature name)."""
        if "coef" in coefs or hasattr(self, "coef"):
            return dataclasses.replace(self, coef=coefs.get("coef", 0.0), std={"coef": stds.get("coef", 0.0)})
        return self

    # --- simulation and equations --------------------------------------------------------
    def contribute(self, c: StepContext) -> None:
        """Add the term's part of one step to ``c.Tn`` / ``c.x_new`` (in place)."""

    def add_equations(self, e: EquationParts) -> None:
        """Add the term's part to the matrix form (in place); raise ModelError when it has none."""
        raise ModelError(f"{self.cause} term has no time-invariant linear/bilinear equations")

    def gain_adjustment(self, index, profile: np.ndarray, step: float, holidays=()) -> np.ndarray | None:
        """Calendar adjustment of the internal gains (n, nz) [K per step], or None (``holidays``: the model's
        calendar, whose days read Sunday's profile)."""
        return None

    # --- diagnosis ---------------------------------------------------------------------
    @classmethod
    def screen(cls, sig, terms, W, resid: np.ndarray, options: dict) -> list:
        """Candidates of this cause (list of :class:`Candidate`) with their evidence.

        ``sig`` Signals, ``terms`` the current terms, ``W`` the within transform over the
        training rows, ``resid`` (len(W.rows), nz) current one-step within residuals [K],
        ``options`` the diagnosis options (``_resid_all``: one-step residuals on every row,
        NaN outside the training folds).
        """
        return []

    @classmethod
    def compete(cls, cand, sig, terms, W, resid) -> dict:
        """Cause-specific evidence computed after the candidate's fit (default: nothing)."""
        return {}


@dataclasses.dataclass
class Candidate:
    """One candidate cause at one location.

    Attributes
    ----------
    cause : str
        Registered cause id.
    location : dict
        Zones, facade, pair, delay ... (JSON-ready).
    variants : list of Term
        Terms to try (e.g. several time constants); the best one is kept.
    hyper : int
        Number of searched hyper-parameters charged in the information criterion.
    status : str
        ``"found"``, ``"not significant"``, ``"no held-out gain"``, ``"no evidence"``,
        ``"untestable"``, ``"not tested"``.
    reason : str
    evidence : dict
        Numbers from the data (correlations, conditional means, lags ...).
    test : dict
        Likelihood-ratio test on the training rows and the cross-validation.
    term : Term or None
        The fitted term (best variant).
    heldout : dict or None
        Held-out RMS before/after per affected zone and ``gain_percent``.
    """

    cause: str
    location: dict
    variants: list = dataclasses.field(default_factory=list)
    hyper: int = 0
    status: str = "not tested"
    reason: str = ""
    evidence: dict = dataclasses.field(default_factory=dict)
    test: dict = dataclasses.field(default_factory=dict)
    term: object = None
    heldout: dict | None = None
    #: gain profiles (season -> (n_tow, nz)) the candidate's features use, per variant key (DST shift)
    profiles: dict | None = None
    cv: dict | None = None
    competitors: list = dataclasses.field(default_factory=list)
    #: runner-up variants, best one-step fit first, each ``{"term", "test", "history"}``: the diagnosis may
    #: cross-validate them (an actuation delay's length is picked by the 24-h prediction)
    alternatives: list = dataclasses.field(default_factory=list)

    @property
    def key(self) -> str:
        loc = ",".join(f"{k}={v}" for k, v in sorted(self.location.items()) if k not in ("dates",))
        return f"{self.cause}({loc})"

    def to_dict(self) -> dict:
        return {
            "cause": self.cause,
            "location": self.location,
            "status": self.status,
            "reason": self.reason,
            "evidence": self.evidence,
            "test": self.test,
            "cv": self.cv,
            "competitors": self.competitors,
            "parameters": None if self.term is None else term_params(self.term),
            "heldout": self.heldout,
        }


def term_params(term) -> dict:
    """Coefficients of a term with their standard deviations (JSON-ready)."""
    out = {}
    std = term.std or {}
    for k, v in term.coefficients().items():
        if isinstance(v, dict):
            out[k] = {z: {"value": float(c), "std": float(std.get(k, {}).get(z, 0.0))} for z, c in v.items()}
        elif k in std:
            out[k] = {"value": float(v), "std": float(std[k])}
        else:
            out[k] = {"value": float(v), "std": None}
    return out
