"""Construction templates: Model B's physics tables from a building's zones, facades, adjacency and one name.

A building file may name a template instead of layer-by-layer tables::

    construction_template = "concrete_slab_office_1990s"

    [physics]                      # optional: overrides (ground_temperature, nominal, ...)

The template supplies ``[[materials]]``, ``[[constructions]]``, ``[[windows]]``
and ``[[elements]]`` (:func:`expand_template`); the zones' ``area``, ``volume``,
``facades`` (orientation, window and opaque wall area) and ``adjacent`` lists
place them:

- each facade: a window of its ``window_area`` and an exterior wall of its
  ``wall_area`` (when the opaque area is not given, 1.5 times the window area);
- each zone: a floor and a ceiling of its floor area, against ``adiabatic``
  (a mid-height storey: the storeys above and below are conditioned alike, so
  no net heat crosses the slab's mid-plane; each side holds half the slab);
- each adjacent pair: a partition of height ``volume / area`` times the side of
  a square of the smaller zone's area (the building file gives no wall lengths:
  an estimate, stated in ``meta``).

Values are typical, rounded figures, not the properties of any particular
building; the identification (:func:`~hvacfmu.models.physics.fit_physics`)
adjusts the film coefficients and window U-value around them.

Sources
-------
- Material properties (conductivity, density, specific heat): ASHRAE Handbook —
  Fundamentals, ch. 26 "Heat, Air, and Moisture Control in Building Assemblies —
  Material Properties" (table of typical properties of building and insulating
  materials), ch. 27 "... — Examples" (typical wall and floor assemblies).
- Window U-values and solar heat gain coefficients: ASHRAE Handbook —
  Fundamentals, ch. 15 "Fenestration" (typical whole-window values of the
  glazing and frame types named below).
- Surface film coefficients: ISO 6946 surface resistances (interior 0.13 m²K/W
  for horizontal heat flow, 0.10 upwards, 0.17 downwards; exterior 0.04).
- Thermal-mass classes: ISO 13790:2008 table 12, effective heat capacity per
  floor area: very light 80, light 110, medium 165, heavy 260, very heavy
  370 kJ/(m²K) (ISO 13790 was replaced by EN ISO 52016-1:2017, which keeps the
  same idea of mass classes). ``mass_class`` names the class a template is
  meant to represent; it is documentation, not an input of the model (the
  layers are).
"""

from __future__ import annotations

import math

from ...errors import BuildingError

#: Materials: conductivity [W/(m K)], density [kg/m3], specific heat [J/(kg K)]; or r_value [m2 K/W].
MATERIALS = {
    "concrete": {"conductivity": 1.7, "density": 2300.0, "specific_heat": 880.0},
    "precast_concrete": {"conductivity": 1.7, "density": 2300.0, "specific_heat": 880.0},
    "lightweight_concrete": {"conductivity": 0.5, "density": 1300.0, "specific_heat": 880.0},
    "brick": {"conductivity": 0.8, "density": 1800.0, "specific_heat": 840.0},
    "plaster": {"conductivity": 0.7, "density": 1600.0, "specific_heat": 840.0},
    "gypsum_board": {"conductivity": 0.16, "density": 700.0, "specific_heat": 1090.0},
    "mineral_wool": {"conductivity": 0.04, "density": 30.0, "specific_heat": 840.0},
    "steel_stud_insulated_cavity": {"r_value": 1.2},  # 90 mm cavity batts bridged by steel studs (effective)
    "air_gap": {"r_value": 0.17},
    "suspended_ceiling_plenum": {"r_value": 0.16},
    "carpet": {"r_value": 0.1},
}

#: name -> description, mass class, constructions (layers from the room side outwards for walls,
#: from the room down/up for floor/ceiling halves), window U [W/(m2 K)] and SHGC [-], internal mass [J/(K m2)].
TEMPLATES = {
    "concrete_slab_office_1990s": {
        "description": "1990s office: precast concrete panels with 50 mm mineral wool, 200 mm concrete floor "
        "slabs with suspended ceilings, gypsum partitions, double glazing in aluminium frames",
        "mass_class": "heavy",
        "exterior_wall": [("gypsum_board", 0.013), ("mineral_wool", 0.05), ("precast_concrete", 0.15)],
        "partition": [("gypsum_board", 0.013), ("air_gap", None), ("gypsum_board", 0.013)],
        "floor": [("carpet", None), ("concrete", 0.10)],
        "ceiling": [("suspended_ceiling_plenum", None), ("concrete", 0.10)],
        "window_u": 3.2,
        "window_shgc": 0.55,
    },
    "light_steel_frame": {
        "description": "light steel frame: insulated steel-stud walls with gypsum lining, composite steel-deck "
        "floors with a thin concrete topping, suspended ceilings, double glazing",
        "mass_class": "light",
        "exterior_wall": [("gypsum_board", 0.013), ("steel_stud_insulated_cavity", None), ("gypsum_board", 0.013)],
        "partition": [("gypsum_board", 0.013), ("air_gap", None), ("gypsum_board", 0.013)],
        "floor": [("carpet", None), ("lightweight_concrete", 0.04)],
        "ceiling": [("suspended_ceiling_plenum", None), ("lightweight_concrete", 0.04)],
        "window_u": 2.8,
        "window_shgc": 0.40,
    },
    "heavy_masonry": {
        "description": "heavy masonry: 300 mm solid brick walls, plastered inside, without insulation; 250 mm "
        "concrete floors; 115 mm brick partitions; older double glazing",
        "mass_class": "very heavy",
        "exterior_wall": [("plaster", 0.015), ("brick", 0.30)],
        "partition": [("plaster", 0.015), ("brick", 0.115), ("plaster", 0.015)],
        "floor": [("concrete", 0.125)],
        "ceiling": [("plaster", 0.015), ("concrete", 0.125)],
        "window_u": 2.8,
        "window_shgc": 0.60,
    },
}

#: ISO 13790:2008 table 12: effective heat capacity per floor area [J/(m2 K)] of each mass class.
MASS_CLASSES = {"very light": 80e3, "light": 110e3, "medium": 165e3, "heavy": 260e3, "very heavy": 370e3}

#: ISO 6946 surface coefficients [W/(m2 K)] (1 / surface resistance) used as nominal film parameters.
NOMINAL_FILMS = {"gamma_interior_wall": 7.7, "gamma_exterior_wall": 7.7, "gamma_floor": 5.9, "gamma_ceiling": 10.0}
AMBIENT_FILM = 25.0

#: Opaque wall area of a facade without ``wall_area``, relative to its window area.
WALL_PER_WINDOW = 1.5


def template_names() -> tuple:
    return tuple(TEMPLATES)


def _layers(spec):
    return [{"material": m} if t is None else {"material": m, "thickness": t} for m, t in spec]


def _constructions(t):
    return [
        {"name": "exterior_wall", "films": ["exterior_wall", "ambient"], "layers": _layers(t["exterior_wall"])},
        {"name": "partition", "films": ["interior_wall", "interior_wall"], "layers": _layers(t["partition"])},
        {"name": "floor", "films": ["floor", "none"], "layers": _layers(t["floor"])},
        {"name": "ceiling", "films": ["ceiling", "none"], "layers": _layers(t["ceiling"])},
    ]


def _elements(building, t):
    """Windows and elements of every zone from its facades, floor area and adjacency."""
    windows, elements = [], []
    for z in building.zones:
        for f in z.facades:
            if f.window_area > 0:
                windows.append(
                    {
                        "name": f"{z.name}_{f.orientation}_window",
                        "zone": z.name,
                        "orientation": f.orientation,
                        "area": f.window_area,
                        "u_value": t["window_u"],
                        "shgc": t["window_shgc"],
                    }
                )
            wall = f.wall_area if f.wall_area > 0 else WALL_PER_WINDOW * f.window_area
            if wall > 0:
                elements.append(
                    {
                        "name": f"{z.name}_{f.orientation}_wall",
                        "construction": "exterior_wall",
                        "area": wall,
                        "side1": z.name,
                        "side2": "ambient",
                        "orientation": f.orientation,
                    }
                )
        for kind in ("floor", "ceiling"):
            elements.append(
                {
                    "name": f"{z.name}_{kind}",
                    "construction": kind,
                    "area": z.area,
                    "side1": z.name,
                    "side2": "adiabatic",
                }
            )
    area = {z.name: z for z in building.zones}
    for p, q in building.adjacency_pairs():
        small = min(area[p], area[q], key=lambda z: z.area)
        height = small.volume / small.area
        elements.append(
            {
                "name": f"{p}_{q}_partition",
                "construction": "partition",
                "area": height * math.sqrt(small.area),
                "side1": p,
                "side2": q,
            }
        )
    return windows, elements


def expand_template(building, physics: dict) -> dict:
    """The raw physics tables of ``building`` built from its ``construction_template``.

    Parameters
    ----------
    building : hvacfmu.building.Building
        Zones with ``area``, ``volume``, ``facades`` and ``adjacent``.
    physics : dict
        The building's raw physics mapping: ``construction_template`` and an
        optional ``physics`` table whose keys override the template's.

    Returns
    -------
    dict
        ``materials``, ``constructions``, ``windows``, ``elements``, ``physics``
        as a building file would give them.

    Raises
    ------
    BuildingError
        Unknown template, or layer-by-layer tables given as well.
    """
    name = physics.get("construction_template")
    if not isinstance(name, str) or name not in TEMPLATES:
        raise BuildingError(
            f"construction_template {name!r} is not a known template; known: {', '.join(TEMPLATES)} "
            "(hvacfmu.models.physics.templates)"
        )
    both = [k for k in ("materials", "constructions", "windows", "elements") if physics.get(k)]
    if both:
        raise BuildingError(
            f"construction_template {name!r} and the tables {both} are both given; use one: "
            "the template builds every table from the zones' areas, facades and adjacency"
        )
    t = TEMPLATES[name]
    windows, elements = _elements(building, t)
    phys = {"ambient_film": AMBIENT_FILM, "nominal": {"U_win": t["window_u"], **NOMINAL_FILMS}}
    user = dict(physics.get("physics") or {})
    phys["nominal"].update(user.pop("nominal", {}) or {})
    phys.update(user)
    return {
        "materials": [
            {"name": m, **MATERIALS[m]}
            for m in sorted({m for k in ("exterior_wall", "partition", "floor", "ceiling") for m, _ in t[k]})
        ],
        "constructions": _constructions(t),
        "windows": windows,
        "elements": elements,
        "physics": phys,
    }


__all__ = ["MASS_CLASSES", "MATERIALS", "TEMPLATES", "expand_template", "template_names"]
