"""Dataset generation: truth, closed-loop simulation, sensor noise, gaps, files; and the cache."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from ..building import building_from_dict
from .building import TRUE_PARAMETERS, building_dict, true_building_dict
from .controllers import NIGHT_OFF, REHEAT_MODE_AHUS, SCHEDULES
from .effects import EmulatorError, parse_effect, resolve_effects, sensor_offset_time
from .export import (
    UNITS_TABLE,
    apply_faults,
    convert_units,
    time_strings,
    validate_export,
)
from .layouts import (
    BMS_MODES,
    CLIMATES,
    CONSTRUCTION_TEMPLATES,
    HVAC_MODES,
    check_options,
    get_layout,
)
from .occupancy import DEFAULT_OCCUPANCY
from .plant import DT, stream
from .simulate import controller_defaults, simulate
from .thermal import CP_AIR, DEFAULT_EXTRAS

#: Version of the emulator's physics and data; part of the cache key. 1.4: the building file
#: declares the slabs against the storeys (a constant-temperature boundary), not adiabatic.
EMULATOR_VERSION = "1.4"
DEFAULT_START = "2025-09-01T00:00:00"

NOISE = {
    "T_zone": {"std": 0.03, "quantum": 0.05},  # [°C]
    "m_vav": {"std": 0.004, "relative_std": 0.02, "quantum": 0.001},  # [kg/s], [-]
    "T_supply": {"std": 0.05, "quantum": 0.05},
    "T_out": {"std": 0.10, "quantum": 0.1},
    "ghi": {"std": 2.0, "relative_std": 0.03, "quantum": 1.0},  # [W/m2]
    "wind": {"relative_std": 0.05, "quantum": 0.1},  # [m/s] a cup anemometer's reading (own stream)
    "Td": {"std": 0.15, "quantum": 0.05},  # [°C] discharge air ("reheat" mode)
}


@dataclasses.dataclass(frozen=True)
class GeneratedPaths:
    """Files written by :func:`generate`."""

    measurements: Path
    building: Path
    truth: Path

    @property
    def outdir(self) -> Path:
        return self.measurements.parent

    def __str__(self) -> str:
        return "\n".join(
            [
                f"measurements: {self.measurements}",
                f"building:     {self.building}",
                f"truth:        {self.truth}",
            ]
        )


def make_truth(
    weeks: int = 51,
    seed: int = 0,
    effects=(),
    start: str = DEFAULT_START,
    layout: str = "sdh",
    construction: str = "medium",
    climate: str = "mild",
    hvac: str = "vav",
    holidays: str | None = None,
    schedule: str = "always-on",
) -> dict:
    """The truth mapping of a dataset before simulation (structure, parameters, resolved effects).

    ``layout``, ``construction`` and ``climate`` name entries of
    :mod:`hvacfmu.emulator.layouts`; ``start`` is the local start time (ISO, no offset); ``holidays``
    a country code whose public holidays the building closes on (None: it never closes); ``schedule``
    one of :data:`~hvacfmu.emulator.controllers.SCHEDULES` (``night-off``: recorded as ``truth["schedule"]``
    and ``baseline.controllers.schedule``; the default adds nothing, so default truths are unchanged).
    """
    problems = []
    if not isinstance(weeks, (int, np.integer)) or weeks < 1:
        problems.append(f"weeks must be a positive integer, got {weeks!r}")
    if not isinstance(seed, (int, np.integer)) or seed < 0:
        problems.append(f"seed must be a non-negative integer, got {seed!r}")
    problems += check_options(layout, construction, climate, hvac)
    if schedule not in SCHEDULES:
        problems.append(f"schedule must be one of {', '.join(SCHEDULES)}, got {schedule!r}")
    if schedule != "night-off" and any(_effect_name(e) == "off_hours_heater" for e in effects):
        problems.append(
            "effect off_hours_heater heats only while the boxes are shut, which needs schedule 'night-off' "
            "(generate --schedule night-off)"
        )
    if holidays is not None:
        from ..calendars import country_problems

        problems += (
            country_problems(holidays)
            if isinstance(holidays, str)
            else [f"holidays must be a country code, got {holidays!r}"]
        )
    try:
        t0 = pd.Timestamp(start)
        if t0.tzinfo is not None or t0 != t0.normalize():
            problems.append(f"start must be a local midnight without UTC offset like '2025-09-01', got {start!r}")
    except (ValueError, TypeError):
        problems.append(f"start must be an ISO date like '2025-09-01', got {start!r}")
    if problems:
        from ..errors import problems_message

        raise EmulatorError(problems_message("Invalid emulator arguments", problems))
    start = pd.Timestamp(start).strftime("%Y-%m-%dT%H:%M:%S")
    bld = true_building_dict(layout, construction, climate, hvac)
    lay = get_layout(layout)
    clim = CLIMATES[climate]
    controllers = controller_defaults(int(seed), len(bld["vavs"]))
    controllers.update(json.loads(json.dumps(clim["controllers"])))
    if hvac in BMS_MODES:
        mode = HVAC_MODES[hvac]
        controllers["ahus"] = {a["name"]: dict(REHEAT_MODE_AHUS[a["name"]]) for a in bld["ahus"]}
        controllers["T_discharge_max"] = mode["T_discharge_max"]
        controllers["heating_sequence"] = mode["heating_sequence"]
        if mode["heating_sequence"] == "dual":
            controllers["heating_max_fraction"] = mode["heating_max_fraction"]
    if schedule == "night-off":
        controllers["schedule"] = dict(NIGHT_OFF)
    resolved = resolve_effects(list(effects), int(seed), bld, int(weeks), controllers["control_interval"])
    if any(e.get("kind") == "dst" for e in resolved) and not _has_dst(clim["timezone"], start, int(weeks)):
        raise EmulatorError(
            f"Invalid emulator effects: internal_gain_schedule:kind=dst needs daylight saving time, but climate "
            f"{climate!r} ({clim['timezone']}) has none from {start} for {int(weeks)} weeks; use kind=holiday "
            "or another climate"
        )
    occupancy = json.loads(json.dumps(DEFAULT_OCCUPANCY))
    occupancy["peak_gain"] = dict(lay.peak_gain)
    occupancy["meeting_zone"] = lay.meeting_zone
    if lay.meeting_gain is not None:
        occupancy["meeting_gain"] = float(lay.meeting_gain)
    if lay.meeting_probability is not None:
        occupancy["meeting_probability"] = float(lay.meeting_probability)
    closed = None
    if holidays is not None:
        from ..calendars import public_holidays

        t0 = pd.Timestamp(start)
        days = public_holidays(holidays, None, t0.date(), (t0 + pd.Timedelta(weeks=int(weeks))).date())
        closed = {"country": holidays, "dates": {d.isoformat(): n for d, n in days.items() if d.weekday() < 5}}
        # the occupants stay home and the BMS schedule runs unoccupied: a Sunday
        occupancy["holidays"] = controllers["holidays"] = sorted(closed["dates"])
    truth = {
        "version": EMULATOR_VERSION,
        "seed": int(seed),
        "weeks": int(weeks),
        "start": start,
        "timezone": clim["timezone"],
        "step": DT,
        "layout": layout,
        "construction": construction,
        "climate": climate,
        "hvac": hvac,
        "zones": [z["name"] for z in bld["zones"]],
        "vavs": [v["name"] for v in bld["vavs"]],
        "baseline": {
            "building": bld,
            "altitude": clim["altitude"],
            "climate": {"name": climate, **json.loads(json.dumps(clim))},
            "construction": {"name": construction, **CONSTRUCTION_TEMPLATES[construction]},
            "parameters": dict(TRUE_PARAMETERS),
            "extras": dict(DEFAULT_EXTRAS),
            "occupancy": occupancy,
            "controllers": controllers,
            "noise": NOISE,
        },
        "effects": resolved,
    }
    if closed is not None:
        truth["holidays"] = closed
    if schedule != "always-on":
        truth["schedule"] = schedule
    return truth


def _effect_name(spec) -> str:
    """The name of an effect given as a dict or ``name:key=value`` text (not validated here)."""
    return str(spec.get("name")) if isinstance(spec, dict) else str(spec).partition(":")[0].strip()


def _has_dst(timezone: str, start: str, weeks: int) -> bool:
    """True if daylight saving time is in force at some hour of the span in ``timezone``."""
    hours = pd.date_range(pd.Timestamp(start), periods=weeks * 7 * 24, freq="h", tz="UTC").tz_convert(timezone)
    return any(bool(t.dst()) for t in hours[::24])


def _structure(truth: dict, core) -> dict:
    """Human- and machine-readable summary of the true structure (for diagnosis checks)."""
    base = truth["baseline"]
    bld = base["building"]
    ex = base["extras"]
    windows = [
        {
            "zone": w["zone"],
            "facade": w["orientation"],
            "area": w["area"],
            "u_value": base["parameters"]["U_win"],
            "shgc": w["shgc"],
            "solar_fraction_air": ex["solar_fraction_air"],
            "solar_fraction_floor": ex["solar_fraction_floor"],
            "solar_fraction_furniture": ex["solar_fraction_furniture"],
        }
        for w in bld["windows"]
    ]
    solar = {}
    for w in bld["windows"]:
        solar.setdefault(w["zone"], []).append(w["orientation"])
    storeys = bool(get_layout(truth["layout"]).storeys)
    kinds = {"exterior_wall": 0, "interior_wall": 0}
    kinds.update(
        {"intermediate_slab": 0, "roof": 0, "ground_slab": 0} if storeys else {"floor_slab": 0, "ceiling_slab": 0}
    )
    el_cons = {e["name"]: e["construction"] for e in bld["elements"]}
    for name in core.node_names:
        if ":" in name:
            kinds[el_cons[name.split(":")[0]]] += 1
    slabs = (
        "a whole building: concrete slabs between its storeys (floor of the upper zone, ceiling of the lower "
        "one), an insulated roof over the top storey (no solar on it), the ground floor on a slab on grade over "
        "soil whose far side follows T_out; no slab faces T_fl"
        if storeys
        else "concrete floor and ceiling slabs of every zone; their far side faces the floors "
        "below/above at temperature T_fl (not adiabatic)"
    )
    return {
        "n_states": int(core.n_thermal),
        "node_counts": {"air": len(truth["zones"]), "furniture": len(truth["zones"]), **kinds},
        "walls": "multi-node walls: every massive layer split into nodes at most "
        f"{ex['max_node_thickness']} m thick; exterior walls absorb solar on their outer surface "
        f"(absorptance {ex['wall_solar_absorptance']})",
        "slabs": slabs,
        "thermal_mass": {"walls": True, "slabs": True, "furniture_J_per_K_m2": bld["physics"]["internal_mass"]},
        "windows": windows,
        "solar_gain": solar,
        "supply_air": {
            "form": "bilinear",
            "equation": "Q_z = sum_i m_i c_p (T_supply - T_z) + P_reheat,i",
            "c_p": 1005.0,
        },
        "infiltration": {
            "ach": ex["infiltration_ach"],
            "zones": [z["name"] for z in bld["zones"] if z.get("facades")],
        },
        "reheat": {
            "baseline": "every box: in heating mode (room below heating setpoint) airflow stays at m_min "
            "and the coil raises the discharge temperature by up to reheat_rise",
            "reheat_rise": base["controllers"]["reheat_rise"],
        },
        "internal_gains": "area x (base + peak x occupancy): seasonal level (semesters, winter break, "
        "summer), weekday/weekend, random arrival/departure and day factors, meetings in "
        f"{truth['baseline']['occupancy'].get('meeting_zone') or 'C'}; local "
        "wall clock, no holidays",
        "adjacent_floors": "T_fl = mean + workday rise x occupancy + AR(1) noise",
        # diagnosis cause ids present in the baseline (before any injected effect), by location
        "causes": {
            "solar_gain": [{"zone": w["zone"], "facade": w["orientation"]} for w in bld["windows"]],
            "supply_air_bilinear": [{"zone": z} for z in truth["zones"]],
            "thermal_mass": [{"zone": z, "source": "floor/ceiling slabs, walls, furniture"} for z in truth["zones"]],
            "reheat": [{"zone": z, "source": "baseline VAV controllers in heating mode"} for z in truth["zones"]],
            "zone_coupling": [],
            "actuation_delay": [],
            "internal_gain_schedule": [],
        },
    }


def _quantise(x, q):
    return np.round(x / q) * q


def _iso_times(index: pd.DatetimeIndex) -> np.ndarray:
    """ISO 8601 local times with UTC offset, e.g. ``2025-09-01T00:00:00-07:00`` (vectorised)."""
    local = index.tz_localize(None).as_unit("s").asi8
    utc = index.as_unit("s").asi8
    text = np.datetime_as_string(local.astype("datetime64[s]")).astype("S19")
    off = (local - utc) // 60
    uniq, inv = np.unique(off, return_inverse=True)
    labels = np.array([f"{'-' if o < 0 else '+'}{abs(o) // 60:02d}:{abs(o) % 60:02d}" for o in uniq], dtype="S6")
    out = np.empty((len(index), 25), dtype="S1")
    out[:, :19] = text.view("S1").reshape(-1, 19)
    out[:, 19:] = labels[inv].view("S1").reshape(-1, 6)
    return out.view("S25").ravel().astype("U25")


def _gaps(n, weeks, rng, columns):
    """Row gaps (logger outages) and NaN gaps (one sensor) as lists of (start, end[, column])."""
    row_gaps, nan_gaps = [], []
    for _ in range(max(1, int(round(weeks / 12)))):
        length = int(rng.integers(60, 361))
        s = int(rng.integers(1440, max(1441, n - length)))
        row_gaps.append((s, min(n, s + length)))
    for _ in range(max(1, int(round(weeks / 8)))):
        length = int(rng.integers(120, 721))
        s = int(rng.integers(1440, max(1441, n - length)))
        col = columns[int(rng.integers(len(columns)))]
        nan_gaps.append((s, min(n, s + length), col))
    return row_gaps, nan_gaps


def _json_clean(obj):
    if isinstance(obj, dict):
        return {str(k): _json_clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_clean(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _json_clean(obj.tolist())
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        if not np.isfinite(v):
            raise ValueError("non-finite number in truth.json")
        return v
    return obj


def _measured_frame(sim: dict, truth: dict) -> pd.DataFrame:
    """Noisy, quantised one-minute measurements in SI units (``time`` column: ISO with offset)."""
    index = sim["index"]
    n = len(index)
    zones, vavs = truth["zones"], truth["vavs"]
    rng = stream(truth["seed"], "noise")
    cols = {"time": _iso_times(index)}
    nz = NOISE["T_zone"]
    Tn = sim["T_zone"] + rng.normal(0.0, nz["std"], sim["T_zone"].shape)
    for e in truth.get("effects", []):
        if e["name"] == "sensor_offset":  # the measured column only: the plant's controllers read the true room
            on = np.asarray(index >= sensor_offset_time(truth["start"], truth["timezone"], e))
            Tn[on, zones.index(e["zone"])] += e["delta"]
    for i, z in enumerate(zones):
        cols[f"T_{z}"] = _quantise(Tn[:, i], nz["quantum"])
    nm = NOISE["m_vav"]
    m = sim["m_vav"]
    mn = m * (1.0 + rng.normal(0.0, nm["relative_std"], m.shape)) + rng.normal(0.0, nm["std"], m.shape)
    mn = np.clip(_quantise(mn, nm["quantum"]), 0.0, None)
    for j, v in enumerate(vavs):
        cols[f"m_{v}"] = mn[:, j]
    ns = NOISE["T_supply"]
    Ts = sim["T_supply"]
    if Ts.ndim == 1:
        cols["T_supply"] = _quantise(Ts + rng.normal(0.0, ns["std"], n), ns["quantum"])
    else:
        Tsn = _quantise(Ts + rng.normal(0.0, ns["std"], Ts.shape), ns["quantum"])
        for i, a in enumerate(sim["ahus"]):
            cols[f"T_supply_{a}"] = Tsn[:, i]
    no = NOISE["T_out"]
    cols["T_out"] = _quantise(sim["T_out"] + rng.normal(0.0, no["std"], n), no["quantum"])
    ng = NOISE["ghi"]
    ghi = sim["ghi"] * (1.0 + rng.normal(0.0, ng["relative_std"], n)) + rng.normal(0.0, ng["std"], n)
    cols["ghi"] = np.clip(_quantise(np.where(sim["ghi"] > 0, ghi, 0.0), ng["quantum"]), 0.0, None)
    cols["excitation"] = sim["excitation"].astype(np.int8)
    if truth.get("hvac") in BMS_MODES:
        cols.update(_discharge_columns(sim, truth))
    return pd.DataFrame(cols)


def _discharge_columns(sim: dict, truth: dict) -> dict:
    """``Td_<vav>`` (measured discharge air [°C]) and ``rh_<vav>`` (reheat valve command [0..1]) per box."""
    from .simulate import discharge_temperature

    vavs = truth["vavs"]
    cp = truth["baseline"]["controllers"]
    rng = stream(truth["seed"], "noise_discharge")
    nd = NOISE["Td"]
    Tdn = discharge_temperature(sim)
    Tdn += rng.normal(0.0, nd["std"], Tdn.shape)
    Tdn = _quantise(Tdn, nd["quantum"])
    per = int(round(cp["control_interval"] / DT))
    # the valve command of each control interval: power over the coil's power at the discharge limit
    Ts_ctrl = sim["T_supply"][::per][:, sim["box_ahu"]]  # supply air at each control instant
    m_cmd = sim["m_vav"][::per]  # commanded airflow (m_min in heating, more with dual-maximum boxes)
    p_max = np.maximum(m_cmd, 1e-6) * CP_AIR * np.maximum(float(cp["T_discharge_max"]) - Ts_ctrl, 1e-6)
    rh = np.repeat(np.clip(np.round(sim["reheat_command"][::per] / p_max, 2), 0.0, 1.0), per, axis=0)
    out = {}
    for j, v in enumerate(vavs):
        out[f"Td_{v}"] = Tdn[:, j]
    for j, v in enumerate(vavs):
        out[f"rh_{v}"] = rh[:, j]
    return out


def generate(
    outdir,
    weeks: int = 51,
    seed: int = 0,
    effects=(),
    fmt: str = "parquet",
    layout: str = "sdh",
    construction: str = "medium",
    climate: str = "mild",
    start: str = DEFAULT_START,
    hvac: str = "vav",
    units: str = "si",
    clock: str = "aware",
    export_step: int = 60,
    faults=(),
    holidays: str | None = None,
    wind: str | None = None,
    schedule: str = "always-on",
) -> GeneratedPaths:
    """Write an emulated dataset (by default the SDH-like floor in Berkeley).

    Parameters
    ----------
    outdir : path
        Folder to write (created if needed).
    weeks : int
        Length [weeks] of one-minute data from ``start`` (00:00 local time).
    seed : int
        Every random element (weather, occupancy, controllers, experiments,
        noise, gaps, unspecified effect parameters) derives from it.
    effects : sequence of str or dict
        Effects to inject (see :mod:`hvacfmu.emulator.effects`), e.g.
        ``["solar_gain:zone=S", {"name": "zone_coupling"}]``.
    fmt : {"parquet", "csv"}
    layout : {"sdh", "row4", "core9", "quad4", "ell5", "stack4"}
        Floor layout (:mod:`hvacfmu.emulator.layouts`); effect zones and facades
        must exist in it.
    construction : {"medium", "light", "heavy"}
        Construction template (massive layers, furniture).
    climate : {"mild", "cold", "hot"}
        Location and weather statistics (Berkeley, Chicago-like, Phoenix-like).
    start : str
        Local midnight of the first sample, e.g. ``"2025-12-01"``.
    hvac : {"vav", "reheat", "reheat-dual"}
        ``reheat``: the real-BMS-like VAV-with-reheat mode (two air handlers
        ``T_supply_AHU1``/``T_supply_AHU2``, per-box ``Td_<vav>`` and ``rh_<vav>``;
        see :data:`hvacfmu.emulator.layouts.HVAC_MODES`); ``reheat-dual``: the same with
        dual-maximum boxes (airflow rises in heating once the discharge air is at its limit).
    units : {"si", "us"}
    clock : {"aware", "naive-local", "naive-utc"}
    export_step : int [s]
        Trend-log interval (multiple of 60 s).
    faults : sequence of {"outages", "sparse_box", "stuck_sensor"}
        Real-world defects of the export (:mod:`hvacfmu.emulator.export`).
    holidays : str, optional
        Country code (``"US"``): the building closes on its public holidays (Sunday's occupancy, the BMS
        schedule unoccupied), listed in ``truth.json`` ``holidays``; the building file does not declare
        them (a BMS export does not either: :mod:`hvacfmu.data.holidays` finds them).
    wind : {None, "m/s", "km/h", "mph", "kn"}
        Write the site's wind speed (the dataset's own series, :func:`~hvacfmu.emulator.plant.site_wind`) as a
        ``wind`` column in this unit (declared in the building file's ``[units]``); None (default): no column.
        The other columns do not change with it.
    schedule : {"always-on", "night-off"}
        ``always-on`` (default): the boxes never go below ``m_min``, unoccupied hours only set back the set
        points. ``night-off``: outside the occupied hours (weekdays 06:00-20:00, started one hour early) the
        system is off: every box at zero airflow and no reheat, the air handlers off (their ``T_supply``
        columns read the idle duct, relaxing toward the mean room air with a 1-h time constant); the box
        loops restart from zero in the morning. Recorded in ``truth.json`` (``schedule``).

    Returns
    -------
    GeneratedPaths
        ``measurements.parquet`` (or ``.csv``), ``building.toml`` (nominal
        physics tables, declaring the export's units, clock and air handlers), ``truth.json``.
    """
    if fmt not in ("parquet", "csv"):
        raise EmulatorError(f"fmt must be 'parquet' or 'csv', got {fmt!r}")
    faults = tuple(faults)
    validate_export(units, clock, export_step, faults)
    if wind is not None and wind not in WIND_UNITS:
        raise EmulatorError(f"wind must be None or one of {', '.join(WIND_UNITS)}, got {wind!r}")
    truth = make_truth(
        weeks,
        seed,
        effects,
        start=start,
        layout=layout,
        construction=construction,
        climate=climate,
        hvac=hvac,
        holidays=holidays,
        schedule=schedule,
    )
    sim = simulate(truth)
    frame = _measured_frame(sim, truth)
    frame, row_gaps, nan_gaps = _standard_gaps(frame, truth, sim, export_step)
    frame.attrs["step_s"] = float(export_step)
    frame, fault_records = apply_faults(frame, faults, stream(seed, "faults"), truth["zones"], truth["vavs"])
    _record(truth, sim, row_gaps, nan_gaps)
    truth["export"] = {"units": units, "clock": clock, "export_step": int(export_step), "faults": fault_records}
    k = frame.pop("_k").to_numpy()
    frame["time"] = time_strings(sim["index"][k], clock)
    frame = convert_units(frame, units)
    if wind is not None:
        frame["wind"] = _wind_column(sim, truth, k, wind)
        truth["export"]["wind"] = wind

    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    if fmt == "parquet":
        mpath = outdir / "measurements.parquet"
        frame.to_parquet(mpath, index=False)
    else:
        mpath = outdir / "measurements.csv"
        frame.to_csv(mpath, index=False, float_format="%.6g")
    bd = building_dict(layout, construction, climate, nominal=True, hvac=hvac)
    if UNITS_TABLE[units] or wind is not None:
        bd["units"] = dict(UNITS_TABLE[units])
    if wind is not None:
        bd["units"]["wind"] = wind
    if clock == "naive-utc":
        bd["data_timezone"] = "UTC"
    bpath = building_from_dict(bd).save(outdir / "building.toml")
    tpath = outdir / "truth.json"
    tpath.write_text(json.dumps(_json_clean(truth), indent=1, allow_nan=False), encoding="utf-8")
    return GeneratedPaths(mpath, bpath, tpath)


#: Units the emulator can write its ``wind`` column in (:func:`generate`'s ``wind``).
WIND_UNITS = ("m/s", "km/h", "mph", "kn")


def _wind_column(sim: dict, truth: dict, k: np.ndarray, unit: str) -> np.ndarray:
    """The measured wind speed at the kept minutes ``k`` in ``unit`` (noise from its own stream)."""
    from ..data.units import from_si

    nw = NOISE["wind"]
    w = sim["wind"]
    rng = stream(truth["seed"], "noise_wind")
    measured = np.clip(w * (1.0 + rng.normal(0.0, nw["relative_std"], len(w))), 0.0, None)[k]
    return _quantise(from_si(measured, unit), nw["quantum"])


def _standard_gaps(frame, truth, sim, export_step):
    """The emulator's usual gaps (logger outages, one sensor's NaN runs), then the trend-log subsampling.

    Returns the frame with a ``_k`` column (minute index of each kept row) and the gaps.
    """
    n = len(frame)
    zones, vavs = truth["zones"], truth["vavs"]
    supply = [c for c in frame.columns if c.startswith("T_supply")]
    gap_cols = [f"T_{z}" for z in zones] + [f"m_{v}" for v in vavs] + ["T_out", "ghi"] + supply
    row_gaps, nan_gaps = _gaps(n, truth["weeks"], stream(truth["seed"], "gaps"), gap_cols)
    for s, e, col in nan_gaps:
        frame.loc[s : e - 1, col] = np.nan
    keep = np.ones(n, dtype=bool)
    for s, e in row_gaps:
        keep[s:e] = False
    keep &= (np.arange(n) % (int(export_step) // 60)) == 0
    frame["_k"] = np.arange(n)
    return frame[keep].reset_index(drop=True), row_gaps, nan_gaps


def _record(truth, sim, row_gaps, nan_gaps):
    """Add structure, experiments, gaps, weather and a summary to ``truth['baseline']``."""
    index = sim["index"]
    n = len(index)
    zones = truth["zones"]
    iso = _iso_times(index)
    base = truth["baseline"]
    base["structure"] = _structure(truth, sim["core"])
    base["excitation"] = [
        {"start": str(iso[s["start"]]), "end": str(iso[min(s["end"], n - 1)]), "levels": dict(zip(zones, s["levels"]))}
        for s in sim["segments"]
    ]
    base["gaps"] = [{"kind": "rows missing", "start": str(iso[s]), "end": str(iso[e - 1])} for s, e in row_gaps] + [
        {"kind": "NaN", "column": c, "start": str(iso[s]), "end": str(iso[e - 1])} for s, e, c in nan_gaps
    ]
    w = sim["weather"]
    base["weather"] = {
        "model": f"synthetic {CLIMATES[truth['climate']]['description']}: monthly normals, AR(1) daily anomaly, "
        "clear-sky (pvlib Ineichen) x cloud transmittance; facades by Erbs + Perez",
        "T_out_mean": float(np.mean(w["T_out"])),
        "T_out_min": float(np.min(w["T_out"])),
        "T_out_max": float(np.max(w["T_out"])),
        "clear_day_fraction": float(np.mean(w["day_clearness"] > 0.9)),
    }
    base["summary"] = {
        "T_zone_mean": dict(zip(zones, np.mean(sim["T_zone"], axis=0))),
        "T_zone_p01": dict(zip(zones, np.percentile(sim["T_zone"], 1, axis=0))),
        "T_zone_p99": dict(zip(zones, np.percentile(sim["T_zone"], 99, axis=0))),
        "reheat_energy_kWh": float(sim["reheat"].sum() * DT / 3.6e6),
        "internal_gain_mean_W": dict(zip(zones, np.mean(sim["Q_ig"], axis=0))),
    }


def _cache_root() -> Path:
    return Path(os.environ.get("HVACFMU_CACHE", "~/.cache/hvacfmu")).expanduser()


def cache_key(weeks: int, seed: int, effects=(), **options) -> str:
    """Folder name of a cached dataset: arguments and emulator version.

    ``options`` are further :func:`generate` keywords (``layout``, ``climate``,
    ...); options at their defaults do not change the key.
    """
    parsed = [parse_effect(e) for e in effects]
    blob = json.dumps(parsed, sort_keys=True)
    h = hashlib.sha256(blob.encode()).hexdigest()[:12] if parsed else "none"
    key = f"emulator-v{EMULATOR_VERSION}-w{int(weeks)}-s{int(seed)}-{h}"
    options = {k: (tuple(v) if k == "faults" else v) for k, v in options.items()}
    if "start" in options:
        options["start"] = pd.Timestamp(options["start"]).strftime("%Y-%m-%dT%H:%M:%S")
    extra = {k: v for k, v in sorted(options.items()) if v is not None and v != _GENERATE_DEFAULTS.get(k)}
    if extra:
        key += "-" + hashlib.sha256(json.dumps(extra, sort_keys=True).encode()).hexdigest()[:10]
    return key


_GENERATE_DEFAULTS = {
    "layout": "sdh",
    "construction": "medium",
    "climate": "mild",
    "start": DEFAULT_START,
    "hvac": "vav",
    "units": "si",
    "clock": "aware",
    "export_step": 60,
    "faults": (),
    "holidays": None,
    "wind": None,
    "schedule": "always-on",
}


def cached_dataset(weeks: int = 51, seed: int = 0, effects=(), **options) -> GeneratedPaths:
    """Generate a dataset once into ``$HVACFMU_CACHE`` (default ``~/.cache/hvacfmu``) and reuse it.

    ``options`` are passed to :func:`generate` (``layout``, ``construction``,
    ``climate``, ``start``, ...) and are part of the cache key.
    Safe under concurrency (e.g. pytest-xdist workers): each caller that finds
    no cached copy generates into a private temporary folder and renames it into
    place atomically; a caller that loses the race discards its copy.
    """
    unknown = set(options) - set(_GENERATE_DEFAULTS)
    if unknown:
        raise EmulatorError(
            f"cached_dataset: unknown option(s) {', '.join(sorted(unknown))}; known: {', '.join(_GENERATE_DEFAULTS)}"
        )
    root = _cache_root()
    final = root / cache_key(weeks, seed, effects, **options)
    paths = GeneratedPaths(final / "measurements.parquet", final / "building.toml", final / "truth.json")
    if all(p.exists() for p in (paths.measurements, paths.building, paths.truth)):
        return paths
    root.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}-", dir=root))
    try:
        generate(tmp, weeks=weeks, seed=seed, effects=effects, fmt="parquet", **options)
        try:
            os.rename(tmp, final)
        except OSError:
            if not final.exists():
                raise
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return paths
