"""Emulated floors as building files: floor plan, VAV boxes (and air handlers) and construction tables.

The geometry of every layout (``sdh``, ``row4``, ``core9``, ``quad4``, ``ell5``, ``stack4``), the construction
templates and the climates are tables in :mod:`hvacfmu.emulator.layouts`; this
module turns them into building-file mappings. The default layout is described here.

The floor is a 64 m x 40 m rectangle (2,560 m2) split into six zones named as
in the paper (Zhou, Hu, Tomlin, Fig. 1): four perimeter zones with windows,
a long south zone and an interior core ``C`` without facade::

      y=40 +----------------+----------------+
           |       NW       |       NE       |   north facade
      y=28 +------+---------+---------+------+
           |      |                   |      |
           |  W   |         C         |  E   |
      y=10 |      +-------------------+      |
           |      |         S         |      |
       y=0 +------+-------------------+------+
          x=0    12                  52     64

Two tables of construction data exist: the *true* one used by the emulator
and the *nominal* one written to ``building.toml`` (handbook values, as a real
user would have them; deliberately somewhat off the truth).
"""

from __future__ import annotations

import copy

from ..building import Building, building_from_dict
from ..errors import problems_message
from .effects import EmulatorError
from .layouts import BMS_MODES, CLIMATES, CONSTRUCTION_TEMPLATES, HVAC_MODES, SDH, ahu_groups, check_options, get_layout

#: Location of Sutardja Dai Hall, UC Berkeley (the ``mild`` climate).
LATITUDE = 37.8750
LONGITUDE = -122.2587
TIMEZONE = "America/Los_Angeles"
ALTITUDE = 60.0  # [m]

FLOOR_TO_FLOOR = 3.9  # [m] slab to slab
CEILING_HEIGHT = 2.9  # [m] room height below the suspended ceiling
WINDOW_TO_WALL = 0.45  # window fraction of the facade area [-]

#: Zone rectangles (x0, x1, y0, y1) [m] of the default layout (see :mod:`.layouts`).
ZONE_RECTS = dict(SDH.rects)
ZONE_ORDER = SDH.zone_order
FLOOR_EXTENT = SDH.extent

#: VAV boxes per zone and their airflow limits [kg/s] (m_min is ~25 % of m_max).
VAV_LAYOUT = dict(SDH.vavs)


def _facades_of(rect, extent=FLOOR_EXTENT):
    """Exterior facade lengths [m] of a zone rectangle by orientation."""
    x0, x1, y0, y1 = rect
    X0, X1, Y0, Y1 = extent
    out = {}
    if y1 == Y1:
        out["N"] = x1 - x0
    if x1 == X1:
        out["E"] = y1 - y0
    if y0 == Y0:
        out["S"] = x1 - x0
    if x0 == X0:
        out["W"] = y1 - y0
    return out


def _open_edges(rect, others):
    """Edge lengths [m] of a zone rectangle by orientation that no other zone rectangle covers.

    On a floor whose zones tile its outline rectangle these are the edges on the outline; on an
    L-shaped floor (``ell5``) they also include the edges on the re-entrant corner's notch.
    """
    x0, x1, y0, y1 = rect
    edges = {
        "N": (y1, x0, x1, "h", 1),
        "S": (y0, x0, x1, "h", -1),
        "E": (x1, y0, y1, "v", 1),
        "W": (x0, y0, y1, "v", -1),
    }
    out = {}
    for o, (c, a0, a1, kind, side) in edges.items():
        covered = []
        for bx0, bx1, by0, by1 in others:
            if kind == "h" and (by0 if side > 0 else by1) == c:
                lo, hi = max(a0, bx0), min(a1, bx1)
            elif kind == "v" and (bx0 if side > 0 else bx1) == c:
                lo, hi = max(a0, by0), min(a1, by1)
            else:
                continue
            if hi > lo:
                covered.append((lo, hi))
        open_len, pos = 0.0, a0
        for lo, hi in sorted(covered):
            if lo > pos:
                open_len += lo - pos
            pos = max(pos, hi)
        open_len += max(0.0, a1 - pos)
        if open_len > 0:
            out[o] = open_len
    return out


def _shared_length(a, b):
    """Length [m] of the common boundary of two rectangles (0 if they only touch at a corner)."""
    ax0, ax1, ay0, ay1 = a
    bx0, bx1, by0, by1 = b
    if ax1 == bx0 or bx1 == ax0:  # vertical common line
        return max(0.0, min(ay1, by1) - max(ay0, by0))
    if ay1 == by0 or by1 == ay0:  # horizontal common line
        return max(0.0, min(ax1, bx1) - max(ax0, bx0))
    return 0.0


def floor_plan(layout: str = "sdh"):
    """Geometry of the floor of ``layout``.

    Returns
    -------
    dict
        ``zones``: name -> dict(area [m2], volume [m3], facades {orientation: length [m]}),
        ``shared``: {(a, b): shared wall length [m]} for adjacent zone pairs.
    """
    lay = get_layout(layout)
    order = lay.zone_order
    zones = {}
    for name in order:
        x0, x1, y0, y1 = lay.rects[name]
        area = (x1 - x0) * (y1 - y0)
        if lay.outline == "zones":
            others = [r for z, r in lay.rects.items() if z != name and lay.storey(z) == lay.storey(name)]
            edges = _open_edges(lay.rects[name], others)
        else:
            edges = _facades_of(lay.rects[name], lay.extent)
        facades = {o: v for o, v in edges.items() if (name, o) not in lay.blind}
        zones[name] = {"area": area, "volume": area * CEILING_HEIGHT, "facades": facades}
    shared = {}
    for i, a in enumerate(order):
        for b in order[i + 1 :]:
            length = _shared_length(lay.rects[a], lay.rects[b]) if lay.storey(a) == lay.storey(b) else 0.0
            if length > 0:
                shared[(a, b)] = length
    plan = {"zones": zones, "shared": shared}
    if lay.storeys:
        plan["slabs"] = _slabs(lay)
    return plan


def _overlap_area(a, b):
    """Area [m2] common to two rectangles in plan (0 if they do not overlap)."""
    return max(0.0, min(a[1], b[1]) - max(a[0], b[0])) * max(0.0, min(a[3], b[3]) - max(a[2], b[2]))


def _slabs(lay) -> dict:
    """{(upper zone, lower zone): slab area [m2]} of the zones of consecutive storeys whose plans overlap."""
    out = {}
    for upper in lay.zone_order:
        for lower in lay.zone_order:
            if lay.storey(upper) == lay.storey(lower) + 1:
                area = _overlap_area(lay.rects[upper], lay.rects[lower])
                if area > 0:
                    out[(upper, lower)] = area
    return out


# --------------------------------------------------------------------------- materials
#: Nominal (handbook) material data, as written to building.toml.
NOMINAL_MATERIALS = {
    "concrete": {"conductivity": 1.40, "density": 2300.0, "specific_heat": 880.0},
    "insulation": {"conductivity": 0.040, "density": 30.0, "specific_heat": 1400.0},
    "gypsum": {"conductivity": 0.25, "density": 800.0, "specific_heat": 1090.0},
    "carpet": {"r_value": 0.10},
    "stud_cavity": {"r_value": 0.17},
    "ceiling_plenum": {"r_value": 0.30},
}
#: The emulator's true material data.
TRUE_MATERIALS = {
    "concrete": {"conductivity": 1.70, "density": 2400.0, "specific_heat": 900.0},
    "insulation": {"conductivity": 0.046, "density": 35.0, "specific_heat": 1400.0},
    "gypsum": {"conductivity": 0.28, "density": 850.0, "specific_heat": 1050.0},
    "carpet": {"r_value": 0.12},
    "stud_cavity": {"r_value": 0.16},
    "ceiling_plenum": {"r_value": 0.25},
}

CONSTRUCTIONS = {
    # layers listed from side 1 to side 2
    "exterior_wall": {
        "layers": [("concrete", 0.15), ("insulation", 0.08), ("gypsum", 0.016)],
        "films": ["ambient", "exterior_wall"],
    },
    "interior_wall": {
        "layers": [("gypsum", 0.016), ("stud_cavity", 0.0), ("gypsum", 0.016)],
        "films": ["interior_wall", "interior_wall"],
    },
    # floor slab of the zone: side 1 = zone (carpet on top), side 2 = floor below
    "floor_slab": {
        "layers": [("carpet", 0.0), ("concrete", 0.20), ("ceiling_plenum", 0.0)],
        "films": ["floor", "none"],
    },
    # ceiling of the zone: side 1 = zone (suspended ceiling), side 2 = floor above
    "ceiling_slab": {
        "layers": [("ceiling_plenum", 0.0), ("concrete", 0.20), ("carpet", 0.0)],
        "films": ["ceiling", "none"],
    },
}


def constructions_of(template: str = "medium") -> dict:
    """The four constructions of a template (see :data:`.layouts.CONSTRUCTION_TEMPLATES`).

    ``medium`` returns :data:`CONSTRUCTIONS` unchanged; the others change the
    concrete and insulation thicknesses (a zero thickness drops the layer).
    """
    t = CONSTRUCTION_TEMPLATES[template]
    out = copy.deepcopy(CONSTRUCTIONS)
    if template == "medium":
        return out
    ext = [("concrete", t["exterior_concrete"]), ("insulation", t["insulation"]), ("gypsum", 0.016)]
    out["exterior_wall"]["layers"] = [(m, d) for m, d in ext if d > 0]
    for name in ("floor_slab", "ceiling_slab"):
        out[name]["layers"] = [(m, t["slab"] if m == "concrete" else d) for m, d in out[name]["layers"]]
    return out


#: Constructions of a whole building of several storeys (layouts with ``storeys``), on top of the exterior
#: and interior walls: the slab between two storeys (side 1 = the upper zone, carpet on top; side 2 = the lower
#: zone, suspended ceiling), the roof (side 1 = ambient: insulation on the concrete deck) and the ground floor's
#: slab on grade (side 2 = the ground). Thicknesses of the medium template; see :func:`storey_constructions`.
STOREY_CONSTRUCTIONS = {
    "intermediate_slab": {
        "layers": [("carpet", 0.0), ("concrete", 0.20), ("ceiling_plenum", 0.0)],
        "films": ["floor", "ceiling"],
    },
    "roof": {
        "layers": [("insulation", 0.12), ("concrete", 0.20), ("ceiling_plenum", 0.0)],
        "films": ["ambient", "ceiling"],
    },
    "ground_slab": {
        "layers": [("carpet", 0.0), ("concrete", 0.20), ("insulation", 0.05)],
        "films": ["floor", "none"],
    },
}
#: Soil under the slab on grade in the emulator's truth [m]: its far side faces the outdoor air.
SOIL_DEPTH = 1.0
SOIL = {"conductivity": 1.5, "density": 1800.0, "specific_heat": 1000.0}


def storey_constructions(template: str = "medium") -> dict:
    """Walls of ``template`` (:func:`constructions_of`) and the slabs and roof of a building of several storeys.

    The slab thickness follows the template; the roof's insulation is the walls' plus 4 cm.
    """
    t = CONSTRUCTION_TEMPLATES[template]
    walls = constructions_of(template)
    out = {k: walls[k] for k in ("exterior_wall", "interior_wall")}
    for name, c in copy.deepcopy(STOREY_CONSTRUCTIONS).items():
        if template != "medium":
            roof_ins = t["insulation"] + 0.04
            c["layers"] = [
                (m, t["slab"] if m == "concrete" else (roof_ins if (name, m) == ("roof", "insulation") else d))
                for m, d in c["layers"]
            ]
        out[name] = c
    return out


#: The paper's five physical parameters: nominal (handbook) and true values.
NOMINAL_PARAMETERS = {
    "U_win": 2.6,  # [W/(m2 K)]
    "gamma_interior_wall": 3.0,  # [W/(m2 K)]
    "gamma_exterior_wall": 3.0,
    "gamma_floor": 3.0,
    "gamma_ceiling": 3.0,
}
TRUE_PARAMETERS = {
    "U_win": 2.25,
    "gamma_interior_wall": 3.6,
    "gamma_exterior_wall": 3.3,
    "gamma_floor": 2.3,
    "gamma_ceiling": 4.2,
}
NOMINAL_SHGC = 0.40
TRUE_SHGC = 0.32  # effective, with interior blinds
NOMINAL_INTERNAL_MASS = 10000.0  # [J/(K m2)] per floor area
TRUE_INTERNAL_MASS = 16000.0
AMBIENT_FILM = 25.0  # [W/(m2 K)]
#: A floor's slabs face the storeys below and above (the emulator's truth: their air at
#: ``T_fl`` = 21.8 °C + a workday rise + AR(1) noise). The building file declares them against a
#: boundary at a constant temperature (``side2 = "ground"``, ``[physics].ground_temperature``),
#: the schema's closest form; adiabatic slabs would cool with the zone over a weekend setback.
STOREYS_BOUNDARY = "ground"
STOREYS_TEMPERATURE = 22.0  # [°C] the storeys' mean air temperature, rounded


def _physics_tables(nominal: bool, layout: str = "sdh", construction: str = "medium", climate: str = "mild") -> dict:
    lay = get_layout(layout)
    plan = floor_plan(layout)
    materials = NOMINAL_MATERIALS if nominal else TRUE_MATERIALS
    params = NOMINAL_PARAMETERS if nominal else TRUE_PARAMETERS
    shgc = NOMINAL_SHGC if nominal else TRUE_SHGC
    mats = []
    for name, props in materials.items():
        mats.append({"name": name, **props})
    cons = []
    constructions = storey_constructions(construction) if lay.storeys else constructions_of(construction)
    for name, c in constructions.items():
        cons.append(
            {
                "name": name,
                "layers": [{"material": m, "thickness": t} for m, t in c["layers"]],
                "films": list(c["films"]),
            }
        )
    windows, elements = [], []
    for zname in lay.zone_order:
        w, e = _zone_envelope(zname, plan["zones"][zname], lay, params["U_win"], shgc)
        windows += w
        elements += e
    for (a, b), length in plan["shared"].items():
        elements.append(
            {
                "name": f"{a}_{b}_partition",
                "construction": "interior_wall",
                "area": round(length * CEILING_HEIGHT, 2),
                "side1": a,
                "side2": b,
            }
        )
    ground_temperature = STOREYS_TEMPERATURE
    if lay.storeys:
        elements += _storey_elements(lay, plan)
        # the slab on grade faces the ground, declared at the climate's annual mean (as a user would)
        ground_temperature = round(sum(CLIMATES[climate]["monthly_mean"]) / 12.0 * 2.0) / 2.0
    mass = (NOMINAL_INTERNAL_MASS if nominal else TRUE_INTERNAL_MASS) * CONSTRUCTION_TEMPLATES[construction][
        "internal_mass_factor"
    ]
    physics = {
        "ambient_film": AMBIENT_FILM,
        "ground_temperature": ground_temperature,
        "internal_mass": mass,
        "nominal": dict(params),
    }
    return {"materials": mats, "constructions": cons, "windows": windows, "elements": elements, "physics": physics}


def _zone_envelope(zname: str, z: dict, lay, u_win: float, shgc: float) -> tuple[list, list]:
    """Windows and opaque elements (facades, floor and ceiling slabs) of one zone of the floor plan."""
    windows, elements = [], []
    for orient, length in z["facades"].items():
        facade_area = length * FLOOR_TO_FLOOR
        win = round(lay.wwr(zname, orient) * facade_area, 2)
        windows.append(
            {
                "name": f"{zname}_{orient}_window",
                "zone": zname,
                "orientation": orient,
                "area": win,
                "u_value": u_win,
                "shgc": shgc,
            }
        )
        elements.append(
            {
                "name": f"{zname}_exterior_{orient}",
                "construction": "exterior_wall",
                "area": round(facade_area - win, 2),
                "side1": "ambient",
                "side2": zname,
                "orientation": orient,
            }
        )
    if lay.storeys:  # whole building: roof, slab on grade and the slabs between storeys, see _storey_elements
        return windows, elements
    elements.append(
        {
            "name": f"{zname}_floor",
            "construction": "floor_slab",
            "area": z["area"],
            "side1": zname,
            "side2": STOREYS_BOUNDARY,
        }
    )
    elements.append(
        {
            "name": f"{zname}_ceiling",
            "construction": "ceiling_slab",
            "area": z["area"],
            "side1": zname,
            "side2": STOREYS_BOUNDARY,
        }
    )
    return windows, elements


def _storey_elements(lay, plan) -> list[dict]:
    """Roofs of the top storey's zones, slabs on grade of storey 0's, and the slabs between storeys."""
    top = max(lay.storey(z) for z in lay.zone_order)
    out = []
    for z in lay.zone_order:
        area = plan["zones"][z]["area"]
        if lay.storey(z) == top:
            out.append({"name": f"{z}_roof", "construction": "roof", "area": area, "side1": "ambient", "side2": z})
        if lay.storey(z) == 0:
            out.append(
                {"name": f"{z}_ground", "construction": "ground_slab", "area": area, "side1": z, "side2": "ground"}
            )
    for (upper, lower), area in plan["slabs"].items():
        out.append(
            {
                "name": f"{upper}_{lower}_slab",
                "construction": "intermediate_slab",
                "area": area,
                "side1": upper,
                "side2": lower,
            }
        )
    return out


def _check(layout, construction, climate, hvac="vav"):
    problems = check_options(layout, construction, climate, hvac)
    if problems:
        raise EmulatorError(problems_message("Invalid emulator building", problems))


def building_dict(
    layout: str = "sdh", construction: str = "medium", climate: str = "mild", nominal: bool = True, hvac: str = "vav"
) -> dict:
    """A floor as a building-file mapping (see :func:`emulated_building`)."""
    _check(layout, construction, climate, hvac)
    lay = get_layout(layout)
    clim = CLIMATES[climate]
    plan = floor_plan(layout)
    order = lay.zone_order
    zones = []
    adjacent = {n: [] for n in order}
    for a, b in list(plan["shared"]) + list(plan.get("slabs", {})):
        adjacent[a].append(b)
        adjacent[b].append(a)
    tables = _physics_tables(nominal, layout, construction, climate)
    win_area = {(w["zone"], w["orientation"]): w["area"] for w in tables["windows"]}
    for name in order:
        z = plan["zones"][name]
        facades = []
        for orient in ("N", "E", "S", "W"):
            if orient in z["facades"]:
                total = z["facades"][orient] * FLOOR_TO_FLOOR
                facades.append(
                    {
                        "orientation": orient,
                        "window_area": win_area[(name, orient)],
                        "wall_area": round(total - win_area[(name, orient)], 2),
                    }
                )
        zones.append(
            {
                "name": name,
                "area": z["area"],
                "volume": round(z["volume"], 2),
                "adjacent": [n for n in order if n in adjacent[name]],
                "facades": facades,
            }
        )
    vavs = _vavs(lay, clim, hvac)
    title = lay.title
    if (construction, climate) != ("medium", "mild"):
        title = f"{title}, {construction} construction, {climate} climate"
    d = {
        "name": title,
        "latitude": clim["latitude"],
        "longitude": clim["longitude"],
        "timezone": clim["timezone"],
        "zones": zones,
        "vavs": vavs,
    }
    if hvac in BMS_MODES:
        mode = HVAC_MODES[hvac]
        units = sorted(set(ahu_groups(layout).values()))
        d["ahus"] = [{"name": a, "T_supply_max": mode["T_discharge_max"]} for a in units]
    d.update(copy.deepcopy(tables))
    return d


def _vavs(lay, clim, hvac) -> list[dict]:
    """Box entries: the layout's sizing scaled for the climate and the HVAC mode."""
    scale, min_scale = float(clim["airflow_scale"]), float(clim["min_airflow_scale"])
    cap = 1.0
    if hvac in BMS_MODES:
        min_scale *= HVAC_MODES[hvac]["min_airflow_scale"]
        cap = HVAC_MODES[hvac]["max_min_fraction"]
        groups = ahu_groups(lay.name)
    vavs = []
    for name in lay.zone_order:
        n, m_min, m_max = lay.vavs[name]
        if (scale, min_scale) != (1.0, 1.0):
            m_min, m_max = round(m_min * scale * min_scale, 3), round(m_max * scale, 2)
            m_min = min(m_min, round(cap * m_max, 3))
        for i in range(1, n + 1):
            v = {"name": f"VAV_{name}_{i}", "zone": name, "m_min": m_min, "m_max": m_max}
            if hvac in BMS_MODES:
                v["ahu"] = groups[name]
            vavs.append(v)
    return vavs


def sdh_building_dict(nominal: bool = True) -> dict:
    """The default floor as a building-file mapping (see :func:`sdh_building`)."""
    return building_dict("sdh", "medium", "mild", nominal)


def emulated_building(
    layout: str = "sdh", construction: str = "medium", climate: str = "mild", nominal: bool = True, hvac: str = "vav"
) -> Building:
    """An emulated floor as a :class:`~hvacfmu.building.Building`.

    Parameters
    ----------
    layout : {"sdh", "row4", "core9", "quad4", "ell5", "stack4"}
        Floor layout (see :mod:`hvacfmu.emulator.layouts`).
    construction : {"medium", "light", "heavy"}
        Construction template of the massive layers and furniture.
    climate : {"mild", "cold", "hot"}
        Location (latitude, longitude, time zone) and box sizing of the climate.
    nominal : bool
        Nominal handbook tables (as written to ``building.toml``) or the true ones.
    hvac : {"vav", "reheat", "reheat-dual"}
        ``reheat`` and ``reheat-dual`` add the ``[[ahus]]`` (each box's ``ahu``) of the real-BMS-like mode
        and raises the boxes' minimum airflow (see :data:`.layouts.HVAC_MODES`).

    Returns
    -------
    Building
    """
    return building_from_dict(building_dict(layout, construction, climate, nominal, hvac))


def sdh_building(nominal: bool = True) -> Building:
    """The emulated SDH-like 4th floor as a :class:`~hvacfmu.building.Building`.

    Parameters
    ----------
    nominal : bool
        True (default): physics tables with nominal handbook values, as written
        to ``building.toml`` and as a user would have them. False: the same
        tables with the emulator's true values. The emulator's truth is richer
        than this schema (floors and ceilings face the air of the floors below
        and above, whose temperature varies, where the file has a boundary at
        a constant temperature; solar absorbed by opaque walls; infiltration); ``truth.json`` records that structure.

    Returns
    -------
    Building
        Six zones NW, W, S, E, NE, C (2,560 m2), 21 VAV boxes, Berkeley location.
    """
    return building_from_dict(sdh_building_dict(nominal))


def true_building_dict(
    layout: str = "sdh", construction: str = "medium", climate: str = "mild", hvac: str = "vav"
) -> dict:
    """The emulator's true building: true tables, and slabs facing the floors above and below.

    Floor and ceiling slabs are not adiabatic in the truth: their far side faces
    the air of the floor below / above (side ``"adjacent_floor"``, film
    ``"adjacent_floor"``), whose temperature is a boundary input.
    """
    d = building_dict(layout, construction, climate, nominal=False, hvac=hvac)
    d["name"] = d["name"].replace("(emulated)", "(emulator truth)")
    for c in d["constructions"]:
        if c["name"] in ("floor_slab", "ceiling_slab"):
            c["films"] = [c["films"][0], "adjacent_floor"]
    for el in d["elements"]:
        if el["construction"] in ("floor_slab", "ceiling_slab"):
            el["side2"] = "adjacent_floor"
    if get_layout(layout).storeys:
        # the slab on grade lies on SOIL_DEPTH of soil whose far side follows the outdoor air (the file's
        # constant ground temperature is the user's simplification)
        d["materials"].append({"name": "soil", **SOIL})
        for c in d["constructions"]:
            if c["name"] == "ground_slab":
                c["layers"].append({"material": "soil", "thickness": SOIL_DEPTH})
        for el in d["elements"]:
            if el["construction"] == "ground_slab":
                el["side2"] = "ambient"
    return d
