"""Zones, facades, adjacency and physics tables of a building file, read from an IDF's geometry.

What is read (for the selected conditioned zones):

- floor area: sum of the zone's ``Floor`` surfaces (polygon area); volume: the
  zone's ``Volume`` field, else floor area times the zone's height (vertical
  extent of its surfaces);
- facades: exterior (``Outdoors``) walls grouped by orientation N/E/S/W of their
  outward normal (Newell's method, reversed when ``GlobalGeometryRules`` lists the vertices clockwise, rotated
  by the building's north axis and the zone's relative north); window area = the walls' ``FenestrationSurface:Detailed``
  areas (times their multiplier), wall area = gross wall minus windows;
- adjacency: ``Surface``/``Zone`` boundary conditions pointing at another selected zone;
- physics tables (Model B): ``Material`` / ``Material:NoMass`` / ``Material:AirGap``
  layers of each ``Construction`` in the IDF's outside-to-inside order; windows with
  U-factor and SHGC of ``WindowMaterial:SimpleGlazingSystem``.

What is approximated: surfaces towards zones outside the selection (plenums,
attics, other floors) are adiabatic; ground contact (``Ground*`` and F-factor
floors) faces ``ground`` at the annual mean of the IDF's ground temperatures,
with F-factor floors as a 15 cm concrete slab under a no-mass layer that gives
EnergyPlus's resistance ``A / (P F)`` (inside film included; the layer EnergyPlus
adds itself); C-factor underground walls stay a 10 cm slab without insulation
(none in the exported example floors); roofs facing outdoors are treated
as exterior elements with the ``ceiling`` film; windows with other glazing
objects get U = 2.5 W/(m2 K), SHGC = 0.4; internal mass is the zones'
``InternalMass`` heat capacity per floor area; film coefficients start at
EnergyPlus's simple natural-convection values (identified later).
"""

from __future__ import annotations

import math

import numpy as np

from .hvac import sanitise

#: Nominal convective film coefficients [W/(m2 K)] (EnergyPlus "Simple" natural convection:
#: vertical 3.076; horizontal, floors and ceilings, mean of 4.040 up and 0.948 down = 2.5).
NOMINAL_FILMS = {"gamma_interior_wall": 3.076, "gamma_exterior_wall": 3.076, "gamma_floor": 2.5, "gamma_ceiling": 2.5}
DEFAULT_WINDOW = (2.5, 0.4)  # (U [W/(m2 K)], SHGC [-]) for glazing other than the simple system
AMBIENT_FILM = 25.0  # [W/(m2 K)]
SLAB = {"name": "hvacfmu_slab_concrete", "conductivity": 1.4, "density": 2300.0, "specific_heat": 880.0}


def _vertices(obj, first: int) -> np.ndarray:
    """Vertices (n, 3) from field index ``first`` (the number of vertices) onwards."""
    raw = [f for f in obj.fields[first + 1 :] if f.strip()]
    xyz = np.array([float(v) for v in raw[: 3 * (len(raw) // 3)]]).reshape(-1, 3)
    return xyz


def _newell(v: np.ndarray) -> np.ndarray:
    """Newell's normal of a polygon; length = 2 x area, direction outward for counterclockwise vertices."""
    n = np.zeros(3)
    for a, b in zip(v, np.roll(v, -1, axis=0)):
        n += [(a[1] - b[1]) * (a[2] + b[2]), (a[2] - b[2]) * (a[0] + b[0]), (a[0] - b[0]) * (a[1] + b[1])]
    return n


def polygon_area(v: np.ndarray) -> float:
    """Area [m2] of a planar polygon given by vertices (n, 3) [m]."""
    return float(np.linalg.norm(_newell(v)) / 2.0)


def orientation(normal: np.ndarray, rotation_deg: float = 0.0) -> str:
    """N/E/S/W of an outward normal, azimuth measured clockwise from north after ``rotation_deg``."""
    az = (math.degrees(math.atan2(normal[0], normal[1])) + rotation_deg) % 360.0
    return "NESW"[int(((az + 45.0) % 360.0) // 90.0)]


def clockwise(idf) -> bool:
    """Whether the IDF lists vertices clockwise as seen from outside (``GlobalGeometryRules``' vertex entry
    direction; EnergyPlus's default and the usual case is counterclockwise)."""
    rules = idf.one("GlobalGeometryRules")
    return rules is not None and rules.get(1).strip().lower() == "clockwise"


def surfaces(idf) -> list:
    """Every detailed building surface as a dict (name, type, construction, zone, bc, bc_object, area,
    outward normal, z range)."""
    out = []
    sign = -1.0 if clockwise(idf) else 1.0  # Newell's normal points inward for clockwise vertices
    for s in idf.all("BuildingSurface:Detailed"):
        v = _vertices(s, 10)
        out.append(
            {
                "name": s.get(0),
                "type": s.get(1).lower(),
                "construction": s.get(2),
                "zone": s.get(3),
                "bc": s.get(5).lower(),
                "bc_object": s.get(6),
                "area": polygon_area(v),
                "normal": sign * _newell(v),
                "zmin": float(v[:, 2].min()),
                "zmax": float(v[:, 2].max()),
            }
        )
    return out


def windows(idf) -> list:
    """Every window (FenestrationSurface:Detailed of type Window/GlassDoor) with its host surface and area."""
    out = []
    for w in idf.all("FenestrationSurface:Detailed"):
        if w.get(1).lower() not in ("window", "glassdoor"):
            continue
        mult = w.number(7, 1.0) or 1.0
        out.append(
            {"name": w.get(0), "construction": w.get(2), "host": w.get(3), "area": polygon_area(_vertices(w, 8)) * mult}
        )
    return out


def rotations(idf) -> dict:
    """Zone name (lower) -> rotation [deg] of its coordinates (building north axis + zone relative north)."""
    b = idf.one("Building")
    north = b.number(1, 0.0) if b is not None else 0.0
    return {z.name.lower(): north + (z.number(1, 0.0) or 0.0) for z in idf.all("Zone")}


def zone_tables(idf, zones: list, surfs: list, wins: list) -> list:
    """Building-file ``[[zones]]`` entries (names sanitised) for the IDF zones ``zones``."""
    rot = rotations(idf)
    sel = {z.lower(): sanitise(z) for z in zones}
    by_name = {s["name"].lower(): s for s in surfs}
    win_area: dict = {}
    for w in wins:
        win_area[w["host"].lower()] = win_area.get(w["host"].lower(), 0.0) + w["area"]
    idf_zones = idf.by_name("Zone")
    out = []
    for zname in zones:
        zl = zname.lower()
        own = [s for s in surfs if s["zone"].lower() == zl]
        area = sum(s["area"] for s in own if s["type"] == "floor")
        vol = idf_zones[zl].number(8)
        if vol is None:
            height = max(s["zmax"] for s in own) - min(s["zmin"] for s in own) if own else 3.0
            vol = area * height
        facades: dict = {}
        adjacent = set()
        for s in own:
            if s["bc"] == "outdoors" and s["type"] == "wall":
                o = orientation(s["normal"], rot.get(zl, 0.0))
                win = win_area.get(s["name"].lower(), 0.0)
                f = facades.setdefault(o, [0.0, 0.0])
                f[0] += win
                f[1] += max(0.0, s["area"] - win)
            other = _other_zone(s, by_name)
            if other and other.lower() in sel and other.lower() != zl:
                adjacent.add(sel[other.lower()])
        out.append(
            {
                "name": sel[zl],
                "area": round(area, 3),
                "volume": round(vol, 3),
                "adjacent": sorted(adjacent),
                "facades": [
                    {"orientation": o, "window_area": round(facades[o][0], 3), "wall_area": round(facades[o][1], 3)}
                    for o in "NESW"
                    if o in facades
                ],
            }
        )
    return out


def _other_zone(s: dict, by_name: dict) -> str | None:
    if s["bc"] == "surface":
        partner = by_name.get(s["bc_object"].lower())
        return partner["zone"] if partner else None
    if s["bc"] == "zone":
        return s["bc_object"]
    return None
