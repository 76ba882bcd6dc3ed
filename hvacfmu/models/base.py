"""The interface every zone model implements, and JSON (de)serialisation helpers.

Every model kind (lumped and six-zone Model A, physics Model B, extended models
from the diagnosis) is a :class:`ZoneModel`. Evaluation, FMU export, the
harness and MPC only use this interface, so a new kind plugs in without change.

Conventions
-----------
- Argument order is always ``(x, u, v, q)``: state, controlled inputs
  (airflows [kg/s]), disturbances (``T_out``, ``T_supply`` [°C], facade
  irradiance ``I_<o>`` [W/m2]), internal-gain term ``q`` (model specific).
- All array methods accept a leading batch dimension.
- ``frame`` is the prepared measurement table (:func:`hvacfmu.data.prepare`):
  a DataFrame on the model step with a tz-aware local DatetimeIndex.
"""

from __future__ import annotations

import abc
import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..calendars import gain_slots
from ..errors import ModelError
from ..timeutil import n_time_of_week

FORMAT_VERSION = 1
#: ``format_version`` of a Model A file holding one coefficient set per season (its ``seasonal`` block,
#: :class:`~hvacfmu.models.linear.SeasonalZoneModel`): a reader older than session 21 refuses it ("newer than this
#: hvacfmu understands") instead of reading one set. Files of one set keep :data:`FORMAT_VERSION`.
SEASONAL_FORMAT_VERSION = 2


class ZoneModel(abc.ABC):
    """Abstract zone model: discrete-time, one step = ``self.step`` seconds."""

    # Subclasses provide these attributes:
    kind: str  #: model kind ("lumped", "zones", "physics", "extended")
    step: float  #: model step [s]
    outputs: tuple  #: output names (zone names, or ("floor",) for the lumped model)
    inputs: tuple  #: names of the controlled inputs u
    disturbances: tuple  #: frame column names of v, in order
    gains: dict  #: season -> (n_time_of_week, n_q) internal-gain profile
    holidays: tuple = ()  #: ISO dates (weekdays) whose gains follow Sunday's profile (hvacfmu.calendars)

    # ----- dimensions ----------------------------------------------------
    @property
    @abc.abstractmethod
    def n_states(self) -> int: ...

    @property
    def n_outputs(self) -> int:
        return len(self.outputs)

    @property
    def n_inputs(self) -> int:
        return len(self.inputs)

    @property
    def n_disturbances(self) -> int:
        return len(self.disturbances)

    @property
    def seasons(self) -> tuple:
        return tuple(self.gains)

    #: True for a model holding one coefficient set per season (:class:`~hvacfmu.models.linear.SeasonalZoneModel`):
    #: it runs only through :meth:`for_season`.
    seasonal: bool = False

    def for_season(self, season: str) -> ZoneModel:
        """The model that runs in ``season``: ``self`` for a model of one coefficient set (every kind but a
        seasonal Model A, whose override returns that season's set). Every consumer that fixes a season (evaluation
        windows, FMU ``season`` parameter, MPC ``context.season``) runs ``model.for_season(season)``."""
        return self

    # ----- data -> signals ---------------------------------------------
    @abc.abstractmethod
    def measured_outputs(self, frame: pd.DataFrame) -> np.ndarray:
        """Measured outputs (n, n_outputs) [°C] from a prepared frame."""

    @abc.abstractmethod
    def signals(self, frame: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
        """Controlled inputs u (n, n_inputs) and disturbances v (n, n_disturbances)."""

    def gains_at(self, index: pd.DatetimeIndex, season: str) -> np.ndarray:
        """Internal-gain term q (n, n_q) at the timestamps of ``index`` for ``season``."""
        if season not in self.gains:
            raise ModelError(f"model has no internal-gain profile for season {season!r}; has {list(self.gains)}")
        prof = np.asarray(self.gains[season])
        # a holiday weekday reads Sunday's profile (hvacfmu.calendars)
        return prof[gain_slots(index, self.step, getattr(self, "holidays", ())) % prof.shape[0]]

    def initial_state(self, frame: pd.DataFrame, k0: int) -> np.ndarray:
        """State at row ``k0`` of ``frame``; may use rows before it (e.g. a Kalman filter).

        The default takes the measured outputs as the state (valid when the
        state is the zone temperatures).
        """
        return self.measured_outputs(frame.iloc[k0 : k0 + 1])[0]

    # ----- dynamics ------------------------------------------------------
    @abc.abstractmethod
    def step_state(self, x, u, v, q) -> np.ndarray:
        """x(k+1) from x(k), u(k), v(k), q(k); batched over leading dimensions."""

    @abc.abstractmethod
    def output(self, x) -> np.ndarray:
        """y = C x; batched."""

    def simulate(self, x0, u, v, q) -> tuple[np.ndarray, np.ndarray]:
        """Open-loop simulation over n steps.

        Parameters
        ----------
        x0 : array (..., n_states)
        u : array (..., n, n_inputs) [kg/s]
        v : array (..., n, n_disturbances)
        q : array (..., n, n_q)

        Returns
        -------
        X : array (..., n+1, n_states)
        Y : array (..., n+1, n_outputs) [°C]
        """
        x = np.asarray(x0, dtype=float)
        u, v, q = (np.asarray(a, dtype=float) for a in (u, v, q))
        n = u.shape[-2]
        X = np.empty(x.shape[:-1] + (n + 1, x.shape[-1]))
        X[..., 0, :] = x
        for k in range(n):
            x = self.step_state(x, u[..., k, :], v[..., k, :], q[..., k, :])
            X[..., k + 1, :] = x
        return X, self.output(X)

    # ----- persistence ---------------------------------------------------
    @abc.abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready mapping; must contain ``kind`` and ``format_version``."""

    @classmethod
    @abc.abstractmethod
    def from_dict(cls, d: dict[str, Any]) -> ZoneModel: ...

    def save(self, path) -> Path:
        """Write the model as JSON; ``meta["coefficients_sha256"]`` seals its numbers (:func:`coefficients_sha256`)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        d = self.to_dict()
        if isinstance(d.get("meta"), dict):
            d = {**d, "meta": {**d["meta"], "coefficients_sha256": coefficients_sha256(d)}}
        path.write_text(json.dumps(d, indent=1, allow_nan=False), encoding="utf-8")
        return path


def season_model(model, season: str):
    """``model.for_season(season)`` (the model that runs in ``season``); ``model`` itself for an object without
    that method (a duck-typed model of one set). A consumer that fixes a season calls this before it simulates."""
    f = getattr(model, "for_season", None)
    return f(season) if callable(f) else model


def coefficients_sha256(d: dict) -> str:
    """SHA-256 of a model file's mapping without its top-level ``meta`` (coefficients, names, gains, terms).

    :meth:`ZoneModel.save` stores it in ``meta``; :func:`hvacfmu.models.load_model` warns when a file's numbers no
    longer match it (edited by hand or by another tool: the fit's checks and scores in ``meta`` then describe
    another model). JSON floats round-trip exactly, so a file read back unchanged always matches.
    """
    import hashlib

    body = {k: v for k, v in d.items() if k != "meta"}
    return hashlib.sha256(json.dumps(body, sort_keys=True, allow_nan=False, separators=(",", ":")).encode()).hexdigest()


# ----------------------------------------------------------------------------
# helpers for subclasses
# ----------------------------------------------------------------------------
def check_shape(M, shape, name) -> np.ndarray:
    """Return M as a float array, raising ModelError naming ``name`` if its shape is wrong."""
    M = np.asarray(M, dtype=float)
    if M.shape != tuple(shape):
        raise ModelError(f"{name} has shape {M.shape}, expected {tuple(shape)}")
    if not np.all(np.isfinite(M)):
        raise ModelError(f"{name} contains NaN or infinite values")
    return M


def check_names(value, key: str, what: str = "model file") -> tuple:
    """``value`` as a tuple of strings; ModelError naming ``key`` if it is not a list of strings."""
    if not isinstance(value, (list, tuple)) or not all(isinstance(s, str) for s in value):
        raise ModelError(f"{what}: '{key}' must be a list of names (strings), got {type(value).__name__} {value!r:.80}")
    return tuple(value)


def check_dates(value, key: str = "holidays", what: str = "model file") -> tuple:
    """A tuple of ISO dates ``YYYY-MM-DD`` from a model file's list (ModelError naming the bad entry)."""
    import datetime as _dt

    if not isinstance(value, (list, tuple)):
        raise ModelError(f"{what}: {key!r} must be a list of dates 'YYYY-MM-DD', got {type(value).__name__}")
    for d in value:
        try:
            _dt.date.fromisoformat(d)
        except (TypeError, ValueError):
            raise ModelError(f"{what}: {key!r} holds {d!r}, not a date 'YYYY-MM-DD'") from None
    return tuple(value)


def check_number(value, key: str, what: str = "model file", positive: bool = True) -> float:
    """``value`` as a finite float (> 0 when ``positive``); booleans and strings are refused."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise ModelError(f"{what}: '{key}' must be a finite number, got {value!r:.80}")
    if positive and not value > 0:
        raise ModelError(f"{what}: '{key}' must be > 0, got {value!r}")
    return float(value)


def check_mapping(value, key: str, what: str = "model file") -> dict:
    """``value`` as a dict; ModelError naming ``key`` otherwise."""
    if not isinstance(value, dict):
        raise ModelError(f"{what}: '{key}' must be a table (JSON object), got {type(value).__name__}")
    return dict(value)


def require_columns(frame: pd.DataFrame, columns, model, what: str) -> None:
    """Raise ModelError if ``frame`` lacks ``columns`` the model needs, naming the model's and the data's zones.

    Parameters
    ----------
    frame : DataFrame
        Prepared data.
    columns : sequence of str
        Columns the model reads.
    model : ZoneModel
    what : str
        What the columns are for ("zone temperatures", "inputs" ...).
    """
    missing = [c for c in columns if c not in frame.columns]
    if not missing:
        return
    data_zones = [c[2:] for c in frame.columns if c.startswith("T_") and not c.startswith(("T_out", "T_supply"))]
    model_zones = list(getattr(model, "measured_zones", None) or model.outputs)
    raise ModelError(
        f"the {getattr(model, 'kind', '?')} model does not fit these data: they lack the {what} column(s) "
        f"{missing}. Model zones: {model_zones}; data zones: {data_zones}. Fit the model on data of this "
        "building, or use the building file the model was made for"
    )


def building_mismatch(model, building) -> tuple[list[str], list[str]]:
    """``(problems, notes)`` of using ``model`` with ``building`` (a :class:`~hvacfmu.building.Building`).

    Problems: boxes of the model that the building file does not declare (its
    limits and zones cannot be the model's); box coefficients that at the building's ``m_max`` would take a
    room past its supply air in one step (:func:`~hvacfmu.models.loadcheck.box_drive_problems`). Notes: the model's provenance
    (``meta["building"]``, ``meta["building_sha256"]``, written by ``fit``) names
    another building, or the same building from a file that has changed since the
    fit (box limits, zones or areas may differ from what the model learned).
    """
    problems: list[str] = []
    notes: list[str] = []
    if building is None:
        return problems, notes
    known = {v.name for v in getattr(building, "vavs", ())}
    boxes = [str(v) for v in (getattr(model, "vavs", None) or ())]
    missing = [v for v in boxes if v not in known]
    if missing:
        problems.append(
            f"the {getattr(model, 'kind', '?')} model's box(es) {missing[:6]}{' ...' if len(missing) > 6 else ''} "
            f"are not declared in building {building.name!r} (its boxes: {sorted(known)[:6]}"
            f"{' ...' if len(known) > 6 else ''}): use the building file the model was fitted on"
        )
    from .loadcheck import box_drive_problems

    problems += box_drive_problems(model, building)
    own = getattr(model, "building", None)  # a physics model carries its building
    if own is not None and hasattr(own, "zones") and hasattr(own, "vavs"):
        if own.name != building.name:
            notes.append(_other_building(model, own.name, building))
        elif _layout(own) != _layout(building):
            notes.append(
                f"the {getattr(model, 'kind', '?')} model's building {own.name!r} differs from this building file in "
                "its zones (area, volume) or boxes (zone, m_min, m_max): the file changed since the fit; refit the model"
            )
        return problems, notes
    meta = getattr(model, "meta", None) or {}
    fitted_on, fitted_sha = meta.get("building"), meta.get("building_sha256")
    if not isinstance(fitted_on, str) or not isinstance(fitted_sha, str):
        return problems, notes
    import hashlib

    sha = building.sha256 or hashlib.sha256(building.to_toml().encode("utf-8")).hexdigest()
    if fitted_on != building.name:
        notes.append(_other_building(model, fitted_on, building))
    elif fitted_sha != sha:
        notes.append(
            f"the {getattr(model, 'kind', '?')} model was fitted with another version of the building file of "
            f"{building.name!r} (sha256 {fitted_sha[:12]}..., this file {sha[:12]}...): if boxes, their limits or "
            "the zones changed, refit the model"
        )
    return problems, notes


def _other_building(model, fitted_on: str, building) -> str:
    """The note for a model fitted on building ``fitted_on`` and used with another one."""
    return (
        f"the {getattr(model, 'kind', '?')} model was fitted on building {fitted_on!r}, not on {building.name!r}: a "
        "model of another building predicts this one only by chance; fit it on data of this building"
    )


def _layout(b) -> tuple:
    """Zones (name, area, volume) and boxes (name, zone, m_min, m_max) of a building, for comparisons."""
    return (
        tuple((z.name, float(z.area), float(z.volume)) for z in b.zones),
        tuple((v.name, v.zone, float(v.m_min), float(v.m_max)) for v in b.vavs),
    )


def gains_to_json(gains: dict) -> dict:
    return {s: np.asarray(g, dtype=float).tolist() for s, g in gains.items()}


def gains_from_json(d: dict, n_q: int, step: float) -> dict:
    if not isinstance(d, dict):
        raise ModelError(f"'gains' must be a table season -> profile, got {type(d).__name__}")
    n = n_time_of_week(step)
    return {s: check_shape(g, (n, n_q), f"gains[{s!r}]") for s, g in d.items()}


def require_keys(d: dict, keys, what: str):
    missing = [k for k in keys if k not in d]
    if missing:
        raise ModelError(f"{what}: missing keys {missing}")


def check_version(d: dict, what: str = "model file", newest: int = FORMAT_VERSION):
    """Refuse a ``format_version`` that is not an integer >= 1 or is above ``newest``."""
    v = d.get("format_version")
    if isinstance(v, bool) or not isinstance(v, int) or v < 1:
        raise ModelError(f"{what}: no integer 'format_version'")
    if v > newest:
        raise ModelError(
            f"{what}: format_version {v} is newer than this hvacfmu understands ({newest}); upgrade hvacfmu"
        )
