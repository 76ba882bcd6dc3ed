"""Units of measured data and their conversion to SI.

Canonical quantities and their SI units:

=================  ==========================  =======
canonical column   quantity                    SI unit
=================  ==========================  =======
``T_*``            air temperature             °C
``Td_*``           discharge air temperature   °C
``m_*``            air mass flow of a box      kg/s
``rh_*``           reheat command/valve        – (0..1; ``%`` accepted)
``ghi``, ``I_*``   irradiance                  W/m²
``wind``           wind speed at the site      m/s (``km/h``, ``mph``, ``kn``/``kt`` accepted)
``excitation``     experiment flag             – (0/1)
=================  ==========================  =======

Volumetric airflows (m³/s, L/s, cfm, m³/h) become mass flows with the standard air
density :data:`AIR_DENSITY` = 1.2 kg/m³ (dry air at about 20 °C and sea-level
pressure), the convention of HVAC airflow measurements.
"""

from __future__ import annotations

import numpy as np

#: Standard air density used to turn volumetric into mass airflow [kg/m3].
AIR_DENSITY = 1.2

#: One cubic foot per minute in cubic metres per second [m3/s].
CFM_IN_M3_PER_S = 0.3048**3 / 60.0

#: Physical kind of a canonical column -> (SI unit, accepted units).
KINDS = {
    "temperature": ("degC", ("degC", "degF", "K")),
    "airflow": ("kg/s", ("kg/s", "m3/s", "L/s", "cfm", "m3/h")),
    "irradiance": ("W/m2", ("W/m2", "kW/m2", "W/ft2", "Btu/h/ft2")),
    "flag": ("1", ("1",)),
    "fraction": ("1", ("1", "%")),
    "speed": ("m/s", ("m/s", "km/h", "mph", "kn")),
}

#: One square foot in square metres [m2].
FT2_IN_M2 = 0.3048**2
#: One Btu (international table) per hour in watts [W].
BTU_PER_H_IN_W = 1055.05585262 / 3600.0

#: One knot (international nautical mile per hour) in m/s.
KNOT_IN_M_PER_S = 1852.0 / 3600.0
#: One mile per hour in m/s.
MPH_IN_M_PER_S = 1609.344 / 3600.0

_ALIASES = {
    "degc": "degC",
    "c": "degC",
    "celsius": "degC",
    "°c": "degC",
    "deg_c": "degC",
    "degf": "degF",
    "f": "degF",
    "fahrenheit": "degF",
    "°f": "degF",
    "deg_f": "degF",
    "k": "K",
    "kelvin": "K",
    "kg/s": "kg/s",
    "kgs-1": "kg/s",
    "kg s-1": "kg/s",
    "m3/s": "m3/s",
    "m^3/s": "m3/s",
    "m³/s": "m3/s",
    "l/s": "L/s",
    "lps": "L/s",
    "m3/h": "m3/h",
    "m^3/h": "m3/h",
    "m³/h": "m3/h",
    "cmh": "m3/h",
    "cfm": "cfm",
    "ft3/min": "cfm",
    "ft^3/min": "cfm",
    "ft³/min": "cfm",
    "w/m2": "W/m2",
    "w/m^2": "W/m2",
    "w/m²": "W/m2",
    "wm-2": "W/m2",
    "kw/m2": "kW/m2",
    "kw/m^2": "kW/m2",
    "kw/m²": "kW/m2",
    "w/ft2": "W/ft2",
    "w/ft^2": "W/ft2",
    "w/ft²": "W/ft2",
    "w/sqft": "W/ft2",
    "btu/h/ft2": "Btu/h/ft2",
    "btu/hr/ft2": "Btu/h/ft2",
    "btu/h-ft2": "Btu/h/ft2",
    "btu/hr-ft2": "Btu/h/ft2",
    "btu/h·ft²": "Btu/h/ft2",
    "btu/(h ft2)": "Btu/h/ft2",
    "btuh/ft2": "Btu/h/ft2",
    "1": "1",
    "-": "1",
    "": "1",
    "none": "1",
    "bool": "1",
    "%": "%",
    "percent": "%",
    "pct": "%",
    "m/s": "m/s",
    "ms-1": "m/s",
    "m s-1": "m/s",
    "mps": "m/s",
    "km/h": "km/h",
    "kmh": "km/h",
    "kph": "km/h",
    "km/hr": "km/h",
    "mph": "mph",
    "mi/h": "mph",
    "kn": "kn",
    "kt": "kn",
    "kts": "kn",
    "knot": "kn",
    "knots": "kn",
}


def kind_of(canonical: str) -> str:
    """Physical kind (``temperature``, ``airflow``, ``irradiance``, ``flag``, ``fraction``, ``speed``) of a canonical
    column."""
    if canonical.startswith(("T_", "Td_")):
        return "temperature"
    if canonical.startswith("m_"):
        return "airflow"
    if canonical == "ghi" or canonical.startswith("I_"):
        return "irradiance"
    if canonical == "excitation":
        return "flag"
    if canonical.startswith("rh_"):
        return "fraction"
    if canonical == "wind":
        return "speed"
    raise KeyError(f"no physical kind known for column {canonical!r}")


def normalize_unit(unit: str | None, kind: str) -> str:
    """Canonical spelling of ``unit`` for a quantity of ``kind``.

    ``None`` means the SI unit. Raises ``ValueError`` for a unit that does not
    measure ``kind`` (the message lists the accepted units).
    """
    si, accepted = KINDS[kind]
    if unit is None:
        return si
    name = _ALIASES.get(str(unit).strip().lower().replace(" ", ""), None)
    if name is None:
        name = _ALIASES.get(str(unit).strip().lower(), str(unit))
    if name not in accepted:
        raise ValueError(f"unit {unit!r} is not a {kind} unit; use one of {', '.join(accepted)}")
    return name


def to_si(values, unit: str):
    """Convert ``values`` from ``unit`` to SI (°C, kg/s, W/m²).

    Parameters
    ----------
    values : array-like
        Values in ``unit``.
    unit : str
        One of ``degC``, ``degF``, ``K``, ``kg/s``, ``m3/s``, ``L/s``, ``cfm``, ``m3/h``,
        ``W/m2``, ``kW/m2``, ``W/ft2``, ``Btu/h/ft2``, ``1``, ``%``, ``m/s``, ``km/h``, ``mph``, ``kn`` (canonical spellings, see
        :func:`normalize_unit`).

    Returns
    -------
    numpy.ndarray of float
        Temperatures in [°C], airflows in [kg/s] (volumetric flows times
        :data:`AIR_DENSITY`), irradiance in [W/m²], fractions in [1], wind speed in [m/s].
    """
    x = np.asarray(values, dtype=float)
    if unit in ("degC", "kg/s", "W/m2", "1", "m/s"):
        return x.copy()
    if unit == "degF":
        return (x - 32.0) * (5.0 / 9.0)
    if unit == "K":
        return x - 273.15
    if unit == "m3/s":
        return x * AIR_DENSITY
    if unit == "L/s":
        return x * (1e-3 * AIR_DENSITY)
    if unit == "cfm":
        return x * (CFM_IN_M3_PER_S * AIR_DENSITY)
    if unit == "m3/h":
        return x * (AIR_DENSITY / 3600.0)
    if unit == "kW/m2":
        return x * 1000.0
    if unit == "W/ft2":
        return x / FT2_IN_M2
    if unit == "Btu/h/ft2":
        return x * (BTU_PER_H_IN_W / FT2_IN_M2)
    if unit == "%":
        return x / 100.0
    if unit == "km/h":
        return x / 3.6
    if unit == "mph":
        return x * MPH_IN_M_PER_S
    if unit == "kn":
        return x * KNOT_IN_M_PER_S
    raise ValueError(f"unknown unit {unit!r}")


def from_si(values, unit: str):
    """Inverse of :func:`to_si`: convert SI ``values`` (°C, kg/s, W/m²) to ``unit``."""
    x = np.asarray(values, dtype=float)
    if unit in ("degC", "kg/s", "W/m2", "1", "m/s"):
        return x.copy()
    if unit == "degF":
        return x * (9.0 / 5.0) + 32.0
    if unit == "K":
        return x + 273.15
    if unit == "m3/s":
        return x / AIR_DENSITY
    if unit == "L/s":
        return x / (1e-3 * AIR_DENSITY)
    if unit == "cfm":
        return x / (CFM_IN_M3_PER_S * AIR_DENSITY)
    if unit == "m3/h":
        return x / (AIR_DENSITY / 3600.0)
    if unit == "kW/m2":
        return x / 1000.0
    if unit == "W/ft2":
        return x * FT2_IN_M2
    if unit == "Btu/h/ft2":
        return x / (BTU_PER_H_IN_W / FT2_IN_M2)
    if unit == "%":
        return x * 100.0
    if unit == "km/h":
        return x * 3.6
    if unit == "mph":
        return x / MPH_IN_M_PER_S
    if unit == "kn":
        return x / KNOT_IN_M_PER_S
    raise ValueError(f"unknown unit {unit!r}")
