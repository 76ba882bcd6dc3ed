"""The building emulator: office floors (SDH-like by default) that produce realistic "measured" data.

Public API (see DEVELOPING.md):

- :func:`generate` writes ``measurements.parquet`` (or ``.csv``), ``building.toml``
  and ``truth.json``; :func:`cached_dataset` caches it in ``$HVACFMU_CACHE``;
- :func:`parse_effect` parses ``--effect NAME[:key=value,...]``;
- ``layout=`` / ``construction=`` / ``climate=`` / ``hvac=`` and the export options of
  :func:`generate` vary the building and the file (:mod:`.layouts`, :mod:`.export`);
  :func:`generate_fleet` writes many varied buildings and a ``fleet.json`` manifest;
- :func:`sdh_building` is the default floor with nominal physics tables
  (:func:`emulated_building` any layout);
- :class:`Plant` is the same building, steppable from outside.

The emulator is deliberately richer than the models identified from its data
(multi-node walls, slabs facing the floors above and below, furniture mass,
windows with solar gains, infiltration, local VAV controllers with reheat,
supply-air reset, occupancy with calendar and randomness), so identification
is never checked against its own model class.
"""

from .building import (  # noqa: F401
    building_dict,
    emulated_building,
    sdh_building,
    sdh_building_dict,
    true_building_dict,
)
from .effects import (  # noqa: F401
    EFFECT_DEFAULTS,
    EFFECT_NAMES,
    EmulatorError,
    effect_label,
    parse_effect,
)
from .fleet import FLEET_FORMAT, fleet_parameters, generate_fleet  # noqa: F401
from .generate import (  # noqa: F401
    EMULATOR_VERSION,
    GeneratedPaths,
    cache_key,
    cached_dataset,
    generate,
    make_truth,
)
from .layouts import CLIMATES, CONSTRUCTION_TEMPLATES, LAYOUTS  # noqa: F401
from .plant import Plant  # noqa: F401
from .simulate import simulate  # noqa: F401

__all__ = [
    "FLEET_FORMAT",
    "fleet_parameters",
    "generate_fleet",
    "CLIMATES",
    "CONSTRUCTION_TEMPLATES",
    "LAYOUTS",
    "building_dict",
    "emulated_building",
    "EFFECT_DEFAULTS",
    "EFFECT_NAMES",
    "EMULATOR_VERSION",
    "EmulatorError",
    "GeneratedPaths",
    "Plant",
    "cache_key",
    "cached_dataset",
    "effect_label",
    "generate",
    "make_truth",
    "parse_effect",
    "sdh_building",
    "sdh_building_dict",
    "simulate",
    "true_building_dict",
]
