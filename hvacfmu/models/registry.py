"""The one registry of model kinds: name -> class, fit function, capabilities, FMU slave, schema.

Everything that needs to know the model kinds reads this registry: loading a saved model
(:func:`hvacfmu.models.load_model`), fitting (:func:`hvacfmu.fitting.fit`, ``hf.fit``), the
CLI's ``--model`` choices, FMU export (the slave name), MPC adapters (``equations``) and the demo.

A model kind is one module (its class, with ``to_dict``/``from_dict``, ``step_state`` and,
where it is linear or bilinear, ``equations()``) plus one :func:`register_kind` call. Classes
and fit functions are named as ``"module:attribute"`` strings and imported on first use, so
``import hvacfmu.models`` stays cheap and a kind whose optional dependencies are missing
fails only when used.

Examples
--------
>>> from hvacfmu.models.registry import ModelKind, get_kind, kinds, register_kind
>>> [k.name for k in kinds()]
['lumped', 'zones', 'physics', 'extended']
>>> get_kind("zones").fmu_slave
'HvacfmuZones'
>>> register_kind(ModelKind("my_kind", "my model", "mypkg.model:MyModel",
...                         fit="mypkg.model:fit_my_model"))  # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Callable
from typing import Any

from ..errors import ModelError

#: JSON schema version (``format_version``) the built-in kinds write (``hvacfmu.models.base.FORMAT_VERSION``)
SCHEMA_VERSION = 1


@dataclasses.dataclass(frozen=True)
class ModelKind:
    """One registered model kind.

    Attributes
    ----------
    name : str
        The kind, as written in model files (``"kind"``) and given to ``--model``.
    description : str
        One line for ``--help`` and the README.
    model_class : str
        ``"module:Class"`` of the :class:`~hvacfmu.models.base.ZoneModel` subclass that loads
        (``from_dict``) and runs the kind.
    fit : str or None
        ``"module:function"`` with signature ``fit(dataset, **options) -> ZoneModel``; ``None`` for a
        kind that is not identified directly (``fit_note`` then says how it is made).
    equations : bool
        True when the class implements ``equations() -> ModelEquations`` (linear/bilinear form
        consumed by native FMUs and MPC).
    fmu_slave : str
        Name of the FMU slave script and class that serves the kind (``hvacfmu.fmu``).
    schema_version : int
        ``format_version`` of the JSON files the kind writes.
    fit_note : str
        For kinds without ``fit``: how to obtain such a model.
    """

    name: str
    description: str
    model_class: str
    fit: str | None = None
    equations: bool = False
    fmu_slave: str = "HvacfmuModel"
    schema_version: int = SCHEMA_VERSION
    fit_note: str = ""

    def __post_init__(self):
        problems = []
        if not self.name or not self.name.replace("_", "").isalnum():
            problems.append(f"name {self.name!r} must be a non-empty identifier")
        for field, value in (("model_class", self.model_class), ("fit", self.fit)):
            if value is not None and (value.count(":") != 1 or not all(value.split(":"))):
                problems.append(f"{field} {value!r} must be 'module:attribute'")
        if problems:
            raise ModelError(f"invalid model kind {self.name!r}: " + "; ".join(problems))

    def load_class(self) -> type:
        """The model class (imported on first use)."""
        return _resolve(self.model_class, f"model class of kind {self.name!r}")

    def fit_function(self) -> Callable[..., Any]:
        """The fit function ``fit(dataset, **options) -> ZoneModel``.

        Raises
        ------
        ModelError
            If the kind is not identified directly from data (e.g. ``extended``).
        """
        if self.fit is None:
            raise ModelError(
                f"model kind {self.name!r} is not fitted directly from data"
                + (f": {self.fit_note}" if self.fit_note else "")
                + f"; kinds that can be fitted: {fittable_kinds()}"
            )
        return _resolve(self.fit, f"fit function of kind {self.name!r}")


_REGISTRY: dict[str, ModelKind] = {}


def _resolve(target: str, what: str) -> Any:
    module, attr = target.split(":")
    try:
        return getattr(importlib.import_module(module), attr)
    except (ImportError, AttributeError) as exc:
        raise ModelError(f"cannot import the {what} ({target}): {exc}") from exc


def register_kind(kind: ModelKind, *, replace: bool = False) -> ModelKind:
    """Add a model kind to the registry; returns it.

    Parameters
    ----------
    kind : ModelKind
    replace : bool
        Allow replacing an existing kind of the same name (default: an error).

    Raises
    ------
    ModelError
        If the name is taken and ``replace`` is false.
    """
    if not isinstance(kind, ModelKind):
        raise TypeError(f"expected a ModelKind, got {type(kind).__name__}")
    if kind.name in _REGISTRY and not replace and _REGISTRY[kind.name] != kind:
        raise ModelError(
            f"model kind {kind.name!r} is already registered ({_REGISTRY[kind.name].model_class}); "
            "pass replace=True to replace it"
        )
    _REGISTRY[kind.name] = kind
    return kind


def unregister_kind(name: str) -> None:
    """Remove a kind (for tests and plugins that registered a temporary kind)."""
    _REGISTRY.pop(name, None)


def kinds() -> tuple[ModelKind, ...]:
    """Every registered kind, in registration order."""
    return tuple(_REGISTRY.values())


def kind_names() -> list[str]:
    """Names of every registered kind, in registration order."""
    return list(_REGISTRY)


def fittable_kinds() -> list[str]:
    """Names of the kinds identified directly from data (the CLI's ``fit --model`` choices)."""
    return [k.name for k in _REGISTRY.values() if k.fit is not None]


def get_kind(name: str) -> ModelKind:
    """The registered kind ``name``.

    Raises
    ------
    ModelError
        For an unknown name, listing the registered kinds.
    """
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise ModelError(f"unknown model kind {name!r}; choose one of {kind_names()}") from None


# --------------------------------------------------------------------------- built-in kinds
register_kind(
    ModelKind(
        "lumped",
        "Model A, one lumped zone (area-weighted mean temperature, summed airflow)",
        "hvacfmu.models.linear:LinearZoneModel",
        fit="hvacfmu.models.datadriven:fit_lumped",
        equations=True,
        fmu_slave="HvacfmuLumped",
    )
)
register_kind(
    ModelKind(
        "zones",
        "Model A, one state per zone (semiparametric: LOESS + constrained least squares)",
        "hvacfmu.models.linear:LinearZoneModel",
        fit="hvacfmu.models.datadriven:fit_zones",
        equations=True,
        fmu_slave="HvacfmuZones",
    )
)
register_kind(
    ModelKind(
        "physics",
        "Model B, RC network from the building's geometry and constructions, bilinear in airflow",
        "hvacfmu.models.physics:PhysicsModel",
        fit="hvacfmu.models.physics:fit_physics",
        equations=True,
        fmu_slave="HvacfmuPhysics",
    )
)
register_kind(
    ModelKind(
        "extended",
        "Model A plus the extension terms of diagnosed causes",
        "hvacfmu.models.extended:ExtendedModel",
        fit=None,
        equations=True,
        fmu_slave="HvacfmuExtended",
        fit_note="it is the result of the diagnosis (hvacfmu diagnose ... -o model.json, or hf.diagnose(data).model)",
    )
)


__all__ = [
    "SCHEMA_VERSION",
    "ModelKind",
    "fittable_kinds",
    "get_kind",
    "kind_names",
    "kinds",
    "register_kind",
    "unregister_kind",
]
