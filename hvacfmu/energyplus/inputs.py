"""Inputs of an EnergyPlus export: the IDF (an example building or the user's own), the weather file, the site.

The run's IDF is a copy with: one ``RunPeriod`` (the requested calendar year,
start day and number of weeks; weather-file holidays and daylight saving off,
the IDF's own special days kept), ``Timestep,4`` (15-minute zone steps; the
prototypes use 4 already), zone/system sizing on, reports (``Output:*``) removed,
and the IDF's ``RunPeriodControl:DaylightSavingTime`` removed when the site's time
zone has no daylight saving time (so the schedules follow the local clock).
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import zoneinfo
from pathlib import Path

from ..errors import BuildingError, DataError
from .idf import Idf, parse_idf

#: IANA time zone of the US states of the weather files shipped with EnergyPlus (and their neighbours).
US_STATE_TIMEZONES = {
    "AZ": "America/Phoenix",
    "CA": "America/Los_Angeles",
    "NV": "America/Los_Angeles",
    "OR": "America/Los_Angeles",
    "WA": "America/Los_Angeles",
    "CO": "America/Denver",
    "UT": "America/Denver",
    "NM": "America/Denver",
    "WY": "America/Denver",
    "MT": "America/Denver",
    "ID": "America/Boise",
    "IL": "America/Chicago",
    "TX": "America/Chicago",
    "OK": "America/Chicago",
    "MN": "America/Chicago",
    "WI": "America/Chicago",
    "MO": "America/Chicago",
    "IA": "America/Chicago",
    "LA": "America/Chicago",
    "NJ": "America/New_York",
    "NY": "America/New_York",
    "VA": "America/New_York",
    "FL": "America/New_York",
    "GA": "America/New_York",
    "MA": "America/New_York",
    "PA": "America/New_York",
    "MD": "America/New_York",
    "DC": "America/New_York",
    "HI": "Pacific/Honolulu",
    "AK": "America/Anchorage",
}
STEPS_PER_HOUR = 4
#: Latitude/longitude difference [deg] above which the weather file is another site than the IDF's Site:Location.
SITE_TOLERANCE_DEG = 0.5


@dataclasses.dataclass(frozen=True)
class Site:
    """Site of a weather file: ``latitude``/``longitude`` [deg], ``tz_hours`` [h, standard offset from UTC],
    ``elevation`` [m], ``timezone`` (IANA), ``label``."""

    latitude: float
    longitude: float
    tz_hours: float
    elevation: float
    timezone: str
    label: str


def resolve_prototype(prototype) -> Path:
    """Path of an IDF: a file path, an example file name (``ASHRAE901_OfficeMedium_STD2019_Denver``, ``.idf``
    optional) or a ``pyenergyplus.dataset`` key (``office_medium``, ``ref:small_office``)."""
    p = Path(str(prototype))
    if p.suffix.lower() == ".idf" and p.exists():
        return p
    try:
        import pyenergyplus.dataset as ds
    except ImportError:  # pragma: no cover
        raise BuildingError(
            f"IDF {prototype!r} not found and pyenergyplus is not installed (pip install 'hvacfmu[energyplus]')"
        ) from None
    name = str(prototype)
    cand = Path(ds.modeldir) / (name if name.lower().endswith(".idf") else name + ".idf")
    if cand.exists():
        return cand
    key = name.split(":", 1)[-1]
    table = ds.ref_models if name.startswith("ref:") else ds.ashrae_models
    if key in table:
        return Path(table[key])
    names = sorted(x.stem for x in Path(ds.modeldir).glob("*.idf"))
    raise BuildingError(
        f"unknown EnergyPlus prototype {prototype!r}: give an IDF path, one of the example files "
        f"{names}, or a key of pyenergyplus.dataset.ashrae_models {sorted(ds.ashrae_models)}"
    )


def resolve_weather(weather, idf_path: Path) -> Path:
    """Path of an EPW: a file, a ``pyenergyplus.dataset.weather_files`` key, or (None) the example building's city."""
    import pyenergyplus.dataset as ds

    if weather is not None:
        p = Path(str(weather))
        if p.exists():
            return p
        if str(weather) in ds.weather_files:
            return Path(ds.weather_files[str(weather)])
        raise DataError(f"weather file {weather!r} not found; give an EPW path or one of {sorted(ds.weather_files)}")
    stem = idf_path.stem.lower()
    for city, key in (("denver", "usa_co_denver"), ("chicago", "usa_il_chicago")):
        if stem.endswith(city):
            return Path(ds.weather_files[key])
    raise DataError(
        f"IDF {idf_path} is not one of EnergyPlus's example buildings: give its weather file (--weather EPW)"
    )


def read_site(epw: Path, timezone: str | None = None) -> Site:
    """The site of an EPW file from its ``LOCATION`` line; ``timezone`` overrides the IANA zone guessed from the state."""
    first = epw.read_text(encoding="latin-1").splitlines()[0].split(",")
    if first[0].strip().upper() != "LOCATION" or len(first) < 10:
        raise DataError(f"weather file {epw}: first line is not an EPW LOCATION record")
    state, lat, lon, tzh, elev = first[2].strip(), float(first[6]), float(first[7]), float(first[8]), float(first[9])
    tz = timezone or US_STATE_TIMEZONES.get(state.upper())
    if tz is None:
        raise DataError(
            f"weather file {epw}: cannot tell the IANA time zone of {first[1]} ({state}, {first[3]}, UTC"
            f"{tzh:+g} h); give it (timezone='Europe/Berlin', --timezone)"
        )
    try:
        zone = zoneinfo.ZoneInfo(tz)
    except zoneinfo.ZoneInfoNotFoundError:
        raise DataError(f"time zone {tz!r} is not an IANA time zone name") from None
    jan = _dt.datetime(2021, 1, 15, tzinfo=zone).utcoffset().total_seconds() / 3600
    jul = _dt.datetime(2021, 7, 15, tzinfo=zone).utcoffset().total_seconds() / 3600
    if abs(min(jan, jul) - tzh) > 0.01:
        raise DataError(
            f"time zone {tz} (standard offset {min(jan, jul):+g} h) does not match the weather file "
            f"{epw.name} (UTC{tzh:+g} h)"
        )
    return Site(lat, lon, tzh, elev, tz, f"{first[1].strip()}, {state}")


def has_dst(tz: str, year: int) -> bool:
    zone = zoneinfo.ZoneInfo(tz)
    offs = {_dt.datetime(year, m, 15, tzinfo=zone).utcoffset() for m in range(1, 13)}
    return len(offs) > 1


def run_dates(year: int, start: str, weeks: int | None, days: int | None) -> tuple:
    """(first day, last day) of the run period; ``weeks``/``days`` None = to the end of the year."""
    try:
        m, d = (int(x) for x in start.split("-"))
        first = _dt.date(year, m, d)
    except ValueError:
        raise DataError(f"start {start!r} is not a month-day like '01-01'") from None
    n = days if days is not None else (7 * weeks if weeks is not None else None)
    last = _dt.date(year, 12, 31) if n is None else first + _dt.timedelta(days=n - 1)
    if n is not None and n < 1:
        raise DataError(f"the run period must last at least one day, got {n}")
    if last.year != year:
        raise DataError(
            f"run period {first} + {n} days ends in {last.year}: EnergyPlus runs one calendar year here; "
            "start earlier or ask for fewer weeks"
        )
    return first, last


def prepare_idf(idf: Idf, first: _dt.date, last: _dt.date, site: Site) -> list:
    """Edit ``idf`` in place for the export run (see module docstring); returns notes on what was changed."""
    notes = []
    idf.remove("RunPeriod")
    idf.add(
        "RunPeriod",
        "hvacfmu",
        first.month,
        first.day,
        first.year,
        last.month,
        last.day,
        last.year,
        "",
        "No",
        "No",
        "No",
        "Yes",
        "Yes",
    )
    ts = idf.one("Timestep")
    if ts is None or ts.number(0) != STEPS_PER_HOUR:
        notes.append(f"Timestep set to {STEPS_PER_HOUR} per hour (was {ts.get(0) if ts else 'unset'})")
    idf.remove("Timestep")
    idf.add("Timestep", STEPS_PER_HOUR)
    sc = idf.one("SimulationControl")
    if sc is not None:
        sc.fields[:5] = ["Yes", "Yes", sc.get(2, "Yes"), "No", "Yes"]
    for o in list(idf.objects):
        if o.cls.lower().startswith("output:") or o.cls.lower().startswith("outputcontrol:"):
            idf.objects.remove(o)
    notes += limit_reheat_air(idf)
    if idf.one("RunPeriodControl:DaylightSavingTime") is not None and not has_dst(site.timezone, first.year):
        idf.remove("RunPeriodControl:DaylightSavingTime")
        notes.append(f"RunPeriodControl:DaylightSavingTime removed: {site.timezone} has no daylight saving time")
    elif idf.one("RunPeriodControl:DaylightSavingTime") is None and has_dst(site.timezone, first.year):
        notes.append(
            f"the IDF has no daylight saving period although {site.timezone} has one: its schedules run "
            "on standard time"
        )
    return notes


#: Discharge limit [°C] given to a VAV reheat box that has none: the DOE's 90.1 prototypes of the same buildings
#: set 40 °C; without it the Ref (2004) medium office's electric coils blow 84 °C air at 0.3 x m_max during the
#: morning warm-up, which no box with a high-limit delivers and which the data check refuses (> 80 °C).
MAX_REHEAT_AIR = 40.0
_REHEAT_LIMIT_FIELD = 18  # AirTerminal:SingleDuct:VAV:Reheat "Maximum Reheat Air Temperature" (0-based, after class)


def limit_reheat_air(idf: Idf) -> list:
    """Give every ``AirTerminal:SingleDuct:VAV:Reheat`` without a maximum reheat air temperature :data:`MAX_REHEAT_AIR`."""
    changed = []
    for o in idf.all("AirTerminal:SingleDuct:VAV:Reheat"):
        if o.get(_REHEAT_LIMIT_FIELD):
            continue
        o.fields.extend([""] * (_REHEAT_LIMIT_FIELD + 1 - len(o.fields)))
        o.fields[_REHEAT_LIMIT_FIELD] = f"{MAX_REHEAT_AIR:g}"
        changed.append(o.name)
    if not changed:
        return []
    return [
        f"Maximum Reheat Air Temperature set to {MAX_REHEAT_AIR:g} °C (was unset: no limit) on {len(changed)} "
        f"VAV reheat box(es): {', '.join(changed)}"
    ]


def site_mismatch(idf: Idf, site: Site, epw_name: str) -> str | None:
    """A warning when the weather file is not at the IDF's ``Site:Location`` (None when it is, or the IDF has none).

    EnergyPlus then runs at the weather file's site, but the IDF's design days (``SizingPeriod:DesignDay``), hence
    the autosized boxes and air handlers, and its ground temperatures stay those of the IDF's city: the export is
    that city's design in another climate.
    """
    loc = idf.one("Site:Location")
    if loc is None:
        return None
    lat, lon = loc.number(1), loc.number(2)
    if lat is None or lon is None:
        return None
    if abs(lat - site.latitude) <= SITE_TOLERANCE_DEG and abs(lon - site.longitude) <= SITE_TOLERANCE_DEG:
        return None
    days = [d.name for d in idf.all("SizingPeriod:DesignDay")]
    return (
        f"weather file {epw_name} ({site.label}, {site.latitude:.2f}, {site.longitude:.2f}) is not at the IDF's "
        f"Site:Location {loc.name!r} ({lat:.2f}, {lon:.2f}): EnergyPlus runs at the weather file's site, but the "
        f"HVAC is autosized on the IDF's {len(days)} design day(s) ({'; '.join(days) or 'none'}) and the IDF's "
        "ground temperatures are kept, so the data are that design in this climate (boxes and units may be "
        "too small or too large for it); give an IDF sized for the site to export a building designed for it"
    )


def add_objects(idf: Idf, text: str) -> list:
    """Append the IDF objects of ``text`` to ``idf`` (in place); returns one note per object added.

    Raises
    ------
    BuildingError
        When ``text`` ends inside an object (a missing ``;``) or holds no object.
    """
    extra = parse_idf(text, source="extra_idf")
    if not extra.objects:
        raise BuildingError("extra_idf holds no IDF object (objects are 'Class, field, ...;')")
    idf.objects.extend(extra.objects)
    return [f"added {o.cls} {o.name!r} (extra_idf)" for o in extra.objects]
