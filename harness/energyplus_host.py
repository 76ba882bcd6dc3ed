"""EnergyPlus as the co-simulation host: one of our FMUs and our MPC in the loop of an EnergyPlus building.

EnergyPlus runs the building (its own HVAC, its own zone thermostats) through its
Python API. At the end of every 15-minute zone step the host

1. reads what a BMS would (zone temperatures, box airflows and discharge
   temperatures, supply temperatures, weather; as :mod:`hvacfmu.energyplus` exports);
2. steps the FMU (a zone model identified on this building's own exported data)
   with the measured airflows and disturbances: the FMU predicts the zone
   temperatures, logged next to EnergyPlus's (a digital twin in the loop);
3. asks the controller (``harness.mpc.cosim_controller``) for the box airflows of
   the next step; a supervisory MPC cannot command EnergyPlus's VAV terminals
   directly (EnergyPlus has no airflow actuator for them), so the temperature the
   MPC's plan reaches at the end of the next step becomes each zone's cooling
   setpoint (``Zone Temperature Control`` actuator; heating setpoint = the band's
   lower limit) during occupied hours; outside them EnergyPlus's own schedules
   apply (actuators released). EnergyPlus's terminals then deliver the air.

Every value written at step k is read back at step k+1 from EnergyPlus's own
``Zone Thermostat ... Setpoint Temperature`` (what EnergyPlus used), and
:attr:`HostResult.mismatches` counts any difference. An exception in a callback
stops EnergyPlus at once and is re-raised after the run (EnergyPlus would
otherwise swallow it). Without a controller the run is EnergyPlus's own control,
the reference for energy and comfort (:func:`compare`).
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from hvacfmu.energyplus import hvac, inputs
from hvacfmu.energyplus.generate import STEP_HOURS, export_probes, select_boxes
from hvacfmu.energyplus.idf import read_idf
from hvacfmu.energyplus.run import Probe, simulate, step_start
from hvacfmu.errors import FMUError, HvacfmuError
from hvacfmu.timeutil import seconds_of_week

#: EnergyPlus meters recorded per step [J] (those the building has).
METERS = (
    "Electricity:HVAC",
    "NaturalGas:HVAC",
    "Heating:Electricity",
    "Heating:NaturalGas",
    "Cooling:Electricity",
    "Fans:Electricity",
)
SETPOINT_TOL = 1e-6  # [K] written vs. read back


@dataclasses.dataclass(frozen=True)
class HostSettings:
    """Comfort band [°C] and occupied hours [local h, start inclusive, end exclusive] on weekdays."""

    band: tuple = (21.0, 24.0)
    occupied: tuple = (7, 19)

    def is_occupied(self, t: pd.Timestamp) -> bool:
        return t.weekday() < 5 and self.occupied[0] <= t.hour < self.occupied[1]


@dataclasses.dataclass
class HostResult:
    """One run: ``table`` (one row per 15-minute step, local time index), ``summary``, ``mismatches``
    (setpoints EnergyPlus used that differ from those sent), ``controller`` name."""

    table: pd.DataFrame
    summary: dict
    mismatches: list
    controller: str

    def format_summary(self) -> str:
        s = self.summary
        lines = [
            (
                f"{self.controller}: {s['steps']} steps, HVAC energy {s['energy_kWh']:.1f} kWh "
                f"({', '.join(f'{k} {v:.1f}' for k, v in s['meters_kWh'].items())}), "
                f"comfort violation {s['violation_Kh']:.2f} Kh over occupied hours"
            )
        ]
        if "fmu_rms_K" in s:
            lines.append(
                f"  FMU in the loop (open loop from the run's start, fed the measured airflows): RMS "
                f"{s['fmu_rms_K']:.3f} K against EnergyPlus's zone temperatures"
            )
        if s.get("setpoints_sent"):
            lines.append(
                f"  setpoints sent {s['setpoints_sent']}, read back by EnergyPlus identical: "
                f"{s['setpoints_sent'] - len(self.mismatches)}"
            )
        return "\n".join(lines)


class _FMUStepper:
    """Steps one of our model FMUs (FMPy) with live EnergyPlus values; outputs the zones' ``T_<zone>``."""

    def __init__(self, path, zones, season):
        from harness.cosim import FMUInstance

        self.inst = FMUInstance(path, instance_name="energyplus_host")
        self.zones, self.season = zones, season
        self.follow = False  # season = 0: the FMU follows the calendar's seasons (a span across a boundary)
        v = self.inst.vars
        self.inputs = [n for n, x in v.items() if x.causality == "input"]
        self.outputs = [f"T_{z}" for z in zones if f"T_{z}" in v and v[f"T_{z}"].causality == "output"]
        if not self.outputs:
            raise FMUError(f"FMU {path} has no output T_<zone> for the zones {list(zones)}")
        self.started = False

    def _value(self, name, live, frow, t_local):
        if name == "time_of_week":
            return float(seconds_of_week(pd.DatetimeIndex([t_local]))[0])
        val = live.get(name, frow.get(name) if frow is not None else None)
        if val is None or not np.isfinite(val):
            raise FMUError(f"no value for FMU input {name!r} at {t_local} (EnergyPlus row or the run's data frame)")
        return float(val) + (273.15 if self.inst.vars[name].unit == "K" else 0.0)

    def _start(self, t, live, frow, t_local):
        fmu, sv = self.inst.fmu, {}
        for e in (self.inst.interface or {}).get("variables", []):
            if e.get("role") == "y0" and e["name"][: -len("_start")] in live:
                sv[e["name"]] = live[e["name"][: -len("_start")]]
            elif e.get("role") == "season":
                sv["season"] = 0 if self.follow else self.inst.interface["seasons"].index(self.season) + 1
            elif e.get("role") == "t_abs" and self.follow:  # Unix epoch [s] of FMU time 0
                sv["start_time"] = pd.Timestamp(t_local).timestamp() - t
            elif e.get("role") == "tow":
                sv["start_time_of_week"] = float(seconds_of_week(pd.DatetimeIndex([t_local]))[0]) - t
        fmu.setupExperiment(startTime=t)
        fmu.enterInitializationMode()
        for name, value in sv.items():
            var = self.inst.vars[name]
            (fmu.setInteger if var.type == "Integer" else fmu.setReal)([var.vr], [type(value)(value)])
        self._set_inputs(live, frow, t_local)
        fmu.exitInitializationMode()
        self.started = True

    def _set_inputs(self, live, frow, t_local):
        vals = [self._value(n, live, frow, t_local) for n in self.inputs]
        self.inst.fmu.setReal([self.inst.vars[n].vr for n in self.inputs], vals)

    def step(self, t, dt, live, frow, t_local, start_temps) -> dict:
        """Step from ``t`` [s] over ``dt`` [s] with this step's inputs; returns the outputs at the step's end."""
        try:
            if not self.started:
                self._start(t, {**live, **start_temps}, frow, t_local)
            self._set_inputs(live, frow, t_local)
            self.inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=dt)
            vals = self.inst.fmu.getReal([self.inst.vars[n].vr for n in self.outputs])
        except Exception as exc:
            raise FMUError(
                f"FMU {self.inst.path.name} failed at {t_local}: {exc}; FMU log: {self.inst.errors()}"
            ) from exc
        off = [273.15 if self.inst.vars[n].unit == "K" else 0.0 for n in self.outputs]
        return {n: v - o for n, v, o in zip(self.outputs, vals, off)}

    def close(self):
        self.inst.close()


class _Loop:
    """The per-step work of :func:`run_host` (called from EnergyPlus's zone-step callback)."""

    def __init__(self, probes, zones, frame, settings, controller, fmu, lo, hi, site):
        self.col = {p.column: i for i, p in enumerate(probes)}
        self.zones, self.frame, self.settings = zones, frame, settings
        self.controller, self.fmu, self.lo, self.hi, self.site = controller, fmu, lo, hi, site
        self.rows, self.sent, self.mismatches = [], {}, []
        self.act = self.meters = None
        self.n_sent = 0

    def _handles(self, state, api):
        x = self.api = api.exchange
        self.act = {}
        for z in self.zones:
            for kind in ("Cooling Setpoint", "Heating Setpoint"):
                h = x.get_actuator_handle(state, "Zone Temperature Control", kind, self.zones[z])
                if h < 0:
                    raise HvacfmuError(
                        f"EnergyPlus has no actuator Zone Temperature Control/{kind} for zone {self.zones[z]!r}"
                    )
                self.act[(z, kind)] = h
        self.meters = {m: x.get_meter_handle(state, m) for m in METERS}
        self.meters = {m: h for m, h in self.meters.items() if h >= 0}

    def step_start(self, api, state) -> pd.Timestamp:
        x = api.exchange
        start = step_start(
            x.calendar_year(state), x.day_of_year(state), x.current_time(state), self.site.tz_hours, STEP_HOURS
        )
        return pd.Timestamp(start, tz="UTC").round("1s").tz_convert(self.site.timezone)

    def __call__(self, state, api, k, row):
        if self.act is None:
            self._handles(state, api)
        t = self.step_start(api, state)
        if not (self.lo <= t < self.hi):
            return
        i = int(self.frame.index.get_indexer([t])[0])
        if i < 0:
            raise HvacfmuError(f"EnergyPlus step {t} is not a row of the run's data frame")
        live = {c: float(row[j]) for c, j in self.col.items()}
        rec = {"time": t, **{f"T_{z}": live[f"T_{z}"] for z in self.zones}}
        rec.update({f"m_{c[2:]}": live[c] for c in self.col if c.startswith("m_")})
        rec.update({f"J_{m}": api.exchange.get_meter_value(state, h) for m, h in self.meters.items()})
        self._check_received(i, live, rec)
        if self.fmu is not None:
            temps = {f"T_{z}": live[f"T_{z}"] for z in self.zones}
            pred = self.fmu.step(i * 900.0, 900.0, live, self.frame.iloc[i], t, temps)
            rec.update({f"fmu_{n}": v for n, v in pred.items()})
        if self.controller is not None and i + 1 < len(self.frame):
            self._control(state, api, i, t, live, rec)
        self.rows.append(rec)

    def _check_received(self, i, live, rec):
        """What EnergyPlus used in step i equals what was sent at the end of step i - 1."""
        for z in self.zones:
            seen = live[f"spc_{z}"]
            rec[f"sp_cool_seen_{z}"] = seen
            sent = self.sent.pop((i, z), None)
            if sent is not None and abs(seen - sent) > SETPOINT_TOL:
                self.mismatches.append((rec["time"], z, sent, seen))

    def _control(self, state, api, i, t, live, rec):
        y = np.array([live[f"T_{z}"] for z in self.zones])
        v = {c: live[c] for c in ("T_out", "T_supply") if c in live}
        self.controller(i + 1, (i + 1) * 900.0, y, v)
        plan = self.controller.mpc.plans[-1]
        t_next = t + pd.Timedelta(minutes=15)
        lo, hi = self.settings.band
        for j, z in enumerate(self.controller.model.outputs):
            if z not in self.zones:
                continue
            if self.settings.is_occupied(t_next) and plan.found:
                sp = float(np.clip(plan.Y[1][j], lo + 0.5, hi))
                api.exchange.set_actuator_value(state, self.act[(z, "Cooling Setpoint")], sp)
                api.exchange.set_actuator_value(state, self.act[(z, "Heating Setpoint")], lo)
                self.sent[(i + 1, z)] = sp
                self.n_sent += 1
                rec[f"sp_cool_sent_{z}"] = sp
            else:
                api.exchange.reset_actuator(state, self.act[(z, "Cooling Setpoint")])
                api.exchange.reset_actuator(state, self.act[(z, "Heating Setpoint")])


def run_host(
    prototype,
    building,
    frame,
    *,
    floor=None,
    weather=None,
    fmu=None,
    controller=None,
    season=None,
    settings: HostSettings | None = None,
    model=None,
    workdir=None,
) -> HostResult:
    """Run an EnergyPlus building over ``frame``'s span with an FMU and a controller in the loop.

    Parameters
    ----------
    prototype : str or path
        The IDF (see :func:`hvacfmu.energyplus.generate`); must be the building ``building`` was exported from.
    building : hvacfmu.building.Building
        Its exported building file (zones, boxes; names as exported).
    frame : DataFrame
        The prepared data over the run (``Dataset.frame`` rows, whole local days): disturbance previews for the
        MPC (a perfect forecast: the same weather) and facade irradiance for the FMU.
    fmu : path, optional
        A model FMU (``hvacfmu export``) stepped with the live values.
    controller : optional
        A harness controller with an ``mpc`` attribute (``harness.mpc.cosim_controller(model, building)``); None:
        EnergyPlus's own control.
    season : str, optional
        Season of the run (the FMU's and MPC's gain profile); default the building's season of the first row.

    Returns
    -------
    HostResult

    Raises
    ------
    harness.energyplus_host.CallbackError (from :mod:`hvacfmu.energyplus.run`)
        When anything fails inside the loop: EnergyPlus stops at that step.
    """
    settings = settings or HostSettings()
    idf_path = inputs.resolve_prototype(prototype)
    epw = inputs.resolve_weather(weather, idf_path)
    site = inputs.read_site(epw, building.timezone)
    idf = read_idf(idf_path)
    boxes = select_boxes(hvac.air_boxes(idf), floor, None)
    zones = {hvac.sanitise(b.zone): b.zone for b in boxes}
    ahus = {a: next(b.supply_node for b in boxes if b.ahu == a) for a in dict.fromkeys(b.ahu for b in boxes)}
    probes = export_probes(boxes, ahus, list(zones.values()))
    probes += [Probe(f"spc_{z}", "Zone Thermostat Cooling Setpoint Temperature", name) for z, name in zones.items()]
    lo, hi = frame.index[0], frame.index[-1] + pd.Timedelta(minutes=15)
    first = max(lo.date() - _dt.timedelta(days=1), _dt.date(lo.year, 1, 1))
    inputs.prepare_idf(idf, first, (hi - pd.Timedelta(minutes=15)).date(), site)
    given = season is not None
    season = season or building.season_of(lo)
    stepper = _FMUStepper(fmu, tuple(zones), season) if fmu is not None else None
    if stepper is not None:  # a span across a season boundary: the FMU follows the calendar, or refused
        from harness.cosim import plan_season_span, season_pieces

        try:
            stepper.follow = plan_season_span(
                season_pieces(frame.index, building),
                stepper.inst.interface,
                stepper.inst.path.name,
                building,
                season,
                given,
                controller is not None,
            )
        except Exception:
            stepper.close()
            raise
    if controller is not None:
        _reset_controller(controller, building, frame, settings, season, model, tuple(zones))
    loop = _Loop(probes, zones, frame, settings, controller, stepper, lo, hi, site)
    try:
        with tempfile.TemporaryDirectory(prefix="hvacfmu-host-") as tmp:
            work = Path(workdir) if workdir else Path(tmp)
            work.mkdir(parents=True, exist_ok=True)
            (work / "in.idf").write_text(idf.text(), encoding="latin-1")
            simulate(work / "in.idf", epw, work / "out", probes, on_step=loop)
    finally:
        if stepper is not None:
            stepper.close()
    return _result(loop, settings, controller)


def _reset_controller(controller, building, frame, settings, season, model, zones):
    from harness.controllers import ControlContext

    ctx = ControlContext(
        frame=frame,
        building=building,
        vavs=building.vav_names,
        outputs=tuple(f"T_{z}" for z in zones),
        output_zones=tuple((z,) for z in zones),
        step=900.0,
        band=tuple(settings.band),
        season=season,
        model=model or getattr(controller, "model", None),
    )
    controller.reset(ctx)


def _result(loop, settings, controller) -> HostResult:
    table = pd.DataFrame(loop.rows).set_index("time")
    zones = list(loop.zones)
    occ = np.array([settings.is_occupied(t) for t in table.index])
    T = table[[f"T_{z}" for z in zones]].to_numpy()
    lo, hi = settings.band
    excess = np.clip(lo - T, 0, None) + np.clip(T - hi, 0, None)
    meters = {m[2:]: float(table[m].sum()) / 3.6e6 for m in table.columns if m.startswith("J_")}
    summary = {
        "steps": len(table),
        "energy_kWh": meters.get("Electricity:HVAC", 0.0) + meters.get("NaturalGas:HVAC", 0.0),
        "meters_kWh": meters,
        "violation_Kh": float(excess[occ].sum() * 0.25),
        "setpoints_sent": loop.n_sent,
        "mismatches": len(loop.mismatches),
    }
    if loop.fmu is not None:
        P = table[[f"fmu_T_{z}" for z in zones if f"fmu_T_{z}" in table]].to_numpy()
        summary["fmu_rms_K"] = float(np.sqrt(np.mean((P[:-1] - T[1:, : P.shape[1]]) ** 2)))
    name = (
        "EnergyPlus own control"
        if controller is None
        else f"{getattr(controller, 'name', 'controller')} (supervisory setpoints)"
    )
    return HostResult(table, summary, list(loop.mismatches), name)


def compare(reference: HostResult, other: HostResult) -> str:
    """Energy and comfort of ``other`` against ``reference`` (EnergyPlus's own control), as text."""
    e0, e1 = reference.summary["energy_kWh"], other.summary["energy_kWh"]
    d = 100.0 * (e1 - e0) / e0 if e0 else float("nan")
    return "\n".join(
        [
            reference.format_summary(),
            other.format_summary(),
            (
                f"energy {e1:.1f} vs {e0:.1f} kWh ({d:+.1f} %), comfort violation "
                f"{other.summary['violation_Kh']:.2f} vs {reference.summary['violation_Kh']:.2f} Kh"
            ),
        ]
    )
