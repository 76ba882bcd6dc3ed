"""The registry of diagnosis causes: one module per cause, each a :class:`~.base.Term` subclass.

A cause module holds its screen (candidates and evidence, ``Term.screen``), its regressors
(``Term.features``), its model term (``Term.contribute``, fit via ``Term.with_fit``) and its
matrix form for native FMUs and MPC (``Term.add_equations``). :class:`~hvacfmu.models.extended.ExtendedModel`
loads terms through :func:`term_from_dict`; the diagnosis' selection loop iterates :func:`causes`.

Register a new cause with :func:`register_cause` (a third-party package can do it on import)::

    from hvacfmu.models.causes import register_cause
    from hvacfmu.models.causes.base import Term

    @register_cause
    @dataclasses.dataclass(frozen=True)
    class MyCause(Term):
        cause = "my_cause"
        ...
"""

from __future__ import annotations

from ...errors import ModelError, problems_message
from .actuation_delay import ActuationDelay
from .base import Candidate, Term, term_params
from .held_setpoint import HeldSetpoint
from .internal_gain_schedule import InternalGainSchedule
from .reheat import Reheat
from .sensor_offset import SensorOffset
from .solar_gain import SolarGain
from .supply_air_bilinear import SupplyAirBilinear
from .thermal_mass import ThermalMass
from .unused_input import UnusedInput
from .wind_infiltration import WindInfiltration
from .zone_coupling import ZoneCoupling

_REGISTRY: dict = {}


def register_cause(term_class: type) -> type:
    """Register a :class:`Term` subclass under its ``cause`` id (usable as a class decorator).

    Raises
    ------
    ModelError
        If the class is not a Term, has no cause id, or the id is taken by another class.
    """
    if not (isinstance(term_class, type) and issubclass(term_class, Term)):
        raise ModelError(f"register_cause needs a Term subclass, got {term_class!r}")
    name = getattr(term_class, "cause", "")
    if not name or not name.replace("_", "").isalnum():
        raise ModelError(f"cause class {term_class.__name__} needs a 'cause' id (an identifier), got {name!r}")
    old = _REGISTRY.get(name)
    if old is not None and old is not term_class and old.__qualname__ != term_class.__qualname__:
        raise ModelError(f"cause {name!r} is already registered by {old.__module__}.{old.__qualname__}")
    _REGISTRY[name] = term_class
    return term_class


def unregister_cause(name: str) -> None:
    """Remove a registered cause (tests, plugins that withdraw)."""
    _REGISTRY.pop(name, None)


def causes() -> tuple:
    """Registered cause classes, in registration order (built-in catalogue first)."""
    return tuple(_REGISTRY.values())


def cause_names() -> tuple:
    """Registered cause ids."""
    return tuple(_REGISTRY)


def get_cause(name: str) -> type:
    """The Term class of cause ``name``; a clear error listing the choices otherwise."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise ModelError(f"unknown cause {name!r}; registered causes: {list(_REGISTRY)}") from None


def term_from_dict(d: dict, zone_names: tuple) -> Term:
    """Rebuild one term from its JSON mapping, validating every field."""
    if not isinstance(d, dict) or d.get("cause") not in _REGISTRY:
        raise ModelError(f"extension term {d!r}: 'cause' must be one of {list(_REGISTRY)}")
    problems: list = []
    std = d.get("std", {})
    if not isinstance(std, dict):
        problems.append(f"extension term {d['cause']}: 'std' must be a mapping")
        std = {}
    t = _REGISTRY[d["cause"]].from_dict(d, tuple(zone_names), problems, std)
    if problems:
        raise ModelError(problems_message("Invalid extension term", problems))
    return t


for _cls in (
    SolarGain,
    SupplyAirBilinear,
    ZoneCoupling,
    ThermalMass,
    InternalGainSchedule,
    ActuationDelay,
    Reheat,
    UnusedInput,
    WindInfiltration,
    SensorOffset,
    HeldSetpoint,
):
    register_cause(_cls)

__all__ = [
    "ActuationDelay",
    "Candidate",
    "HeldSetpoint",
    "InternalGainSchedule",
    "Reheat",
    "SensorOffset",
    "SolarGain",
    "SupplyAirBilinear",
    "Term",
    "ThermalMass",
    "UnusedInput",
    "WindInfiltration",
    "ZoneCoupling",
    "cause_names",
    "causes",
    "get_cause",
    "register_cause",
    "term_from_dict",
    "term_params",
    "unregister_cause",
]
