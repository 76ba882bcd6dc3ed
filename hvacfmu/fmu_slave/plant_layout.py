"""Variable layout of the plant FMU (the emulated building, :class:`hvacfmu.emulator.Plant`)."""

from __future__ import annotations

from hvacfmu.fmu_slave.names import BOUNDS, SLAVE_API_VERSION, box_entry, entry, signal_entry, zone_entries
from hvacfmu.fmu_slave.plant_discharge import plant_discharge_entries

#: internal step of the emulated plant [s]; communication steps must be multiples of it
PLANT_STEP = 60.0

FACADE_INPUTS = ("I_N", "I_E", "I_S", "I_W")


def plant_boxes(truth: dict) -> dict:
    """Box name -> {"zone", "m_min", "m_max"} [kg/s] of the emulated building (``truth.json``'s building)."""
    return {
        str(v["name"]): {"zone": str(v["zone"]), "m_min": float(v["m_min"]), "m_max": float(v["m_max"])}
        for v in truth["baseline"]["building"]["vavs"]
    }


def plant_layout(plant, truth: dict) -> dict:
    """Variable layout of the plant FMU (:class:`hvacfmu.emulator.Plant`; ``truth``: its ``truth.json``).

    Box airflow inputs are bounded by the emulated building's boxes (0 to
    ``M_MAX_MARGIN`` x ``m_max``, nominal ``m_max``, zone named), temperature and
    irradiance inputs by their plausible ranges
    (:data:`~hvacfmu.fmu_slave.names.SIGNAL_BOUNDS`), like the model FMUs.
    """
    boxes = plant_boxes(truth)
    var = [box_entry(b, boxes.get(b)) for b in plant.vavs]
    var += [signal_entry(name) for name in ("T_out", "T_supply", *FACADE_INPUTS)]
    var += _plant_switches()
    var += zone_entries(plant.zones, "zone", "zone ", " (all its nodes)")
    var.append(_local_reheat_parameter())
    var += plant_discharge_entries(plant)  # appended last: earlier value references unchanged
    start = truth.get("start", "?")
    return {
        "slave_api": SLAVE_API_VERSION,
        "kind": "plant",
        "step": PLANT_STEP,
        "start": start,
        "timezone": truth.get("timezone"),
        "span": float(plant.horizon),
        "boxes": {b: boxes[b] for b in sorted(boxes)},
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
