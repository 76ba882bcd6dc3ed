"""Floor layouts, construction templates and climates the emulator can build.

A *layout* is a rectangular floor split into rectangular zones; facades are the
zone edges on the floor's outline (minus the edges a layout declares blind,
e.g. a party wall), adjacency is a shared edge of positive length (or, in a
building of several storeys, a shared slab). Six layouts exist:

``sdh`` (default)
    The SDH-like 4th floor of the paper: NW, W, S, E, NE and a core C (2,560 m2).
``row4``
    A 60 m x 14 m row of four zones R1..R4 along an east-west axis. Facades differ
    per zone: R1 has W, N and S; R2 has N and S with a large south glazing;
    R3 has only S (its north side is a party wall to a neighbouring building,
    adiabatic); R4 has E, N and S with small windows.
``core9``
    A 60 m x 45 m floor of nine zones: four corner zones (two facades each), four
    edge zones N, E, S, W (one facade each) and a core C without facades.
``quad4``
    A 36 m x 28 m floor of four corner offices NW, NE, SE, SW of unequal size (split at
    x = 20 m and y = 12 m: 320, 256, 192 and 240 m2), two facades each. An interior wall
    separates each adjacent pair (NW-NE, NE-SE, SE-SW, SW-NW); the diagonal pairs NW-SE and
    NE-SW touch at a point only and are not adjacent. Its own boxes (3 in NW, 2 elsewhere),
    window-to-wall ratios (0.25 on NE's north side to 0.60 on SE's south side), peak gains
    (11-17 W/m2), no meeting room, and two air handlers (north zones on AHU1, south on AHU2).
    No diagnosis rule was tuned on it (added in session 15 to measure the diagnosis on a
    layout it never saw; the fleet does not draw it, so fleet seeds keep their buildings).
``ell5``
    An L-shaped floor (the 64 m x 44 m rectangle less its 40 m x 20 m north-east corner),
    five zones of unequal size: N (480 m2, the north end of the west wing, three facades N,
    W and E, its east facade on the re-entrant corner), W (192 m2, W and S), an interior
    zone C (256 m2, no facade), S (128 m2, south only: a glazed meeting room with a strong
    meeting schedule, 3.5 kW meetings in half the weekday hours 9..17) and E (960 m2, the
    east wing, three facades S, E and N, its north facade on the notch). Boxes 1-4 per zone
    (S 1, W 2, C 2, N 3, E 4), window ratios 0.30-0.65, two air handlers (west wing N, W, C
    on AHU1; S and E on AHU2). N and E touch at the inner corner's point only. Facades are
    the zone edges no other zone covers (``outline="zones"``). Added in session 17 so the
    whole pipeline can be run on a floor no rule was tuned on; the fleet does not draw it.
``stack4``
    A whole two-storey building (32 m x 20 m, 3.9 m storeys), split north/south at y = 8 m on
    both storeys: N1 (384 m2) and S1 (256 m2) on the ground floor, N2 and S2 above them::

        storey 1 (roof above)        storey 0 (slab on grade)
        y=20 +--------------+        y=20 +--------------+
             |      N2      |        party|      N1      |
         y=8 +--------------+         y=8 + wall -------+
             |      S2      |        (W)  |      S1      |
         y=0 +--------------+         y=0 +--------------+
            x=0            32            x=0            32

    The storeys are joined by a 20 cm concrete slab (floor of N2 / S2, ceiling of N1 / S1):
    N1-N2 and S1-S2 are adjacent through it, N1-S1 and N2-S2 through an interior wall; the
    diagonal pairs N1-S2 and S1-N2 touch along a line only and are not adjacent. Physics none of
    the single-floor layouts has: an insulated roof to ambient on the upper storey only (no sun
    on it: the emulator's inputs carry vertical irradiance only), the ground floor on a slab on
    grade (in the emulator's truth 1 m of soil down to the outdoor air; the building file declares
    ``ground`` at the climate's annual mean), no slab facing other storeys (``T_fl`` unused), a
    party wall on the ground floor's west side (its upper storey has a west facade), a
    shop-front south glazing in S1 (0.60), its own boxes and gains, meetings upstairs in N2,
    one air handler per storey. Added in session 20 to test the diagnosis on a building no rule
    was tuned on; the fleet does not draw it.

A *construction template* scales the massive layers and the furniture mass:
``medium`` (the default, the SDH-like concrete frame), ``light`` (steel frame,
thin slabs on metal deck, light furniture) and ``heavy`` (masonry walls, thick
slabs, archives). A *climate* sets the location and the monthly weather
statistics: ``mild`` (Berkeley, default), ``cold`` (Chicago-like winters) and
``hot`` (Phoenix-like summers, no daylight saving).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .effects import EmulatorError


@dataclasses.dataclass(frozen=True)
class Layout:
    """Geometry and design data of one floor layout.

    Attributes
    ----------
    name : str
    title : str
        Human-readable building name.
    extent : tuple (x0, x1, y0, y1) [m]
        The floor outline.
    rects : dict zone -> (x0, x1, y0, y1) [m], in zone order.
    vavs : dict zone -> (number of boxes, m_min [kg/s], m_max [kg/s])
    peak_gain : dict zone -> [W/m2] peak occupancy gain
    window_to_wall : dict (zone, orientation) -> [-], default :data:`WINDOW_TO_WALL`
    blind : frozenset of (zone, orientation)
        Outline edges that are not facades (party walls, adiabatic).
    meeting_zone : str or None
        Zone with conference rooms (random meetings).
    ahu_of_zone : dict zone -> air handler name, optional
        Air handlers of the ``reheat`` HVAC mode; default: perimeter zones on
        ``AHU1``, zones without facades on ``AHU2``.
    outline : {"extent", "zones"}
        Where the facades are: ``extent`` (default) the zone edges on the ``extent``
        rectangle (the zones tile it); ``zones`` every zone edge no other zone covers
        (a floor that is not a rectangle, e.g. the L of ``ell5``).
    meeting_gain : float or None
        [W] gain of one meeting in ``meeting_zone``; None: the occupancy default.
    meeting_probability : float or None
        [-] probability of a meeting per weekday hour 9..17; None: the occupancy default.
    storeys : dict zone -> storey (0 = ground floor), optional
        Empty (default): one floor of a taller building, its slabs facing the storeys below and
        above (``T_fl``). Given: a whole building of ``max + 1`` storeys, each tiling ``extent``;
        the top storey's zones are under a roof (to ambient), storey 0's on a slab on grade (the
        ground), zones of consecutive storeys whose plans overlap share an intermediate slab
        (floor of the upper zone, ceiling of the lower one) and are adjacent.
    """

    name: str
    title: str
    extent: tuple
    rects: dict
    vavs: dict
    peak_gain: dict
    window_to_wall: dict = dataclasses.field(default_factory=dict)
    blind: frozenset = frozenset()
    meeting_zone: str | None = None
    ahu_of_zone: dict = dataclasses.field(default_factory=dict)
    outline: str = "extent"
    meeting_gain: float | None = None
    meeting_probability: float | None = None
    storeys: dict = dataclasses.field(default_factory=dict)

    @property
    def zone_order(self) -> tuple:
        return tuple(self.rects)

    def wwr(self, zone: str, orientation: str) -> float:
        return float(self.window_to_wall.get((zone, orientation), WINDOW_TO_WALL))

    def storey(self, zone: str) -> int:
        """The storey of ``zone`` (0 = ground floor; 0 for every zone of a single-floor layout)."""
        return int(self.storeys.get(zone, 0))


WINDOW_TO_WALL = 0.45  # default window fraction of the facade area [-]


def _sized_vavs(rects, per_box_area=130.0, flow_per_area=0.0042):
    """Boxes per zone sized like the SDH floor: ~130 m2 per box, m_max ~ 0.0042 kg/(s m2), m_min 25 %."""
    out = {}
    for z, (x0, x1, y0, y1) in rects.items():
        area = (x1 - x0) * (y1 - y0)
        n = max(1, round(area / per_box_area))
        m_max = round(float(np.clip(flow_per_area * area / n, 0.25, 0.65)), 2)
        out[z] = (n, round(0.25 * m_max, 3), m_max)
    return out


SDH = Layout(
    name="sdh",
    title="SDH-like floor 4 (emulated)",
    extent=(0.0, 64.0, 0.0, 40.0),
    rects={
        "NW": (0.0, 32.0, 28.0, 40.0),
        "W": (0.0, 12.0, 0.0, 28.0),
        "S": (12.0, 52.0, 0.0, 10.0),
        "E": (52.0, 64.0, 0.0, 28.0),
        "NE": (32.0, 64.0, 28.0, 40.0),
        "C": (12.0, 52.0, 10.0, 28.0),
    },
    vavs={
        "NW": (3, 0.13, 0.55),
        "W": (3, 0.12, 0.50),
        "S": (4, 0.13, 0.55),
        "E": (3, 0.12, 0.50),
        "NE": (3, 0.13, 0.55),
        "C": (5, 0.12, 0.50),
    },
    peak_gain={"NW": 12.0, "W": 16.0, "S": 16.0, "E": 16.0, "NE": 12.0, "C": 13.0},
    meeting_zone="C",
)

_ROW4_RECTS = {
    "R1": (0.0, 15.0, 0.0, 14.0),
    "R2": (15.0, 30.0, 0.0, 14.0),
    "R3": (30.0, 45.0, 0.0, 14.0),
    "R4": (45.0, 60.0, 0.0, 14.0),
}
ROW4 = Layout(
    name="row4",
    title="Four-zone row (emulated)",
    extent=(0.0, 60.0, 0.0, 14.0),
    rects=_ROW4_RECTS,
    vavs=_sized_vavs(_ROW4_RECTS),
    peak_gain={"R1": 14.0, "R2": 16.0, "R3": 12.0, "R4": 15.0},
    window_to_wall={
        ("R2", "S"): 0.65,
        ("R2", "N"): 0.25,
        ("R3", "S"): 0.40,
        ("R4", "E"): 0.25,
        ("R4", "N"): 0.25,
        ("R4", "S"): 0.30,
        ("R1", "W"): 0.35,
    },
    blind=frozenset({("R3", "N")}),
    ahu_of_zone={"R1": "AHU1", "R2": "AHU1", "R3": "AHU2", "R4": "AHU2"},
)

_CORE9_RECTS = {
    "NW": (0.0, 12.0, 33.0, 45.0),
    "N": (12.0, 48.0, 33.0, 45.0),
    "NE": (48.0, 60.0, 33.0, 45.0),
    "E": (48.0, 60.0, 12.0, 33.0),
    "SE": (48.0, 60.0, 0.0, 12.0),
    "S": (12.0, 48.0, 0.0, 12.0),
    "SW": (0.0, 12.0, 0.0, 12.0),
    "W": (0.0, 12.0, 12.0, 33.0),
    "C": (12.0, 48.0, 12.0, 33.0),
}
CORE9 = Layout(
    name="core9",
    title="Nine-zone floor with a core (emulated)",
    extent=(0.0, 60.0, 0.0, 45.0),
    rects=_CORE9_RECTS,
    vavs=_sized_vavs(_CORE9_RECTS),
    peak_gain={"NW": 13.0, "N": 12.0, "NE": 13.0, "E": 15.0, "SE": 14.0, "S": 16.0, "SW": 14.0, "W": 15.0, "C": 13.0},
    window_to_wall={("N", "N"): 0.40, ("S", "S"): 0.50},
    meeting_zone="C",
)

_QUAD4_RECTS = {
    "NW": (0.0, 20.0, 12.0, 28.0),
    "NE": (20.0, 36.0, 12.0, 28.0),
    "SE": (20.0, 36.0, 0.0, 12.0),
    "SW": (0.0, 20.0, 0.0, 12.0),
}
QUAD4 = Layout(
    name="quad4",
    title="Four corner offices, 2 x 2 (emulated)",
    extent=(0.0, 36.0, 0.0, 28.0),
    rects=_QUAD4_RECTS,
    vavs={
        "NW": (3, 0.11, 0.45),
        "NE": (2, 0.14, 0.55),
        "SE": (2, 0.10, 0.42),
        "SW": (2, 0.12, 0.50),
    },
    peak_gain={"NW": 11.0, "NE": 14.0, "SE": 17.0, "SW": 13.0},
    window_to_wall={
        ("NW", "N"): 0.30,
        ("NW", "W"): 0.35,
        ("NE", "N"): 0.25,
        ("NE", "E"): 0.50,
        ("SE", "S"): 0.60,
        ("SE", "E"): 0.40,
        ("SW", "S"): 0.45,
        ("SW", "W"): 0.55,
    },
    ahu_of_zone={"NW": "AHU1", "NE": "AHU1", "SE": "AHU2", "SW": "AHU2"},
)

_ELL5_RECTS = {
    "N": (0.0, 24.0, 24.0, 44.0),
    "W": (0.0, 8.0, 0.0, 24.0),
    "C": (8.0, 24.0, 8.0, 24.0),
    "S": (8.0, 24.0, 0.0, 8.0),
    "E": (24.0, 64.0, 0.0, 24.0),
}
ELL5 = Layout(
    name="ell5",
    title="L-shaped floor of five zones (emulated)",
    extent=(0.0, 64.0, 0.0, 44.0),
    rects=_ELL5_RECTS,
    vavs={
        "N": (3, 0.14, 0.60),
        "W": (2, 0.10, 0.42),
        "C": (2, 0.11, 0.45),
        "S": (1, 0.16, 0.65),
        "E": (4, 0.19, 0.75),
    },
    peak_gain={"N": 12.0, "W": 14.0, "C": 15.0, "S": 9.0, "E": 16.0},
    window_to_wall={
        ("N", "N"): 0.35,
        ("N", "W"): 0.30,
        ("N", "E"): 0.55,
        ("W", "W"): 0.50,
        ("W", "S"): 0.40,
        ("S", "S"): 0.65,
        ("E", "S"): 0.45,
        ("E", "E"): 0.30,
        ("E", "N"): 0.40,
    },
    meeting_zone="S",
    meeting_gain=3500.0,
    meeting_probability=0.5,
    ahu_of_zone={"N": "AHU1", "W": "AHU1", "C": "AHU1", "S": "AHU2", "E": "AHU2"},
    outline="zones",
)

_STACK4_RECTS = {
    "N1": (0.0, 32.0, 8.0, 20.0),
    "S1": (0.0, 32.0, 0.0, 8.0),
    "N2": (0.0, 32.0, 8.0, 20.0),
    "S2": (0.0, 32.0, 0.0, 8.0),
}
STACK4 = Layout(
    name="stack4",
    title="Two-storey building, 2 zones per storey (emulated)",
    extent=(0.0, 32.0, 0.0, 20.0),
    rects=_STACK4_RECTS,
    vavs={
        "N1": (3, 0.12, 0.50),
        "S1": (2, 0.14, 0.55),
        "N2": (3, 0.13, 0.55),
        "S2": (2, 0.15, 0.60),
    },
    peak_gain={"N1": 11.0, "S1": 17.0, "N2": 13.0, "S2": 12.0},
    window_to_wall={
        ("N1", "N"): 0.25,
        ("N1", "E"): 0.35,
        ("S1", "S"): 0.60,
        ("S1", "E"): 0.30,
        ("N2", "N"): 0.35,
        ("N2", "E"): 0.40,
        ("N2", "W"): 0.30,
        ("S2", "S"): 0.45,
        ("S2", "E"): 0.25,
        ("S2", "W"): 0.55,
    },
    blind=frozenset({("N1", "W"), ("S1", "W")}),
    meeting_zone="N2",
    ahu_of_zone={"N1": "AHU1", "S1": "AHU1", "N2": "AHU2", "S2": "AHU2"},
    storeys={"N1": 0, "S1": 0, "N2": 1, "S2": 1},
)

LAYOUTS = {lay.name: lay for lay in (SDH, ROW4, CORE9, QUAD4, ELL5, STACK4)}


# --------------------------------------------------------------------------- constructions
#: Construction templates: thickness [m] of the massive layers and furniture mass [J/(K m2)].
#: ``medium`` is the SDH-like concrete frame (the default; its values are those of building.py).
CONSTRUCTION_TEMPLATES = {
    "medium": {
        "exterior_concrete": 0.15,
        "insulation": 0.08,
        "slab": 0.20,
        "internal_mass_factor": 1.0,
        "description": "concrete frame: 15 cm concrete exterior walls with 8 cm insulation, 20 cm slabs",
    },
    "light": {
        "exterior_concrete": 0.0,
        "insulation": 0.12,
        "slab": 0.10,
        "internal_mass_factor": 0.5,
        "description": "steel frame: insulated metal-panel walls (no concrete), 10 cm slabs on metal deck, "
        "light furniture",
    },
    "heavy": {
        "exterior_concrete": 0.30,
        "insulation": 0.06,
        "slab": 0.30,
        "internal_mass_factor": 1.5,
        "description": "masonry: 30 cm solid walls with 6 cm insulation, 30 cm slabs, heavy contents",
    },
}


# --------------------------------------------------------------------------- climates
#: Climates: location and monthly normals (daily mean [°C], diurnal range [K], probability of an
#: overcast day [-], Linke turbidity [-]), the design airflow scales of the boxes [-] (maximum, and
#: minimum on top of it: cold-climate boxes have a higher minimum to carry the reheat) and
#: controller settings that differ from the defaults (a larger reheat coil in the cold climate).
CLIMATES = {
    "mild": {
        "description": "Berkeley, CA: mild, cool summers, wet winters",
        "latitude": 37.8750,
        "longitude": -122.2587,
        "timezone": "America/Los_Angeles",
        "altitude": 60.0,
        "monthly_mean": [10.3, 11.5, 12.6, 13.7, 15.2, 16.8, 17.2, 17.8, 18.4, 16.8, 13.1, 10.3],
        "monthly_range": [7.5, 8.0, 8.5, 9.0, 9.5, 10.0, 10.0, 10.0, 11.0, 10.5, 9.0, 7.5],
        "monthly_cloudy": [0.55, 0.50, 0.45, 0.35, 0.25, 0.15, 0.10, 0.10, 0.15, 0.25, 0.40, 0.55],
        "monthly_linke": [2.8, 2.9, 3.1, 3.3, 3.5, 3.6, 3.6, 3.5, 3.3, 3.1, 2.9, 2.8],
        "anomaly_std": 1.5,
        "airflow_scale": 1.0,
        "min_airflow_scale": 1.0,
        "controllers": {},
    },
    "cold": {
        "description": "Chicago-like: cold winters (daily means below -5 °C on cold spells), warm summers",
        "latitude": 41.8781,
        "longitude": -87.6298,
        "timezone": "America/Chicago",
        "altitude": 180.0,
        "monthly_mean": [-4.6, -2.6, 3.2, 9.4, 15.3, 20.8, 23.6, 22.8, 18.7, 12.2, 4.9, -1.4],
        "monthly_range": [7.5, 8.0, 9.0, 10.0, 10.5, 10.5, 10.0, 9.5, 10.0, 10.0, 8.0, 7.0],
        "monthly_cloudy": [0.60, 0.55, 0.55, 0.50, 0.40, 0.35, 0.30, 0.30, 0.35, 0.40, 0.55, 0.65],
        "monthly_linke": [2.6, 2.7, 3.0, 3.3, 3.6, 3.9, 4.0, 3.9, 3.5, 3.1, 2.8, 2.6],
        "anomaly_std": 3.5,
        "airflow_scale": 1.1,
        "min_airflow_scale": 1.4,
        "controllers": {"reheat_rise": 19.0},
    },
    "hot": {
        "description": "Phoenix-like: hot, sunny summers, mild winters; Arizona keeps standard time all year",
        "latitude": 33.4484,
        "longitude": -112.0740,
        "timezone": "America/Phoenix",
        "altitude": 340.0,
        "monthly_mean": [13.5, 15.4, 18.6, 22.6, 27.8, 33.0, 35.2, 34.6, 31.6, 25.3, 17.9, 12.8],
        "monthly_range": [12.5, 13.0, 13.5, 14.5, 15.0, 15.0, 12.0, 11.5, 12.5, 13.5, 13.0, 12.5],
        "monthly_cloudy": [0.25, 0.25, 0.20, 0.10, 0.08, 0.05, 0.25, 0.25, 0.12, 0.12, 0.15, 0.25],
        "monthly_linke": [2.6, 2.8, 3.0, 3.3, 3.5, 3.6, 3.8, 3.8, 3.5, 3.1, 2.8, 2.6],
        "anomaly_std": 1.8,
        "airflow_scale": 1.35,
        "min_airflow_scale": 1.0,
        "controllers": {},
    },
}


#: HVAC modes: ``vav`` (default: one air handler, boxes heat at minimum airflow by reheat; the data
#: log airflow and one supply temperature), ``reheat`` (a real-BMS-like VAV-with-reheat system:
#: constant minimum airflow in heating, discharge air modulated up to ``T_discharge_max``, two air
#: handlers with their own supply temperature reset, discharge temperature and reheat valve logged)
#: and ``reheat-dual`` (the same with dual-maximum boxes: airflow also rises in heating).
HVAC_MODES = {
    "vav": {"description": "one air handler; reheat at minimum airflow, discharge temperature not logged"},
    "reheat": {
        "description": "VAV with hot-water reheat: two air handlers with their own supply-air reset, "
        "constant minimum airflow in heating, discharge air up to T_discharge_max, "
        "per-box Td_<vav> and rh_<vav> logged",
        "min_airflow_scale": 1.5,  # [-] boxes keep a higher constant minimum (ventilation, heating)
        "max_min_fraction": 0.45,  # [-] cap of m_min / m_max
        "T_discharge_max": 35.0,  # [°C] heating limit of the discharge air, declared per air handler
        "heating_sequence": "single",
    },
    "reheat-dual": {
        "description": "as reheat, with dual-maximum boxes: in heating the discharge air rises first, then the "
        "airflow rises from its minimum to heating_max_fraction x m_max at the discharge limit "
        "(more air = more heat in winter)",
        "min_airflow_scale": 1.5,
        "max_min_fraction": 0.45,
        "T_discharge_max": 35.0,
        "heating_sequence": "dual",
        "heating_max_fraction": 0.6,  # [-] heating maximum airflow / m_max
    },
}
#: HVAC modes with several air handlers and logged discharge air (real-BMS-like).
BMS_MODES = ("reheat", "reheat-dual")


def ahu_groups(layout: str) -> dict:
    """Air handler of every zone of ``layout`` in the ``reheat`` mode (zone -> unit name)."""
    from .building import floor_plan

    lay = get_layout(layout)
    if lay.ahu_of_zone:
        return dict(lay.ahu_of_zone)
    plan = floor_plan(layout)
    return {z: ("AHU1" if plan["zones"][z]["facades"] else "AHU2") for z in lay.zone_order}


def get_layout(name: str) -> Layout:
    """The :class:`Layout` called ``name``; unknown names raise :class:`EmulatorError` listing the known ones."""
    if name not in LAYOUTS:
        raise EmulatorError(f"unknown layout {name!r}; known layouts: {', '.join(LAYOUTS)}")
    return LAYOUTS[name]


def check_options(layout="sdh", construction="medium", climate="mild", hvac="vav") -> list[str]:
    """Problems (empty if none) with a layout / construction / climate / HVAC mode choice."""
    problems = []
    if hvac not in HVAC_MODES:
        problems.append(f"unknown hvac mode {hvac!r}; known modes: {', '.join(HVAC_MODES)}")
    if layout not in LAYOUTS:
        problems.append(f"unknown layout {layout!r}; known layouts: {', '.join(LAYOUTS)}")
    if construction not in CONSTRUCTION_TEMPLATES:
        problems.append(f"unknown construction {construction!r}; known: {', '.join(CONSTRUCTION_TEMPLATES)}")
    if climate not in CLIMATES:
        problems.append(f"unknown climate {climate!r}; known climates: {', '.join(CLIMATES)}")
    return problems
