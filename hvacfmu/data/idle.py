"""Supply air temperature while its air handler is off (issues #13/#15).

When every box of an air handler has (near) zero airflow, the unit's logged supply temperature reads an idle
duct node (EnergyPlus's idle supply node, the emulator's ``--schedule night-off``). A model that takes the
supply temperature as a linear input (Model A's airflow form, where ``C · T_supply`` and the ``A`` diagonal
linearise ``m c_p (T_supply − T)`` around the mean flow) then reads a temperature no air carries. Two
substitutions for those rows:

- ``"zone"``: the mean air temperature of the zones the unit serves (weighted by the boxes' ``m_max``): the
  mean-flow term ``m̄ c_p (T_supply − T)`` then vanishes, as the heat of a unit that moves no air does;
- ``"last"``: the unit's last running value: the term stays what it was while the unit last ran (a unit
  still blowing its mean flow at its last supply temperature).

The rule is plain data (JSON) so that a saved model can carry it and apply it to raw data.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..building import Building
from ..errors import DataError

MODES = ("zone", "last")


def box_off_bounds(building: Building, fraction: float, floor: float) -> dict:
    """``{airflow column: bound [kg/s]}``: a box is off at or below ``max(floor, fraction · m_min)``.

    Measured airflow of a shut box is rarely exactly 0 (sensor noise: the emulator's reads up to ~0.01 kg/s).
    """
    return {f"m_{v.name}": max(float(floor), float(fraction) * float(v.m_min)) for v in building.vavs}


def idle_supply_rule(building: Building, columns, bounds: dict, mode: str = "zone") -> dict:
    """``{supply column: {"flows": {airflow column: off bound}, "zones": {T_<zone>: weight}}}``.

    ``T_supply`` (the single implicit unit, or the flow-weighted mean of several units) is idle only when every
    box is off; ``T_supply_<ahu>`` when every box of that unit is off; a measured discharge temperature
    ``Td_<vav>`` when its box is off. ``bounds``: :func:`box_off_bounds`.
    ``mode`` ``"zone"`` adds the zones (weights: summed ``m_max`` of the unit's boxes in each zone); ``"last"``
    leaves them out (hold the last running value).
    """
    if mode not in MODES:
        raise ValueError(f"idle supply mode must be one of {MODES}, got {mode!r}")
    columns = set(columns)
    units = []
    if "T_supply" in columns:
        units.append(("T_supply", list(building.vavs)))
    for a in building.ahus:
        if a.supply_column in columns and a.supply_column != "T_supply":
            units.append((a.supply_column, [v for v in building.vavs if v.ahu == a.name]))
    # a shut box's measured discharge air Td_<vav> reads the same idle air (no airflow, no reheat)
    units += [(f"Td_{v.name}", [v]) for v in building.vavs if f"Td_{v.name}" in columns]
    rule = {}
    for col, vavs in units:
        if not vavs:
            continue
        spec: dict = {"flows": {f"m_{v.name}": bounds[f"m_{v.name}"] for v in vavs}}
        if mode == "zone":
            zones: dict = {}
            for v in vavs:
                zones[f"T_{v.zone}"] = zones.get(f"T_{v.zone}", 0.0) + float(v.m_max)
            spec["zones"] = zones
        rule[col] = spec
    return rule


def idle_rows(frame: pd.DataFrame, flows: dict) -> np.ndarray:
    """Rows where every airflow column of ``flows`` (``{column: bound}``) is measured and at most its bound."""
    m = frame[list(flows)].to_numpy(dtype=float)
    bound = np.array(list(flows.values()), dtype=float)
    return np.all(np.isfinite(m), axis=1) & np.all(m <= bound, axis=1)


def hold_idle_supply(frame: pd.DataFrame, rule: dict) -> tuple:
    """``frame`` with each supply column of ``rule`` replaced in its unit's idle rows.

    Idle rows: every airflow column of the unit measured and at most its bound (:func:`idle_supply_rule`).
    With ``zones``: the weighted mean of the zone temperatures measured in the row; otherwise (or where no zone
    temperature is measured) the column's last finite value in a row where a box of the unit had airflow
    (before the first such row: the first one). A unit that never runs is left as it is.

    Returns
    -------
    (DataFrame, dict)
        A copy with the substituted columns (the input when ``rule`` is empty) and ``{column: rows replaced}``.
    """
    if not rule:
        return frame, {}
    need = {c for col, spec in rule.items() for c in (col, *spec["flows"], *spec.get("zones", {}))}
    missing = sorted(need - set(frame.columns))
    if missing:
        raise DataError(f"replacing the idle supply temperature needs the frame columns {missing}")
    out = frame.copy()
    counts = {}
    for col, spec in rule.items():
        flows = spec["flows"]
        off = idle_rows(frame, flows)
        m = frame[list(flows)].to_numpy(dtype=float)
        ran = np.any(np.isfinite(m) & (m > np.array(list(flows.values()), dtype=float)), axis=1)
        t = frame[col].to_numpy(dtype=float)
        value = pd.Series(np.where(ran, t, np.nan), index=frame.index).ffill().bfill().to_numpy()
        zones = spec.get("zones")
        if zones:
            T = frame[list(zones)].to_numpy(dtype=float)
            w = np.where(np.isfinite(T), np.array(list(zones.values()), dtype=float), 0.0)
            with np.errstate(invalid="ignore", divide="ignore"):
                mean = np.nansum(T * w, axis=1) / w.sum(axis=1)
            value = np.where(np.isfinite(mean), mean, value)
        use = off & np.isfinite(value)
        if use.any():
            out[col] = np.where(use, value, t)
        counts[col] = int(use.sum())
    return out, counts


__all__ = ["MODES", "box_off_bounds", "hold_idle_supply", "idle_rows", "idle_supply_rule"]
