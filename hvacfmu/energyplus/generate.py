"""Export an EnergyPlus building as BMS data plus a building file; cache the result.

Files written to ``outdir``: ``measurements.parquet`` (or ``.csv``),
``building.toml`` and ``energyplus.json`` (what was run: IDF, weather, period,
the IDF names behind every zone/box/unit column, the conditioned zones left out
because no box serves them, the changes made to the IDF, the warnings — weather
of another site than the IDF's design days —, the approximations). See :mod:`hvacfmu.energyplus` for the columns.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import hashlib
import json
import logging
import os
import shutil
import tempfile
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from .. import building as _building
from ..data.plausibility import IDENTICAL_SHARE, STUCK_DAYS, STUCK_PREFIXES, stuck_runs
from ..errors import DataError, HvacfmuWarning
from . import geometry, hvac, inputs, physics
from .idf import read_idf
from .run import Probe, simulate, step_times

log = logging.getLogger(__name__)

#: Version of what the export writes; part of the cache key.
EXPORT_VERSION = "1.10"
STEP_HOURS = 1.0 / inputs.STEPS_PER_HOUR
APPROXIMATIONS = (
    "zone temperatures are EnergyPlus zone mean air temperatures averaged over each 15-minute step",
    (
        "box airflow m_<vav> and discharge temperature Td_<vav> are the zone inlet node's mass flow and temperature, "
        "time-averaged over the HVAC steps of each 15-minute step (not flow-weighted)"
    ),
    "T_supply_<ahu> is the air handler's supply outlet node temperature; it holds an idle value when the unit is off",
    "T_supply is the airflow-weighted mean of the units' supply temperatures (plain mean when no air flows)",
    "ghi = direct normal x sin(solar altitude) + diffuse horizontal, from EnergyPlus's site variables",
    (
        "a zone with a multiplier is one copy: its box's airflow and limits are the node's and the sizing's "
        "divided by the multiplier (boxes[].multiplier)"
    ),
    "surfaces towards unselected zones (plenums, attics, other floors) are adiabatic in the physics tables",
    (
        "F-factor ground floors are a 15 cm concrete slab under a no-mass insulation layer giving EnergyPlus's "
        "resistance A / (P F) with the inside film, facing the ground at the annual mean ground temperature"
    ),
)


@dataclasses.dataclass(frozen=True)
class EnergyPlusPaths:
    """Files written by :func:`generate`."""

    measurements: Path
    building: Path
    info: Path

    @property
    def outdir(self) -> Path:
        return self.measurements.parent

    def __str__(self) -> str:
        return f"measurements: {self.measurements}\nbuilding:     {self.building}\ninfo:         {self.info}"


def select_boxes(boxes, floor, zones):
    """The boxes of the zones whose IDF name contains ``floor`` or is in ``zones`` (all when both are None)."""
    if zones:
        want = {z.lower() for z in zones}
        sel = [b for b in boxes if b.zone.lower() in want or hvac.sanitise(b.zone).lower() in want]
    elif floor:
        sel = [b for b in boxes if floor.lower() in b.zone.lower()]
    else:
        sel = list(boxes)
    if not sel:
        names = sorted({b.zone for b in boxes})
        raise DataError(
            f"no conditioned zone matches floor={floor!r} zones={zones!r}; the IDF's conditioned zones are {names}"
        )
    return sel


def _zones_left_out(idf, all_boxes, floor, zones) -> dict:
    """Conditioned zones (zone equipment) of the selection that are not exported because no box serves them."""
    out, kinds = {}, {}
    for zone, equipment in hvac.zones_without_boxes(idf, all_boxes).items():
        if zones and zone.lower() not in {z.lower() for z in zones}:
            continue
        if not zones and floor and floor.lower() not in zone.lower():
            continue
        what = ", ".join(equipment) or "none"
        out[zone] = (
            f"zone equipment {what} but no air terminal on an AirLoopHVAC: not exported "
            "(no T_ column; its surfaces towards exported zones are adiabatic in the physics tables)"
        )
        kinds.setdefault(what, []).append(zone)
    if out:  # one line, however many zones (the 90.1 small hotel has 48)
        log.info(
            "EnergyPlus: %d conditioned zone(s) not exported, zone equipment but no air terminal on an AirLoopHVAC "
            "(see energyplus.json zones_left_out): %s",
            len(out),
            "; ".join(
                f"{w}: {', '.join(zs[:5])}" + (f" and {len(zs) - 5} more" if len(zs) > 5 else "")
                for w, zs in kinds.items()
            ),
        )
    return out


def _unmeasured_warning(idf, boxes) -> str | None:
    """A warning naming the exported zones whose other zone equipment the export cannot measure (None if none)."""
    found = hvac.unmeasured_equipment(idf, boxes)
    if not found:
        return None
    listed = "; ".join(f"{z}: {', '.join(kinds)}" for z, kinds in list(found.items())[:5])
    more = f" and {len(found) - 5} more" if len(found) > 5 else ""
    return (
        f"{len(found)} exported zone(s) have zone equipment whose heat no column carries (no zone inlet node of "
        f"its own): {listed}{more}; the data miss that heat, models fitted on them see it as a disturbance"
    )


def _refrigeration_warning(found: dict) -> str | None:
    """A warning naming the exported zones with refrigerated cases or walk-ins (``found``:
    :func:`~hvacfmu.energyplus.hvac.refrigeration_in_zones`), whose heat no column carries."""
    if not found:
        return None
    listed = "; ".join(f"{z}: {len(names)}" for z, names in found.items())
    return (
        f"{len(found)} exported zone(s) hold refrigerated cases or walk-ins (Refrigeration:Case/WalkIn; cases per "
        f"zone: {listed}): they take heat out of the zone air all year (case credits, varying with restocking, "
        "defrost and the zone's air), and no column carries that heat; models fitted on these data see it as a "
        "disturbance (energyplus.json refrigeration lists the objects)"
    )


def _mixing_warning(found: dict, boxes) -> str | None:
    """A warning naming the exported zones that receive another zone's air through a (cross) mixing object
    (``found``: :func:`~hvacfmu.energyplus.hvac.mixing_into_zones`), whose heat no column carries."""
    if not found:
        return None
    exported = {b.zone.lower() for b in boxes}
    listed = "; ".join(
        f"{z} from {', '.join(src + ('' if src.lower() in exported else ' (not exported)') for _, src in pairs)}"
        for z, pairs in found.items()
    )
    return (
        f"{len(found)} exported zone(s) receive another zone's air through ZoneMixing/ZoneCrossMixing ({listed}): its "
        "heat m cp (T_source - T_zone) is in no column (no airflow of it is exported); models fitted on these data "
        "see it as a disturbance (energyplus.json mixing lists the objects)"
    )


#: Share of the steps held at one value above which the export advises leaving a zone out.
MOSTLY_HELD = 0.5


def _held_warning(frame: pd.DataFrame) -> str | None:
    """A warning naming the temperature columns EnergyPlus holds at exactly one value for ``STUCK_DAYS`` or longer.

    EnergyPlus's ideal control can hold a zone exactly at its setpoint for days (the 90.1 large office's data centre
    at 27 C for 87 % of a year); a real sensor never repeats one value that long, and hvacfmu's data check masks such
    runs as a stuck sensor. Said here, where the cause is known, rather than left to that check. None when no column
    has such a run.
    """
    times = pd.DatetimeIndex(frame.index).as_unit("ns").asi8
    held, mostly = [], []
    for col in frame.columns:
        if not col.startswith(STUCK_PREFIXES):
            continue
        values = frame[col].to_numpy(dtype=float)
        runs = stuck_runs(values, times, STUCK_DAYS * 86400)
        n = sum(b - a for a, b in runs)
        if n:
            held.append(f"{col} ({values[runs[0][0]]:g} °C in {100 * n / len(values):.0f} % of the steps)")
            if n >= MOSTLY_HELD * len(values):
                mostly.append(col)
    if not held:
        return None
    # leaving a zone out is the way only where it is held most of the time: the 90.1 mid-rise apartments hold every flat
    # at its setpoint for a few days (1-7 % of a year), which costs some test windows, not the zone
    advice = (
        f"leave the zones held most of the time out (--zone): {', '.join(mostly)}"
        if mostly
        else f"held in less than {100 * MOSTLY_HELD:.0f} % of the steps, the zones are worth keeping: only the windows "
        "those runs touch are lost"
    )
    return (
        f"EnergyPlus holds {len(held)} temperature column(s) at exactly one value for {STUCK_DAYS:g} days or longer "
        f"(ideal control at the setpoint): {', '.join(held)}; hvacfmu's data check masks such runs as a stuck sensor, "
        f"so those steps count as missing (a zone's windows are then skipped): {advice}"
    )


def twin_zones(frame: pd.DataFrame, zones) -> dict:
    """``{zone: the earlier zone whose air it repeats}`` for zones EnergyPlus computes identically.

    Zones that are copies of each other (the Ref 2004 outpatient clinic's exam halls: same floor, volume, facade,
    loads and box) get the same ``Zone Mean Air Temperature`` to the last digit in every step. A real BMS never
    writes that for two sensors, so hvacfmu's data check refuses the pair as one point exported twice
    (``IDENTICAL_SHARE`` of equal rows, columns that move). The first zone of each set is kept.
    """
    cols = {z: f"T_{hvac.sanitise(z)}" for z in zones if f"T_{hvac.sanitise(z)}" in frame.columns}
    values = {z: frame[c].to_numpy(dtype=float) for z, c in cols.items()}
    out: dict = {}
    names = list(values)
    for i, a in enumerate(names):
        if a in out:
            continue
        x = values[a]
        for b in names[i + 1 :]:
            if b in out:
                continue
            y = values[b]
            both = np.isfinite(x) & np.isfinite(y)
            if both.sum() < 100 or np.std(x[both]) < 0.01:
                continue
            if float((x[both] == y[both]).mean()) >= IDENTICAL_SHARE:
                out[b] = a
    return out


def _leave_twins_out(frame, boxes, ahus, twins, left_out):
    """Drop the twin zones' columns and boxes (and an air handler left without boxes); note each in ``left_out``;
    returns ``(frame, boxes, ahus, warning)``."""
    drop = [f"T_{hvac.sanitise(z)}" for z in twins]
    for z, keep in twins.items():
        gone = [b.name for b in boxes if b.zone == z]
        drop += [f"{p}_{n}" for n in gone for p in ("m", "Td")]
        left_out[z] = (
            f"EnergyPlus computes the same air as zone {keep} in every step (a copy of it: same geometry, loads and "
            f"box); not exported (box {', '.join(gone)} too): two columns of one value read as one point exported "
            "twice, which hvacfmu's data check refuses"
        )
    boxes = [b for b in boxes if b.zone not in twins]
    kept = {b.ahu for b in boxes}
    drop += [f"T_supply_{hvac.sanitise(a)}" for a in ahus if a not in kept]
    ahus = {a: n for a, n in ahus.items() if a in kept}
    frame = frame.drop(columns=[c for c in drop if c in frame.columns])
    pairs = ", ".join(f"{z} (= {k})" for z, k in twins.items())
    return (
        frame,
        boxes,
        ahus,
        f"EnergyPlus computes {len(twins)} zone(s) exactly as another one in every step (copies of it): {pairs}; "
        "left out with their boxes (energyplus.json zones_left_out), since two identical columns are refused as one "
        "point exported twice",
    )


def export_probes(boxes, ahus, zones, wind: bool = False):
    """The :class:`~hvacfmu.energyplus.run.Probe` list of an export (weather, zones, boxes, air handlers; with
    ``wind`` the site wind speed last, so the other columns keep their order)."""
    p = [
        Probe("T_out", "Site Outdoor Air Drybulb Temperature", "Environment"),
        Probe("_dni", "Site Direct Solar Radiation Rate per Area", "Environment"),
        Probe("_dhi", "Site Diffuse Solar Radiation Rate per Area", "Environment"),
        Probe("_alt", "Site Solar Altitude Angle", "Environment"),
    ]
    p += [Probe(f"T_{hvac.sanitise(z)}", "Zone Mean Air Temperature", z) for z in zones]
    for b in boxes:
        p.append(Probe(f"m_{b.name}", "System Node Mass Flow Rate", b.outlet_node, system=True))
        p.append(Probe(f"Td_{b.name}", "System Node Temperature", b.outlet_node, system=True))
    for name, node in ahus.items():
        p.append(Probe(f"T_supply_{hvac.sanitise(name)}", "System Node Temperature", node, system=True))
    if wind:
        p.append(Probe("wind", "Site Wind Speed", "Environment"))
    return p


def _frame(values, times, probes, site, boxes, ahus) -> pd.DataFrame:
    utc = step_times(times, site.tz_hours, STEP_HOURS)
    df = pd.DataFrame(values, columns=[p.column for p in probes], index=utc.tz_convert(site.timezone))
    for b in boxes:  # the node carries the air of every copy of a multiplied zone: keep one zone's (hvac docstring)
        if b.multiplier != 1.0:
            df[f"m_{b.name}"] = df[f"m_{b.name}"] / b.multiplier
    alt = np.radians(df.pop("_alt").to_numpy())
    ghi = df.pop("_dni").to_numpy() * np.clip(np.sin(alt), 0.0, None) + df.pop("_dhi").to_numpy()
    df["ghi"] = np.clip(ghi, 0.0, None)
    flows = np.zeros(len(df))
    weighted = np.zeros(len(df))
    for name in ahus:
        col = f"T_supply_{hvac.sanitise(name)}"
        m = sum(df[f"m_{b.name}"].to_numpy() for b in boxes if b.ahu == name)
        flows += m
        weighted += m * df[col].to_numpy()
    plain = df[[f"T_supply_{hvac.sanitise(a)}" for a in ahus]].mean(axis=1).to_numpy()
    df["T_supply"] = np.where(flows > 1e-6, weighted / np.maximum(flows, 1e-12), plain)
    if "wind" in df.columns:  # the optional column last: the export's other columns keep their order
        df["wind"] = df.pop("wind")
    df.index.name = "time"
    return df.round(4)


def _iso(index: pd.DatetimeIndex) -> list:
    return [t.isoformat() for t in index]


def _sizing_limits(idf, boxes, eio, rho):
    return hvac.box_limits(idf, boxes, hvac.read_sizing(eio), rho)


#: Setpoint managers of single-zone units whose field 3 is the maximum supply air temperature and field 4 the zone.
_SZ_HEATING = ("SetpointManager:SingleZone:Heating", "SetpointManager:SingleZone:Reheat")
#: Field of ``AirTerminal:SingleDuct:VAV:Reheat``: Maximum Reheat Air Temperature [°C].
_MAX_REHEAT_FIELD = 18


def _control_limit(idf, box) -> float | None:
    """Highest discharge air temperature [°C] the controls of ``box`` allow: its VAV reheat terminal's maximum
    reheat air temperature, else its zone's single-zone heating setpoint manager's maximum; None when neither."""
    if box.terminal_type.lower() == "airterminal:singleduct:vav:reheat":
        term = idf.by_name(box.terminal_type).get(box.terminal.lower())
        return term.number(_MAX_REHEAT_FIELD) if term is not None else None
    vals = [s.number(3) for cls in _SZ_HEATING for s in idf.all(cls) if s.get(4).lower() == box.zone.lower()]
    vals = [v for v in vals if v is not None]
    return max(vals) if vals else None


def _heating_limit(idf, boxes):
    """Heating limit [°C] of the discharge air of one unit's ``boxes``: what its controls allow when every box has
    a limit (:func:`_control_limit`), else the highest zone heating design supply air temperature (Sizing:Zone);
    None when neither is known or plausible (15..80 °C)."""
    limits = [_control_limit(idf, b) for b in boxes]
    if limits and all(v is not None for v in limits):
        t = max(limits)
    else:
        zones = {b.zone.lower() for b in boxes}
        vals = []
        for s in idf.all("Sizing:Zone"):
            if s.get(0).lower() in zones and s.get(4).lower().startswith("supplyairtemperature"):
                v = s.number(5)
                if v is not None:
                    vals.append(v)
        t = max(vals) if vals else None
    return t if t is not None and 15.0 <= t <= 80.0 else None


def _building_dict(idf, site, boxes, ahus, limits, label):
    zones = list(dict.fromkeys(b.zone for b in boxes))
    surfs, wins = geometry.surfaces(idf), geometry.windows(idf)
    d = {
        "name": label,
        "latitude": site.latitude,
        "longitude": site.longitude,
        "timezone": site.timezone,
        "zones": geometry.zone_tables(idf, zones, surfs, wins),
        "vavs": [
            {
                "name": b.name,
                "zone": hvac.sanitise(b.zone),
                "m_min": limits[b.name][0],
                "m_max": limits[b.name][1],
                "ahu": hvac.sanitise(b.ahu),
            }
            for b in boxes
        ],
    }
    d["ahus"] = []
    for name in ahus:
        a = {"name": hvac.sanitise(name)}
        t = _heating_limit(idf, [b for b in boxes if b.ahu == name])
        if t is not None:
            a["T_supply_max"] = t
        d["ahus"].append(a)
    d.update(physics.physics_tables(idf, zones, surfs, wins))
    return d


def generate(
    outdir,
    prototype,
    *,
    weather=None,
    weeks: int | None = None,
    days: int | None = None,
    start: str = "01-01",
    year: int = 2017,
    floor: str | None = None,
    zones=None,
    timezone: str | None = None,
    fmt: str = "parquet",
    extra_idf: str | None = None,
    files: Mapping[str, str] | None = None,
    wind: bool = False,
) -> EnergyPlusPaths:
    """Run an EnergyPlus building and write what its BMS would export.

    Parameters
    ----------
    outdir : path
        Folder to write (created if needed).
    prototype : str or path
        An IDF file, an example file name (``ASHRAE901_OfficeMedium_STD2019_Denver``) or a
        ``pyenergyplus.dataset`` key (``office_medium``; ``ref:small_office`` for the DOE reference buildings).
    weather : str or path, optional
        EPW file or ``pyenergyplus.dataset.weather_files`` key; default the example building's city.
    weeks, days : int, optional
        Length of the run from ``start``; default to the end of ``year``.
    start : str
        First day, month-day (``"01-01"``).
    year : int
        Calendar year of the run (2017 starts on a Sunday, as the prototypes' run periods).
    floor : str, optional
        Keep only conditioned zones whose IDF name contains this text (``"mid"``).
    zones : sequence of str, optional
        Keep only these IDF zones.
    timezone : str, optional
        IANA time zone of the site; default from the weather file's state.
    fmt : {"parquet", "csv"}
    extra_idf : str, optional
        IDF objects (text) added to the run's IDF after its export edits, e.g. an effect a test bed injects: an
        ``InternalMass``, a ``ZoneCrossMixing``, an ``ElectricEquipment`` on a ``Schedule:File``, a
        ``RunPeriodControl:SpecialDays``. The building file is still read from the unedited IDF, so what is added
        here is invisible to its zones, facades and physics tables (as a hidden effect is to a BMS); EnergyPlus's
        autosizing does see it, so the boxes' ``m_min``/``m_max`` are those of the edited building. ``{run_dir}`` in the text is replaced by the
        folder ``files`` are written to.
    files : mapping of str to str, optional
        ``{file name: text}`` written into the run's folder before EnergyPlus starts (``Schedule:File`` data of
        ``extra_idf``, referenced as ``{run_dir}/name``). Names are plain file names.
    wind : bool
        Also write the site's wind speed (``Site Wind Speed`` [m/s], the weather file's, at the site's height) as a
        ``wind`` column. Off by default: an option of the cache key only when on (:func:`cache_key`), so the
        cached exports without it stay valid.

    Returns
    -------
    EnergyPlusPaths

    Raises
    ------
    DataError, BuildingError
        Naming the file, zone or object that could not be used.
    """
    if fmt not in ("parquet", "csv"):
        raise DataError(f"fmt must be 'parquet' or 'csv', got {fmt!r}")
    idf_path = inputs.resolve_prototype(prototype)
    epw = inputs.resolve_weather(weather, idf_path)
    site = inputs.read_site(epw, timezone)
    first, last = inputs.run_dates(year, start, weeks, days)
    idf = read_idf(idf_path)
    all_boxes = hvac.air_boxes(idf)
    boxes = select_boxes(all_boxes, floor, zones)
    left_out = _zones_left_out(idf, all_boxes, floor, zones)
    multiplied = {b.zone: b.multiplier for b in boxes if b.multiplier != 1.0}
    if multiplied:
        log.info(
            "EnergyPlus: %d zone(s) with a zone multiplier, exported as one copy (airflow and box limits divided): %s",
            len(multiplied),
            ", ".join(f"{z} x{m:g}" for z, m in multiplied.items()),
        )
    ahus = dict.fromkeys(b.ahu for b in boxes)
    ahus = {a: next(b.supply_node for b in boxes if b.ahu == a) for a in ahus}
    zone_names = list(dict.fromkeys(b.zone for b in boxes))
    # EnergyPlus days are standard-time days: start a day early so that local midnight (23:00 standard time in
    # daylight saving time) is covered, then keep whole local days [first 00:00, last + 1 day 00:00).
    run_first = max(first - _dt.timedelta(days=1), _dt.date(first.year, 1, 1))
    notes = inputs.prepare_idf(idf, run_first, last, site)
    files = dict(files or {})
    bad = [n for n in files if not n or Path(n).name != n or n in (".", "..")]
    if bad:
        raise DataError(f"files: names must be plain file names (no folder), got {bad}")
    refrigeration = hvac.refrigeration_in_zones(idf, boxes)
    mixing = hvac.mixing_into_zones(idf, boxes)
    warned = [
        w
        for w in (
            inputs.site_mismatch(idf, site, epw.name),
            _unmeasured_warning(idf, boxes),
            _refrigeration_warning(refrigeration),
            _mixing_warning(mixing, boxes),
        )
        if w
    ]
    for w in warned:
        warnings.warn(w, HvacfmuWarning, stacklevel=2)
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="hvacfmu-eplus-") as work:
        run_idf = Path(work) / "in.idf"
        if extra_idf:
            notes += inputs.add_objects(idf, extra_idf.replace("{run_dir}", work))
        for name, text in files.items():
            (Path(work) / name).write_text(text, encoding="latin-1")
        run_idf.write_text(idf.text(), encoding="latin-1")
        probes = export_probes(boxes, ahus, zone_names, wind=wind)
        log.info("EnergyPlus: %s with %s, %s to %s", idf_path.name, epw.name, first, last)
        values, times, eio = simulate(run_idf, epw, Path(work) / "out", probes)
    if len(values) == 0:
        raise DataError(f"EnergyPlus run of {idf_path} produced no weather-period steps")
    frame = _frame(values, times, probes, site, boxes, ahus)
    lo = pd.Timestamp(first).tz_localize(site.timezone)
    hi = pd.Timestamp(last + _dt.timedelta(days=1)).tz_localize(site.timezone)
    frame = frame[(frame.index >= lo) & (frame.index < hi)]
    twins = twin_zones(frame, zone_names)
    if twins:
        frame, boxes, ahus, twin_warning = _leave_twins_out(frame, boxes, ahus, twins, left_out)
        zone_names = [z for z in zone_names if z not in twins]
        warnings.warn(twin_warning, HvacfmuWarning, stacklevel=2)
        warned.append(twin_warning)
    held = _held_warning(frame)
    if held:
        warnings.warn(held, HvacfmuWarning, stacklevel=2)
        warned.append(held)
    limits = _sizing_limits(read_idf(idf_path), boxes, eio, hvac.std_air_density(site.elevation))
    label = f"{idf_path.stem} ({site.label})" + (f", zones with {floor!r}" if floor else "")
    d = _building_dict(read_idf(idf_path), site, boxes, ahus, limits, label)
    _building.building_from_dict(d)  # validates; raises BuildingError naming every problem
    return _write(
        outdir,
        frame,
        d,
        fmt,
        {
            "idf": str(idf_path),
            "weather": str(epw),
            "site": dataclasses.asdict(site),
            "start": str(first),
            "end": str(last),
            "year": year,
            "floor": floor,
            "zones": {hvac.sanitise(z): z for z in zone_names},
            "boxes": [dataclasses.asdict(b) for b in boxes],
            "air_density": hvac.std_air_density(site.elevation),
            "zones_left_out": left_out,
            "refrigeration": refrigeration,
            "mixing": {z: [{"object": n, "source": src} for n, src in pairs] for z, pairs in mixing.items()},
            "idf_changes": [n.replace(work, "{run_dir}") for n in notes],
            "files": {n: hashlib.sha256(t.encode("latin-1")).hexdigest() for n, t in files.items()},
            "warnings": warned,
            "approximations": list(APPROXIMATIONS),
            "export_version": EXPORT_VERSION,
        },
    )


def _write(outdir: Path, frame: pd.DataFrame, d: dict, fmt: str, info: dict) -> EnergyPlusPaths:
    import tomli_w

    out = frame.reset_index(drop=True)
    out.insert(0, "time", _iso(frame.index))
    meas = outdir / f"measurements.{fmt}"
    if fmt == "parquet":
        out.to_parquet(meas, index=False)
    else:
        out.to_csv(meas, index=False)
    bpath = outdir / "building.toml"
    bpath.write_text(tomli_w.dumps(d), encoding="utf-8")
    ipath = outdir / "energyplus.json"
    ipath.write_text(json.dumps(info, indent=1, default=str), encoding="utf-8")
    return EnergyPlusPaths(meas, bpath, ipath)


def cache_key(prototype, **options) -> str:
    """Folder name of a cached export: prototype, options, the IDF's and EPW's content and the export version."""
    idf_path = inputs.resolve_prototype(prototype)
    epw = inputs.resolve_weather(options.get("weather"), idf_path)
    if not options.get("wind", True):
        options = {k: v for k, v in options.items() if k != "wind"}  # wind=False is the export without the option
    h = hashlib.sha256()
    h.update(json.dumps({k: options[k] for k in sorted(options)}, sort_keys=True, default=str).encode())
    h.update(idf_path.read_bytes())
    h.update(epw.read_bytes())
    return f"energyplus-v{EXPORT_VERSION}-{idf_path.stem}-{h.hexdigest()[:12]}"


def cached_export(prototype, **options) -> EnergyPlusPaths:
    """:func:`generate` once into ``$HVACFMU_CACHE`` (default ``~/.cache/hvacfmu``) and reuse it (atomic rename)."""
    root = Path(os.environ.get("HVACFMU_CACHE", Path.home() / ".cache" / "hvacfmu"))
    final = root / cache_key(prototype, **options)
    paths = EnergyPlusPaths(final / "measurements.parquet", final / "building.toml", final / "energyplus.json")
    if all(p.exists() for p in (paths.measurements, paths.building, paths.info)):
        return paths
    root.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}-", dir=root))
    try:
        generate(tmp, prototype, fmt="parquet", **options)
        try:
            os.rename(tmp, final)
        except OSError:
            if not final.exists():
                raise
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return paths
