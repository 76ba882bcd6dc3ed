"""Discharge air commands of the plant FMU (issue 13 p.3): optional inputs ``Td_<vav>`` [degC].

A box reheats its supply air to the commanded discharge temperature, ``m c_p max(Td - T_supply, 0)``
(:meth:`hvacfmu.emulator.Plant.discharge_reheat`). The inputs are appended after every other variable
(earlier value references unchanged); their start value 0 degC lies below any supply air, so a box whose
``Td_`` is not set discharges at its unit's supply temperature, as the plant did before these inputs.
"""

from __future__ import annotations

import numpy as np

from hvacfmu.fmu_slave.names import BOUNDS, entry, sanitize_name


def plant_discharge_entries(plant) -> list:
    """Layout entries (role ``td``) of the inputs ``Td_<vav>`` of every box of ``plant``."""
    return [
        entry(
            "td",
            sanitize_name(f"Td_{b}"),
            "Real",
            "input",
            0.0,
            "degC",
            f"Discharge air temperature command of VAV box {b} [degC]: the box reheats its supply air to it "
            "(m c_p (Td - T_supply)); at or below the supply temperature (default 0): no reheat",
            BOUNDS["degC"],
        )
        for b in plant.vavs
    ]


def plant_discharge_reheat(plant, values, td_vrs, m, T_supply):
    """Reheat power [W] per box from the ``Td_`` inputs, or None when every one is at or below the supply air."""
    Td = np.array([values[vr] for vr in td_vrs], dtype=float)
    if not Td.size or np.all(Td <= np.min(T_supply)):
        return None
    return plant.discharge_reheat(m, T_supply, Td)
