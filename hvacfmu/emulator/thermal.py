"""The emulator's resistance-capacitance network and its exact discretisation.

The network is built from a building mapping in the building-file schema
(materials, constructions, windows, elements) with the *true* values, plus
parameters that only the emulator knows (``extras``). It is deliberately richer
than the models identified from its data:

- every massive layer is split into several nodes (at most ``max_node_thickness``
  thick);
- floor and ceiling slabs face the floors below and above, whose air
  temperature ``T_fl`` is a boundary input (not adiabatic);
- windows conduct heat to ambient and transmit solar gains, split between zone
  air, the floor surface and the furniture; opaque exterior walls absorb solar
  irradiance on their outer surface;
- every zone has a furniture (internal mass) node and infiltration to ambient;
- heat injected at a surface (solar, radiant internal gains) splits between the
  air and the first massive node in proportion to the conductances
  (massless surface node, solved exactly).

Inputs ``w`` of the network (in this order, see :data:`INPUT_NAMES`)::

    T_out, T_fl          boundary temperatures [°C]
    I_N, I_E, I_S, I_W   irradiance on vertical facades [W/m2]
    Q_ig_<zone>          internal gains of each zone [W] (convective + radiant)
    Q_hvac_<zone>        heat delivered by the VAV boxes to each zone's air [W]

The continuous model ``dx/dt = A x + B w`` is discretised exactly for a
zero-order hold of ``w`` over ``dt`` (matrix exponential of the augmented
matrix). The airflow term ``Q_hvac = sum_i m_i c_p (T_supply + dT_reheat,i - T_zone)``
is evaluated by the caller at the start of each ``dt`` (see
:mod:`hvacfmu.emulator.plant`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.linalg

CP_AIR = 1005.0  # [J/(kg K)]
RHO_AIR = 1.2  # [kg/m3]
ORIENTATIONS = ("N", "E", "S", "W")

#: Emulator-only physical parameters (true values), recorded in truth.json.
DEFAULT_EXTRAS = {
    "max_node_thickness": 0.05,  # [m] thicker massive layers are split into several nodes
    "air_capacity_multiplier": 2.0,  # [-] air node capacity = multiplier * rho c_p V (light contents)
    "furniture_area_ratio": 1.2,  # [-] exposed furniture area per floor area
    "furniture_film": 4.0,  # [W/(m2 K)]
    "adjacent_floor_film": 3.0,  # [W/(m2 K)] film on the far side of floor/ceiling slabs
    "infiltration_ach": 0.20,  # [1/h] perimeter zones only
    "wall_solar_absorptance": 0.55,  # [-] opaque exterior walls
    "solar_fraction_air": 0.30,  # [-] of transmitted solar gain: to zone air
    "solar_fraction_floor": 0.45,  # [-] absorbed at the floor surface
    "solar_fraction_furniture": 0.25,  # [-] absorbed by furniture
    "gain_fraction_convective": 0.60,  # [-] of internal gains to the air
    "gain_fraction_floor": 0.15,  # [-] radiant part to the floor surface
    "gain_fraction_furniture": 0.25,  # [-] radiant part to furniture
}


def input_names(zones):
    """Names of the network inputs ``w`` for zone names ``zones``."""
    return (
        ["T_out", "T_fl"]
        + [f"I_{o}" for o in ORIENTATIONS]
        + [f"Q_ig_{z}" for z in zones]
        + [f"Q_hvac_{z}" for z in zones]
    )


@dataclasses.dataclass(frozen=True)
class Network:
    """Continuous-time RC network ``dx/dt = A x + B w``.

    Attributes
    ----------
    A : ndarray (nx, nx) [1/s]
    B : ndarray (nx, nw) [K/s per input unit]
    capacities : ndarray (nx,) [J/K]
    node_names : tuple of str
        The first ``len(zones)`` nodes are the zone air nodes, in zone order.
    zones : tuple of str
    inputs : tuple of str
    """

    A: np.ndarray
    B: np.ndarray
    capacities: np.ndarray
    node_names: tuple
    zones: tuple
    inputs: tuple

    @property
    def n_states(self) -> int:
        return self.A.shape[0]

    def input_index(self, name: str) -> int:
        return self.inputs.index(name)

    def discretize(self, dt: float):
        """Exact zero-order-hold discretisation over ``dt`` [s] -> (Ad, Bd)."""
        nx, nw = self.B.shape
        M = np.zeros((nx + nw, nx + nw))
        M[:nx, :nx] = self.A * dt
        M[:nx, nx:] = self.B * dt
        E = scipy.linalg.expm(M)
        return E[:nx, :nx].copy(), E[:nx, nx:].copy()


class _Builder:
    """Collects nodes, conductances and heat injections of an RC network."""

    def __init__(self, zones, inputs):
        self.zones = list(zones)
        self.inputs = list(inputs)
        self.names: list[str] = []
        self.caps: list[float] = []
        self.links: list[tuple[int, int, float]] = []  # node-node conductance [W/K]
        self.bounds: list[tuple[int, int, float]] = []  # node-input(temperature) conductance [W/K]
        self.heats: list[tuple[int, int, float]] = []  # node, input, gain [W per input unit]

    def node(self, name, capacity):
        if not capacity > 0:
            raise ValueError(f"node {name}: capacity must be > 0 J/K, got {capacity}")
        self.names.append(name)
        self.caps.append(float(capacity))
        return len(self.names) - 1

    def link(self, a, b, G):
        """Conductance ``G`` [W/K] between endpoints; an endpoint is a node index or ('input', k)."""
        if isinstance(a, tuple) and isinstance(b, tuple):
            return
        if isinstance(a, tuple):
            a, b = b, a
        if isinstance(b, tuple):
            self.bounds.append((a, b[1], float(G)))
        else:
            self.links.append((a, b, float(G)))

    def heat(self, node, k, gain):
        self.heats.append((node, k, float(gain)))

    def surface_heat(self, surface, k, gain):
        """Heat injected at a massless surface between a boundary endpoint and a massive node."""
        outer, first, r_film, r_inner = surface
        if first is None:  # massless construction: everything to the outer endpoint
            if not isinstance(outer, tuple):
                self.heat(outer, k, gain)
            return
        if outer is None or math.isinf(r_film):
            self.heat(first, k, gain)
            return
        to_first = r_film / (r_film + r_inner)
        self.heat(first, k, gain * to_first)
        if not isinstance(outer, tuple):
            self.heat(outer, k, gain * (1.0 - to_first))

    def build(self):
        n, m = len(self.names), len(self.inputs)
        C = np.array(self.caps)
        A = np.zeros((n, n))
        B = np.zeros((n, m))
        for a, b, G in self.links:
            A[a, a] -= G / C[a]
            A[a, b] += G / C[a]
            A[b, b] -= G / C[b]
            A[b, a] += G / C[b]
        for a, k, G in self.bounds:
            A[a, a] -= G / C[a]
            B[a, k] += G / C[a]
        for a, k, g in self.heats:
            B[a, k] += g / C[a]
        return Network(A, B, C, tuple(self.names), tuple(self.zones), tuple(self.inputs))


def _film_value(film, params, extras, ambient_film):
    return {
        "ambient": ambient_film,
        "exterior_wall": params["gamma_exterior_wall"],
        "interior_wall": params["gamma_interior_wall"],
        "floor": params["gamma_floor"],
        "ceiling": params["gamma_ceiling"],
        "adjacent_floor": extras["adjacent_floor_film"],
        "none": math.inf,
    }[film]


def build_network(building: dict, params: dict, extras: dict | None = None, effects=()) -> Network:
    """Assemble the emulator's RC network.

    Parameters
    ----------
    building : dict
        Building mapping with ``zones`` and the physics tables (true values).
        An element side may also be ``"adjacent_floor"`` (the floors above and
        below, at temperature ``T_fl``).
    params : dict
        ``U_win``, ``gamma_interior_wall``, ``gamma_exterior_wall``,
        ``gamma_floor``, ``gamma_ceiling`` [W/(m2 K)].
    extras : dict, optional
        Emulator-only parameters, defaults :data:`DEFAULT_EXTRAS`.
    effects : sequence of dict
        Resolved effects; ``zone_coupling``, ``thermal_mass`` and
        ``solar_gain`` change the network.

    Returns
    -------
    Network
    """
    ex = dict(DEFAULT_EXTRAS)
    ex.update(extras or {})
    phys = building.get("physics", {})
    zones = [z["name"] for z in building["zones"]]
    zinfo = {z["name"]: z for z in building["zones"]}
    inputs = input_names(zones)
    bld = _Builder(zones, inputs)
    air = {}
    for z in zones:
        air[z] = bld.node(f"air_{z}", ex["air_capacity_multiplier"] * RHO_AIR * CP_AIR * zinfo[z]["volume"])
    furn = {}
    for z in zones:
        area = zinfo[z]["area"]
        furn[z] = bld.node(f"furniture_{z}", float(phys["internal_mass"]) * area)
        bld.link(air[z], furn[z], ex["furniture_film"] * ex["furniture_area_ratio"] * area)
    walls = _Envelope(bld, building, params, ex, air, inputs)
    for el in building["elements"]:
        walls.add_element(el)
    # solar absorbed by opaque exterior walls (sol-air at the outer surface)
    for surface, area, orient in walls.ext_surfaces:
        if orient in ORIENTATIONS:
            bld.surface_heat(surface, inputs.index(f"I_{orient}"), ex["wall_solar_absorptance"] * area)
    k_out = inputs.index("T_out")
    # windows: conduction to ambient, transmitted solar
    for w in building.get("windows", []):
        z = w["zone"]
        bld.link(air[z], ("input", k_out), float(params["U_win"]) * float(w["area"]))
        k_i = inputs.index(f"I_{w['orientation']}")
        gain = float(w["shgc"]) * float(w["area"])
        bld.heat(air[z], k_i, gain * ex["solar_fraction_air"])
        bld.heat(furn[z], k_i, gain * ex["solar_fraction_furniture"])
        bld.surface_heat(walls.floor_surface[z], k_i, gain * ex["solar_fraction_floor"])
    # infiltration of perimeter zones
    for z in zones:
        if zinfo[z].get("facades"):
            G = RHO_AIR * CP_AIR * zinfo[z]["volume"] * ex["infiltration_ach"] / 3600.0
            bld.link(air[z], ("input", k_out), G)
    # internal gains and HVAC
    for z in zones:
        k_q = inputs.index(f"Q_ig_{z}")
        bld.heat(air[z], k_q, ex["gain_fraction_convective"])
        bld.heat(furn[z], k_q, ex["gain_fraction_furniture"])
        bld.surface_heat(walls.floor_surface[z], k_q, ex["gain_fraction_floor"])
        bld.heat(air[z], inputs.index(f"Q_hvac_{z}"), 1.0)
    _add_effects(bld, building, air, inputs, effects)
    return bld.build()


def _add_effects(bld, building: dict, air: dict, inputs: list, effects) -> None:
    """Effects that change the network: a zone coupling, an extra thermal mass, extra solar gain."""
    for eff in effects:
        if eff["name"] == "zone_coupling":
            a, b = eff["zones"]
            bld.link(air[a], air[b], float(eff["ua"]))
        elif eff["name"] == "thermal_mass":
            z = eff["zone"]
            node = bld.node(f"extra_mass_{z}", float(eff["capacitance"]))
            bld.link(air[z], node, float(eff["ua"]))
        elif eff["name"] == "solar_gain":
            z = eff["zone"]
            win = [w for w in building["windows"] if w["zone"] == z and w["orientation"] == eff["facade"]]
            area = sum(float(w["area"]) for w in win)
            bld.heat(air[z], inputs.index(f"I_{eff['facade']}"), float(eff["shgc"]) * area)


class _Envelope:
    """Adds the building elements (walls, floors, ceilings) to a :class:`_Builder`, layer by layer.

    Records each zone's floor surface (where transmitted sun and radiant gains land) and the exterior
    surfaces with their orientation (sol-air gains).
    """

    def __init__(self, bld, building: dict, params: dict, ex: dict, air: dict, inputs: list):
        self.bld, self.params, self.ex, self.air = bld, params, ex, air
        self.ambient_film = float(building.get("physics", {}).get("ambient_film", 25.0))
        self.k_out, self.k_fl = inputs.index("T_out"), inputs.index("T_fl")
        self.materials = {m["name"]: m for m in building["materials"]}
        self.constructions = {c["name"]: c for c in building["constructions"]}
        self.floor_surface: dict = {}
        self.ext_surfaces: list = []  # (surface, area, orientation)

    def endpoint(self, side):
        if side in self.air:
            return self.air[side]
        if side == "ambient":
            return ("input", self.k_out)
        if side == "adjacent_floor":
            return ("input", self.k_fl)
        if side == "adiabatic":
            return None
        raise ValueError(f"unknown element side {side!r}")

    def add_element(self, el: dict) -> None:
        """Nodes of every massive (sub-)layer of ``el`` and the conductances between them, from side 1 to 2."""
        cons = self.constructions[el["construction"]]
        area = float(el["area"])
        ends = (self.endpoint(el["side1"]), self.endpoint(el["side2"]))
        films = [_film_value(f, self.params, self.ex, self.ambient_film) for f in cons["films"]]
        r_film = [1.0 / (h * area) if math.isfinite(h) else 0.0 for h in films]
        prev = ends[0]
        r_acc = r_film[0]
        first = None
        r_first_inner = None
        for layer in cons["layers"]:
            mat = self.materials[layer["material"]]
            if "r_value" in mat:
                r_acc += float(mat["r_value"]) / area
                continue
            thick = float(layer["thickness"])
            k = float(mat["conductivity"])
            n = max(1, int(math.ceil(thick / self.ex["max_node_thickness"] - 1e-9)))
            dx = thick / n
            for i in range(n):
                r_acc += 0.5 * dx / (k * area)
                node = self.bld.node(
                    f"{el['name']}:{layer['material']}{i + 1}",
                    float(mat["density"]) * float(mat["specific_heat"]) * dx * area,
                )
                if first is None:
                    first = node
                    r_first_inner = r_acc - r_film[0]
                if prev is not None:
                    self.bld.link(prev, node, 1.0 / r_acc)
                prev = node
                r_acc = 0.5 * dx / (k * area)
        r_acc += r_film[1]
        if prev is not None and ends[1] is not None and r_acc > 0:
            self.bld.link(prev, ends[1], 1.0 / r_acc)
        surface1 = (ends[0], first, r_film[0] if ends[0] is not None else math.inf, r_first_inner or 0.0)
        if el["side1"] in self.air and cons["films"][0] == "floor":
            self.floor_surface[el["side1"]] = surface1
        if el["side1"] == "ambient":
            self.ext_surfaces.append((surface1, area, el.get("orientation")))
