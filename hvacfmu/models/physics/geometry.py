"""Parse and validate the physics tables of a building file (Model B input).

The tables follow the README's "Building file" section: ``[[materials]]``,
``[[constructions]]``, ``[[windows]]``, ``[[elements]]`` and ``[physics]``. They
are kept as a raw mapping in :attr:`hvacfmu.building.Building.physics` and
checked here; :func:`parse_physics` reports every problem at once as a
:class:`~hvacfmu.errors.BuildingError`.

Instead of the four tables, a building file may name a construction template
(top-level ``construction_template = "..."``, see
:mod:`hvacfmu.models.physics.templates`); ``[physics]`` then overrides the
template's values.

Schema extensions (optional keys, backwards compatible), all in ``[physics]``:

- ``furniture_capacity`` [J/(K m2)]: heat capacity per floor area lumped into
  each zone's air node (default :data:`DEFAULT_FURNITURE_CAPACITY`).
- ``max_layer_thickness`` [m]: massive layers thicker than this are split into
  several nodes (default :data:`DEFAULT_MAX_LAYER_THICKNESS`).
- ``solar_air_fraction`` [-]: share of the solar gain transmitted by windows
  that heats the zone air directly; the rest is absorbed at the zone's floor
  surfaces (default 0: all absorbed at the floor, as transmitted beam
  radiation mostly is).
"""

from __future__ import annotations

import dataclasses
import math
import warnings

from ...building import ORIENTATIONS, Building
from ...errors import BuildingError, HvacfmuWarning, problems_message

#: The five physical parameters of the paper, in order (names used in ``[physics].nominal``).
PARAM_NAMES = ("U_win", "gamma_interior_wall", "gamma_exterior_wall", "gamma_floor", "gamma_ceiling")
#: Film kind in a construction's ``films`` -> parameter name (identified films).
FILM_PARAMS = {
    "interior_wall": "gamma_interior_wall",
    "exterior_wall": "gamma_exterior_wall",
    "floor": "gamma_floor",
    "ceiling": "gamma_ceiling",
}
#: Film kinds with no identified parameter.
FIXED_FILMS = ("ambient", "none")
#: Element sides that are not zones.
BOUNDARIES = ("ambient", "ground", "adiabatic")

#: Density of air [kg/m3] and specific heat of air at constant pressure [J/(kg K)].
RHO_AIR = 1.2
CP_AIR = 1005.0
#: Default heat capacity of furniture lumped into the air node [J/(K m2) of floor area].
DEFAULT_FURNITURE_CAPACITY = 3000.0
#: Thickest layer [m] a construction may declare; above it the value is in another unit (mm, cm).
MAX_PLAUSIBLE_LAYER_THICKNESS = 2.0
#: Default maximum thickness of one node of a massive layer [m].
DEFAULT_MAX_LAYER_THICKNESS = 0.02

_WARNED: set = set()
_MATERIAL_KEYS = {"name", "conductivity", "density", "specific_heat", "r_value"}
_CONSTRUCTION_KEYS = {"name", "layers", "films"}
_LAYER_KEYS = {"material", "thickness"}
_WINDOW_KEYS = {"name", "zone", "orientation", "area", "u_value", "shgc"}
_ELEMENT_KEYS = {"name", "construction", "area", "side1", "side2", "orientation"}
_PHYSICS_KEYS = {
    "ambient_film",
    "ground_temperature",
    "internal_mass",
    "nominal",
    "furniture_capacity",
    "gain_days",
    "max_layer_thickness",
    "solar_air_fraction",
}


@dataclasses.dataclass(frozen=True)
class Material:
    """A material: massive (``conductivity`` [W/(m K)], ``density`` [kg/m3],
    ``specific_heat`` [J/(kg K)]) or massless (``r_value`` [m2 K/W])."""

    name: str
    conductivity: float = math.nan
    density: float = math.nan
    specific_heat: float = math.nan
    r_value: float = math.nan

    @property
    def massless(self) -> bool:
        return not math.isnan(self.r_value)


@dataclasses.dataclass(frozen=True)
class Layer:
    """A layer of a construction: ``material`` and ``thickness`` [m]."""

    material: Material
    thickness: float


@dataclasses.dataclass(frozen=True)
class Construction:
    """Ordered layers from side 1 to side 2 and the film kind on each side."""

    name: str
    layers: tuple[Layer, ...]
    films: tuple[str, str]


@dataclasses.dataclass(frozen=True)
class Window:
    """A window of ``zone``: ``area`` [m2], ``u_value`` [W/(m2 K)], ``shgc`` [-]."""

    name: str
    zone: str
    orientation: str
    area: float
    u_value: float
    shgc: float = 0.0


@dataclasses.dataclass(frozen=True)
class Element:
    """A building element of ``construction`` with ``area`` [m2] between ``side1`` and ``side2``."""

    name: str
    construction: Construction
    area: float
    side1: str
    side2: str
    orientation: str | None = None


@dataclasses.dataclass(frozen=True)
class PhysicsSpec:
    """The validated physics description of a building.

    Attributes
    ----------
    zones : tuple of str
    zone_area, zone_volume : dict zone -> float [m2], [m3]
    vav_zone : tuple of str
        Zone of each VAV box, in the building's VAV order.
    materials, constructions : dict name -> Material / Construction
    windows, elements : tuple
    ambient_film : float [W/(m2 K)]
    ground_temperature : float or None [°C]
    internal_mass : float [J/(K m2)] (0: no internal-mass node)
    furniture_capacity : float [J/(K m2)]
    max_layer_thickness : float [m]
    nominal : dict parameter name -> float
    """

    zones: tuple
    zone_area: dict
    zone_volume: dict
    vav_zone: tuple
    materials: dict
    constructions: dict
    windows: tuple
    elements: tuple
    ambient_film: float
    ground_temperature: float | None
    internal_mass: float
    furniture_capacity: float
    max_layer_thickness: float
    nominal: dict
    solar_air_fraction: float = 0.0

    @property
    def has_ground(self) -> bool:
        return any("ground" in (e.side1, e.side2) for e in self.elements)


def _num(value, what, problems, positive=False, nonneg=False):
    """A finite float from ``value``; records a problem (and returns nan) otherwise."""
    if isinstance(value, bool):
        problems.append(f"{what}: expected a number, got {value!r}")
        return math.nan
    try:
        x = float(value)
    except (TypeError, ValueError):
        problems.append(f"{what}: expected a number, got {value!r}")
        return math.nan
    if not math.isfinite(x):
        problems.append(f"{what}: must be finite, got {value!r}")
    elif positive and not x > 0:
        problems.append(f"{what}: must be > 0, got {x:g}")
    elif nonneg and x < 0:
        problems.append(f"{what}: must be >= 0, got {x:g}")
    return x


def _table(phys, key, problems):
    rows = phys.get(key, [])
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        problems.append(f"[[{key}]] must be an array of tables")
        return []
    return rows


def _unknown_keys(row, allowed, where, problems):
    extra = sorted(set(row) - allowed)
    if extra:
        problems.append(f"{where}: unknown key(s) {extra} (known: {sorted(allowed)})")


def _names(rows, kind, problems, warn_duplicates=False):
    names = [str(r.get("name", "")) for r in rows]
    for i, n in enumerate(names):
        if not n:
            problems.append(f"{kind}[{i}]: missing 'name'")
    dups = sorted({n for n in names if n and names.count(n) > 1})
    if dups and warn_duplicates:
        # elements and windows are never referenced by name: keep them all, but say so (once per process)
        msg = f"{kind} names used more than once: {dups} (all are kept; check for duplicated entries)"
        if msg not in _WARNED:
            _WARNED.add(msg)
            warnings.warn(msg, HvacfmuWarning, stacklevel=3)
    else:
        for n in dups:
            problems.append(f"{kind} name {n!r} is used more than once")


def physics_problems(building: Building) -> list[str]:
    """Every problem of ``building``'s physics tables (empty list if usable)."""
    try:
        parse_physics(building)
    except BuildingError as exc:
        lines = str(exc).splitlines()
        # a list of problems under a heading ("  - ..." lines), or one problem on one line (a template's refusal)
        return [line[4:] for line in lines[1:]] if len(lines) > 1 else lines
    return []


def parse_physics(building: Building, **overrides) -> PhysicsSpec:
    """Validate the physics tables of ``building`` and return a :class:`PhysicsSpec`.

    Parameters
    ----------
    building : Building
    **overrides
        ``furniture_capacity`` [J/(K m2)], ``max_layer_thickness`` [m],
        ``internal_mass`` [J/(K m2)], ``solar_air_fraction`` [-]: replace the
        ``[physics]`` values.

    Raises
    ------
    BuildingError
        Listing every problem found (unknown zones, constructions or materials,
        non-positive thicknesses, conductivities or areas, zones without
        elements, VAV boxes without a zone, ...).
    """
    phys = dict(building.physics or {})
    if "construction_template" in phys:
        from .templates import expand_template

        phys = expand_template(building, phys)
    problems: list[str] = []
    where_b = f"building {building.source or building.name!r}"
    if not phys.get("elements") or not phys.get("constructions"):
        problems.append(
            "no [[elements]] or [[constructions]] tables: the physics model needs the building's "
            "materials, constructions and elements (see README, 'Building file'), or a top-level "
            "construction_template = one of concrete_slab_office_1990s, light_steel_frame, heavy_masonry"
        )
    zones = building.zone_names
    zone_set = set(zones)
    for v in building.vavs:
        if v.zone not in zone_set:
            problems.append(f"VAV {v.name}: serves zone {v.zone!r}, which is not a zone of this building")

    p = _physics_values(phys, overrides, problems)
    materials = _parse_materials(phys, problems)
    constructions = _parse_constructions(phys, materials, problems)
    windows = _parse_windows(phys, zones, problems)
    elements = _parse_elements(phys, zones, constructions, p["ambient_film"], p["ground_temperature"], problems)

    if problems:
        raise BuildingError(problems_message(f"Invalid physics description of {where_b}", problems))
    return PhysicsSpec(
        zones=zones,
        zone_area={z.name: z.area for z in building.zones},
        zone_volume={z.name: z.volume for z in building.zones},
        vav_zone=tuple(v.zone for v in building.vavs),
        materials=materials,
        constructions=constructions,
        windows=tuple(windows),
        elements=tuple(elements),
        **p,
    )


def _physics_values(phys: dict, overrides: dict, problems: list) -> dict:
    """The ``[physics]`` table's scalars and nominal parameters (``overrides`` first), as PhysicsSpec keywords."""
    p = phys.get("physics", {})
    if not isinstance(p, dict):
        problems.append("[physics] must be a table")
        p = {}
    _unknown_keys(p, _PHYSICS_KEYS, "[physics]", problems)
    ambient_film = (
        _num(p.get("ambient_film", math.nan), "[physics].ambient_film [W/(m2 K)]", problems, positive=True)
        if "ambient_film" in p
        else math.nan
    )
    ground_temperature = (
        _num(p["ground_temperature"], "[physics].ground_temperature [°C]", problems)
        if "ground_temperature" in p
        else None
    )
    internal_mass = _num(
        overrides.get("internal_mass", p.get("internal_mass", 0.0)),
        "[physics].internal_mass [J/(K m2)]",
        problems,
        nonneg=True,
    )
    furniture = overrides.get("furniture_capacity")
    if furniture is None:
        furniture = p.get("furniture_capacity", DEFAULT_FURNITURE_CAPACITY)
    furniture = _num(furniture, "[physics].furniture_capacity [J/(K m2)]", problems, nonneg=True)
    max_thick = overrides.get("max_layer_thickness")
    if max_thick is None:
        max_thick = p.get("max_layer_thickness", DEFAULT_MAX_LAYER_THICKNESS)
    max_thick = _num(max_thick, "max_layer_thickness [m]", problems, positive=True)
    saf = overrides.get("solar_air_fraction")
    if saf is None:
        saf = p.get("solar_air_fraction", 0.0)
    saf = _num(saf, "[physics].solar_air_fraction [-]", problems, nonneg=True)
    if saf > 1:
        problems.append(f"[physics].solar_air_fraction must lie in [0, 1], got {saf:g}")
    nominal_raw = p.get("nominal", {})
    nominal = {}
    if not isinstance(nominal_raw, dict):
        problems.append("[physics].nominal must be a table of the five parameters")
        nominal_raw = {}
    for name in PARAM_NAMES:
        if name not in nominal_raw:
            problems.append(f"[physics].nominal: missing {name!r} (need {list(PARAM_NAMES)})")
        else:
            nominal[name] = _num(nominal_raw[name], f"[physics].nominal.{name}", problems, positive=True)
    extra = sorted(set(nominal_raw) - set(PARAM_NAMES))
    if extra:
        problems.append(f"[physics].nominal: unknown parameter(s) {extra} (known: {list(PARAM_NAMES)})")
    return {
        "ambient_film": ambient_film,
        "ground_temperature": ground_temperature,
        "internal_mass": internal_mass,
        "furniture_capacity": furniture,
        "max_layer_thickness": max_thick,
        "nominal": nominal,
        "solar_air_fraction": saf,
    }


def _parse_materials(phys: dict, problems: list) -> dict:
    """``[[materials]]``: name -> :class:`Material` (massless with ``r_value``)."""
    mat_rows = _table(phys, "materials", problems)
    _names(mat_rows, "materials", problems)
    materials = {}
    for i, r in enumerate(mat_rows):
        name = str(r.get("name", f"#{i}"))
        where = f"material {name}"
        _unknown_keys(r, _MATERIAL_KEYS, where, problems)
        if "r_value" in r:
            if any(k in r for k in ("conductivity", "density", "specific_heat")):
                problems.append(
                    f"{where}: give either r_value (massless) or conductivity/density/specific_heat, not both"
                )
            materials[name] = Material(
                name, r_value=_num(r["r_value"], f"{where}: r_value [m2 K/W]", problems, positive=True)
            )
        else:
            vals = {}
            for key, unit in (("conductivity", "W/(m K)"), ("density", "kg/m3"), ("specific_heat", "J/(kg K)")):
                if key not in r:
                    problems.append(f"{where}: missing {key!r} [{unit}] (or give r_value for a massless layer)")
                    vals[key] = math.nan
                else:
                    vals[key] = _num(r[key], f"{where}: {key} [{unit}]", problems, positive=True)
            materials[name] = Material(name, **vals)
    return materials


def _parse_constructions(phys: dict, materials: dict, problems: list) -> dict:
    """``[[constructions]]``: name -> :class:`Construction` (layers of known materials, two film kinds)."""
    con_rows = _table(phys, "constructions", problems)
    _names(con_rows, "constructions", problems)
    constructions = {}
    film_kinds = tuple(FILM_PARAMS) + FIXED_FILMS
    for i, r in enumerate(con_rows):
        name = str(r.get("name", f"#{i}"))
        where = f"construction {name}"
        _unknown_keys(r, _CONSTRUCTION_KEYS, where, problems)
        layers = []
        rows = r.get("layers", [])
        if not isinstance(rows, list) or not rows:
            problems.append(f"{where}: needs a non-empty 'layers' list")
            rows = []
        for j, lay in enumerate(rows):
            lw = f"{where}: layers[{j}]"
            if not isinstance(lay, dict):
                problems.append(f"{lw}: must be a table {{material = ..., thickness = ...}}")
                continue
            _unknown_keys(lay, _LAYER_KEYS, lw, problems)
            mname = str(lay.get("material", ""))
            mat = materials.get(mname)
            if mat is None:
                problems.append(f"{lw}: unknown material {mname!r} (materials: {sorted(materials)})")
            if mat is not None and mat.massless and "thickness" not in lay:
                thick = 0.0
            elif "thickness" not in lay:
                problems.append(f"{lw}: missing 'thickness' [m]")
                thick = math.nan
            else:
                thick = _num(
                    lay["thickness"],
                    f"{lw}: thickness [m]",
                    problems,
                    positive=not (mat is not None and mat.massless),
                    nonneg=True,
                )
                if thick > MAX_PLAUSIBLE_LAYER_THICKNESS:
                    problems.append(
                        f"{lw}: thickness [m] = {thick:g} m is thicker than any building layer "
                        f"(> {MAX_PLAUSIBLE_LAYER_THICKNESS:g} m): is it in mm ({thick / 1000:g} m) or cm "
                        f"({thick / 100:g} m)? thicknesses are in m"
                    )
            if mat is not None:
                layers.append(Layer(mat, thick))
        films = r.get("films", ["none", "none"])
        if not isinstance(films, list) or len(films) != 2:
            problems.append(f"{where}: 'films' must list two film kinds (side 1, side 2), got {films!r}")
            films = ["none", "none"]
        for f in films:
            if f not in film_kinds:
                problems.append(f"{where}: film {f!r} is not one of {list(film_kinds)}")
        constructions[name] = Construction(name, tuple(layers), (str(films[0]), str(films[1])))
    return constructions


def _parse_windows(phys: dict, zones: tuple, problems: list) -> list:
    """``[[windows]]`` of known zones and orientations."""
    zone_set = set(zones)
    win_rows = _table(phys, "windows", problems)
    _names(win_rows, "windows", problems, warn_duplicates=True)
    windows = []
    for i, r in enumerate(win_rows):
        name = str(r.get("name", f"#{i}"))
        where = f"window {name}"
        _unknown_keys(r, _WINDOW_KEYS, where, problems)
        zone = str(r.get("zone", ""))
        if zone not in zone_set:
            problems.append(f"{where}: unknown zone {zone!r} (zones: {list(zones)})")
        orient = str(r.get("orientation", ""))
        if orient not in ORIENTATIONS:
            problems.append(f"{where}: orientation {orient!r} is not one of {list(ORIENTATIONS)}")
        area = _num(r.get("area", math.nan), f"{where}: area [m2]", problems, positive=True)
        u = _num(r.get("u_value", math.nan), f"{where}: u_value [W/(m2 K)]", problems, positive=True)
        shgc = _num(r.get("shgc", 0.0), f"{where}: shgc [-]", problems, nonneg=True)
        if shgc > 1:
            problems.append(f"{where}: shgc must lie in [0, 1], got {shgc:g}")
        windows.append(Window(name, zone, orient, area, u, shgc))
    return windows


def _parse_elements(phys, zones, constructions, ambient_film, ground_temperature, problems) -> list:
    """``[[elements]]``: walls, floors, ceilings between zones and boundaries; every zone must be touched."""
    zone_set = set(zones)
    el_rows = _table(phys, "elements", problems)
    _names(el_rows, "elements", problems, warn_duplicates=True)
    elements = []
    touched = set()
    sides_ok = zone_set | set(BOUNDARIES)
    for i, r in enumerate(el_rows):
        name = str(r.get("name", f"#{i}"))
        where = f"element {name}"
        _unknown_keys(r, _ELEMENT_KEYS, where, problems)
        cname = str(r.get("construction", ""))
        con = constructions.get(cname)
        if con is None:
            problems.append(f"{where}: unknown construction {cname!r} (constructions: {sorted(constructions)})")
        area = _num(r.get("area", math.nan), f"{where}: area [m2]", problems, positive=True)
        sides = []
        for key in ("side1", "side2"):
            s = str(r.get(key, ""))
            if s not in sides_ok:
                problems.append(f"{where}: {key} {s!r} is neither a zone ({list(zones)}) nor one of {list(BOUNDARIES)}")
            sides.append(s)
        if all(s in sides_ok for s in sides) and not any(s in zone_set for s in sides):
            problems.append(f"{where}: touches no zone (side1={sides[0]!r}, side2={sides[1]!r})")
        touched.update(s for s in sides if s in zone_set)
        orient = r.get("orientation")
        if orient is not None and str(orient) not in ORIENTATIONS:
            problems.append(f"{where}: orientation {orient!r} is not one of {list(ORIENTATIONS)}")
        if con is not None:
            if "ambient" in sides and math.isnan(ambient_film) and "ambient" in con.films:
                problems.append(f"{where}: faces ambient with an 'ambient' film but [physics].ambient_film is missing")
            if "ground" in sides and ground_temperature is None:
                problems.append(f"{where}: faces the ground but [physics].ground_temperature [°C] is missing")
            elements.append(Element(name, con, area, sides[0], sides[1], None if orient is None else str(orient)))
    for z in zones:
        if z not in touched:
            problems.append(f"zone {z}: no building element touches it (each zone needs walls, floor or ceiling)")
    return elements
