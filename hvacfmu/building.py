"""The building file: location, zones, VAV boxes, seasons, column mapping, physics.

A building file is TOML. The generic part is parsed and validated here; the
``materials``, ``constructions``, ``windows`` and ``elements`` tables used by the
physics model (Model B) are kept as plain data in :attr:`Building.physics` and
validated by :mod:`hvacfmu.models.physics`.

Example (abridged)::

    name = "SDH floor 4"
    latitude = 37.8750
    longitude = -122.2587
    timezone = "America/Los_Angeles"

    [[zones]]
    name = "NW"
    area = 420.0        # [m2]
    volume = 1260.0     # [m3]
    adjacent = ["W", "C", "NE"]
    facades = [{orientation = "N", window_area = 40.0, wall_area = 60.0}]

    [[ahus]]             # optional: several air handlers
    name = "AHU1"
    T_supply_max = 35.0 # [°C] optional heating limit of the discharge air
    columns = {T_supply = "AHU-1 SA-T"}   # optional: file column of its supply temperature

    [[vavs]]
    name = "VAV_NW_1"
    zone = "NW"
    ahu = "AHU1"        # required when [[ahus]] are declared
    m_min = 0.05        # [kg/s]
    m_max = 0.8         # [kg/s]

    [[seasons]]          # optional; default: the paper's seasons plus summer
    name = "fall"
    start = "09-01"
    end = "12-15"

    [columns]            # optional: canonical name = column name in the data file
    T_NW = "RM4-NW ZN-T"

    [units]              # optional: canonical name or glob = unit of the data file
    "T_*" = "degF"
    "Td_*" = "degF"
    "m_*" = "cfm"
    "rh_*" = "%"

    [holidays]           # optional: weekdays run on Sunday's schedule (hvacfmu.calendars)
    country = "US"       # public holidays of a country; without [holidays] the data decide
    dates = ["2026-12-24..2027-01-01"]   # further closed days
    open = ["2026-10-12"]                # public holidays the building works on

Air handlers
------------
Without ``[[ahus]]`` every box belongs to one implicit air handler whose supply
temperature is the column ``T_supply``. With ``[[ahus]]``, each ``[[vavs]]``
entry names its unit (``ahu = "AHU1"``) and the supply temperature of unit ``X``
is the column ``T_supply_X`` (a single declared unit may keep the plain
``T_supply`` column). Per box, the data may add the discharge air temperature
``Td_<vav>`` [°C] and the reheat command ``rh_<vav>`` [0..1].

Time zones
----------
``timezone`` is the building's local zone: the clock of the calendar, the
seasons, the time of week and the index of prepared data. ``data_timezone``
(optional, default ``timezone``) is the zone the data logger's clock is in: the
zone in which *naive* timestamps of the measurements file are read (e.g.
``"UTC"`` for an export in naive UTC). Timestamps with a UTC offset ignore it.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import fnmatch
import functools
import hashlib
import numbers
from pathlib import Path
from typing import Any

import numpy as np

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

from .calendars import HolidaySpec, holidays_from_toml, zone_table_rows
from .errors import BuildingError, problems_message

ORIENTATIONS = ("N", "E", "S", "W")

#: The paper's seasons (Zhou, Hu, Tomlin), plus summer for the rest of the year.
DEFAULT_SEASONS = (
    ("fall", "09-01", "12-15"),
    ("winter", "12-16", "01-25"),
    ("spring", "01-26", "05-15"),
    ("summer", "05-16", "08-31"),
)


@dataclasses.dataclass(frozen=True)
class Facade:
    """An exterior facade of a zone.

    Parameters
    ----------
    orientation : str
        One of ``N``, ``E``, ``S``, ``W``.
    window_area : float [m2]
    wall_area : float [m2]
        Opaque area (optional, 0 if unknown).
    """

    orientation: str
    window_area: float = 0.0
    wall_area: float = 0.0


@dataclasses.dataclass(frozen=True)
class Zone:
    """A thermal zone. ``area`` [m2], ``volume`` [m3]."""

    name: str
    area: float
    volume: float
    facades: tuple[Facade, ...] = ()
    adjacent: tuple[str, ...] = ()

    @property
    def orientations(self) -> tuple[str, ...]:
        """Orientations of this zone's exterior facades, in N, E, S, W order."""
        have = {f.orientation for f in self.facades}
        return tuple(o for o in ORIENTATIONS if o in have)


@dataclasses.dataclass(frozen=True)
class Vav:
    """A VAV box serving one zone; airflow limits ``m_min``, ``m_max`` [kg/s].

    ``ahu`` names the air handler feeding the box (None: the implicit single unit).
    """

    name: str
    zone: str
    m_min: float = 0.0
    m_max: float = 1.0
    ahu: str | None = None


#: Per-unit quantities an ``[[ahus]]`` entry may map to file columns in its ``columns`` table.
AHU_QUANTITIES = ("T_supply",)


@dataclasses.dataclass(frozen=True)
class Ahu:
    """An air handler feeding VAV boxes.

    Parameters
    ----------
    name : str
    T_supply_max : float or None [°C]
        Heating limit of the air the unit's boxes may discharge (None: unknown).
    columns : dict
        Per-unit quantity (``T_supply``) -> column name in the data file
        (default ``T_supply_<name>``).
    """

    name: str
    T_supply_max: float | None = None
    columns: dict = dataclasses.field(default_factory=dict)

    @property
    def supply_column(self) -> str:
        """Canonical name of this unit's supply temperature column [°C]."""
        return f"T_supply_{self.name}"


@dataclasses.dataclass(frozen=True)
class Season:
    """A season spanning month-day ``start`` to ``end`` inclusive (may wrap the new year)."""

    name: str
    start: str
    end: str

    def _md(self, s):
        m, d = (int(p) for p in s.split("-"))
        return m, d

    def contains(self, month: int, day: int) -> bool:
        """True if the calendar day (month, day) lies in this season."""
        a, b, x = self._md(self.start), self._md(self.end), (month, day)
        if a <= b:
            return a <= x <= b
        return x >= a or x <= b


@dataclasses.dataclass(frozen=True)
class Building:
    """A building description. See the module docstring for the file format."""

    name: str
    latitude: float
    longitude: float
    timezone: str
    zones: tuple[Zone, ...]
    vavs: tuple[Vav, ...]
    seasons: tuple[Season, ...] = tuple(Season(*s) for s in DEFAULT_SEASONS)
    ahus: tuple[Ahu, ...] = ()
    data_timezone: str | None = None
    columns: dict = dataclasses.field(default_factory=dict)
    units: dict = dataclasses.field(default_factory=dict)
    physics: dict = dataclasses.field(default_factory=dict)
    holidays: HolidaySpec = HolidaySpec()
    source: str | None = None
    sha256: str | None = None

    def __post_init__(self):
        problems = validate_building(self)
        if problems:
            where = f"building file {self.source}" if self.source else "building"
            raise BuildingError(problems_message(f"Invalid {where}", problems))

    # --- names ---------------------------------------------------------
    @property
    def zone_names(self) -> tuple[str, ...]:
        return tuple(z.name for z in self.zones)

    @property
    def vav_names(self) -> tuple[str, ...]:
        return tuple(v.name for v in self.vavs)

    @property
    def season_names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.seasons)

    def zone(self, name: str) -> Zone:
        for z in self.zones:
            if z.name == name:
                return z
        raise KeyError(f"no zone named {name!r}; zones are {list(self.zone_names)}")

    @property
    def ahu_names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.ahus)

    def vav(self, name: str) -> Vav:
        for v in self.vavs:
            if v.name == name:
                return v
        raise KeyError(f"no VAV box named {name!r}; boxes are {list(self.vav_names)}")

    def ahu_of(self, vav: str) -> Ahu | None:
        """The air handler feeding box ``vav``; None for the implicit single unit (no ``[[ahus]]``)."""
        name = self.vav(vav).ahu
        for a in self.ahus:
            if a.name == name:
                return a
        return None

    def supply_column(self, vav: str) -> str:
        """Canonical supply temperature column [°C] of the unit feeding box ``vav``.

        ``T_supply_<ahu>`` when ``[[ahus]]`` are declared, ``T_supply`` otherwise.
        """
        ahu = self.ahu_of(vav)
        return "T_supply" if ahu is None else ahu.supply_column

    def supply_columns(self) -> tuple[str, ...]:
        """Canonical supply temperature columns of the declared units (empty without ``[[ahus]]``)."""
        return tuple(a.supply_column for a in self.ahus)

    @property
    def clock_timezone(self) -> str:
        """Zone of naive timestamps in the measurements: ``data_timezone`` or ``timezone``."""
        return self.data_timezone or self.timezone

    def vavs_of(self, zone: str) -> tuple[Vav, ...]:
        """VAV boxes serving ``zone``."""
        return tuple(v for v in self.vavs if v.zone == zone)

    def adjacency_pairs(self) -> tuple[tuple[str, str], ...]:
        """Unordered adjacent zone pairs (i < j in zone order), symmetric closure."""
        idx = {n: i for i, n in enumerate(self.zone_names)}
        pairs = set()
        for z in self.zones:
            for other in z.adjacent:
                i, j = sorted((idx[z.name], idx[other]))
                if i != j:
                    pairs.add((i, j))
        return tuple((self.zone_names[i], self.zone_names[j]) for i, j in sorted(pairs))

    def zone_vav_matrix(self):
        """(n_zones, n_vavs) 0/1 matrix summing box airflows into zone airflows."""
        M = np.zeros((len(self.zones), len(self.vavs)))
        idx = {n: i for i, n in enumerate(self.zone_names)}
        for j, v in enumerate(self.vavs):
            M[idx[v.zone], j] = 1.0
        return M

    def area_weights(self):
        """Zone floor areas normalised to sum to one (for the lumped model)."""
        a = np.array([z.area for z in self.zones], dtype=float)
        return a / a.sum()

    # --- seasons -------------------------------------------------------
    def season_of(self, when) -> str:
        """Season name of a date/timestamp (anything with ``.month`` and ``.day``)."""
        for s in self.seasons:
            if s.contains(when.month, when.day):
                return s.name
        raise BuildingError(f"{when} lies in no season of building {self.name!r}")

    # --- columns / units -----------------------------------------------
    def column_for(self, canonical: str) -> str:
        """Name of the data-file column holding canonical quantity ``canonical``.

        ``[columns]`` first, then an air handler's own ``columns`` table for its
        ``T_supply_<ahu>``, else the canonical name itself.
        """
        if canonical in self.columns:
            return self.columns[canonical]
        for a in self.ahus:
            for quantity, name in a.columns.items():
                if canonical == f"{quantity}_{a.name}":
                    return name
        return canonical

    def unit_for(self, canonical: str) -> str | None:
        """Declared unit of canonical column ``canonical`` (exact name beats glob), or None.

        Of several matching globs the most specific wins (the most characters that are not wildcards:
        ``T_supply_*`` over ``T_*``), whatever their order in the file; ties go to the first.
        """
        if canonical in self.units:
            return self.units[canonical]
        matching = [(p, u) for p, u in self.units.items() if fnmatch.fnmatchcase(canonical, p)]
        if not matching:
            return None
        return max(matching, key=lambda pu: len(pu[0].replace("*", "").replace("?", "")))[1]

    def expected_columns(self) -> dict[str, bool]:
        """Canonical columns a measurement file should have -> whether required."""
        cols = {f"T_{z}": True for z in self.zone_names}
        cols.update({f"m_{v}": True for v in self.vav_names})
        cols.update({c: True for c in self.supply_columns()})
        # with declared units, T_supply is optional (a single unit may use it as its supply column)
        cols.update({"T_supply": not self.ahus, "T_out": True, "ghi": False, "excitation": False})
        cols.update({f"I_{o}": False for o in ORIENTATIONS})
        cols.update({f"Td_{v}": False for v in self.vav_names})
        cols.update({f"rh_{v}": False for v in self.vav_names})
        cols["wind"] = False  # wind speed at the site [m/s] (hvacfmu.models.causes.wind_infiltration)
        return cols

    # --- serialisation -------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        d = {
            "name": self.name,
            "latitude": self.latitude,
            "longitude": self.longitude,
            "timezone": self.timezone,
            "zones": [
                {
                    "name": z.name,
                    "area": z.area,
                    "volume": z.volume,
                    "adjacent": list(z.adjacent),
                    "facades": [dataclasses.asdict(f) for f in z.facades],
                }
                for z in self.zones
            ],
            "vavs": [{k: x for k, x in dataclasses.asdict(v).items() if x is not None} for v in self.vavs],
            "seasons": [dataclasses.asdict(s) for s in self.seasons],
        }
        if self.data_timezone:
            d["data_timezone"] = self.data_timezone
        if self.ahus:
            d["ahus"] = [
                {"name": a.name}
                | ({"T_supply_max": a.T_supply_max} if a.T_supply_max is not None else {})
                | ({"columns": dict(a.columns)} if a.columns else {})
                for a in self.ahus
            ]
        if self.columns:
            d["columns"] = dict(self.columns)
        if self.units:
            d["units"] = dict(self.units)
        if self.holidays.declared:
            d["holidays"] = self.holidays.to_toml()
        d.update(self.physics)
        return d

    def to_toml(self) -> str:
        import tomli_w

        return tomli_w.dumps(self.to_dict())

    def save(self, path) -> Path:
        path = Path(path)
        path.write_text(self.to_toml(), encoding="utf-8")
        return path


#: Top-level keys of a building file that belong to the physics model.
PHYSICS_KEYS = ("materials", "constructions", "windows", "elements", "physics", "construction_template")


def _as_float(value, what, problems, default=None):
    """A finite float from a TOML value; booleans, text and inf/nan are problems (None: ``default``)."""
    if value is None and default is not None:
        return default
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        problems.append(f"{what}: expected a number, got {value!r} ({type(value).__name__})")
        return float("nan")
    value = float(value)
    if not np.isfinite(value):
        problems.append(f"{what}: expected a finite number, got {value!r}")
    return value


def _as_str(value, what, problems, default=None):
    """A non-empty string from a TOML value (numbers, booleans, tables are problems)."""
    if value is None and default is not None:
        return default
    if not isinstance(value, str):
        problems.append(f"{what}: expected text, got {value!r} ({type(value).__name__})")
        return str(value)
    return value


def _tables(d, key, where, problems) -> list:
    """The entries of an array of tables ``key``; non-table entries are problems and skipped."""
    value = d.get(key, [])
    if isinstance(value, dict):
        value = [value]
    if not isinstance(value, list):
        problems.append(f"{where}{key}: expected an array of tables ([[{key}]]), got {value!r}")
        return []
    out = []
    for i, entry in enumerate(value):
        if isinstance(entry, dict):
            out.append((i, entry))
        else:
            problems.append(
                f"{where}{key}[{i}]: expected a table (e.g. [[{key}]] with name = ...), got {entry!r} "
                f"({type(entry).__name__})"
            )
    return out


def _str_list(value, what, problems) -> tuple:
    if value is None:
        return ()
    if not isinstance(value, list) or not all(isinstance(x, str) for x in value):
        problems.append(f'{what}: expected a list of names such as ["B", "C"], got {value!r}')
        return ()
    return tuple(value)


def _str_map(value, what, problems) -> dict:
    if value is None:
        return {}
    if not isinstance(value, dict) or not all(isinstance(k, str) and isinstance(x, str) for k, x in value.items()):
        problems.append(f'{what}: expected a table of text values (name = "text"), got {value!r}')
        return {}
    return dict(value)


def _zone_from(i, z, problems) -> Zone:
    where = f"zones[{i}] ({z.get('name', '?')})"
    for key in ("name", "area", "volume"):
        if key not in z:
            problems.append(f"{where}: missing {key!r}")
    facades = []
    for j, f in _tables(z, "facades", f"{where}.", problems):
        if "orientation" not in f:
            problems.append(f"{where}.facades[{j}]: missing 'orientation'")
            continue
        facades.append(
            Facade(
                _as_str(f["orientation"], f"{where}.facades[{j}].orientation", problems),
                _as_float(f.get("window_area", 0.0), f"{where}.facades[{j}].window_area", problems),
                _as_float(f.get("wall_area", 0.0), f"{where}.facades[{j}].wall_area", problems),
            )
        )
    return Zone(
        _as_str(z.get("name"), f"{where}.name", problems, default=f"zone{i}"),
        _as_float(z.get("area", 1.0), f"{where}.area", problems),
        _as_float(z.get("volume", 1.0), f"{where}.volume", problems),
        tuple(facades),
        _str_list(z.get("adjacent"), f"{where}.adjacent", problems),
    )


def _vav_from(i, v, problems) -> Vav:
    where = f"vavs[{i}] ({v.get('name', '?')})"
    for key in ("name", "zone"):
        if key not in v:
            problems.append(f"{where}: missing {key!r}")
    unknown = set(v) - {"name", "zone", "m_min", "m_max", "ahu"}
    if unknown:
        problems.append(f"{where}: unknown key(s) {sorted(unknown)} (known: ahu, m_max, m_min, name, zone)")
    ahu = v.get("ahu")
    return Vav(
        _as_str(v.get("name"), f"{where}.name", problems, default=f"vav{i}"),
        _as_str(v.get("zone"), f"{where}.zone", problems, default=""),
        _as_float(v.get("m_min", 0.0), f"{where}.m_min [kg/s]", problems),
        _as_float(v.get("m_max", 1.0), f"{where}.m_max [kg/s]", problems),
        None if ahu is None else _as_str(ahu, f"{where}.ahu", problems),
    )


def _ahu_from(i, a, problems) -> Ahu:
    where = f"ahus[{i}] ({a.get('name', '?')})"
    if "name" not in a:
        problems.append(f"{where}: missing 'name'")
    unknown = set(a) - {"name", "T_supply_max", "columns"}
    if unknown:
        problems.append(f"{where}: unknown key(s) {sorted(unknown)} (known: T_supply_max, columns, name)")
    columns = _str_map(a.get("columns"), f"{where}.columns", problems)
    for q in columns:
        if q not in AHU_QUANTITIES:
            problems.append(f"{where}.columns: unknown quantity {q!r} (known: {', '.join(AHU_QUANTITIES)})")
    t_max = a.get("T_supply_max")
    return Ahu(
        _as_str(a.get("name"), f"{where}.name", problems, default=f"ahu{i}"),
        None if t_max is None else _as_float(t_max, f"{where}.T_supply_max [°C]", problems),
        columns,
    )


def building_from_dict(d: dict, source: str | None = None, sha256: str | None = None) -> Building:
    """Build a :class:`Building` from a parsed TOML mapping, reporting every problem.

    Raises
    ------
    BuildingError
        Listing every problem: missing or unknown keys, values of the wrong type
        (a boolean or text where a number belongs, a name where a table belongs),
        and every inconsistency found by :func:`validate_building`.
    """
    problems: list[str] = []
    if not isinstance(d, dict):
        raise BuildingError(f"building {source or ''}: expected a table of keys, got {type(d).__name__}")
    known = {
        "name",
        "latitude",
        "longitude",
        "timezone",
        "data_timezone",
        "zones",
        "vavs",
        "ahus",
        "seasons",
        "columns",
        "units",
        "holidays",
    }
    known |= set(PHYSICS_KEYS)
    for key in d:
        if key not in known:
            problems.append(f"unknown top-level key {key!r} (known: {sorted(known)})")
    for key in ("name", "latitude", "longitude", "timezone", "zones", "vavs"):
        if key not in d:
            problems.append(f"missing required key {key!r}")
    zones = [_zone_from(i, z, problems) for i, z in _tables(d, "zones", "", problems)]
    vavs = [_vav_from(i, v, problems) for i, v in _tables(d, "vavs", "", problems)]
    ahus = [_ahu_from(i, a, problems) for i, a in _tables(d, "ahus", "", problems)]
    seasons = tuple(
        Season(*(_as_str(s.get(k), f"seasons[{i}].{k}", problems) for k in ("name", "start", "end")))
        for i, s in _tables(d, "seasons", "", problems)
    ) or tuple(Season(*s) for s in DEFAULT_SEASONS)
    physics = {k: d[k] for k in PHYSICS_KEYS if k in d}
    data_tz = d.get("data_timezone")
    fields = {
        "name": _as_str(d.get("name"), "name", problems, default=""),
        "latitude": _as_float(d.get("latitude", 0.0), "latitude [deg]", problems),
        "longitude": _as_float(d.get("longitude", 0.0), "longitude [deg]", problems),
        "timezone": _as_str(d.get("timezone"), "timezone", problems, default="UTC"),
        "data_timezone": None if data_tz is None else _as_str(data_tz, "data_timezone", problems),
        "columns": _str_map(d.get("columns"), "columns", problems),
        "units": _str_map(d.get("units"), "units", problems),
        "holidays": holidays_from_toml(d["holidays"], problems) if "holidays" in d else HolidaySpec(),
    }
    if problems:
        raise BuildingError(problems_message(f"Invalid building file {source or ''}".strip(), problems))
    return Building(
        zones=tuple(zones),
        vavs=tuple(vavs),
        ahus=tuple(ahus),
        seasons=seasons,
        physics=physics,
        source=source,
        sha256=sha256,
        **fields,
    )


def load_building(path) -> Building:
    """Read and validate a building TOML file.

    Raises
    ------
    BuildingError
        Listing every problem found (file name included).
    """
    path = Path(path)
    if not path.exists():
        raise BuildingError(f"building file {path} does not exist")
    raw = path.read_bytes()
    try:
        d = tomllib.loads(raw.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise BuildingError(f"building file {path} is not valid TOML: {exc}") from None
    return building_from_dict(d, source=str(path), sha256=hashlib.sha256(raw).hexdigest())


def _valid_md(s) -> bool:
    try:
        m, d = (int(p) for p in str(s).split("-"))
        _dt.date(2001 if (m, d) != (2, 29) else 2000, m, d)
        return True
    except (ValueError, TypeError):
        return False


#: Few VAV boxes deliver more air than this [kg/s] (about 16 000 cfm); a box above it is refused when it also renews
#: its zone's air more than :data:`ACH_LIMIT` times an hour (a unit error: cfm, l/s or m3/h read as kg/s multiplies the
#: air by 800 to 3 000). A large zone's packaged unit can exceed it (the DOE supermarket's sales area: 11.4 kg/s into
#: 16 000 m3, 2 air changes an hour).
M_MAX_LIMIT = 10.0
#: Air changes per hour [1/h] above which a box of more than :data:`M_MAX_LIMIT` is taken for a unit error (mixing
#: ventilation stays below it: hospital operating rooms 20-25, kitchens up to about 30; a data centre's unit carries its
#: IT heat: the DOE 90.1 large office's basement, 484 W/m2, 25.5 kg/s = 40 an hour). A unit error gives thousands.
ACH_LIMIT = 100.0
#: Air density used to turn a box's mass flow into air changes [kg/m3].
_RHO_AIR = 1.2


def _valid_name(name) -> bool:
    return bool(name) and not any(c in name for c in " .[]")


def valid_timezone(name) -> bool:
    """True if ``name`` is a known IANA time zone name (``UTC`` included)."""
    import zoneinfo

    try:
        zoneinfo.ZoneInfo(str(name))
        return bool(name)
    except Exception:  # noqa: BLE001 - any failure means an unusable zone name
        return False


#: A zone whose volume / area is below this [m] cannot be a room (areas in ft2 with volumes in m3).
MIN_ZONE_HEIGHT = 1.5
#: ... above this [m] it is flagged (atria exist; areas in ft2 with volumes in ft3 read 3.3 times too high).
MAX_ZONE_HEIGHT = 8.0


def building_notes(b: Building) -> list[str]:
    """Usable but suspicious settings of a building file (warnings of ``check`` and ``prepare``)."""
    notes = []
    tall = [z for z in b.zones if z.area > 0 and z.volume / z.area > MAX_ZONE_HEIGHT]
    if tall:
        parts = ", ".join(f"{z.name} {z.volume / z.area:.3g} m" for z in tall[:6])
        notes.append(
            f"building {b.name!r}: zone volume / area above {MAX_ZONE_HEIGHT:g} m of ceiling height ({parts}): "
            "an atrium or hall? if the areas are ft2 and the volumes ft3, convert them to m2 and m3"
        )
    return notes


#: A longitude farther than this [deg] (4 h of sun) from every meridian of its time zone's offsets is refused.
LONGITUDE_ZONE_LIMIT = 60.0
#: Zone names without a place: any longitude goes with them.
_PLACELESS_ZONES = {
    "UTC",
    "Etc/UTC",
    "GMT",
    "Etc/GMT",
    "UCT",
    "Etc/UCT",
    "Universal",
    "Etc/Universal",
    "Zulu",
    "Etc/Zulu",
}


def _zone_offsets(name: str) -> list[float]:
    """UTC offsets [h] of a time zone in January and July (standard and daylight saving time)."""
    import zoneinfo

    tz = zoneinfo.ZoneInfo(name)
    out = []
    for month in (1, 7):
        off = _dt.datetime(2025, month, 1, 12, tzinfo=tz).utcoffset()
        if off is not None:
            out.append(off.total_seconds() / 3600.0)
    return sorted(set(out))


def _longitude_problems(b: Building) -> list[str]:
    """The longitude against the building's time zone: the sun crosses a zone within a few hours of its offset.

    Offsets of a zone differ from longitude/15 by at most about 3 h anywhere on
    Earth (western China, Spain, Argentina: 1.5-3 h); a longitude 4 h or more from
    every offset of ``timezone`` is a sign slip (west is negative) or the zone of
    another site, and the clock check would then blame the timestamps.
    """
    if b.timezone in _PLACELESS_ZONES or not valid_timezone(b.timezone) or not -180 <= b.longitude <= 180:
        return []
    offsets = _zone_offsets(b.timezone)
    if not offsets:
        return []

    def gap(lon):
        return min(abs((lon - 15.0 * o + 180.0) % 360.0 - 180.0) for o in offsets)

    if gap(b.longitude) <= LONGITUDE_ZONE_LIMIT:
        return []
    zone = " or ".join(f"UTC{o:+g}" for o in offsets)
    meridians = " or ".join(f"{15.0 * o:+g}°" for o in offsets)
    hint = f"is the sign wrong ({-b.longitude:g}: west of Greenwich is negative)?" if gap(-b.longitude) <= 30.0 else ""
    return [
        f"longitude {b.longitude:g}° is {gap(b.longitude) / 15.0:.1f} h of sun away from the time zone "
        f"{b.timezone} ({zone}: the sun crosses it near longitude {meridians}); {hint or 'is it the longitude of '}"
        + ("" if hint else "this site, and the time zone of this building?")
    ]


@functools.lru_cache(maxsize=1)
def _zone_latitudes() -> dict:
    """Time zone name -> latitude [deg] of its principal city, from the tz database's zone tables (may be empty)."""
    import re

    out: dict = {}
    for parts in zone_table_rows():
        m = re.match(r"([+-])(\d{2})(\d{2})(\d{2})?[+-]", parts[1])
        if m:
            lat = int(m.group(2)) + int(m.group(3)) / 60 + int(m.group(4) or 0) / 3600
            out.setdefault(parts[2], lat if m.group(1) == "+" else -lat)
    return out


def _latitude_problems(b: Building) -> list[str]:
    """The latitude against the hemisphere of the building's time zone (a sign slip puts the sun in the north)."""
    if not -90 <= b.latitude <= 90 or abs(b.latitude) < 10:
        return []
    city = _zone_latitudes().get(b.timezone)
    if city is None or abs(city) < 15 or (city > 0) == (b.latitude > 0):
        return []
    here, there = ("north", "south") if city > 0 else ("south", "north")
    return [
        f"latitude {b.latitude:g}° is in the {there}ern hemisphere, but the time zone {b.timezone} is "
        f"{here} of the equator (about {city:.0f}°); is the sign wrong ({-b.latitude:g}: south of the equator "
        "is negative)? the sun, the facades' irradiance and the seasons depend on it"
    ]


def _validate_ahus(b: Building) -> list[str]:
    """Problems of the air handlers and of the boxes' ``ahu`` references."""
    problems = []
    names = [a.name for a in b.ahus]
    for n in sorted({n for n in names if names.count(n) > 1}):
        problems.append(f"air handler name {n!r} is used more than once in [[ahus]]")
    for a in b.ahus:
        if not _valid_name(a.name):
            problems.append(f"air handler name {a.name!r} must be non-empty and contain no spaces, dots or brackets")
        if a.T_supply_max is not None and not 15.0 <= a.T_supply_max <= 80.0:
            problems.append(
                f"air handler {a.name}: T_supply_max = {a.T_supply_max:g} °C is not a plausible heating limit of "
                "supply/discharge air (15..80 °C); is it in °F?"
            )
        if not any(v.ahu == a.name for v in b.vavs):
            problems.append(f'air handler {a.name}: no VAV box names it (set ahu = "{a.name}" on its [[vavs]])')
    for v in b.vavs:
        if v.ahu is None and b.ahus:
            problems.append(
                f"VAV {v.name}: no 'ahu' although [[ahus]] are declared; set ahu to one of {', '.join(names)}"
            )
        elif v.ahu is not None and v.ahu not in names:
            declared = f"declared units are {', '.join(names)}" if names else "no [[ahus]] are declared"
            problems.append(f"VAV {v.name}: ahu {v.ahu!r} is not a declared air handler ({declared})")
    return problems


def _validate_columns(b: Building) -> list[str]:
    """Two canonical quantities mapped to one file column are a problem (one would silently copy the other)."""
    used: dict = {}
    implicit = {"T_supply"} if b.ahus and "T_supply" not in b.columns else set()  # may be a unit's own column
    names = dict.fromkeys(c for c in ["time", *b.expected_columns(), *b.columns] if c not in implicit)
    names.update(dict.fromkeys(f"{q}_{a.name}" for a in b.ahus for q in a.columns))
    for canonical in names:
        used.setdefault(b.column_for(canonical), []).append(canonical)
    return [
        f"[columns]: {', '.join(names)} all map to the file column {col!r}; each quantity needs its own column"
        for col, names in used.items()
        if len(names) > 1
    ]


def validate_building(b: Building) -> list[str]:
    """Every problem of a :class:`Building`, as readable strings (empty if fine)."""
    problems = []
    if not -90 <= b.latitude <= 90:
        problems.append(f"latitude {b.latitude} is outside -90..90")
    if not -180 <= b.longitude <= 180:
        problems.append(f"longitude {b.longitude} is outside -180..180")
    for key in ("timezone", "data_timezone"):
        value = getattr(b, key)
        if value is not None and not valid_timezone(value):
            problems.append(f"{key} {value!r} is not a known IANA time zone (e.g. 'America/Los_Angeles' or 'UTC')")
    problems += _longitude_problems(b) + _latitude_problems(b)
    if not b.zones:
        problems.append("no zones defined")
    if not b.vavs:
        problems.append("no VAV boxes defined")
    names = [z.name for z in b.zones]
    for n in {n for n in names if names.count(n) > 1}:
        problems.append(f"zone name {n!r} is used more than once")
    zone_set = set(names)
    for z in b.zones:
        if z.name == "supply" or z.name.startswith("supply_") or z.name == "out":
            problems.append(f"zone name {z.name!r} is reserved (T_{z.name} is an air handler or outdoor column)")
        if not _valid_name(z.name):
            problems.append(f"zone name {z.name!r} must be non-empty and contain no spaces, dots or brackets")
        if not z.area > 0:
            problems.append(f"zone {z.name}: area must be > 0 m2, got {z.area}")
        if not z.volume > 0:
            problems.append(f"zone {z.name}: volume must be > 0 m3, got {z.volume}")
        elif z.area > 0 and z.volume / z.area < MIN_ZONE_HEIGHT:
            problems.append(
                f"zone {z.name}: volume / area = {z.volume:g} m3 / {z.area:g} m2 = {z.volume / z.area:.2g} m of "
                f"ceiling height, below {MIN_ZONE_HEIGHT:g} m: is the area in ft2 (1 m2 = 10.76 ft2) or the volume "
                "in another unit? area is in m2, volume in m3"
            )
        for a in z.adjacent:
            if a not in zone_set:
                problems.append(f"zone {z.name}: adjacent zone {a!r} is not a zone of this building")
            elif a == z.name:
                problems.append(f"zone {z.name}: lists itself as adjacent")
        for f in z.facades:
            if f.orientation not in ORIENTATIONS:
                problems.append(f"zone {z.name}: facade orientation {f.orientation!r} is not one of N/E/S/W")
            if f.window_area < 0 or f.wall_area < 0:
                problems.append(f"zone {z.name}: facade {f.orientation} has a negative area")
    volumes = {z.name: z.volume for z in b.zones}
    vnames = [v.name for v in b.vavs]
    for n in {n for n in vnames if vnames.count(n) > 1}:
        problems.append(f"VAV name {n!r} is used more than once")
    for v in b.vavs:
        if v.zone not in zone_set:
            problems.append(f"VAV {v.name}: serves zone {v.zone!r}, which is not a zone of this building")
        if not _valid_name(v.name):
            problems.append(f"VAV name {v.name!r} must be non-empty and contain no spaces, dots or brackets")
        if not (0 <= v.m_min <= v.m_max):
            problems.append(f"VAV {v.name}: need 0 <= m_min <= m_max, got m_min={v.m_min}, m_max={v.m_max} kg/s")
        if not v.m_max > 0:
            problems.append(f"VAV {v.name}: m_max must be > 0 kg/s (a box that can deliver no air), got {v.m_max}")
        elif v.m_max > M_MAX_LIMIT:
            volume = volumes.get(v.zone, 0.0)
            ach = v.m_max / _RHO_AIR * 3600.0 / volume if volume > 0 else float("inf")
            if ach > ACH_LIMIT:
                problems.append(
                    f"VAV {v.name}: m_max = {v.m_max:g} kg/s is more than any VAV box delivers (> {M_MAX_LIMIT:g} "
                    f"kg/s, about 16 000 cfm) and would renew the air of zone {v.zone} ({volume:g} m3) {ach:.0f} times "
                    f"an hour (> {ACH_LIMIT:g}); is the value in kg/s?"
                )
    problems += _validate_ahus(b)
    problems += _validate_columns(b)
    for z in b.zones:
        if z.name in zone_set and not any(v.zone == z.name for v in b.vavs) and b.vavs:
            problems.append(f"zone {z.name}: no VAV box serves it")
    snames = [s.name for s in b.seasons]
    for n in {n for n in snames if snames.count(n) > 1}:
        problems.append(f"season name {n!r} is used more than once")
    for s in b.seasons:
        for which in ("start", "end"):
            if not _valid_md(getattr(s, which)):
                problems.append(f"season {s.name}: {which} {getattr(s, which)!r} is not a month-day like '09-01'")
    if not problems:
        # every calendar day must belong to exactly one season
        day = _dt.date(2001, 1, 1)
        for _ in range(365):
            hits = [s.name for s in b.seasons if s.contains(day.month, day.day)]
            if len(hits) != 1:
                what = "no season" if not hits else f"several seasons ({', '.join(hits)})"
                problems.append(f"seasons: {day:%m-%d} belongs to {what}; every day needs exactly one")
                break
            day += _dt.timedelta(days=1)
    return problems
