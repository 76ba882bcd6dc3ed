"""FMU variable names, units, bounds and descriptions (the pieces of a layout entry).

A *layout* (:func:`hvacfmu.fmu_slave.zone_layout.zone_model_layout`,
:func:`hvacfmu.fmu_slave.plant_layout.plant_layout`) is the JSON list of the
FMU's variables, in value-reference order; each entry is made by :func:`entry`.
"""

from __future__ import annotations

#: version of the slave's variable layout; stored in the FMU description
SLAVE_API_VERSION = 1

#: physical bounds by unit, checked on every input before a step (min, max)
BOUNDS = {
    "degC": (-60.0, 80.0),
    "kg/s": (0.0, 50.0),
    "W/m2": (0.0, 2000.0),
    "m/s": (0.0, 60.0),
}

#: plausible ranges of temperature inputs by name prefix [°C] (checked before every step). Supply and discharge
#: air reach down to the outdoor air's bound: an air handler that is off leaves its supply sensor (and its boxes'
#: discharge sensors) in an idle duct that follows the outdoor or return air, and the data and the models read
#: those values (EnergyPlus's DOE secondary school in Boulder: T_supply -4.9 °C, a shut box's Td -2.4 °C in
#: January; before session 21 the bound was 0 °C and `cosim`'s warm-up of such a building stopped on them)
SIGNAL_BOUNDS = {
    "T_out": (-60.0, 60.0),
    "T_supply": (-60.0, 80.0),
    "Td_": (-60.0, 80.0),
}

#: plausible range of a zone air temperature [°C] (start-value parameters): outside it, a unit or sensor error
ZONE_BOUNDS = (-40.0, 60.0)

#: box airflow upper bound = this factor x the box's design maximum ``m_max`` (measured flows overshoot
#: ``m_max`` by a few per cent through sensor error and loop overshoot: up to 2 % in the emulated data)
M_MAX_MARGIN = 1.2

_FACADES = {"N": "north", "E": "east", "S": "south", "W": "west"}


def entry(role, name, vtype, causality, start, unit=None, description="", bounds=(None, None)) -> dict:
    """One layout entry: ``role`` (what the slave does with it), FMI name, type, causality, start, unit, bounds."""
    return {
        "role": role,
        "name": name,
        "type": vtype,
        "causality": causality,
        "start": start,
        "unit": unit,
        "description": description,
        "min": bounds[0],
        "max": bounds[1],
    }


def sanitize_name(name: str) -> str:
    """An FMI variable name without ``.``, ``[`` or ``]`` (any non-word character becomes ``_``)."""
    out = "".join(c if (c.isalnum() or c == "_") else "_" for c in str(name))
    return out if out and not out[0].isdigit() else "_" + out


def signal_unit(name: str) -> str | None:
    """Unit of a frame column / signal name (README nomenclature)."""
    if name.startswith(("T_", "Td_")):  # zone, outdoor, supply and discharge air temperatures
        return "degC"
    if name.startswith("m_"):
        return "kg/s"
    if name.startswith("I_") or name == "ghi":
        return "W/m2"
    if name.startswith("Qrh_"):
        return "kW"
    if name == "wind":
        return "m/s"
    return None


def signal_bounds(name: str):
    """(min, max) of an input signal: by name (``T_out``, ``T_supply*``, ``Td_*``) or by unit."""
    for prefix, bounds in SIGNAL_BOUNDS.items():
        if name == prefix or (prefix.endswith("_") and name.startswith(prefix)) or name.startswith(prefix + "_"):
            return bounds
    return BOUNDS.get(signal_unit(name) or "", (None, None))


def signal_start(name: str) -> float:
    """Start value of a disturbance input: typical conditions (15 degC outdoors, 14 degC supply air, no sun)."""
    if name == "T_out":
        return 15.0
    if name.startswith(("T_supply", "Td_")):
        return 14.0
    return 0.0


def signal_description(name: str) -> str:
    """A description a Modelica or EnergyPlus user can map by eye."""
    if name == "T_out":
        return "Outdoor air dry-bulb temperature [degC] (EnergyPlus: Site Outdoor Air Drybulb Temperature)"
    if name == "T_supply":
        return "Supply (discharge) air temperature of the VAV boxes [degC]"
    if name.startswith("T_supply_"):
        return f"Supply air temperature of air handler {name[len('T_supply_') :]} [degC]"
    if name.startswith("Td_"):
        return f"Discharge air temperature of VAV box {name[3:]} [degC] (after its reheat coil)"
    if name == "ghi":
        return "Global horizontal irradiance [W/m2]"
    if name == "wind":
        return "Wind speed at the site [m/s] (EnergyPlus: Site Wind Speed)"
    if name.startswith("I_") and name[2:] in _FACADES:
        return (
            f"Total solar irradiance on a vertical {_FACADES[name[2:]]}-facing facade [W/m2] "
            "(EnergyPlus: Surface Outside Face Incident Solar Radiation Rate per Area)"
        )
    if name.startswith("m_"):
        return f"Air mass flow rate of {name[2:]} [kg/s]"
    if name.startswith("Qrh_"):
        return (
            f"Reheat heat into zone {name[4:]} [kW]: sum over its boxes of m_<vav> * 1.005 kJ/(kg K) * "
            "max(Td_<vav> - the supply air of the box's unit, 0), from the measured discharge air"
        )
    if name.startswith("rh_"):
        return f"Reheat signal of VAV box {name[3:]} as recorded in the data (valve or coil command, its own unit)"
    return name


def signal_entry(name: str) -> dict:
    """Layout entry of the disturbance input ``name`` (``T_out``, ``T_supply``, ``I_N`` ...)."""
    return entry(
        "v",
        sanitize_name(name),
        "Real",
        "input",
        signal_start(name),
        signal_unit(name),
        signal_description(name),
        signal_bounds(name),
    )


def box_limits(model, building=None) -> dict:
    """Box name -> {"zone", "m_min", "m_max"} [kg/s] from ``building`` or the model's own building (physics).

    Empty when neither is known (data-driven model files keep only the building's name and hash).
    """
    b = building if building is not None else getattr(model, "building", None)
    if b is None:
        b = getattr(getattr(model, "base", None), "building", None)
    try:
        return {v.name: {"zone": v.zone, "m_min": float(v.m_min), "m_max": float(v.m_max)} for v in b.vavs}
    except AttributeError:
        return {}


def box_entry(b: str, limits: dict | None) -> dict:
    """Layout entry of the airflow input of box ``b``; bounds and nominal from its ``limits`` when known."""
    if not limits:
        return entry(
            "m",
            sanitize_name(f"m_{b}"),
            "Real",
            "input",
            0.0,
            "kg/s",
            f"Supply air mass flow rate of VAV box {b} [kg/s]",
            BOUNDS["kg/s"],
        )
    hi = round(M_MAX_MARGIN * limits["m_max"], 12)
    e = entry(
        "m",
        sanitize_name(f"m_{b}"),
        "Real",
        "input",
        0.0,
        "kg/s",
        f"Supply air mass flow rate of VAV box {b} serving zone {limits['zone']} [kg/s]; design range "
        f"m_min={limits['m_min']:g} to m_max={limits['m_max']:g} kg/s (building file), accepted up to "
        f"{M_MAX_MARGIN:g} x m_max",
        (0.0, hi),
    )
    e["nominal"] = limits["m_max"]
    return e


def zone_entries(zones, label: str = "zone", start_label: str = "", start_note: str = "") -> list:
    """Output ``T_<zone>`` [°C] and start-value parameter ``T_<zone>_start`` entries of ``zones``.

    Descriptions: "Air temperature of <label> <zone>" and "Initial air temperature of <start_label><zone><start_note>".
    """
    out = [
        entry(
            "y",
            sanitize_name(f"T_{z}"),
            "Real",
            "output",
            21.0,
            "degC",
            f"Air temperature of {label} {z} [degC] (EnergyPlus: Zone Mean Air Temperature)",
        )
        for z in zones
    ]
    out += [
        entry(
            "y0",
            sanitize_name(f"T_{z}_start"),
            "Real",
            "parameter",
            21.0,
            "degC",
            f"Initial air temperature of {start_label}{z}{start_note} [degC]",
            ZONE_BOUNDS,
        )
        for z in zones
    ]
    return out


def check_unique(variables) -> None:
    """ValueError naming the FMI variable names that clash (after :func:`sanitize_name`)."""
    names = [v["name"] for v in variables]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"FMU variable names clash after sanitising: {dup}")
