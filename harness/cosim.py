"""Co-simulation master: an FMU (ours or foreign) with a controller in the loop, on FMPy's low-level API.

One run: load the FMU with :class:`fmpy.fmi2.FMU2Slave`, feed the measured
disturbances of a prepared dataset row by row (one row per communication step,
zero-order hold), ask the controller for the VAV airflows at each step, step
the FMU and record everything. The result is a table plus summary figures:
energy proxy Σ m² and total airflow, comfort violation in K·h outside the band,
compute time per step. A run that does not cover the requested span (the FMU
refused a step, the controller failed) raises :class:`~hvacfmu.errors.FMUError`
with the partial result attached, unless ``allow_partial=True``.

Command line::

    hvacfmu cosim --fmu fmus/build/Zones.fmu --data measurements.parquet --building building.toml \\
        --controller rule --week 2 --out results.csv

Our FMUs are mapped by name (inputs ``m_<vav>``, ``T_out``, ``T_supply``,
``I_N`` ...; outputs ``T_<zone>`` or ``T_floor``; parameters
``T_<zone>_start``, ``season``, ``start_time_of_week``). A foreign FMU needs a
mapping file (JSON)::

    {"inputs": {"fmu variable": "data column", ...},      # m_<vav>, T_out, T_supply, I_N ...
     "outputs": {"fmu variable": "zone name", ...},
     "start_values": {"fmu variable": value, ...},          # optional
     "time_origin": "2025-09-01T00:00:00-07:00"}            # optional, FMU time 0 [default: run start]

Inputs or outputs declared in kelvin (``unit="K"``) are converted from/to °C.

The plant FMU (the emulated building) has unobservable wall and slab
temperatures: a run on it starts ``warmup`` earlier (default one week, as far
as the data reaches) and replays the measured airflows and disturbances up to
the span's start, so the building's thermal mass is where the measurements put
it (a flat start at the measured air temperatures leaves a bias of ~0.3 K that
decays over days). A controller may ask the FMU for start values through an
attribute ``fmu_start_values`` (used when the FMU has the variable): the replay
controller sets the plant's ``local_reheat=1``, because the measured airflows
come with the boxes' (unmeasured) reheat.
"""

from __future__ import annotations

import ctypes
import dataclasses
import functools
import json
import logging
import math
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from hvacfmu.errors import DataError, FMUError, HvacfmuError, problems_message
from hvacfmu.progress import progress as progress_iter
from hvacfmu.timeutil import seconds_of_week

from .controllers import DEFAULT_HORIZON_H, ControlContext, ReplayController, RuleController, default_horizon
from .schedule import SYSTEMS, RunSchedule, check_system, off_steps, running_supply, unit_of_boxes

logger = logging.getLogger(__name__)

#: FMI 2.0 status names
STATUS = ("ok", "warning", "discard", "error", "fatal", "pending")
CONTROLLERS = ("replay", "rule", "mpc")
#: FMU inputs left at their default when the data has no such column
OPTIONAL_INPUTS = ("ghi", "excitation")
#: facade irradiance inputs: kept at their start value (with a warning) when the data have no solar columns
SOLAR_INPUTS = ("I_N", "I_E", "I_S", "I_W")
#: specific heat of air [J/(kg K)] (issue 13: delivered heat m c_p (Td - T_zone))
CP_AIR = 1005.0
#: warm-up of the plant FMU before the span [s] (its slab and walls settle within days)
PLANT_WARMUP = 7 * 86400.0
DEFAULT_BAND = (20.0, 22.0)
#: [K] a zone temperature that moves more than this in one step and back the next "reverses" (summary
#: ``oscillation``): a controller cycling with the plant every step (a model whose first-step gain is far
#: below the plant's, or a rule gain too high for a light zone), not a building's own dynamics at 15 min
OSCILLATION_K = 0.5


# =============================================================================
# result
# =============================================================================
@dataclasses.dataclass
class CosimResult:
    """Outcome of :func:`run_cosim`.

    Attributes
    ----------
    table : DataFrame
        One row per communication point (``n_steps + 1`` rows when complete),
        tz-aware local index ``time``: FMU outputs ``T_<zone>`` [°C] at that
        time, the commands ``m_<vav>`` [kg/s] and disturbances held over the
        following step (NaN on the last row), measured ``T_<zone>_measured``
        [°C] when the data have them, ``controller_time`` and ``fmu_time`` [s].
    summary : dict
        Figures of the run (see :meth:`format_summary`).
    log : list of (status, category, message)
        Messages the FMU logged.
    """

    table: pd.DataFrame
    summary: dict
    log: list = dataclasses.field(default_factory=list)

    @property
    def covered(self) -> bool:
        """True when every requested step was taken."""
        return bool(self.summary["covered"])

    def to_pandas(self) -> pd.DataFrame:
        return self.table

    def save(self, path) -> Path:
        """Write the table (``.csv`` or ``.parquet``) and the summary beside it (``.json``)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.suffix.lower() == ".parquet":
            self.table.to_parquet(path)
        elif path.suffix.lower() == ".csv":
            self.table.to_csv(path)
        else:
            raise HvacfmuError(f"results file {path} must end in .csv or .parquet")
        summary = dict(self.summary, fmu_log=[list(m) for m in self.log])
        path.with_suffix(".json").write_text(json.dumps(summary, indent=1, default=str), encoding="utf-8")
        return path

    def plot(self, path) -> Path:
        """Figure of the run (temperatures in the band, total airflow) as an image file."""
        from .cosim_plots import plot_cosim

        return plot_cosim(self, path)

    def format_summary(self) -> str:
        s = self.summary
        lines = [
            f"co-simulation of {s['fmu']} with controller {s['controller']!r}",
            f"  span            {s['start']} .. {s['end']} ({s['steps_requested']} steps of {s['step']:g} s)",
            f"  completed       {s['steps_completed']} / {s['steps_requested']} steps"
            + ("" if s["covered"] else "   <-- STOPPED EARLY: " + (s.get("stopped_because") or "?")),
        ]
        if s.get("seasons_followed"):
            lines.append(
                "  seasons         the FMU followed the calendar (season 0): "
                + "; ".join(f"{p['season']} {p['from']} .. {p['to']}" for p in s["seasons_followed"])
            )
        lines += [
            f"  energy proxy    {s['energy_proxy']:.4f} (kg/s)^2 summed over steps and boxes",
            f"  total airflow   {s['total_airflow_kg']:.0f} kg (mean {s['mean_airflow']:.3f} kg/s)",
            f"  comfort         {s['comfort_violation_Kh']:.2f} K*h outside [{s['band'][0]:g}, {s['band'][1]:g}] degC"
            + _measured_comfort_note(s),
        ]
        by = sorted(((sum(v), k, v) for k, v in (s.get("comfort_by_output") or {}).items()), reverse=True)
        if len(by) > 1 and by[0][0] >= 0.05:  # where the K*h are: a controller that keeps one zone cold and one hot
            lines.append(
                "    by output     "
                + ", ".join(
                    f"{k} {b:.1f} below / {a:.1f} above"
                    if b >= 0.05 and a >= 0.05
                    else f"{k} {b + a:.1f} {'below' if b >= a else 'above'}"
                    for tot, k, (b, a) in by[:5]
                    if tot >= 0.05
                )
                + (f" (+{len(by) - 5} more)" if len(by) > 5 and by[5][0] >= 0.05 else "")
            )
        heating = f"  heating         {s.get('heating_kWh', 0.0):.1f} kWh of reheat commanded through Td_<vav>"
        if not s.get("heating_commanded", True):
            # a model FMU reads the data's discharge air as an input: no reheat is commanded, whatever the data heat
            heating = (
                "  heating         none commanded: the FMU has no Td_<vav> command input (a model FMU takes the "
                "data's measured inputs, their Td_<vav> if any; a plant FMU takes reheat commands)"
            )
        lines += [
            heating,
            f"  compute / step  median {1e3 * s['step_time_median']:.3f} ms, max {1e3 * s['step_time_max']:.3f} ms "
            f"(controller median {1e3 * s['controller_time_median']:.3f} ms, FMU median {1e3 * s['fmu_time_median']:.3f} ms)",
        ]
        if s.get("oscillation"):
            worst = sorted(s["oscillation"].items(), key=lambda kv: -kv[1])
            n_steps = max(s["steps_completed"] - 1, 0)
            line = (
                f"  oscillation     {', '.join(f'{k} {n}' for k, n in worst)} of {n_steps} "
                f"steps reverse a move of more than {OSCILLATION_K:g} K"
            )
            measured = s.get("measured_oscillation")
            name, count = worst[0]
            sustained = count >= 0.1 * n_steps  # a tenth of the run: sustained, not a few disturbances
            if sustained and measured is not None and measured.get(name, 0) >= count:
                # the data reverse at least as often: the building's own loop, not the controller and the plant
                line += (
                    f"; the measured zone temperatures reverse as often ({name} {measured.get(name, 0)}): "
                    "the building's own loop cycles at this step (e.g. a small zone on one fast box), not the "
                    "controller with the plant"
                )
            elif sustained and s.get("controller") == "replay":
                line += (
                    f": the replayed airflows do not respond to the run, so the model's own response to the "
                    f"measured inputs reverses more often than the data ({name} {(measured or {}).get(name, 0)}): "
                    "see fit's warnings (a first-step gain far above the building's)"
                )
            elif sustained:
                line += (
                    ": the controller cycles with the plant (for MPC: the model's first-step response is far "
                    "below the plant's; the offset-free estimate, --option offset_gain, can drive the cycle; the "
                    "input-gain adaptation, --option gain_adapt (on in the plant preset), corrects a plant up to "
                    "--option gain_max times stronger than the model; a model whose "
                    "gain is this wrong should be refitted: see fit's warnings)"
                )
            lines.append(line)
        lines += _schedule_lines(s)
        if s.get("filled_inputs"):
            lines.append(f"  gap-filled      {s['filled_inputs']} input values (time interpolation)")
        if s.get("controller_stats"):
            lines.append(f"  controller      {s['controller_stats']}")
            lines += _mpc_stats_lines(s["controller_stats"])
        return "\n".join(lines)


def _schedule_lines(s: dict) -> list:
    """The schedule and the limits check in words (the building's off periods, the option, what was applied)."""
    out = []
    sc = s.get("schedule") or {}
    n = s["steps_requested"]
    if sc.get("off_steps"):
        periods = sc.get("off_periods") or []
        units = sc.get("unit_off_steps") or {}
        which, per_unit = "the data's air handler", ""
        if len(units) > 1:  # several units: which are off, and how often (the 90.1 small hotel: 1 of 4 units)
            off_units = {u: k for u, k in units.items() if k}
            which = "an air handler of the data"
            per_unit = (
                f"{len(off_units)} of {len(units)} units: "
                + ", ".join(f"{u} {k} step{'s' if k != 1 else ''}" for u, k in off_units.items())
                + "; "
            )
        head = f"  schedule        {which} is off in {sc['off_steps']} of {n} steps ({per_unit}{len(periods)} periods"
        if sc["system"] == "schedule":
            line = (
                head + "): the run follows it (--system schedule, the default): 0 airflow and no reheat in "
                f"{sc['off_box_steps']} box-steps"
                + (
                    f", {sc['overridden_box_steps']} of them where the controller asked for air or reheat"
                    if sc.get("overridden_box_steps")
                    else ""
                )
            )
        else:
            held = ", ".join(f"{c} {k}" for c, k in (sc.get("held_supply") or {}).items()) or "none"
            line = (
                head + "): --system always-on runs the boxes through them; the supply temperature there is the "
                f"unit's last running value (values replaced: {held}), not the idle duct reading"
            )
        out.append(line)
        out.append(
            f"    off rule      {sc['rule']}"
            + (
                f" ({sc['off_steps_noise']} of them with a shut box reading sensor noise above its 5 % bound)"
                if sc.get("off_steps_noise")
                else ""
            )
        )
    lim = s.get("limits") or {}
    if lim:
        text = f"  box limits      applied airflows: {lim['in_range']} box-steps in [m_min, m_max]" + (
            f", {lim['off']} off at 0" if lim["off"] or sc.get("off_steps") else ""
        )
        if lim["outside"]:
            text += f", {lim['outside']} OUTSIDE both (up to {lim['outside_max']:.3g} kg/s)"
        out.append(text)
    return out


def _mpc_stats_lines(st: dict) -> list:
    """The MPC's statistics that change how a run reads, in words (the dict above keeps every figure).

    Fourth EnergyPlus round: the restaurant's MPC under the default band had 164 of 192 planned moves beyond the boxes'
    range (by up to 20 kg/s) and 47 steps not converged, said only as keys of a dict."""
    n = int(st.get("steps") or 0)
    if not n or "projected_steps" not in st:
        return []
    out = []
    if st.get("horizon"):
        out.append(
            f"  horizon         {int(st['horizon'])} steps ({float(st['horizon_h']):.3g} h)"
            + (
                f" (the default: {DEFAULT_HORIZON_H:g} h at the data's step; --horizon N sets it)"
                if st.get("horizon_default")
                else " (--horizon)"
            )
        )
    p = int(st.get("projected_steps") or 0)
    if p:
        out.append(
            f"  limits          {p} of {n} steps planned airflows beyond the boxes' [m_min, m_max] (up to "
            f"{float(st.get('projected_max') or 0.0):.3g} kg/s), applied at the limit: the band may be out of the "
            "boxes' reach there (too tight a band, or too little range at these supply temperatures)"
        )
    nc = int(st.get("not_converged") or 0)
    if nc:
        out.append(f"  convergence     {nc} of {n} steps did not converge; the best iterate was applied")
    f = int(st.get("failures") or 0)
    if f:
        out.append(
            f"  failures        {f} of {n} steps found no plan (the previous plan's next move, else the minimum, applied)"
        )
    return out


def _measured_comfort_note(s: dict) -> str:
    """``(the measured data: X K*h)``, and a pointer to --band when the measured building itself is far outside."""
    measured = s.get("measured_comfort_violation_Kh")
    if measured is None:
        return ""
    note = f" (the measured zone temperatures: {measured:.2f} K*h"
    zone_hours = s["steps_completed"] * s["step"] / 3600.0 * s.get("outputs", 1)
    if zone_hours and measured > 0.5 * zone_hours:  # the measured zones are 0.5 K outside on average
        note += "; the building runs outside this band itself: give its own band with --band T_MIN T_MAX"
    return note + ")"


# =============================================================================
# FMU handling
# =============================================================================
@dataclasses.dataclass
class _Var:
    name: str
    vr: int
    causality: str
    type: str
    unit: str | None
    start: object


def _fmu_variables(md) -> dict:
    out = {}
    for v in md.modelVariables:
        unit = (
            v.unit if getattr(v, "unit", None) else (v.declaredType.unit if getattr(v, "declaredType", None) else None)
        )
        out[v.name] = _Var(v.name, v.valueReference, v.causality, v.type, unit, v.start)
    return out


def _read_interface(unzipdir) -> dict | None:
    p = Path(unzipdir) / "resources" / "interface.json"
    if not p.is_file():
        return None
    try:
        return json.loads(p.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return None


def _callbacks(sink: list):
    """fmi2CallbackFunctions whose logger appends (status, category, message) to ``sink``."""
    from fmpy import calloc, free
    from fmpy.fmi2 import (
        fmi2CallbackAllocateMemoryTYPE,
        fmi2CallbackFreeMemoryTYPE,
        fmi2CallbackFunctions,
        fmi2CallbackLoggerTYPE,
    )

    def log_message(component, instance_name, status, category, message):
        text = message.decode("utf-8", errors="replace") if message else ""
        cat = category.decode("utf-8", errors="replace") if category else ""
        sink.append((STATUS[status] if 0 <= status < len(STATUS) else str(status), cat, text))
        logger.log(
            logging.ERROR if status >= 3 else logging.WARNING if status >= 1 else logging.DEBUG,
            "FMU [%s] %s",
            STATUS[status] if 0 <= status < len(STATUS) else status,
            text,
        )

    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(log_message)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    # No fmpy.logging.addLoggerProxy here: the proxy keeps ONE process-wide pointer to the last logger
    # registered, so two instances would log into each other's sink and, once this instance's callback is
    # freed, any later FMU using FMPy's default callbacks (fmpy.simulate_fmu) calls a dangling pointer and
    # segfaults (measured). Our FMUs pass preformatted messages; a foreign FMU's printf-style arguments
    # are not substituted.
    return cb, log_message


def _restore_fmpy_logger():
    """Point FMPy's process-wide logger proxy back to its default printer (see :func:`_callbacks`).

    ``fmpy.simulate_fmu(logger=f)`` registers ``f``'s ctypes wrapper in the proxy and frees it on return; a
    later FMU on FMPy's default callbacks would then call freed memory.
    """
    global _DEFAULT_LOGGER
    try:
        from fmpy.fmi1 import printLogMessage
        from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
        from fmpy.logging import addLoggerProxy
    except Exception:  # pragma: no cover - FMPy without the proxy
        return
    if _DEFAULT_LOGGER is None:
        _DEFAULT_LOGGER = fmi2CallbackLoggerTYPE(printLogMessage)  # kept for the life of the process
    tmp = fmi2CallbackFunctions()
    tmp.logger = _DEFAULT_LOGGER
    addLoggerProxy(ctypes.byref(tmp))


_DEFAULT_LOGGER = None


class FMUInstance:
    """An instantiated co-simulation FMU with message capture (context manager).

    Parameters
    ----------
    path : path
        The FMU.
    instance_name : str
    """

    def __init__(self, path, instance_name="hvacfmu"):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        self.path = Path(path)
        if not self.path.is_file():
            raise FMUError(f"FMU {self.path} does not exist")
        try:
            self.md = read_model_description(str(self.path))
        except Exception as exc:  # noqa: BLE001 - FMPy raises plain exceptions
            raise FMUError(f"cannot read {self.path}: {exc}") from None
        if self.md.coSimulation is None:
            raise FMUError(f"{self.path} is not a co-simulation FMU")
        self.vars = _fmu_variables(self.md)
        self.unzipdir = extract(str(self.path))
        self.interface = _read_interface(self.unzipdir)
        self.log: list = []
        self._cb, self._cb_fn = _callbacks(self.log)
        self.fmu = FMU2Slave(
            guid=self.md.guid,
            unzipDirectory=self.unzipdir,
            modelIdentifier=self.md.coSimulation.modelIdentifier,
            instanceName=instance_name,
        )
        try:
            self.fmu.instantiate(callbacks=self._cb, loggingOn=True)
        except Exception as exc:  # noqa: BLE001
            shutil.rmtree(self.unzipdir, ignore_errors=True)
            raise FMUError(f"cannot instantiate {self.path}: {exc}; FMU log: {self.errors()}") from None
        self._alive = True

    def errors(self) -> list:
        """Messages logged with status warning or worse."""
        return [m for s, _, m in self.log if s not in ("ok",)]

    def close(self):
        if self._alive:
            self._alive = False
            try:
                self.fmu.terminate()
            except Exception:  # noqa: BLE001 - terminating a failed instance may fail again
                pass
            try:
                self.fmu.freeInstance()
            finally:
                shutil.rmtree(self.unzipdir, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


# =============================================================================
# the run
# =============================================================================
def _select_span(dataset, week=None, start=None, stop=None):
    """Rows of the run and its season (a week's season, or None for a free span)."""
    frame = dataset.frame
    if week is not None:
        weeks = {w.number: w for w in dataset.weeks}
        if week not in weeks:
            raise DataError(f"week {week} is not in the data; weeks: {sorted(weeks)}")
        w = weeks[week]
        return dataset.week_frame(w), w.season
    if start is None and stop is None:
        tests = dataset.test_weeks() or dataset.weeks
        if tests:
            w = tests[0]
            return dataset.week_frame(w), w.season
        return frame, None
    idx = frame.index

    def local(ts):
        ts = pd.Timestamp(ts)
        return ts.tz_convert(idx.tz) if ts.tzinfo else ts.tz_localize(idx.tz)

    i0 = 0 if start is None else idx.searchsorted(local(start))
    i1 = len(idx) if stop is None else idx.searchsorted(local(stop))
    return frame.iloc[i0:i1], None


def _default_mapping(inst: FMUInstance, frame, building):
    """Inputs by name (box airflows, disturbances) and outputs T_<zone>/T_floor for our FMUs.

    Returns ``(inputs, controls, outputs, problems, defaulted)``; ``defaulted`` lists the facade
    irradiance inputs the data cannot feed (no solar columns): they keep their start value (0 W/m2).
    """
    boxes = {f"m_{v}": v for v in building.vav_names}
    plant = (inst.interface or {}).get("kind") == "plant"
    inputs, controls, outputs, problems, defaulted, discharge = {}, {}, {}, [], [], {}
    for name, var in inst.vars.items():
        if var.causality == "input":
            if plant and name.startswith("Td_") and name[3:] in building.vav_names:
                discharge[name] = name[3:]  # a command for the controller (unset: no reheat), never the data's Td
                continue
            if name in OPTIONAL_INPUTS and name not in frame.columns:
                continue  # keeps its default (e.g. the plant's ghi: use I_N..I_W)
            if name in SOLAR_INPUTS and name not in frame.columns and var.start is not None:
                defaulted.append(name)
                continue
            if name in boxes:
                controls[name] = boxes[name]
            elif name in frame.columns:
                inputs[name] = name
            else:
                hint = (
                    f" (the reheat heat of zone {name[4:]} an extended model derives from the discharge air "
                    "Td_<vav>: pass that model with --model)"
                    if name.startswith("Qrh_")
                    else ""
                )
                problems.append(f"FMU input {name!r} is neither a box airflow m_<vav> nor a data column{hint}")
        elif var.causality == "output":
            if name == "T_floor":
                outputs[name] = tuple(building.zone_names)
            elif name.startswith("T_") and name[2:] in building.zone_names:
                outputs[name] = (name[2:],)
            else:
                problems.append(f"FMU output {name!r} is not T_<zone> of a zone of the building")
    return inputs, controls, outputs, problems, defaulted, discharge


def _mapping_from_file(inst: FMUInstance, mapping: dict, frame, building):
    boxes = set(building.vav_names)
    inputs, controls, outputs, problems = {}, {}, {}, []
    for fmu_name, col in (mapping.get("inputs") or {}).items():
        if fmu_name not in inst.vars or inst.vars[fmu_name].causality != "input":
            problems.append(f"mapping: {fmu_name!r} is not an input of the FMU")
        elif col.startswith("m_") and col[2:] in boxes:
            controls[fmu_name] = col[2:]
        elif col in frame.columns:
            inputs[fmu_name] = col
        else:
            problems.append(f"mapping: input {fmu_name!r} -> {col!r} is neither m_<vav> nor a data column")
    for fmu_name, zone in (mapping.get("outputs") or {}).items():
        zones = tuple(zone) if isinstance(zone, (list, tuple)) else (zone,)
        if fmu_name not in inst.vars or inst.vars[fmu_name].causality != "output":
            problems.append(f"mapping: {fmu_name!r} is not an output of the FMU")
        elif not set(zones) <= set(building.zone_names):
            problems.append(f"mapping: output {fmu_name!r} -> {zone!r} names no zone of the building")
        else:
            outputs[fmu_name] = zones
    return inputs, controls, outputs, problems


def _fill(series: pd.Series) -> tuple[pd.Series, int]:
    n = int(series.isna().sum())
    if n == 0:
        return series, 0
    if n == len(series):
        raise DataError(f"column {series.name!r} has no data in the co-simulation span")
    return series.interpolate(method="time", limit_direction="both"), n


def _warmup_rows(dataset, t_start, warmup, earliest, inputs, controls, outputs, V, building):
    """Measured rows of the ``warmup`` seconds before ``t_start`` (at most ``earliest``) and their inputs.

    Returns ``(frame, M, V)``: the rows, the box airflows (gaps held, box
    minimum before the first value) and the disturbances (gaps interpolated,
    the span's first value where a column has none). No rows when the data
    holds no zone temperature for an output there (nothing to start from).
    """
    full = dataset.frame
    seconds = max(0.0, min(warmup, earliest))
    i_start = full.index.get_loc(t_start)
    i_warm = full.index.searchsorted(t_start - pd.Timedelta(seconds=seconds))
    # the index is regular (Dataset checks it): the rows end exactly one step before the span
    wframe = full.iloc[i_warm:i_start]
    wframe = wframe.assign(time_of_week=seconds_of_week(wframe.index).astype(float))
    zones = {z for zs in outputs.values() for z in zs}
    if any(f"T_{z}" not in wframe or not wframe[f"T_{z}"].notna().any() for z in zones):
        wframe = wframe.iloc[:0]
    n = len(wframe)
    Vw = np.empty((n, len(inputs)))
    for j, (fmu_name, col) in enumerate(inputs.items()):
        s = wframe[col].interpolate(method="time", limit_direction="both") if n else wframe[col]
        Vw[:, j] = s.fillna(V[fmu_name][0]).to_numpy(dtype=float)
    m_min = {b.name: b.m_min for b in building.vavs}
    Mw = np.empty((n, len(controls)))
    for j, b in enumerate(controls.values()):
        col = f"m_{b}"
        Mw[:, j] = wframe[col].ffill().fillna(m_min[b]).to_numpy(dtype=float) if col in wframe else m_min[b]
    return wframe, Mw, Vw


def _measured_start(name, zones, frame, building, model):
    """Measured value of an output at the first row (gaps filled from the nearest rows)."""
    if model is not None and tuple(model.outputs) and name in {f"T_{z}" for z in model.outputs}:
        cols = [f"T_{z}" for z in getattr(model, "measured_zones", ())]
        if cols and all(c in frame for c in cols):
            T = frame[cols].apply(lambda s: _fill(s)[0]).iloc[:1]
            y = model.measured_outputs(T)[0]
            return float(y[[f"T_{z}" for z in model.outputs].index(name)])
    cols = [f"T_{z}" for z in zones]
    missing = [c for c in cols if c not in frame]
    if missing:
        raise DataError(f"no measured {missing} for the start value of {name}")
    T = np.array([_fill(frame[c])[0].iloc[0] for c in cols])
    if len(zones) == 1:
        return float(T[0])
    w = building.area_weights()
    sel = [building.zone_names.index(z) for z in zones]
    return float(T @ (w[sel] / w[sel].sum()))


def run_cosim(
    fmu_path,
    dataset,
    controller,
    *,
    week=None,
    start=None,
    stop=None,
    model=None,
    mapping=None,
    band=DEFAULT_BAND,
    season=None,
    start_values=None,
    allow_partial=False,
    progress=False,
    warmup=None,
    system="schedule",
) -> CosimResult:
    """Co-simulate an FMU with a controller in the loop over a span of measured data.

    Parameters
    ----------
    fmu_path : path
        Co-simulation FMU (ours: mapped by name; foreign: give ``mapping``).
    dataset : hvacfmu.data.Dataset
        Prepared data; one row per communication step (``dataset.step`` [s]).
    controller : Controller
        See :mod:`harness.controllers`.
    week : int, optional
        Week number of the dataset to run. Default: the first held-out week
        (or the span ``start``..``stop`` when given).
    start, stop : timestamp-like, optional
        Span ``[start, stop)`` instead of a week.
    model : ZoneModel, optional
        Passed to the controller (e.g. the MPC's model); also used to map
        measured zone temperatures to its outputs (lumped model).
    mapping : dict, optional
        Input/output mapping of a foreign FMU (see the module docstring).
    band : (float, float) [°C]
        Comfort band for the violation figure and the controllers.
    season : str, optional
        Season of the gains profile for the whole run (default: the week's season; a free span's first row's).
        A free span across a season boundary of the building file, without ``season``: an FMU exported with the
        building file follows the calendar (``season = 0``), any other is refused (:func:`plan_season_span`).
    start_values : dict, optional
        Extra FMU start values by variable name (override the defaults).
    allow_partial : bool
        Return a partial result instead of raising when the run stops early.
    warmup : float [s], optional
        Replay the measured airflows and disturbances of this long before the
        span (as far as the data reaches) to settle the FMU's unobserved states;
        the table starts at the span. Default: :data:`PLANT_WARMUP` for the
        plant FMU and for model FMUs with states the measurements do not set
        (a physics model's walls), 0 for the others (their states start from
        the measurements).
    progress : bool
        Show a progress bar.
    system : str
        ``"schedule"`` (default): follow the building's operating schedule: in the steps where the data's air
        handler is off (:mod:`harness.schedule`, :mod:`hvacfmu.data.idle`'s rule) every box of the unit gets 0
        airflow and no reheat, whatever the controller returns (controllers are told through
        ``ControlContext.off``). ``"always-on"``: run the system through those steps; the unit's supply
        temperature there is its last running value in the data, not the idle duct reading. Data without off
        periods run the same either way.

    Returns
    -------
    CosimResult

    Raises
    ------
    FMUError
        The FMU cannot be loaded, initialised, or stopped before the end of the
        span: the message names the time, the FMI call and its status (the
        partial result is ``exc.result``).
    DataError
        The data cannot feed the FMU (missing columns, empty span).
    """
    check_system(system)
    dataset = _with_derived_columns(dataset, _fmu_model(fmu_path) or model)
    run = _Run.for_span(dataset, week, start, stop, season, band)
    with FMUInstance(fmu_path) as inst:
        _connect(run, inst, mapping)
        _plan_seasons(run, inst, model)
        _apply_system(run, system)
        _locate_in_time(run, inst, mapping, warmup)
        sv = _start_values(run, inst, model, controller, mapping, start_values)
        controller.reset(
            ControlContext(
                frame=run.cframe,
                building=run.building,
                vavs=run.vavs,
                outputs=run.out_names,
                output_zones=tuple(run.outputs[o] for o in run.out_names),
                step=run.step,
                band=tuple(band),
                season=run.season,
                model=model,
                discharge=run.td_boxes,
                off=run.schedule.off if run.schedule.enforced and run.schedule.off.any() else None,
            )
        )
        io = _FmuIO(inst, run)
        _initialise(run, inst, io, sv)
        trace = _step_loop(run, inst, io, controller, progress)
        log = list(inst.log)
    result = CosimResult(
        table=_result_table(run, trace), summary=_summary(run, trace, fmu_path, controller, sv), log=log
    )
    if run.follow_calendar:  # the FMU switched season at the span's boundaries (season = 0)
        result.summary["seasons_followed"] = [{"season": p, "from": str(a), "to": str(b)} for p, a, b in run.pieces]
    if not result.covered:
        msg = (
            f"co-simulation stopped early: {trace.completed} of {run.n} steps "
            f"({run.frame.index[0]} .. {run.end} requested, reached {result.table.index[-1]}): {trace.stopped}"
        )
        logger.error(msg)
        if not allow_partial:
            err = FMUError(msg)
            err.result = result
            raise err
    return result


def _with_derived_columns(dataset, model):
    """``dataset`` with the disturbance columns ``model`` derives from the data and the data lack.

    An extended model whose diagnosis found a zone's reheat through its discharge air reads ``Qrh_<zone>`` [kW],
    the heat of the zone's coils from ``m``, ``Td_<vav>`` and the supply air; its FMU takes that as an input.
    On a model FMU the recorded reheat is the input it was fitted with (the controller commands airflow only).
    """
    if model is None or not getattr(model, "terms", ()):
        return dataset
    from .mpc.heating import reheat_disturbances

    frame = dataset.frame
    derived = {c: q for c, q in reheat_disturbances(model, frame).items() if c not in frame.columns}
    return dataclasses.replace(dataset, frame=frame.assign(**derived)) if derived else dataset


@dataclasses.dataclass
class _Run:
    """What one run works on: the span, the connection to the FMU and its time axis (filled step by step)."""

    frame: pd.DataFrame
    dataset: object
    season: str | None
    band: tuple
    step: float
    #: a free span's calendar seasons in order: (season, first row, last row) (:func:`season_pieces`); one piece
    #: for a week or a span inside one season
    pieces: list = dataclasses.field(default_factory=list)
    season_given: bool = False  # the caller chose the season (``season=``, ``--season``)
    follow_calendar: bool = False  # the FMU's season parameter is 0: it switches season at the boundaries itself
    inputs: dict = dataclasses.field(default_factory=dict)  # FMU input -> data column
    controls: dict = dataclasses.field(default_factory=dict)  # FMU input -> box
    outputs: dict = dataclasses.field(default_factory=dict)  # FMU output -> zones
    defaulted: list = dataclasses.field(default_factory=list)  # FMU inputs left at their start value
    discharge: dict = dataclasses.field(default_factory=dict)  # FMU input Td_<vav> -> box (plant: a command)
    V: dict = dataclasses.field(default_factory=dict)
    filled: dict = dataclasses.field(default_factory=dict)
    cframe: pd.DataFrame | None = None
    kind: str | None = None
    t0: float = 0.0  # FMU time of the span's first row [s]
    wframe: pd.DataFrame | None = None
    Mw: np.ndarray | None = None
    Vw: np.ndarray | None = None
    schedule: RunSchedule | None = None

    @classmethod
    def for_span(cls, dataset, week, start, stop, season, band):
        frame, week_season = _select_span(dataset, week, start, stop)
        if len(frame) == 0:
            raise DataError("the co-simulation span holds no data")
        # local time of week of every step: our FMUs take it as the optional input `time_of_week`,
        # which makes their gain profile follow daylight-saving time as the Python models do
        frame = frame.assign(time_of_week=seconds_of_week(frame.index).astype(float))
        given = season is not None
        pieces = season_pieces(frame.index, dataset.building) if week_season is None else []
        season = season or week_season or dataset.season_of_row[dataset.frame.index.get_loc(frame.index[0])]
        return cls(
            frame=frame,
            dataset=dataset,
            season=season,
            band=tuple(band),
            step=float(dataset.step),
            pieces=pieces,
            season_given=given,
        )

    @property
    def building(self):
        return self.dataset.building

    @property
    def n(self) -> int:
        return len(self.frame)

    @property
    def nw(self) -> int:
        return 0 if self.wframe is None else len(self.wframe)

    @property
    def vavs(self) -> tuple:
        return tuple(self.controls.values())

    @property
    def out_names(self) -> tuple:
        return tuple(self.outputs)

    @property
    def td_boxes(self) -> tuple:
        return tuple(self.discharge.values())

    @property
    def end(self):
        return self.frame.index[-1] + pd.Timedelta(seconds=self.step)


def season_pieces(index: pd.DatetimeIndex, building) -> list:
    """The calendar seasons of the rows ``index`` (local time) in order: ``[(season, first row, last row), ...]``.

    Each row's season is its local calendar day's in the building file (:meth:`hvacfmu.building.Building.season_of`),
    the dates an FMU following the calendar (``season = 0``) switches at.
    """
    if not len(index):
        return []
    days = index.normalize()
    names = {d: building.season_of(d) for d in days.unique()}
    row_season = np.array([names[d] for d in days], dtype=object)
    cuts = np.flatnonzero(row_season[1:] != row_season[:-1]) + 1
    starts = np.concatenate([[0], cuts])
    ends = np.concatenate([cuts, [len(index)]]) - 1
    return [(str(row_season[a]), index[a], index[b]) for a, b in zip(starts, ends)]


def follows_calendar(interface) -> bool:
    """True if one of our model FMUs can follow the calendar's seasons (``season = 0``; exported with a building)."""
    if not interface or not interface.get("season_dates"):
        return False
    return any(e.get("role") == "t_abs" for e in interface.get("variables", ()))


def _plan_seasons(run: _Run, inst: FMUInstance, model) -> None:
    """:func:`plan_season_span` for a run of :func:`run_cosim` (sets ``run.follow_calendar``)."""
    run.follow_calendar = plan_season_span(
        run.pieces, inst.interface, inst.path.name, run.building, run.season, run.season_given, model is not None
    )


def plan_season_span(pieces, interface, fmu_name, building, season, given, planner) -> bool:
    """A free span across a season boundary: True when the FMU follows the calendar (``season = 0``), else refused.

    An FMU with one ``season`` parameter runs that season's internal gains (and coefficient set) for the whole run;
    a span from February to May would silently run spring's all along. ``pieces``: :func:`season_pieces` of the
    span. With the season ``given`` by the caller the run keeps it, with a warning naming the boundaries; an FMU
    that can follow the calendar (:func:`follows_calendar`) is run with ``season = 0`` (a warning when a
    ``planner``, the controller's model, keeps the first season); otherwise DataError naming the dates, the
    seasons and the remedies (also when the FMU's season table is not ``building``'s). False (one season) for a
    span inside one season or an FMU without ``season``.
    """
    has_season = any(e.get("role") == "season" for e in (interface or {}).get("variables", ()))
    if len(pieces) < 2 or not has_season:
        return False
    import warnings

    from hvacfmu.errors import HvacfmuWarning

    parts = ", ".join(f"{s} {a:%Y-%m-%d %H:%M} .. {b:%Y-%m-%d %H:%M}" for s, a, b in pieces)
    where = (
        f"the span {pieces[0][1]:%Y-%m-%d %H:%M} .. {pieces[-1][2]:%Y-%m-%d %H:%M} crosses "
        f"{len(pieces) - 1} season boundar{'y' if len(pieces) == 2 else 'ies'} of building "
        f"{building.name!r} ({parts})"
    )
    if given:
        warnings.warn(
            f"{fmu_name}: {where}; season {season!r} was chosen and runs for the whole span "
            "(its internal gains and coefficient set)",
            HvacfmuWarning,
            stacklevel=4,
        )
        return False
    if follows_calendar(interface):
        ours = [[x.name, x.start, x.end] for x in building.seasons]
        if [list(map(str, row)) for row in interface["season_dates"]] != ours:
            raise DataError(
                f"{where}; the FMU {fmu_name} would follow its own season table {interface['season_dates']}, "
                f"which is not the building file's {ours}: export the FMU again with this building file "
                "(hvacfmu export -b BUILDING), or split the run at the boundaries"
            )
        logger.info("%s: %s; the FMU follows the calendar (season = 0)", fmu_name, where)
        if planner:
            warnings.warn(
                f"{fmu_name}: {where}; the FMU switches season at the boundaries (season = 0), the "
                f"controller's model keeps season {season!r} for the whole run: split the run at the "
                "boundaries for a controller that plans with each season's model",
                HvacfmuWarning,
                stacklevel=4,
            )
        return True
    raise DataError(
        f"{where}; the FMU {fmu_name} runs one season's internal gains (and coefficient set) for the whole "
        "run, so the later season(s) would be simulated with the first one's. Split the run at the boundaries "
        "(--start/--stop, one run per season), give --season to run one season throughout, or export the FMU "
        "again with the building file (hvacfmu export -b BUILDING): its season = 0 follows the calendar"
    )


def _connect(run: _Run, inst: FMUInstance, mapping) -> None:
    """Map FMU inputs/outputs to boxes, data columns and zones; gap-fill the disturbances."""
    if mapping is None:
        found = _default_mapping(inst, run.frame, run.building)
    else:
        found = _mapping_from_file(inst, mapping, run.frame, run.building)
    run.inputs, run.controls, run.outputs, problems = found[:4]
    run.defaulted = list(found[4]) if len(found) > 4 else []
    run.discharge = dict(found[5]) if len(found) > 5 else {}
    if not run.outputs:
        problems.append("no FMU output is mapped to a zone temperature")
    if problems:
        raise FMUError(problems_message(f"cannot connect {inst.path.name} to the data and building", problems))
    if run.defaulted:
        import warnings

        from hvacfmu.errors import HvacfmuWarning

        warnings.warn(
            f"{inst.path.name}: the data have no column for the FMU input(s) {run.defaulted}; they stay "
            "at their start values (e.g. no sun on the facades)",
            HvacfmuWarning,
            stacklevel=3,
        )
    for fmu_name, col in run.inputs.items():
        series, k = _fill(run.frame[col])
        run.V[fmu_name] = series.to_numpy(dtype=float)
        if k:
            run.filled[col] = k
    run.cframe = run.frame.copy()
    for fmu_name, col in run.inputs.items():
        run.cframe[col] = run.V[fmu_name]


def _apply_system(run: _Run, system: str) -> None:
    """The run's schedule: the data's off steps per box; always-on: the running supply temperature there.

    Always-on feeds each unit's supply temperature column, in the steps its unit is off in the data, with its
    last running value (taken over the whole dataset, so a span that starts at night holds the evening's).
    """
    off, noise = off_steps(run.frame, run.building, run.vavs)
    held = {}
    if system == "always-on" and off.any():
        frame, _ = running_supply(run.dataset.frame, run.building)
        rows = frame.index.get_indexer(run.frame.index)
        for fmu_name, col in run.inputs.items():
            if col not in frame.columns:
                continue
            new = frame[col].iloc[rows]
            changed = new.to_numpy(float) != run.frame[col].to_numpy(float)
            changed &= np.isfinite(new.to_numpy(float))
            if changed.any():
                series, _ = _fill(new)
                run.V[fmu_name] = series.to_numpy(dtype=float)
                run.cframe[col] = run.V[fmu_name]
                held[col] = int(changed.sum())
    run.schedule = RunSchedule(system, off, held, noise, tuple(unit_of_boxes(run.building, run.vavs)))


def _unset_states(interface) -> int:
    """How many of a model FMU's states its start values do not set from the measurements (walls, slabs, masses).

    The zone temperatures start at the measured ones (``role == "y0"``); a physics FMU's wall nodes (the 90.1
    outpatient clinic's 8 rooms: 166 states) start flat, and a run without warm-up drifts: replaying a March day of
    that clinic's data gave 164 K*h outside [20, 22] degC against 75 after a week's warm-up (69.6 measured)."""
    if not interface or interface.get("kind") == "plant":
        return 0
    set_from_data = sum(1 for e in interface.get("variables", ()) if e.get("role") == "y0")
    return max(int(interface.get("n_states") or 0) - set_from_data, 0)


def _locate_in_time(run: _Run, inst: FMUInstance, mapping, warmup) -> None:
    """FMU time of the span's start (plant: since the dataset start; foreign: its time origin) and warm-up rows."""
    run.kind = (inst.interface or {}).get("kind")
    t_start = run.frame.index[0]
    origin = t_start
    if run.kind == "plant" and inst.interface.get("start"):
        origin = pd.Timestamp(inst.interface["start"])
        origin = origin.tz_localize(inst.interface.get("timezone")) if origin.tzinfo is None else origin
    if mapping is not None and mapping.get("time_origin"):
        origin = pd.Timestamp(mapping["time_origin"])
    run.t0 = (t_start - origin).total_seconds()
    if warmup is None:
        warmup = PLANT_WARMUP if run.kind == "plant" or _unset_states(inst.interface) else 0.0
    run.wframe, run.Mw, run.Vw = _warmup_rows(
        run.dataset,
        t_start,
        float(warmup),
        run.t0 if run.kind == "plant" else math.inf,
        run.inputs,
        run.controls,
        run.outputs,
        run.V,
        run.building,
    )


def _start_values(run: _Run, inst: FMUInstance, model, controller, mapping, start_values) -> dict:
    """Start values: measured zone temperatures, season, time of week, calendar start, then the overrides."""
    sv = {}
    t_start = run.frame.index[0]
    sframe = run.wframe if run.nw else run.frame
    for e in (inst.interface or {}).get("variables", ()):
        if e.get("role") == "y0":
            out = e["name"][: -len("_start")]
            if out in run.outputs:
                sv[e["name"]] = _measured_start(out, run.outputs[out], sframe, run.building, model)
        elif e.get("role") == "season":
            seasons = inst.interface["seasons"]
            if run.season not in seasons:
                raise FMUError(f"the FMU has no internal-gain profile for season {run.season!r}; it has {seasons}")
            sv["season"] = 0 if run.follow_calendar else seasons.index(run.season) + 1
        elif e.get("role") == "tow":
            sv["start_time_of_week"] = float(seconds_of_week(pd.DatetimeIndex([t_start]))[0]) - run.t0
        elif e.get("role") == "t_abs":  # calendar-dependent model: Unix epoch [s] of FMU time 0
            sv[e["name"]] = (t_start - pd.Timedelta(seconds=run.t0)).timestamp()
    wanted = getattr(controller, "fmu_start_values", None) or {}
    sv.update({k: val for k, val in wanted.items() if k in inst.vars})
    if mapping is not None:
        sv.update(mapping.get("start_values") or {})
    sv.update(start_values or {})
    unknown = [k for k in sv if k not in inst.vars]
    if unknown:
        raise FMUError(f"start values for unknown FMU variables: {unknown}")
    if "start_time_of_week" in sv:
        sv["start_time_of_week"] %= 7 * 86400.0
    return sv


class _FmuIO:
    """Preallocated ctypes buffers for setting all inputs and getting all outputs per step (°C <-> K offsets)."""

    K = 273.15

    def __init__(self, inst: FMUInstance, run: _Run):
        def offset(name):
            return self.K if inst.vars[name].unit == "K" else 0.0

        self.fmu = inst.fmu
        names = list(run.controls) + list(run.discharge) + list(run.inputs)
        self.nc, self.nin, self.nout = len(run.controls), len(names), len(run.out_names)
        self.nd = len(run.discharge)  # discharge air commands after the airflows (unset: 0 degC, no reheat)
        self.in_vr = (ctypes.c_uint32 * self.nin)(*[inst.vars[k].vr for k in names])
        self.in_val = (ctypes.c_double * self.nin)()
        self.inp = np.frombuffer(self.in_val, dtype=float)
        self.in_off = np.array(
            [
                offset(k) if (k in run.inputs and run.inputs[k].startswith("T_")) or k in run.discharge else 0.0
                for k in names
            ]
        )
        self.out_vr = (ctypes.c_uint32 * self.nout)(*[inst.vars[k].vr for k in run.out_names])
        self.out_val = (ctypes.c_double * self.nout)()
        self.out = np.frombuffer(self.out_val, dtype=float)
        self.out_off = np.array([offset(k) for k in run.out_names])
        self.Vmat = np.column_stack([run.V[k] for k in run.inputs]) if run.inputs else np.zeros((run.n, 0))

    def set_inputs(self, m, v):
        """Airflows (nc), optionally followed by discharge commands (nd) [degC], and disturbances."""
        m = np.asarray(m, dtype=float)
        nm = self.nc + self.nd
        self.inp[: m.size] = m
        self.inp[m.size : nm] = 0.0  # discharge commands not given: no reheat
        self.inp[self.nc : nm] += self.in_off[self.nc : nm]
        self.inp[nm:] = v + self.in_off[nm:]
        self.fmu.fmi2SetReal(self.fmu.component, self.in_vr, self.nin, self.in_val)

    def outputs(self) -> np.ndarray:
        self.fmu.fmi2GetReal(self.fmu.component, self.out_vr, self.nout, self.out_val)
        return self.out - self.out_off


def _call_failure(exc, what: str, t: float, when, inst: FMUInstance) -> str:
    """'fmi2DoStep at t=... s (time) returned discard: <the FMU's last message>'."""
    status = getattr(exc, "status", None)
    name = STATUS[status] if isinstance(status, int) and 0 <= status < len(STATUS) else None
    errs = inst.errors()
    head = f"{what} at t={t:g} s ({when}) returned {name}" if name else f"{what} at t={t:g} s ({when}) failed: {exc}"
    return head + (f"; FMU log: {errs[-1]}" if errs else "; the FMU logged no reason")


def _initial_airflows(run: _Run) -> np.ndarray:
    """Box airflows set before leaving initialisation: the first warm-up row, else row 0 (box minimum if missing)."""
    if run.nw:
        return run.Mw[0]
    by_name = {b.name: b for b in run.building.vavs}
    m = np.array([run.frame[f"m_{b}"].iloc[0] if f"m_{b}" in run.frame else np.nan for b in run.vavs], dtype=float)
    return np.where(np.isfinite(m), m, [by_name[b].m_min for b in run.vavs])


def _initialise(run: _Run, inst: FMUInstance, io: _FmuIO, sv: dict) -> None:
    """Set up, set start values and the first inputs, leave initialisation, replay the warm-up rows."""
    fmu = inst.fmu
    t_setup = run.t0 - run.nw * run.step
    try:
        fmu.setupExperiment(startTime=t_setup)
        fmu.enterInitializationMode()
        for name, value in sv.items():
            var = inst.vars[name]
            if var.type == "Integer":
                fmu.setInteger([var.vr], [int(value)])
            else:
                fmu.setReal([var.vr], [float(value)])
        # first inputs before leaving initialisation (as FMPy does): they set the FMU's unobserved states
        io.set_inputs(_initial_airflows(run), run.Vw[0] if run.nw else io.Vmat[0])
        fmu.exitInitializationMode()
    except Exception as exc:  # noqa: BLE001
        raise FMUError(
            f"initialising {inst.path.name} failed: "
            f"{_call_failure(exc, 'initialisation', t_setup, 'before the span', inst)}"
        ) from None
    for j in range(run.nw):  # warm-up: the measured airflows and disturbances before the span
        t = run.t0 - (run.nw - j) * run.step
        try:
            io.set_inputs(run.Mw[j], run.Vw[j])
            fmu.fmi2DoStep(fmu.component, t, run.step, 1)
        except Exception as exc:  # noqa: BLE001
            raise FMUError(
                f"warm-up of {inst.path.name} failed: {_call_failure(exc, 'fmi2DoStep', t, run.wframe.index[j], inst)}"
            ) from None
    if inst.errors():
        raise FMUError(problems_message(f"{inst.path.name} reported errors at initialisation", inst.errors()))


@dataclasses.dataclass
class _Trace:
    """Per-step record of a run."""

    Y: np.ndarray
    M: np.ndarray
    t_ctrl: np.ndarray
    t_fmu: np.ndarray
    completed: int = 0
    stopped: str | None = None
    overridden: int = 0  # box-steps off in the schedule where the controller asked for airflow or reheat


def _switched_off(m, off, nc, td_cols, tr: _Trace) -> np.ndarray:
    """``m`` with the off boxes at 0 airflow and their discharge commands at 0 degC (no reheat); counts overrides."""
    m = np.array(m, dtype=float)
    asked = np.abs(m[:nc][off]) > 1e-9
    m[:nc][off] = 0.0
    if m.size > nc:
        td_off = off[td_cols]
        m[nc:][td_off] = 0.0
    tr.overridden += int(asked.sum())
    return m


def _step_loop(run: _Run, inst: FMUInstance, io: _FmuIO, controller, progress) -> _Trace:
    """One controller call and one FMU step per row; stops (with the reason) at the first failure."""
    n, nc = run.n, io.nc
    tr = _Trace(
        Y=np.full((n + 1, io.nout), np.nan),
        M=np.full((n + 1, nc + io.nd), np.nan),
        t_ctrl=np.full(n, np.nan),
        t_fmu=np.full(n, np.nan),
    )
    tr.Y[0] = io.outputs()
    v_names = list(run.inputs.values())
    # a bar on a terminal, plain log lines otherwise (hvacfmu.progress)
    iterator = progress_iter(range(n), desc="cosim", unit="step", enabled=bool(progress))
    fmu, index = inst.fmu, run.frame.index
    sched = run.schedule
    off = sched.off if sched is not None and sched.enforced and sched.off.any() else None
    td_cols = [run.vavs.index(b) for b in run.td_boxes]
    for k in iterator:
        t = run.t0 + k * run.step
        c0 = time.perf_counter()
        try:
            m = np.asarray(controller(k, index[k], tr.Y[k].copy(), dict(zip(v_names, io.Vmat[k]))), dtype=float)
        except Exception as exc:  # noqa: BLE001 - the run stops, the result says why
            tr.stopped = f"controller raised {type(exc).__name__} at step {k} ({index[k]}): {exc}"
            break
        c1 = time.perf_counter()
        if m.shape not in ((nc,), (nc + io.nd,)) or not np.all(np.isfinite(m)):
            need = f"{nc} finite airflows" + (f" (then {io.nd} discharge temperatures)" if io.nd else "")
            tr.stopped = f"controller returned {m!r} at step {k} ({index[k]}; need {need})"
            break
        if off is not None and off[k].any():
            m = _switched_off(m, off[k], nc, td_cols, tr)
        tr.M[k, : m.size] = m
        try:
            io.set_inputs(m, io.Vmat[k])
            fmu.fmi2DoStep(fmu.component, t, run.step, 1)
            y = io.outputs()
        except Exception as exc:  # noqa: BLE001 - FMICallException: discard, error or fatal
            tr.stopped = _call_failure(exc, "fmi2DoStep", t, index[k], inst)
            break
        c2 = time.perf_counter()
        if not np.all(np.isfinite(y)):
            tr.stopped = f"the FMU returned non-finite outputs {y!r} after the step at t={t:g} s ({index[k]})"
            break
        tr.Y[k + 1] = y
        tr.t_ctrl[k], tr.t_fmu[k] = c1 - c0, c2 - c1
        tr.completed = k + 1
    return tr


def _result_table(run: _Run, tr: _Trace) -> pd.DataFrame:
    """The run's table: outputs, commands, disturbances, measurements, timings (cut at the last step taken)."""
    frame = run.frame
    index = frame.index.append(pd.DatetimeIndex([run.end]))
    index.name = "time"
    table = pd.DataFrame(tr.Y, index=index, columns=list(run.out_names))
    for j, b in enumerate(run.vavs):
        table[f"m_{b}"] = tr.M[:, j]
    for j, b in enumerate(run.td_boxes):
        if np.any(np.isfinite(tr.M[: tr.completed, len(run.vavs) + j])):  # only when the controller commands it
            table[f"Td_{b}"] = tr.M[:, len(run.vavs) + j]
    for fmu_name, col in run.inputs.items():
        table[col] = np.append(run.V[fmu_name], np.nan)
    for o in run.out_names:
        zones = run.outputs[o]
        if len(zones) == 1 and f"T_{zones[0]}" in frame:
            table[f"{o}_measured"] = np.append(frame[f"T_{zones[0]}"].to_numpy(dtype=float), np.nan)
    if run.schedule is not None and run.schedule.off.any():  # boxes whose unit is off in the data, per step
        table["off_boxes"] = np.append(run.schedule.off.sum(axis=1), 0).astype(int)
    table["controller_time"] = np.append(tr.t_ctrl, np.nan)
    table["fmu_time"] = np.append(tr.t_fmu, np.nan)
    return table.iloc[: tr.completed + 1] if tr.completed < run.n else table


def _heating_kwh(run: _Run, tr: _Trace) -> float:
    """Reheat commanded through the discharge inputs: Σ m c_p max(Td - T_supply, 0) · step [kWh] (0 without)."""
    c, nc = tr.completed, len(run.vavs)
    if not run.discharge or c == 0 or "T_supply" not in run.V:
        return 0.0
    cols = [run.vavs.index(b) for b in run.td_boxes]
    m, Td = tr.M[:c, cols], tr.M[:c, nc:]
    q = m * CP_AIR * np.maximum(Td - run.V["T_supply"][:c, None], 0.0)
    return float(np.nansum(q) * run.step / 3.6e6)


def oscillation_counts(Y, names, amplitude: float = OSCILLATION_K) -> dict:
    """``{output: n}`` of the outputs whose step change reverses with both steps above ``amplitude`` [K].

    ``Y`` (steps, outputs) [°C] of the run; ``n`` counts the steps ``k`` with
    ``|y(k+1) - y(k)| > amplitude``, ``|y(k) - y(k-1)| > amplitude`` and opposite signs. Outputs
    without such a step are left out (an empty dict: no output cycled).
    """
    Y = np.asarray(Y, dtype=float)
    out = {}
    if Y.ndim != 2 or Y.shape[0] < 3:
        return out
    d = np.diff(Y, axis=0)
    big = np.abs(d) > amplitude
    rev = big[1:] & big[:-1] & (np.sign(d[1:]) * np.sign(d[:-1]) < 0)
    for j, name in enumerate(names):
        n = int(np.sum(rev[:, j]))
        if n:
            out[str(name)] = n
    return out


def _measured_violation(run: _Run, completed: int):
    """K*h of the measured zone temperatures outside the band over the steps taken (None without them).

    The figure that makes the run's own readable: a band that is not the building's (the default 20-22 degC against a
    restaurant held at 24 degC all summer) shows as the measured data being far outside it too."""
    Y = _measured_outputs(run, completed)
    if Y is None:
        return None
    below, above = _band_excess(Y, run.band)
    return float(np.nansum(below + above) * run.step / 3600.0)


def _measured_oscillation(run: _Run, completed: int):
    """:func:`oscillation_counts` of the measured zone temperatures over the steps taken (None without them).

    A zone whose own loop cycles at the data's step (a small zone on one fast box) reverses in the data as in the
    run: the run's count is then the building's, not a controller cycling with the plant."""
    Y = _measured_outputs(run, completed)
    return None if Y is None else oscillation_counts(Y, run.out_names)


def _measured_outputs(run: _Run, completed: int):
    """The measured zone temperatures of the run's outputs over the steps taken [°C] (None without them)."""
    weights = dict(zip(run.building.zone_names, run.building.area_weights())) if run.building is not None else {}
    columns = []
    for o in run.out_names:
        zones = run.outputs[o]
        if any(f"T_{z}" not in run.frame for z in zones) or (len(zones) > 1 and not all(z in weights for z in zones)):
            return None
        w = np.array([weights[z] for z in zones], dtype=float) if len(zones) > 1 else np.ones(1)
        T = run.frame[[f"T_{z}" for z in zones]].to_numpy(dtype=float)
        columns.append(T @ (w / w.sum()))  # a floor output (lumped model): the area-weighted mean of its zones
    Y = np.column_stack(columns)[1 : completed + 1]
    if not len(Y) or not np.isfinite(Y).any():
        return None
    return Y


def _band_excess(Y, band):
    """``(below, above)`` [K]: how far each value of ``Y`` lies under and over the band ``(lo, hi)`` (0 inside it)."""
    lo, hi = band
    return np.clip(lo - Y, 0, None), np.clip(Y - hi, 0, None)


def _summary(run: _Run, tr: _Trace, fmu_path, controller, sv) -> dict:
    c = tr.completed
    Mc, Yc = tr.M[:c, : len(run.vavs)], tr.Y[1 : c + 1]
    lo, hi = run.band
    below, above = _band_excess(Yc, run.band)
    st = (tr.t_ctrl + tr.t_fmu)[:c]
    stats = getattr(controller, "stats", None)

    def med(a):
        return float(np.median(a)) if c else math.nan

    return {
        "fmu": str(Path(fmu_path).name),
        "controller": getattr(controller, "name", type(controller).__name__),
        "start": str(run.frame.index[0]),
        "end": str(run.end),
        "step": run.step,
        "season": run.season,
        "steps_requested": run.n,
        "steps_completed": c,
        "covered": c == run.n,
        "stopped_because": tr.stopped,
        "energy_proxy": float(np.sum(Mc**2)),
        "total_airflow_kg": float(np.sum(Mc) * run.step),
        "mean_airflow": float(np.mean(np.sum(Mc, axis=1))) if c else math.nan,
        "comfort_violation_Kh": float(np.sum(below + above) * run.step / 3600.0),
        "measured_comfort_violation_Kh": _measured_violation(run, c),
        "outputs": len(run.out_names),
        "comfort_by_output": {
            n: [float(b), float(a)]
            for n, b, a in zip(
                run.out_names,
                np.nansum(below, axis=0) * run.step / 3600.0,
                np.nansum(above, axis=0) * run.step / 3600.0,
            )
        },
        "heating_kWh": _heating_kwh(run, tr),
        "heating_commanded": bool(run.discharge),
        "band": [float(lo), float(hi)],
        "step_time_median": med(st),
        "step_time_max": float(np.max(st)) if c else math.nan,
        "controller_time_median": med(tr.t_ctrl[:c]),
        "fmu_time_median": med(tr.t_fmu[:c]),
        "filled_inputs": run.filled,
        "defaulted_inputs": run.defaulted,
        "oscillation": oscillation_counts(Yc, run.out_names),
        "measured_oscillation": _measured_oscillation(run, c),
        "controller_stats": stats() if callable(stats) else {},
        "start_values": sv,
        "warmup_steps": run.nw,
        "schedule": _schedule_summary(run, tr),
        "limits": limits_check(Mc, run.building, run.vavs),
    }


def _schedule_summary(run: _Run, tr: _Trace) -> dict:
    if run.schedule is None:
        return {}
    out = run.schedule.summary(run.frame.index)
    out["overridden_box_steps"] = tr.overridden
    return out


def limits_check(M, building, vavs, tol: float = 1e-9) -> dict:
    """Applied airflows against the boxes' limits: each box-step is off (0) or inside ``[m_min, m_max]``.

    Parameters
    ----------
    M : array (steps, boxes) [kg/s]
        Applied airflows (order ``vavs``).

    Returns
    -------
    dict
        ``off`` (box-steps at 0), ``in_range`` (inside the limits, ``tol`` [kg/s] allowed), ``outside`` (neither)
        and ``outside_max`` [kg/s] (the largest distance to the nearest allowed value).
    """
    by_name = {b.name: b for b in building.vavs}
    lo = np.array([by_name[b].m_min for b in vavs], dtype=float)
    hi = np.array([by_name[b].m_max for b in vavs], dtype=float)
    M = np.asarray(M, dtype=float).reshape(-1, len(vavs))
    zero = np.abs(M) <= tol
    inside = (M >= lo - tol) & (M <= hi + tol)
    bad = ~(zero | inside)
    dist = np.minimum(np.abs(M), np.maximum(lo - M, M - hi))
    return {
        "off": int(np.sum(zero & ~inside)),
        "in_range": int(np.sum(inside)),
        "outside": int(np.sum(bad)),
        "outside_max": float(np.max(dist[bad], initial=0.0)),
    }


# =============================================================================
# fmpy.simulate_fmu, checked
# =============================================================================
def simulate_fmu_checked(path, *, stop_time: float, output_interval: float, start_time: float = 0.0, **kwargs):
    """``fmpy.simulate_fmu`` that never returns a silently truncated result.

    FMPy stops without an exception when an FMU answers ``fmi2Discard`` and
    returns the rows up to there. This wrapper captures the FMU's log and raises
    :class:`~hvacfmu.errors.FMUError` naming the time reached, the requested end
    and the FMU's last message when the result does not reach ``stop_time``.

    Parameters
    ----------
    path : path
        The FMU.
    stop_time, output_interval, start_time : float [s]
        As for ``fmpy.simulate_fmu`` (``output_interval`` is required: FMPy does
        not take the step from the FMU).
    **kwargs
        Passed on (``input``, ``start_values``, ``output`` ...).

    Returns
    -------
    numpy structured array
        FMPy's result, covering ``start_time .. stop_time``.
    """
    from fmpy import simulate_fmu

    messages = []

    def log(component, instance, status, category, message):
        text = message.decode("utf-8", errors="replace") if isinstance(message, bytes) else str(message)
        messages.append((STATUS[status] if 0 <= status < len(STATUS) else str(status), text))

    try:
        res = simulate_fmu(
            str(path),
            start_time=start_time,
            stop_time=stop_time,
            output_interval=output_interval,
            logger=log,
            debug_logging=False,
            **kwargs,
        )
    except Exception as exc:  # noqa: BLE001 - FMPy raises plain exceptions
        last = next((m for st, m in reversed(messages) if st != "ok"), None)
        raise FMUError(f"simulating {Path(path).name} failed: {exc}" + (f"; FMU log: {last}" if last else "")) from None
    finally:
        _restore_fmpy_logger()
    reached = float(res["time"][-1]) if len(res) else start_time
    if reached < stop_time - 1e-6 * max(1.0, abs(stop_time)):
        last = next((f"[{st}] {m}" for st, m in reversed(messages) if st != "ok"), "the FMU logged no reason")
        raise FMUError(
            f"simulating {Path(path).name} stopped early at t={reached:g} s of {stop_time:g} s "
            f"({len(res)} rows): {last}"
        )
    return res


# =============================================================================
# controllers by name
# =============================================================================
def _parse_options(items) -> dict:
    out = {}
    for item in items or ():
        if "=" not in item:
            raise HvacfmuError(f"controller option {item!r} must be KEY=VALUE")
        key, value = item.split("=", 1)
        for conv in (int, float):
            try:
                value = conv(value)
                break
            except ValueError:
                continue
        out[key.strip()] = value
    return out


def _check_controller_options(name, cls, options) -> None:
    """HvacfmuError naming the options ``cls`` does not take (``--horizon`` is the MPC's), and the ones it does."""
    import inspect

    kinds = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    params = [n for n, p in inspect.signature(cls).parameters.items() if p.kind in kinds]
    unknown = [k for k in options if k not in params]
    if unknown:
        what = ", ".join("horizon (--horizon is the MPC's)" if k == "horizon" else k for k in unknown)
        takes = ", ".join(params) if params else "none"
        raise HvacfmuError(
            f"controller {name!r} takes no option {what}; its options (--option KEY=VALUE): {takes}. "
            "Drop it, or use --controller mpc"
        )


def make_controller(name, model=None, building=None, options=None):
    """A controller by name: ``replay``, ``rule`` or ``mpc``.

    ``mpc`` is the dispatch point to :mod:`harness.mpc` (issue #6): it calls
    ``harness.mpc.cosim_controller(model, building, **options)``, which must
    return an object following the controller protocol of
    :mod:`harness.controllers`.
    """
    options = dict(options or {})
    if name in ("replay", "rule"):
        cls = ReplayController if name == "replay" else RuleController
        _check_controller_options(name, cls, options)
        return cls(**options)
    if name == "mpc":
        if model is None:
            raise HvacfmuError("--controller mpc needs the controller's model: --model model.json")
        try:
            from harness.mpc import cosim_controller
        except ImportError as exc:
            raise HvacfmuError(f"the MPC controller is not available (harness.mpc.cosim_controller): {exc}") from None
        return cosim_controller(model, building, **options)
    raise HvacfmuError(f"unknown controller {name!r}; choose one of {CONTROLLERS}")


# =============================================================================
# command line
# =============================================================================
def add_cosim_arguments(parser):
    """Arguments of ``hvacfmu cosim``."""
    parser.add_argument(
        "--fmu", "--plant", dest="fmu", required=True, help="co-simulation FMU to run (a model FMU or the plant FMU)"
    )
    parser.add_argument("--data", "-d", required=True, help="measurements file (CSV or Parquet)")
    parser.add_argument("--building", "-b", required=True, help="building file (TOML)")
    parser.add_argument(
        "--controller",
        "-c",
        choices=CONTROLLERS,
        default="replay",
        help="replay measured airflows, rule-based PI, or MPC (default replay)",
    )
    parser.add_argument("--model", "-m", help="model file (JSON): the MPC's model; maps measured outputs")
    parser.add_argument("--week", type=int, help="week number to run (default: the first held-out week)")
    parser.add_argument("--start", help="start of the span instead of --week (local time)")
    parser.add_argument("--stop", help="end of the span (exclusive)")
    parser.add_argument("--out", "-o", help="results table (.csv or .parquet); summary beside it (.json)")
    parser.add_argument("--plot", help="figure of the run (.png, .pdf, .svg)")
    parser.add_argument("--mapping", help="JSON mapping of a foreign FMU's variables (see harness.cosim)")
    parser.add_argument(
        "--band",
        type=float,
        nargs=2,
        default=DEFAULT_BAND,
        metavar=("T_MIN", "T_MAX"),
        help="comfort band [degC] (default 20 22)",
    )
    parser.add_argument(
        "--season",
        help="season of the gains profile for the whole run (default: the week's; a --start/--stop span across a "
        "season boundary follows the calendar when the FMU was exported with -b, else it is refused)",
    )
    parser.add_argument(
        "--horizon",
        type=int,
        help=f"MPC horizon in steps (passed to harness.mpc; default {DEFAULT_HORIZON_H:g} h in steps of the data: "
        f"{default_horizon(900)} at 15-min steps, {default_horizon(300)} at 5-min, as hvacfmu demo runs; "
        "--horizon 3 = the paper's 45 min at 15-min steps)",
    )
    parser.add_argument(
        "--option",
        action="append",
        metavar="KEY=VALUE",
        help="controller option (repeatable), e.g. kp=0.8 for rule, rho=100 for mpc",
    )
    parser.add_argument(
        "--warmup",
        type=float,
        metavar="HOURS",
        help="replay the measured data this long before the span first (default: 168 h for "
        "the plant FMU and for model FMUs with states the data do not set, a physics model's walls; 0 for the others)",
    )
    parser.add_argument("--step", type=float, default=900.0, help="model/communication step [s] (default 900)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the train/test week split (default 0)")
    parser.add_argument(
        "--interpolate-gaps",
        type=float,
        default=None,
        metavar="MINUTES",
        help="interpolate data gaps up to this length when preparing the data",
    )
    parser.add_argument(
        "--system",
        choices=SYSTEMS,
        default="schedule",
        help="schedule (default): where the data's air handler is off (every box at most max(1e-6 kg/s, 5 %% of "
        "m_min), or none at half its m_min) the boxes get 0 airflow and no reheat, whatever the controller; "
        "always-on: run the system through those steps, with the unit's last running supply temperature",
    )
    parser.add_argument(
        "--allow-partial", action="store_true", help="exit 0 even if the FMU stopped early (the error is still printed)"
    )


def _fmu_model(path):
    """The zone model an hvacfmu FMU carries (``resources/model.json``), or None (a plant, another tool's FMU).

    Read once per file version: ``cosim`` asks for it when checking the building file and again for the run.
    """
    try:
        stat = Path(path).stat()
    except OSError:
        return None
    return _fmu_model_of(str(Path(path).resolve()), stat.st_mtime_ns, stat.st_size)


@functools.lru_cache(maxsize=4)
def _fmu_model_of(path: str, mtime_ns: int, size: int):
    import zipfile

    from hvacfmu.errors import HvacfmuError
    from hvacfmu.models import model_from_dict

    try:
        with zipfile.ZipFile(path) as z:
            d = json.loads(z.read("resources/model.json").decode("utf-8"))
        return model_from_dict(d)
    except (OSError, KeyError, ValueError, zipfile.BadZipFile, HvacfmuError):
        return None


def _warn_building_mismatch(args, model, building) -> None:
    """Warn when the model or the FMU's model was fitted with another building file than ``building``."""
    import warnings

    from hvacfmu.errors import HvacfmuWarning
    from hvacfmu.models.base import building_mismatch
    from hvacfmu.models.loadcheck import require_box_drive

    for what, m in ((args.model, model), (args.fmu, _fmu_model(args.fmu))):
        if m is None:
            continue
        require_box_drive(m, building, str(what))
        problems, notes = building_mismatch(m, building)
        for note in problems + notes:
            warnings.warn(f"{what}: {note}", HvacfmuWarning, stacklevel=3)


def main_cosim(args) -> int:
    """Run ``hvacfmu cosim``; returns the exit code (1 if the run stopped early)."""
    from hvacfmu.data import prepare
    from hvacfmu.models import load_model

    dataset = prepare(args.data, args.building, step=args.step, seed=args.seed, interpolate_limit=args.interpolate_gaps)
    model = load_model(args.model) if args.model else None
    _warn_building_mismatch(args, model, dataset.building)
    options = _parse_options(args.option)
    if args.horizon is not None:
        options["horizon"] = args.horizon
    controller = make_controller(args.controller, model, dataset.building, options)
    mapping = None
    if args.mapping:
        try:
            mapping = json.loads(Path(args.mapping).read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as exc:
            raise HvacfmuError(f"cannot read mapping file {args.mapping}: {exc}") from None
    result = run_cosim(
        args.fmu,
        dataset,
        controller,
        week=args.week,
        start=args.start,
        stop=args.stop,
        model=model,
        mapping=mapping,
        band=tuple(args.band),
        season=args.season,
        allow_partial=True,
        progress=not getattr(args, "quiet", True),
        warmup=None if getattr(args, "warmup", None) is None else args.warmup * 3600.0,
        system=getattr(args, "system", "schedule"),
    )
    print(result.format_summary())
    if args.out:
        print(f"wrote {result.save(args.out)}")
    if args.plot:
        print(f"wrote {result.plot(args.plot)}")
    if not result.covered:
        print(f"hvacfmu cosim: error: the FMU stopped early: {result.summary['stopped_because']}", file=sys.stderr)
        return 0 if args.allow_partial else 1
    return 0


__all__ = [
    "CosimResult",
    "FMUInstance",
    "add_cosim_arguments",
    "main_cosim",
    "make_controller",
    "run_cosim",
    "simulate_fmu_checked",
]
