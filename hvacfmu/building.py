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

    [[vavs]]
    name = "VAV_NW_1"
    zone = "NW"
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
    "m_*" = "cfm"
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import fnmatch
import hashlib
from pathlib import Path
from typing import Any

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

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
    """A VAV box serving one zone; airflow limits ``m_min``, ``m_max`` [kg/s]."""

    name: str
    zone: str
    m_min: float = 0.0
    m_max: float = 1.0


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
    columns: dict = dataclasses.field(default_factory=dict)
    units: dict = dataclasses.field(default_factory=dict)
    physics: dict = dataclasses.field(default_factory=dict)
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
        import numpy as np

        M = np.zeros((len(self.zones), len(self.vavs)))
        idx = {n: i for i, n in enumerate(self.zone_names)}
        for j, v in enumerate(self.vavs):
            M[idx[v.zone], j] = 1.0
        return M

    def area_weights(self):
        """Zone floor areas normalised to sum to one (for the lumped model)."""
        import numpy as np

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
        """Name of the data-file column holding canonical quantity ``canonical``."""
        return self.columns.get(canonical, canonical)

    def unit_for(self, canonical: str) -> str | None:
        """Declared unit of canonical column ``canonical`` (exact name beats glob), or None."""
        if canonical in self.units:
            return self.units[canonical]
        for pattern, unit in self.units.items():
            if fnmatch.fnmatchcase(canonical, pattern):
                return unit
        return None

    def expected_columns(self) -> dict[str, bool]:
        """Canonical columns a measurement file should have -> whether required."""
        cols = {f"T_{z}": True for z in self.zone_names}
        cols.update({f"m_{v}": True for v in self.vav_names})
        cols.update({"T_supply": True, "T_out": True, "ghi": False, "excitation": False})
        cols.update({f"I_{o}": False for o in ORIENTATIONS})
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
            "vavs": [dataclasses.asdict(v) for v in self.vavs],
            "seasons": [dataclasses.asdict(s) for s in self.seasons],
        }
        if self.columns:
            d["columns"] = dict(self.columns)
        if self.units:
            d["units"] = dict(self.units)
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
PHYSICS_KEYS = ("materials", "constructions", "windows", "elements", "physics")


def _as_float(value, what, problems):
    try:
        return float(value)
    except (TypeError, ValueError):
        problems.append(f"{what}: expected a number, got {value!r}")
        return float("nan")


def building_from_dict(d: dict, source: str | None = None, sha256: str | None = None) -> Building:
    """Build a :class:`Building` from a parsed TOML mapping, reporting every problem."""
    problems: list[str] = []
    known = {"name", "latitude", "longitude", "timezone", "zones", "vavs", "seasons", "columns", "units"}
    known |= set(PHYSICS_KEYS)
    for key in d:
        if key not in known:
            problems.append(f"unknown top-level key {key!r} (known: {sorted(known)})")
    for key in ("name", "latitude", "longitude", "timezone", "zones", "vavs"):
        if key not in d:
            problems.append(f"missing required key {key!r}")
    zones = []
    for i, z in enumerate(d.get("zones", [])):
        where = f"zones[{i}] ({z.get('name', '?')})"
        for key in ("name", "area", "volume"):
            if key not in z:
                problems.append(f"{where}: missing {key!r}")
        facades = []
        for j, f in enumerate(z.get("facades", [])):
            if "orientation" not in f:
                problems.append(f"{where}.facades[{j}]: missing 'orientation'")
                continue
            facades.append(
                Facade(
                    str(f["orientation"]),
                    _as_float(f.get("window_area", 0.0), f"{where}.facades[{j}].window_area", problems),
                    _as_float(f.get("wall_area", 0.0), f"{where}.facades[{j}].wall_area", problems),
                )
            )
        zones.append(
            Zone(
                str(z.get("name", f"zone{i}")),
                _as_float(z.get("area", float("nan")), f"{where}.area", problems),
                _as_float(z.get("volume", float("nan")), f"{where}.volume", problems),
                tuple(facades),
                tuple(str(a) for a in z.get("adjacent", [])),
            )
        )
    vavs = []
    for i, v in enumerate(d.get("vavs", [])):
        where = f"vavs[{i}] ({v.get('name', '?')})"
        for key in ("name", "zone"):
            if key not in v:
                problems.append(f"{where}: missing {key!r}")
        vavs.append(
            Vav(
                str(v.get("name", f"vav{i}")),
                str(v.get("zone", "")),
                _as_float(v.get("m_min", 0.0), f"{where}.m_min", problems),
                _as_float(v.get("m_max", 1.0), f"{where}.m_max", problems),
            )
        )
    seasons = tuple(
        Season(str(s.get("name")), str(s.get("start")), str(s.get("end"))) for s in d.get("seasons", [])
    ) or tuple(Season(*s) for s in DEFAULT_SEASONS)
    physics = {k: d[k] for k in PHYSICS_KEYS if k in d}
    if problems:
        raise BuildingError(problems_message(f"Invalid building file {source or ''}".strip(), problems))
    return Building(
        name=str(d["name"]),
        latitude=_as_float(d["latitude"], "latitude", problems),
        longitude=_as_float(d["longitude"], "longitude", problems),
        timezone=str(d["timezone"]),
        zones=tuple(zones),
        vavs=tuple(vavs),
        seasons=seasons,
        columns=dict(d.get("columns", {})),
        units=dict(d.get("units", {})),
        physics=physics,
        source=source,
        sha256=sha256,
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


def validate_building(b: Building) -> list[str]:
    """Every problem of a :class:`Building`, as readable strings (empty if fine)."""
    problems = []
    if not -90 <= b.latitude <= 90:
        problems.append(f"latitude {b.latitude} is outside -90..90")
    if not -180 <= b.longitude <= 180:
        problems.append(f"longitude {b.longitude} is outside -180..180")
    try:
        import zoneinfo

        zoneinfo.ZoneInfo(b.timezone)
    except Exception:  # noqa: BLE001 - any failure means an unusable zone name
        problems.append(f"timezone {b.timezone!r} is not a known IANA time zone (e.g. 'America/Los_Angeles')")
    if not b.zones:
        problems.append("no zones defined")
    if not b.vavs:
        problems.append("no VAV boxes defined")
    names = [z.name for z in b.zones]
    for n in {n for n in names if names.count(n) > 1}:
        problems.append(f"zone name {n!r} is used more than once")
    zone_set = set(names)
    for z in b.zones:
        if not z.name or any(c in z.name for c in " .[]"):
            problems.append(f"zone name {z.name!r} must be non-empty and contain no spaces, dots or brackets")
        if not z.area > 0:
            problems.append(f"zone {z.name}: area must be > 0 m2, got {z.area}")
        if not z.volume > 0:
            problems.append(f"zone {z.name}: volume must be > 0 m3, got {z.volume}")
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
    vnames = [v.name for v in b.vavs]
    for n in {n for n in vnames if vnames.count(n) > 1}:
        problems.append(f"VAV name {n!r} is used more than once")
    for v in b.vavs:
        if v.zone not in zone_set:
            problems.append(f"VAV {v.name}: serves zone {v.zone!r}, which is not a zone of this building")
        if not (0 <= v.m_min <= v.m_max):
            problems.append(f"VAV {v.name}: need 0 <= m_min <= m_max, got m_min={v.m_min}, m_max={v.m_max} kg/s")
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
