"""EnergyPlus as a data source: run a building through EnergyPlus's Python API and export BMS-like data.

Optional extra: ``pip install 'hvacfmu[energyplus]'`` (the ``pyenergyplus-lbnl``
wheel: the EnergyPlus engine with its Python API, example buildings and weather
files). Same layer as :mod:`hvacfmu.emulator`; imports only
:mod:`hvacfmu.building`, :mod:`hvacfmu.data` and :mod:`hvacfmu.errors`.

- :func:`generate` (``hvacfmu generate --engine energyplus --prototype NAME``)
  writes ``measurements.parquet``, ``building.toml`` and ``energyplus.json``;
- :func:`cached_export` does it once into ``$HVACFMU_CACHE``.

What it maps
------------
Columns (15-minute step averages, labelled by the start of the step, ISO 8601
local time with UTC offset — EnergyPlus's clock is standard time at the end of
the step; daylight saving time comes from the site's IANA time zone):

- ``T_<zone>`` [°C]: Zone Mean Air Temperature of each conditioned zone;
- ``m_<vav>`` [kg/s], ``Td_<vav>`` [°C]: mass flow and temperature of the box's
  zone inlet node (the air terminal's outlet, after any reheat coil);
- ``T_supply_<ahu>`` [°C]: the air handler's supply outlet node; ``T_supply``:
  their airflow-weighted mean;
- ``T_out`` [°C]: site outdoor dry bulb; ``ghi`` [W/m2]: direct normal ·
  sin(solar altitude) + diffuse horizontal.

Building file, read from the IDF and EnergyPlus's sizing results (``eplusout.eio``):
zones (floor area from floor polygons, volume), adjacency (interzone surfaces),
facades (exterior wall and window areas by orientation), boxes with limits
(``m_max`` = autosized or given maximum flow × standard air density at the
site's altitude; ``m_min`` = the terminal's constant, fixed or scheduled
minimum), ``[[ahus]]`` with each box's unit and as ``T_supply_max`` the highest
discharge temperature the unit's controls allow (VAV reheat terminals' maximum
reheat air temperature, single-zone heating setpoint managers' maximum supply air
temperature; else the zones' heating design supply temperature), and the physics tables (materials,
constructions, windows, elements; see :mod:`hvacfmu.energyplus.geometry`).
Box names are ``VAV_<zone>``; zone equipment that blows air into a zone beside
its air terminal (the large hotel's fan coils) is a box of its own single-box
unit, ``FCU_<zone>`` (``UH_``, ``PTAC_``, ... ``UNIT_``), whose supply temperature
is its outlet node; equipment whose heat has no zone inlet node of its own (a
baseboard) is named in a warning; a zone with a zone multiplier is one copy
(airflows and limits divided). IDF names are sanitised to letters, digits and
``_``; ``energyplus.json`` maps them back.

What it approximates
--------------------
See ``APPROXIMATIONS`` in :mod:`hvacfmu.energyplus.generate` (also written to
``energyplus.json``) and :mod:`hvacfmu.energyplus.geometry`; the run's IDF is
changed as listed in :mod:`hvacfmu.energyplus.inputs` (run period, 15-minute
time step, no report objects).
"""

from .cli import add_energyplus_arguments, generate_from_args
from .generate import (
    APPROXIMATIONS,
    EXPORT_VERSION,
    EnergyPlusPaths,
    cache_key,
    cached_export,
    generate,
)

__all__ = [
    "APPROXIMATIONS",
    "EXPORT_VERSION",
    "EnergyPlusPaths",
    "add_energyplus_arguments",
    "cache_key",
    "cached_export",
    "generate",
    "generate_from_args",
]
