"""Heat delivered by the supply air of VAV boxes: inlet temperature per box and ``m c_p (T_in - T_zone)``.

A box heats (or cools) its zone by ``Q = m c_p (T_d - T_zone)`` with ``m`` its
airflow [kg/s], ``c_p = 1005 J/(kg K)`` and ``T_d`` its discharge air
temperature [°C] (after the reheat coil). Where ``Td_<vav>`` is not measured,
the box's inlet falls back to its air handler's supply temperature
(``T_supply_<ahu>``, or ``T_supply`` for the single implicit unit). The heat is
zero at zero flow, so the idle node temperature an air handler reports while
it is off never enters a model.

Pure functions; the model kinds (Model A :mod:`~hvacfmu.models.linear`, Model B
:mod:`~hvacfmu.models.physics`) build on them.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

#: Specific heat of air [J/(kg K)] (the emulator's and Model B's value).
CP_AIR = 1005.0

#: A box whose airflow is at most this is off [kg/s].
OFF_FLOW = 1e-6

#: Minimum share of a box's rows with airflow where ``Td_<vav>`` must be measured to use it.
MIN_TD_COVERAGE = 0.5


def inlet_columns(building, frame: pd.DataFrame, rows=None, min_coverage: float = MIN_TD_COVERAGE):
    """Column of each box's inlet (discharge) air temperature: ``Td_<vav>`` where measured, else its unit's supply.

    Parameters
    ----------
    building : hvacfmu.building.Building
    frame : DataFrame
        Prepared measurements (``m_<vav>``, ``Td_<vav>``, ``T_supply_<ahu>``, ``T_supply`` [°C]).
    rows : array of bool, optional
        Rows that count for coverage (e.g. the training weeks); default all.
    min_coverage : float
        ``Td_<vav>`` is used when it is finite in at least this share of the
        counted rows in which the box's airflow is measured.

    Returns
    -------
    inlets : tuple of str
        One frame column per box (``building.vav_names`` order).
    notes : list of str
        One line per box whose ``Td_<vav>`` column exists but is too sparse to use.
    """
    n = len(frame)
    rows = np.ones(n, bool) if rows is None else np.asarray(rows, bool)
    inlets, notes = [], []
    for v in building.vav_names:
        td = f"Td_{v}"
        fallback = building.supply_column(v)
        if fallback not in frame.columns:
            fallback = "T_supply"
        if td not in frame.columns:
            inlets.append(fallback)
            continue
        m = frame[f"m_{v}"].to_numpy(float) if f"m_{v}" in frame.columns else np.zeros(n)
        have = rows & np.isfinite(m)
        cov = float(np.isfinite(frame[td].to_numpy(float))[have].mean()) if have.any() else 0.0
        if cov >= min_coverage:
            inlets.append(td)
        else:
            inlets.append(fallback)
            notes.append(
                f"column {td}: measured in only {100 * cov:.1f} % of the rows with airflow (need "
                f"{100 * min_coverage:.0f} %); box {v} uses its air handler's supply temperature {fallback} instead"
            )
    return tuple(inlets), notes


def delivered_heat(m, T_in, T_zone):
    """Heat delivered by boxes ``m c_p (T_in - T_zone)`` [kW]; batched, elementwise.

    Parameters
    ----------
    m : array (..., n_vav) [kg/s]
    T_in : array (..., n_vav) [°C]
        Discharge (inlet) air temperature of each box.
    T_zone : array (..., n_vav) [°C]
        Air temperature of the zone each box serves.

    Returns
    -------
    array (..., n_vav) [kW]
    """
    return np.asarray(m, float) * (CP_AIR / 1000.0) * (np.asarray(T_in, float) - np.asarray(T_zone, float))


def air_handler_off_share(building, m, rows=None, off_flow=OFF_FLOW) -> float:
    """Share of ``rows`` in which every box of at least one air handler has zero airflow (``<= off_flow``).

    In those rows the air handler's supply temperature is an idle node
    temperature, meaningless as an input unless multiplied by the airflow.

    Parameters
    ----------
    building : hvacfmu.building.Building
    m : array (n, n_vav) [kg/s]
        Box airflows in ``building.vav_names`` order (NaN: missing).
    rows : array of bool, optional
    off_flow : float or array (n_vav,) [kg/s]
        Airflow at or below which a box counts as off (default :data:`OFF_FLOW`; per box for noisy sensors).
    """
    m = np.asarray(m, float)
    bound = np.broadcast_to(np.asarray(off_flow, float), (m.shape[1],))
    rows = np.ones(m.shape[0], bool) if rows is None else np.asarray(rows, bool)
    units = {}
    for j, v in enumerate(building.vavs):
        units.setdefault(v.ahu, []).append(j)
    off = np.zeros(m.shape[0], bool)
    for cols in units.values():
        mu = m[:, cols]
        off |= np.all(np.isfinite(mu), axis=1) & np.all(mu <= bound[cols], axis=1)
    sel = rows & np.all(np.isfinite(m), axis=1)
    return float(off[sel].mean()) if sel.any() else 0.0


__all__ = ["CP_AIR", "MIN_TD_COVERAGE", "OFF_FLOW", "air_handler_off_share", "delivered_heat", "inlet_columns"]
