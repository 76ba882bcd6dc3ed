"""Variable layout of the plant FMU (the emulated building, :class:`hvacfmu.emulator.Plant`)."""

from __future__ import annotations

from hvacfmu.fmu_slave.names import (
    BOUNDS,
    SLAVE_API_VERSION,
    entry,
    sanitize_name,
    signal_description,
    signal_unit,
    zone_entries,
)

#: internal step of the emulated plant [s]; communication steps must be multiples of it
PLANT_STEP = 60.0

FACADE_INPUTS = ("I_N", "I_E", "I_S", "I_W")


def plant_layout(plant, truth: dict) -> dict:
    """Variable layout of the plant FMU (:class:`hvacfmu.emulator.Plant`; ``truth``: its ``truth.json``)."""
    var = [
        entry(
            "m",
            sanitize_name(f"m_{b}"),
            "Real",
            "input",
            0.0,
            "kg/s",
            f"Supply air mass flow rate of VAV box {b} [kg/s]",
            BOUNDS["kg/s"],
        )
        for b in plant.vavs
    ]
    for name, start in (("T_out", 15.0), ("T_supply", 14.0)) + tuple((i, 0.0) for i in FACADE_INPUTS):
        unit = signal_unit(name)
        var.append(entry("v", name, "Real", "input", start, unit, signal_description(name), BOUNDS[unit]))
    var += _plant_switches()
    var += zone_entries(plant.zones, "zone", "zone ", " (all its nodes)")
    var.append(_local_reheat_parameter())
    start = truth.get("start", "?")
    return {
        "slave_api": SLAVE_API_VERSION,
        "kind": "plant",
        "step": PLANT_STEP,
        "start": start,
        "timezone": truth.get("timezone"),
        "span": float(plant.horizon),
        "description": (
            f"hvacfmu emulated building (plant): {len(plant.zones)} zones, {len(plant.vavs)} VAV boxes. "
            f"FMU time is seconds since the emulated dataset's start {start} ({truth.get('timezone')}); "
            f"defined for {plant.horizon:g} s. Communication steps must be multiples of {PLANT_STEP:g} s. "
            "Runs in the host's Python, which needs the hvacfmu package."
        ),
        "variables": var,
    }


def _plant_switches() -> list:
    """Inputs ``ghi`` (facades from the emulator's sky model when >= 0) and ``excitation`` (0/1)."""
    return [
        entry(
            "ghi",
            "ghi",
            "Real",
            "input",
            -1.0,
            "W/m2",
            "Global horizontal irradiance [W/m2]; when >= 0 the facade irradiance is computed from it "
            "with the emulator's own model (Erbs + Perez) and I_N..I_W are ignored; "
            "-1 (default): use I_N..I_W",
            (-1.0, BOUNDS["W/m2"][1]),
        ),
        entry(
            "exc",
            "excitation",
            "Real",
            "input",
            0.0,
            None,
            "1 while a forced-response experiment overrides the boxes (their local reheat loops are "
            "off and reset), 0 otherwise (default)",
            (0.0, 1.0),
        ),
    ]


def _local_reheat_parameter() -> dict:
    return entry(
        "local_reheat",
        "local_reheat",
        "Integer",
        "parameter",
        0,
        None,
        "1: the boxes keep their local reheat loops (the building's own heating sequence; the "
        "commanded airflows replace only the airflow loops); 0 (default): no reheat",
        (0, 1),
    )
