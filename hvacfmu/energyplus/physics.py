"""Physics-model tables (materials, constructions, windows, elements) read from an IDF.

See :mod:`hvacfmu.energyplus.geometry` for what is read and what is approximated.
Layers are listed from side 1 to side 2; an element's side 1 is the outside of
the IDF surface (ambient, ground, the other zone or adiabatic) and side 2 the
selected zone, so the IDF's outside-to-inside layer order carries over.
"""

from __future__ import annotations

import numpy as np

from .geometry import (
    AMBIENT_FILM,
    DEFAULT_WINDOW,
    NOMINAL_FILMS,
    SLAB,
    _other_zone,
    orientation,
    rotations,
)
from .hvac import sanitise

_GROUND_BC = (
    "ground",
    "groundfcfactormethod",
    "groundslabpreprocessoraverage",
    "groundslabpreprocessorcore",
    "groundslabpreprocessorperimeter",
    "groundbasementpreprocessoraveragewall",
    "foundation",
)
_ZONE_FILM = {"wall": "interior_wall", "floor": "floor", "ceiling": "ceiling", "roof": "ceiling"}
_OTHER_FILM = {"wall": "interior_wall", "floor": "ceiling", "ceiling": "floor", "roof": "floor"}


def _materials(idf) -> dict:
    """IDF material name (lower) -> building-file material row and thickness [m]."""
    out = {}
    for m in idf.all("Material"):
        out[m.name.lower()] = (
            {
                "name": sanitise(m.name),
                "conductivity": m.number(3),
                "density": m.number(4),
                "specific_heat": m.number(5),
            },
            m.number(2),
        )
    for m in idf.all("Material:NoMass"):
        out[m.name.lower()] = ({"name": sanitise(m.name), "r_value": m.number(2)}, 0.0)
    for m in idf.all("Material:AirGap"):
        out[m.name.lower()] = ({"name": sanitise(m.name), "r_value": m.number(1)}, 0.0)
    return out


def _glazing(idf) -> dict:
    """Window construction name (lower) -> (U [W/(m2 K)], SHGC [-])."""
    simple = {g.name.lower(): (g.number(1), g.number(2)) for g in idf.all("WindowMaterial:SimpleGlazingSystem")}
    out = {}
    for c in idf.all("Construction"):
        layer = c.get(1).lower()
        if layer in simple:
            out[c.name.lower()] = simple[layer]
    return out


def _ground_temperature(idf) -> float:
    for cls in ("Site:GroundTemperature:FCfactorMethod", "Site:GroundTemperature:BuildingSurface"):
        g = idf.one(cls)
        if g is not None:
            vals = [float(f) for f in g.fields if f.strip()]
            if vals:
                return round(float(np.mean(vals)), 2)
    return 15.0


def _heat_capacity(idf, cons_name: str, mats: dict) -> float:
    """Heat capacity [J/(K m2)] of a construction."""
    c = idf.by_name("Construction").get(cons_name.lower())
    total = 0.0
    for layer in c.fields[1:] if c else []:
        row, thick = mats.get(layer.strip().lower(), ({}, 0.0))
        if "density" in row and thick:
            total += row["density"] * row["specific_heat"] * thick
    return total


def _element_key(s: dict, zl: str, zname: str, sel: dict, by_name: dict, rot: dict):
    """(construction, side1, side2, orientation, films) of a surface of selected zone ``zname``, or None."""
    typ, bc = s["type"], s["bc"]
    if bc == "outdoors":
        o = orientation(s["normal"], rot.get(zl, 0.0)) if typ == "wall" else None
        film = "exterior_wall" if typ == "wall" else _ZONE_FILM.get(typ, "ceiling")
        return s["construction"], "ambient", zname, o, ("ambient", film)
    if bc in _GROUND_BC:
        return s["construction"], "ground", zname, None, ("none", _ZONE_FILM.get(typ, "floor"))
    other = _other_zone(s, by_name)
    if other and other.lower() in sel and other.lower() != zl:
        if other.lower() < zl:  # the partner surface of the other zone describes this element
            return None
        return (
            s["construction"],
            sel[other.lower()],
            zname,
            None,
            (_OTHER_FILM.get(typ, "interior_wall"), _ZONE_FILM.get(typ, "interior_wall")),
        )
    return s["construction"], "adiabatic", zname, None, ("none", _ZONE_FILM.get(typ, "interior_wall"))


def physics_tables(idf, zones: list, surfs: list, wins: list) -> dict:
    """``materials``, ``constructions``, ``windows``, ``elements`` and ``physics`` tables for the IDF zones ``zones``."""
    mats, glazing, rot = _materials(idf), _glazing(idf), rotations(idf)
    sel = {z.lower(): sanitise(z) for z in zones}
    by_name = {s["name"].lower(): s for s in surfs}
    win_by_host: dict = {}
    for w in wins:
        win_by_host.setdefault(w["host"].lower(), []).append(w)
    groups: dict = {}
    win_groups: dict = {}
    for s in surfs:
        zl = s["zone"].lower()
        if zl not in sel:
            continue
        key = _element_key(s, zl, sel[zl], sel, by_name, rot)
        if key is None:
            continue
        hosted = win_by_host.get(s["name"].lower(), [])
        groups[key] = groups.get(key, 0.0) + max(0.0, s["area"] - sum(w["area"] for w in hosted))
        for w in hosted:
            u, g = glazing.get(w["construction"].lower(), DEFAULT_WINDOW)
            wk = (sel[zl], key[3] or orientation(s["normal"], rot.get(zl, 0.0)))
            acc = win_groups.setdefault(wk, [0.0, 0.0, 0.0])
            acc[0] += w["area"]
            acc[1] += u * w["area"]
            acc[2] += g * w["area"]
    return _tables(idf, mats, groups, win_groups, zones, surfs)


#: EnergyPlus's F-factor ground floor: a fictitious insulation layer under 15 cm of concrete, whose total resistance
#: with the inside film (0.135 m2 K/W) is ``A / (P F)`` (area, exposed perimeter, F-factor); no exposed perimeter:
#: this resistance [m2 K/W] (the floor exchanges next to no heat with the ground).
FFACTOR_INSIDE_FILM = 0.135
FFACTOR_NO_PERIMETER_R = 1000.0


def ffactor_resistance(ff) -> float:
    """Resistance [m2 K/W] of the fictitious layer of a ``Construction:FfactorGroundFloor`` under the export's 15 cm
    slab: ``A / (P F)`` minus the inside film and the slab, as EnergyPlus builds it (>= 0)."""
    f, area, perimeter = ff.number(1), ff.number(2), ff.number(3)
    if f and area and perimeter and f > 0 and area > 0 and perimeter > 0:
        r_eff = area / (perimeter * f)
    else:
        r_eff = FFACTOR_NO_PERIMETER_R
    return max(r_eff - FFACTOR_INSIDE_FILM - 0.15 / SLAB["conductivity"], 0.0)


def _construction_layers(idf, name: str, mats: dict, used: dict) -> list:
    ff = idf.by_name("Construction:FfactorGroundFloor").get(name.lower())
    if ff is not None:
        used[SLAB["name"]] = dict(SLAB)
        layers = [{"material": SLAB["name"], "thickness": 0.15}]
        r_fic = ffactor_resistance(ff)
        if r_fic > 0:  # side 1 is the ground: the insulation first, then the slab towards the zone
            row = {"name": f"{sanitise(name)}_ffactor_insulation", "r_value": round(r_fic, 4)}
            used[row["name"]] = row
            layers.insert(0, {"material": row["name"], "thickness": 0.0})
        return layers
    c = idf.by_name("Construction").get(name.lower())
    layers = []
    for layer in c.fields[1:] if c else []:
        row, thick = mats.get(layer.strip().lower(), (None, 0.0))
        if row is None:
            continue
        used[row["name"]] = row
        layers.append({"material": row["name"], "thickness": float(thick or 0.0)})
    if not layers:
        used[SLAB["name"]] = dict(SLAB)
        layers = [{"material": SLAB["name"], "thickness": 0.1}]
    return layers


def _tables(idf, mats, groups, win_groups, zones, surfs) -> dict:
    used: dict = {}
    constructions: dict = {}
    elements = []
    for (cons, side1, side2, orient, films), area in sorted(groups.items(), key=lambda kv: str(kv[0])):
        if area <= 0.01:
            continue
        cname = f"{sanitise(cons)}__{films[0]}_{films[1]}"
        if cname not in constructions:
            constructions[cname] = {
                "name": cname,
                "layers": _construction_layers(idf, cons, mats, used),
                "films": list(films),
            }
        el = {
            "name": f"{side2}_{sanitise(cons)}_{side1}" + (f"_{orient}" if orient else ""),
            "construction": cname,
            "area": round(area, 3),
            "side1": side1,
            "side2": side2,
        }
        if orient:
            el["orientation"] = orient
        elements.append(el)
    windows, u_sum, a_sum = [], 0.0, 0.0
    for (zone, orient), (a, ua, ga) in sorted(win_groups.items()):
        windows.append(
            {
                "name": f"{zone}_{orient}_window",
                "zone": zone,
                "orientation": orient,
                "area": round(a, 3),
                "u_value": round(ua / a, 4),
                "shgc": round(ga / a, 4),
            }
        )
        u_sum, a_sum = u_sum + ua, a_sum + a
    floor = sum(s["area"] for s in surfs if s["zone"].lower() in {z.lower() for z in zones} and s["type"] == "floor")
    cap = 0.0
    for m in idf.all("InternalMass"):
        if m.get(2).lower() in {z.lower() for z in zones}:
            cap += _heat_capacity(idf, m.get(1), mats) * (m.number(4, 0.0) or 0.0)
    nominal = {"U_win": round(u_sum / a_sum, 4) if a_sum else DEFAULT_WINDOW[0], **NOMINAL_FILMS}
    physics = {
        "ambient_film": AMBIENT_FILM,
        "ground_temperature": _ground_temperature(idf),
        "internal_mass": round(cap / floor, 1) if floor and cap else 10000.0,
        "nominal": nominal,
    }
    return {
        "materials": sorted(used.values(), key=lambda r: r["name"]),
        "constructions": list(constructions.values()),
        "windows": windows,
        "elements": elements,
        "physics": physics,
    }
