"""How a generated dataset is exported: units, clock, trend-log interval and real-world faults.

A real BMS export differs from the emulator's clean one-minute SI file in ways
the pipeline must survive; each is an option of :func:`hvacfmu.emulator.generate`
and is declared in the building file it writes (as a user would declare it):

``units="us"``
    Temperatures in °F (``T_*``, ``Td_*``, 0.1 °F resolution), box airflows in
    CFM (standard air, 1.2 kg/m³; 1 CFM resolution), reheat valves in %;
    the building file gets ``[units]`` globs.
``clock``
    ``"aware"`` (ISO 8601 with UTC offset, default), ``"naive-local"`` (local
    wall clock without offset: an hour repeats in autumn, one is skipped in
    spring) or ``"naive-utc"`` (UTC without offset; the building file declares
    ``data_timezone = "UTC"``).
``export_step``
    Trend-log interval [s]: instantaneous samples every ``export_step`` seconds
    (60 = every simulated minute).
``faults``
    ``"outages"``: frequent logger outages (whole rows missing, minutes to
    hours, about 5 % of the rows) and isolated dropped rows; ``"sparse_box"``:
    one box whose columns hold data in only about 6 % of the rows (a box
    controller that rarely answers the trend poll); ``"stuck_sensor"``: one
    zone temperature sensor frozen at its last value for two to four days.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .effects import EmulatorError

UNIT_SYSTEMS = ("si", "us")
CLOCKS = ("aware", "naive-local", "naive-utc")
FAULTS = ("outages", "sparse_box", "stuck_sensor")
AIR_DENSITY = 1.2  # [kg/m3] standard air, as hvacfmu.data.units
CFM_IN_M3_PER_S = 0.3048**3 / 60.0
SPARSE_COVERAGE = 0.06  # [-] share of rows a sparse box answers

#: ``[units]`` table of the building file for each unit system (columns absent from the file are harmless).
UNITS_TABLE = {"si": {}, "us": {"T_*": "degF", "Td_*": "degF", "m_*": "cfm", "rh_*": "%"}}


def check_export(units="si", clock="aware", export_step=60, faults=()) -> list[str]:
    """Problems (empty if none) with the export options."""
    problems = []
    if units not in UNIT_SYSTEMS:
        problems.append(f"units must be one of {', '.join(UNIT_SYSTEMS)}, got {units!r}")
    if clock not in CLOCKS:
        problems.append(f"clock must be one of {', '.join(CLOCKS)}, got {clock!r}")
    if not isinstance(export_step, (int, np.integer)) or export_step < 60 or export_step % 60:
        problems.append(f"export_step must be a positive multiple of 60 s, got {export_step!r}")
    for f in faults:
        if f not in FAULTS:
            problems.append(f"unknown fault {f!r}; known faults: {', '.join(FAULTS)}")
    return problems


def time_strings(index: pd.DatetimeIndex, clock: str) -> np.ndarray:
    """Timestamps as text: ISO with offset (``aware``), naive local wall clock or naive UTC."""
    if clock == "aware":
        from .generate import _iso_times

        return _iso_times(index)
    naive = index.tz_localize(None) if clock == "naive-local" else index.tz_convert("UTC").tz_localize(None)
    return np.datetime_as_string(naive.as_unit("s").asi8.astype("datetime64[s]")).astype("U19")


def convert_units(frame: pd.DataFrame, units: str) -> pd.DataFrame:
    """Columns converted from SI to ``units`` and quantised to what a BMS logs there."""
    if units == "si":
        return frame
    out = frame.copy()
    for c in out.columns:
        if c.startswith("T_") or c.startswith("Td_"):
            out[c] = np.round((out[c] * 9.0 / 5.0 + 32.0) * 10.0) / 10.0
        elif c.startswith("m_"):
            out[c] = np.round(out[c] / AIR_DENSITY / CFM_IN_M3_PER_S)
        elif c.startswith("rh_"):
            out[c] = np.round(out[c] * 100.0)
    return out


def apply_faults(frame: pd.DataFrame, faults, rng, zones, vavs) -> tuple[pd.DataFrame, list[dict]]:
    """Inject the requested faults into a one-row-per-sample frame (``time`` column first).

    Returns
    -------
    frame : DataFrame
        Rows dropped for outages, NaN for the sparse box, frozen values for the stuck sensor.
    records : list of dict
        One dict per fault with its location (for ``truth.json``); row positions
        refer to the frame before any row is dropped, times are the ``time`` text.
    """
    n = len(frame)
    times = frame["time"].to_numpy()
    records = []
    keep = np.ones(n, dtype=bool)
    if "stuck_sensor" in faults:
        z = str(rng.choice(list(zones)))
        length = min(n - 2, int(round(rng.uniform(2.0, 4.0) / _days_per_row(frame))))
        s = int(rng.integers(1, max(2, n - length)))
        col = f"T_{z}"
        frame.loc[s : s + length - 1, col] = frame[col].iloc[s - 1]
        records.append(
            {
                "kind": "stuck sensor",
                "column": col,
                "start": str(times[s]),
                "end": str(times[min(s + length, n) - 1]),
                "value": float(frame[col].iloc[s - 1]),
            }
        )
    if "sparse_box" in faults:
        v = str(rng.choice(list(vavs)))
        answered = rng.random(n) < SPARSE_COVERAGE
        cols = [c for c in (f"m_{v}", f"Td_{v}", f"rh_{v}") if c in frame.columns]
        frame.loc[~answered, cols] = np.nan
        records.append({"kind": "sparse box", "vav": v, "columns": cols, "coverage": float(answered.mean())})
    if "outages" in faults:
        rows_per_hour = 1.0 / (24.0 * _days_per_row(frame))
        n_out = max(1, int(round(n / rows_per_hour / 24.0 / 3.5)))  # about two outages a week
        for _ in range(n_out):
            length = max(1, int(rng.uniform(0.25, 8.0) * rows_per_hour))
            s = int(rng.integers(0, max(1, n - length)))
            keep[s : s + length] = False
            records.append({"kind": "outage", "start": str(times[s]), "end": str(times[min(s + length, n) - 1])})
        drops = rng.random(n) < 0.005
        keep &= ~drops
        records.append({"kind": "dropped rows", "rows": int(drops.sum())})
    return frame[keep].reset_index(drop=True), records


def _days_per_row(frame) -> float:
    """Sampling interval of the frame [days] (from its ``step_s`` attribute)."""
    return float(frame.attrs.get("step_s", 60.0)) / 86400.0


def validate_export(units, clock, export_step, faults):
    problems = check_export(units, clock, export_step, faults)
    if problems:
        from ..errors import problems_message

        raise EmulatorError(problems_message("Invalid export options", problems))
