"""Supply air temperature while its air handler is off (issue #13/#15).

When every box of an air handler has (near) zero airflow, the unit's logged supply temperature reads an idle
duct node (EnergyPlus's idle supply node, the emulator's ``--schedule night-off``). A model that takes the
supply temperature as a linear input (Model A's airflow form, where ``C · T_supply`` linearises
``m c_p (T_supply − T)`` around the mean flow) then reads a temperature no air carries. Holding the column at the
unit's last running value makes it physically neutral in those rows: the term contributes what it contributed
while the unit last ran, as it would with a constant supply set point.

The rule is plain data (column -> airflow columns) so that a saved model can carry it and apply it to raw data.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..building import Building
from ..errors import DataError


def box_off_bounds(building: Building, fraction: float, floor: float) -> dict:
    """``{airflow column: bound [kg/s]}``: a box is off at or below ``max(floor, fraction · m_min)``.

    Measured airflow of a shut box is rarely exactly 0 (sensor noise: the emulator's reads up to ~0.01 kg/s).
    """
    return {f"m_{v.name}": max(float(floor), float(fraction) * float(v.m_min)) for v in building.vavs}


def idle_supply_rule(building: Building, columns, bounds: dict) -> dict:
    """``{supply column: {airflow column: off bound [kg/s]}}`` for the supply columns in ``columns``.

    ``T_supply`` (the single implicit unit, or the flow-weighted mean of several units) is idle only when every
    box is off; ``T_supply_<ahu>`` when every box of that unit is off. ``bounds``: :func:`box_off_bounds`.
    """
    columns = set(columns)
    rule = {}
    if "T_supply" in columns:
        rule["T_supply"] = {f"m_{v}": bounds[f"m_{v}"] for v in building.vav_names}
    for a in building.ahus:
        if a.supply_column in columns and a.supply_column != "T_supply":
            rule[a.supply_column] = {f"m_{v.name}": bounds[f"m_{v.name}"] for v in building.vavs if v.ahu == a.name}
    return {c: m for c, m in rule.items() if m}


def idle_rows(frame: pd.DataFrame, flows: dict) -> np.ndarray:
    """Rows where every airflow column of ``flows`` (``{column: bound}``) is measured and at most its bound."""
    m = frame[list(flows)].to_numpy(dtype=float)
    bound = np.array(list(flows.values()), dtype=float)
    return np.all(np.isfinite(m), axis=1) & np.all(m <= bound, axis=1)


def hold_idle_supply(frame: pd.DataFrame, rule: dict) -> tuple:
    """``frame`` with each supply column of ``rule`` held at its last running value in the unit's idle rows.

    Idle rows: every airflow column of the unit measured and at most its bound (:func:`idle_supply_rule`). The held value is the column's last
    finite value in a row where a box of the unit had airflow (before the first such row: the first one). A unit that never runs
    (or a column never measured while it runs) is left as it is.

    Returns
    -------
    (DataFrame, dict)
        A copy with the substituted columns (the input when ``rule`` is empty) and ``{column: rows held}``.
    """
    if not rule:
        return frame, {}
    missing = sorted({c for col, flows in rule.items() for c in (col, *flows)} - set(frame.columns))
    if missing:
        raise DataError(f"holding the idle supply temperature needs the frame columns {missing}")
    out = frame.copy()
    counts = {}
    for col, flows in rule.items():
        off = idle_rows(frame, flows)
        m = frame[list(flows)].to_numpy(dtype=float)
        ran = np.any(
            np.isfinite(m) & (m > np.array(list(flows.values()), dtype=float)), axis=1
        )  # a row with missing airflow is no source
        t = frame[col].to_numpy(dtype=float)
        running = pd.Series(np.where(ran, t, np.nan), index=frame.index)
        held = running.ffill().bfill().to_numpy()
        use = off & np.isfinite(held)
        if use.any():
            out[col] = np.where(use, held, t)
        counts[col] = int(use.sum())
    return out, counts


__all__ = ["box_off_bounds", "hold_idle_supply", "idle_rows", "idle_supply_rule"]
