"""Air-side topology of an IDF (boxes, air handlers, nodes) and its sizing results.

A *box* is one air terminal feeding one conditioned zone through a zone inlet
node: ``ZoneHVAC:EquipmentConnections`` (zone -> inlet nodes) and
``ZoneHVAC:AirDistributionUnit`` (outlet node -> terminal). Its air handler is
the ``AirLoopHVAC`` whose supply path splitter (``AirLoopHVAC:ZoneSplitter``)
feeds the terminal's inlet node; the unit's supply temperature is its supply
side outlet node. Zones without an air terminal (plenums, attics, zones with
only unit heaters) are not conditioned zones of the exported building. Other
zone equipment of an exported zone that blows air through one of its inlet nodes
(a fan coil beside a DOAS box) is a box too, of its own one-box unit whose supply
node is that inlet node; equipment that names no inlet node (a baseboard, an
energy recovery ventilator) is listed by :func:`unmeasured_equipment`.

Box limits come from the sizing results EnergyPlus writes to ``eplusout.eio``
(``Component Sizing Information`` lines: design or user-specified maximum air
flow [m3/s]), converted to mass flow with the standard air density at the site's
altitude; ``m_min`` is the terminal's constant minimum flow fraction times that
maximum (VAV terminals; a scheduled minimum: its smallest positive value), 0 for constant-volume terminals whose fan cycles.

A zone with a multiplier (``Zone`` field Multiplier times its ``ZoneGroup``'s zone list multiplier: the 90.1 large
office's mid floor stands for 10 floors, the large hotel's ``Room_3_Mult9_Flr_6`` for 9 rooms) is simulated once,
but its inlet node carries the air of all its copies and its terminal is sized for all of them: a box's airflow
and limits are that divided by the multiplier (``Box.multiplier``), the air of the one zone whose temperature,
surfaces and volume are exported.
"""

from __future__ import annotations

import dataclasses
import re

from ..errors import BuildingError, problems_message

#: Gas constant of dry air [J/(kg K)] and the standard temperature EnergyPlus uses for StdRhoAir [°C].
R_AIR = 287.042
STD_T = 20.0


@dataclasses.dataclass(frozen=True)
class Box:
    """One air terminal: ``name`` (sanitised), ``zone`` (IDF zone name), terminal class and name,
    ``outlet_node`` (the zone inlet node), ``ahu`` (IDF AirLoopHVAC name) and its ``supply_node``;
    ``multiplier``: the zone's multiplier (its node flow and sizing are for that many copies of the zone)."""

    name: str
    zone: str
    terminal_type: str
    terminal: str
    outlet_node: str
    ahu: str
    supply_node: str
    multiplier: float = 1.0


def sanitise(name: str) -> str:
    """A name usable as a zone/box/column suffix: letters, digits and ``_`` only."""
    s = re.sub(r"[^A-Za-z0-9_]+", "_", name.strip()).strip("_")
    return s or "x"


def _node_list(idf, name: str) -> list:
    nl = idf.by_name("NodeList").get(name.lower())
    return [f.strip() for f in nl.fields[1:] if f.strip()] if nl else [name]


def _terminals_of_zone(idf, zone_name: str) -> list:
    """(terminal type, terminal name, outlet node) for each air terminal of a zone."""
    conns = [c for c in idf.all("ZoneHVAC:EquipmentConnections") if c.get(0).lower() == zone_name.lower()]
    if not conns:
        return []
    inlet_nodes = {n.lower() for n in _node_list(idf, conns[0].get(2))}
    eq_list = idf.by_name("ZoneHVAC:EquipmentList").get(conns[0].get(1).lower())
    adus = idf.by_name("ZoneHVAC:AirDistributionUnit")
    found = []
    if eq_list is None:
        return []
    fields = eq_list.fields[2:]
    for k in range(0, len(fields) - 1, 6):
        typ, name = fields[k].strip(), fields[k + 1].strip()
        if typ.lower() == "zonehvac:airdistributionunit" and name.lower() in adus:
            adu = adus[name.lower()]
            if adu.get(1).lower() in inlet_nodes:
                found.append((adu.get(2), adu.get(3), adu.get(1)))
        elif typ.lower().startswith("airterminal:"):
            term = idf.by_name(typ).get(name.lower())
            nodes = [f.strip() for f in term.fields if f.strip().lower() in inlet_nodes] if term else []
            if nodes:
                found.append((typ, name, nodes[0]))
    return found


#: Zone equipment that moves zone air out without conditioning it: no heat of its own for the data to carry.
NO_HEAT_EQUIPMENT = ("fan:zoneexhaust",)
#: Box name prefix of zone equipment that blows air into a zone beside its air terminal (fallback ``UNIT``).
UNIT_PREFIXES = {
    "zonehvac:fourpipefancoil": "FCU",
    "zonehvac:unitheater": "UH",
    "zonehvac:unitventilator": "UV",
    "zonehvac:packagedterminalairconditioner": "PTAC",
    "zonehvac:packagedterminalheatpump": "PTHP",
    "zonehvac:windowairconditioner": "WAC",
    "zonehvac:energyrecoveryventilator": "ERV",
}


def _other_equipment(idf, zone_name: str) -> list:
    """(type, name, zone inlet node or "") of each zone equipment of ``zone_name`` that is not an air terminal: the
    zone inlet node it blows its air into, "" when it has none (a baseboard, a radiant panel, an exhaust fan)."""
    conns = [c for c in idf.all("ZoneHVAC:EquipmentConnections") if c.get(0).lower() == zone_name.lower()]
    eq_list = idf.by_name("ZoneHVAC:EquipmentList").get(conns[0].get(1).lower()) if conns else None
    if eq_list is None:
        return []
    inlet_nodes = {n.lower() for n in _node_list(idf, conns[0].get(2))}
    found = []
    fields = eq_list.fields[2:]
    for k in range(0, len(fields) - 1, 6):
        typ, name = fields[k].strip(), fields[k + 1].strip()
        if not typ or typ.lower() == "zonehvac:airdistributionunit" or typ.lower().startswith("airterminal:"):
            continue
        obj = idf.by_name(typ).get(name.lower())
        nodes = [f.strip() for f in obj.fields[1:] if f.strip().lower() in inlet_nodes] if obj is not None else []
        found.append((typ, name, nodes[0] if nodes else ""))
    return found


def _ahu_of_terminal(idf, typ: str, name: str):
    """(AirLoopHVAC name, supply outlet node) feeding terminal ``name``, or None."""
    term = idf.by_name(typ).get(name.lower())
    if term is None:
        return None
    term_nodes = {f.strip().lower() for f in term.fields if f.strip()}
    loops = {lp.get(8).lower(): lp for lp in idf.all("AirLoopHVAC")}  # demand side inlet node -> loop
    paths = {p.get(1).lower(): p for p in idf.all("AirLoopHVAC:SupplyPath")}
    for sp in idf.all("AirLoopHVAC:ZoneSplitter"):
        # an outlet may name a NodeList (the 90.1 hospital's kitchen unit): compare the nodes it lists
        outlets = {n.lower() for f in sp.fields[2:] if f.strip() for n in _node_list(idf, f.strip())}
        if outlets & term_nodes:
            inlet = sp.get(1).lower()
            loop = loops.get(inlet)
            if loop is None and inlet in paths:
                loop = loops.get(paths[inlet].get(1).lower())
            if loop is not None:
                return loop.get(0), loop.get(9)
    return None


def zone_multipliers(idf) -> dict:
    """``{IDF zone name lower: multiplier}``: each zone's ``Multiplier`` field times the ``Zone List Multiplier`` of
    every ``ZoneGroup`` whose ``ZoneList`` holds it (1 when unset)."""
    out = {z.name.lower(): (z.number(6) or 1.0) for z in idf.all("Zone")}
    lists = idf.by_name("ZoneList")
    for group in idf.all("ZoneGroup"):
        zl = lists.get(group.get(1).lower())
        factor = group.number(2) or 1.0
        for f in zl.fields[1:] if zl is not None else []:
            if f.strip().lower() in out:
                out[f.strip().lower()] *= factor
    return out


def air_boxes(idf) -> list:
    """Every air terminal fed by an air handler, in the IDF's zone order.

    Raises
    ------
    BuildingError
        When no zone of the IDF has an air terminal on an ``AirLoopHVAC``.
    """
    boxes = []
    multipliers = zone_multipliers(idf)
    for zone in idf.all("Zone"):
        terms = _terminals_of_zone(idf, zone.name)
        mult = multipliers.get(zone.name.lower(), 1.0)
        for i, (typ, name, node) in enumerate(terms):
            ahu = _ahu_of_terminal(idf, typ, name)
            if ahu is None:
                continue
            suffix = "" if len(terms) == 1 else f"_{i + 1}"
            boxes.append(Box(f"VAV_{sanitise(zone.name)}{suffix}", zone.name, typ, name, node, ahu[0], ahu[1], mult))
        if not boxes or boxes[-1].zone != zone.name:
            continue
        # a zone of the air loops whose other zone equipment blows air into it too (the large hotel's guest rooms:
        # a DOAS box and a four-pipe fan coil): that air is part of the zone's heat balance, export it as a box of
        # its own unit (its supply temperature is its outlet node, as for a packaged single-zone unit)
        units = [u for u in _other_equipment(idf, zone.name) if u[2]]
        for i, (typ, name, node) in enumerate(units):
            prefix = UNIT_PREFIXES.get(typ.lower(), "UNIT")
            suffix = "" if len(units) == 1 else f"_{i + 1}"
            boxes.append(Box(f"{prefix}_{sanitise(zone.name)}{suffix}", zone.name, typ, name, node, name, node, mult))
    if not boxes:
        raise BuildingError(
            f"IDF file {idf.source}: no zone has an air terminal fed by an AirLoopHVAC "
            "(ZoneHVAC:EquipmentConnections -> ZoneHVAC:AirDistributionUnit -> AirTerminal:* -> "
            "AirLoopHVAC:ZoneSplitter); hvacfmu needs air-side boxes to export airflows"
        )
    return boxes


def unmeasured_equipment(idf, boxes) -> dict:
    """``{IDF zone: [zone equipment types]}`` of the exported zones with zone equipment (other than an exhaust fan)
    that names none of the zone's inlet nodes (a baseboard, a radiant panel; an energy recovery ventilator, whose
    nodes are its fans'): its heat is in the zone but in no column of the export."""
    out = {}
    for zone in dict.fromkeys(b.zone for b in boxes):
        kinds = [t for t, _, node in _other_equipment(idf, zone) if not node and t.lower() not in NO_HEAT_EQUIPMENT]
        if kinds:
            out[zone] = kinds
    return out


#: Refrigeration objects that exchange heat with the air of the zone they stand in (case credits), by the index of
#: their zone field (None: any field, the walk-in's zone names follow its extensible groups).
REFRIGERATION_IN_ZONE = {"refrigeration:case": 2, "refrigeration:walkin": None}


def refrigeration_in_zones(idf, boxes) -> dict:
    """``{IDF zone: [refrigeration object names]}`` of the exported zones that hold refrigerated display cases or
    walk-ins: they take heat (and moisture) out of the zone air all year (the DOE supermarket's sales area: 52 kW of
    sensible cooling on average, 17 kW standard deviation, in January), and no column of the export carries it."""
    zones = {b.zone.lower(): b.zone for b in boxes}
    out: dict = {}
    for typ, field in REFRIGERATION_IN_ZONE.items():
        for obj in idf.all(typ):
            names = [obj.get(field)] if field is not None else [f.strip() for f in obj.fields[1:]]
            for zone in dict.fromkeys(zones[n.lower()] for n in names if n and n.lower() in zones):
                out.setdefault(zone, []).append(obj.name)
    return out


#: Objects that move air from a source zone into a receiving zone (field 1) from a source zone (field 8); a cross
#: mixing moves it both ways.
MIXING = ("zonemixing", "zonecrossmixing")


def mixing_into_zones(idf, boxes) -> dict:
    """``{IDF zone: [(object name, source zone)]}`` of the exported zones that receive air from another zone through a
    ``ZoneMixing`` (transfer air for an exhaust: the DOE supermarket's deli gets 1.08 m3/s of the sales area's air
    while its HVAC runs, up to 3.8 kW in July) or either side of a ``ZoneCrossMixing``: that heat, m cp (T_source -
    T_zone), is in no column of the export (the source zone's temperature is, when it is exported)."""
    zones = {b.zone.lower(): b.zone for b in boxes}
    out: dict = {}
    for typ in MIXING:
        for obj in idf.all(typ):
            ends = [(obj.get(1), obj.get(8))] + ([(obj.get(8), obj.get(1))] if typ == "zonecrossmixing" else [])
            for receiving, source in ends:
                if receiving.lower() in zones:
                    out.setdefault(zones[receiving.lower()], []).append((obj.name, source))
    return out


def zones_without_boxes(idf, boxes) -> dict:
    """``{IDF zone: [zone equipment types]}`` of the zones that have zone equipment but no exported box.

    Such a zone (a vestibule with a unit heater, a zone with baseboards or a fan coil only) is conditioned in the
    simulation but is not a zone of the export: no temperature column, and its surfaces towards exported zones are
    adiabatic in the physics tables. Zones without ``ZoneHVAC:EquipmentConnections`` (plenums, attics) are left out.
    """
    exported = {b.zone.lower() for b in boxes}
    lists = idf.by_name("ZoneHVAC:EquipmentList")
    out = {}
    for c in idf.all("ZoneHVAC:EquipmentConnections"):
        zone = c.get(0)
        if zone.lower() in exported:
            continue
        eq = lists.get(c.get(1).lower())
        fields = eq.fields[2:] if eq is not None else []
        out[zone] = [fields[k].strip() for k in range(0, len(fields) - 1, 6) if fields[k].strip()]
    return out


def std_air_density(elevation: float) -> float:
    """Density of dry air at 20 °C and the standard pressure at ``elevation`` [m] -> [kg/m3]."""
    p = 101325.0 * (1.0 - 2.25577e-5 * elevation) ** 5.2559
    return p / (R_AIR * (STD_T + 273.15))


def read_sizing(eio_text: str) -> dict:
    """``{(component type lower, name lower): {description: value}}`` from ``eplusout.eio``."""
    out: dict = {}
    for line in eio_text.splitlines():
        if not line.startswith(" Component Sizing Information,"):
            continue
        parts = [p.strip() for p in line.split(",")]
        if len(parts) < 5:
            continue
        try:
            value = float(parts[4])
        except ValueError:
            continue
        out.setdefault((parts[1].lower(), parts[2].lower()), {})[parts[3]] = value
    return out


def _sized(sizing: dict, typ: str, name: str, prefix: str):
    values = sizing.get((typ.lower(), name.lower()), {})
    for key in (f"User-Specified {prefix}", f"Design Size {prefix}"):
        for desc, v in values.items():
            if desc.startswith(key):
                return v
    return None


def _schedule_min_positive(idf, name: str) -> float:
    """Smallest positive value of a ``Schedule:Compact``/``Schedule:Constant`` [-] (0 when unknown): the lowest
    minimum the box rests at while it runs.

    A scheduled minimum moves through the day: the 90.1 hospital's and outpatient clinic's operating rooms
    (``OR_MinSA_Sched``) keep 100 % of their design flow from 09:00 to 18:00 on weekdays and 20 % otherwise,
    the medium office's ``PERIMETER_MID_ZN_2_MDP_Sch`` 9.7 % or 1 %. Their boxes sit at 20 % (1 %) every
    night, so that is their ``m_min``: the occupied value (exports up to 1.8) put a running box's night
    airflow under ``0.6 x m_min`` (refused as a unit error) and under the idle bound (read as shut). A zero
    is the damper closing with its air handler, which the idle rule covers.
    """
    for cls in ("Schedule:Compact", "Schedule:Constant"):
        sch = idf.by_name(cls).get(name.lower())
        if sch is None:
            continue
        vals = []
        for f in sch.fields[2:]:
            try:
                vals.append(float(f))
            except ValueError:
                pass
        positive = [x for x in vals if x > 0]
        return min(positive) if positive else 0.0
    return 0.0


#: Sizing descriptions of a zone unit's supply air flow (``Design Size ...`` / ``User-Specified ...``).
_UNIT_FLOWS = ("Maximum Supply Air Flow Rate", "Cooling Supply Air Flow Rate", "Heating Supply Air Flow Rate")


def box_limits(idf, boxes, sizing: dict, rho: float) -> dict:
    """``{box name: (m_min, m_max)}`` [kg/s] from the sizing results and the terminals' inputs, for one copy of the
    box's zone (sized flows divided by ``Box.multiplier``).

    Raises
    ------
    BuildingError
        Naming every box whose maximum flow is neither in the IDF nor in the sizing results.
    """
    limits, problems = {}, []
    for b in boxes:
        term = idf.by_name(b.terminal_type).get(b.terminal.lower())
        v_max = _sized(sizing, b.terminal_type, b.terminal, "Maximum Air Flow Rate")
        if v_max is None:
            v_max = _sized(sizing, "AirTerminal:SingleDuct:VAV:Reheat", b.terminal, "Maximum Air Flow Rate")
        if v_max is None:  # zone equipment (fan coil, unit heater, PTAC): its supply air flow, the larger one
            sized = [_sized(sizing, b.terminal_type, b.terminal, p) for p in _UNIT_FLOWS]
            v_max = max((v for v in sized if v is not None), default=None)
        if v_max is None or v_max <= 0:
            problems.append(
                f"box {b.name} ({b.terminal_type} {b.terminal!r}): no maximum air flow rate in the IDF "
                "or in eplusout.eio's sizing results"
            )
            continue
        frac = 0.0
        if b.terminal_type.lower().startswith("airterminal:singleduct:vav") and term is not None:
            method = term.get(5).lower()
            if method == "constant":
                frac = term.number(6)
                if frac is None:
                    frac = _sized(sizing, b.terminal_type, b.terminal, "Constant Minimum Air Flow Fraction") or 0.0
            elif method == "fixedflowrate":
                frac = (term.number(7) or 0.0) / v_max
            elif method == "scheduled":
                frac = _schedule_min_positive(idf, term.get(8))
        m_max = v_max * rho / b.multiplier
        limits[b.name] = (round(frac * m_max, 5), round(m_max, 5))
    if problems:
        raise BuildingError(problems_message("Box limits could not be read", problems))
    return limits
