"""The emulated building as a steppable plant (for FMUs, the co-simulation harness and MPC).

:class:`Plant` is the same thermal model that produced the dataset: the RC
network of :mod:`hvacfmu.emulator.thermal` with the true parameters and the
injected effects, discretised exactly at 60 s, internal gains and the
temperature of the floors above and below from the emulator's own occupancy
model (same seed). The airflows are commanded directly (no local controller).

Per 60 s sub-step ``k`` the zone air receives from the VAV boxes::

    Q_hvac,z = sum_{i in z} m_i c_p (T_supply - T_z,k) + P_reheat,i

evaluated with the zone temperature at the start of the sub-step (the bilinear
term), and the linear part is advanced exactly:
``x_{k+1} = Ad x_k + Bd [T_out, T_fl, I_N..I_W, Q_ig, Q_hvac]_k``.
"""

from __future__ import annotations

import dataclasses
import zlib

import numpy as np
import pandas as pd

from .effects import EmulatorError
from .occupancy import internal_gains
from .thermal import CP_AIR, ORIENTATIONS, build_network

DT = 60.0  # [s] internal step of the thermal model


def stream(seed: int, name: str) -> np.random.Generator:
    """Independent random stream ``name`` of dataset seed ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), zlib.crc32(name.encode())]))


def dataset_index(start: str, weeks: int, timezone: str) -> pd.DatetimeIndex:
    """One-minute tz-aware index of a dataset of ``weeks`` weeks from local time ``start``."""
    t0 = pd.Timestamp(start)
    t0 = t0.tz_localize(timezone) if t0.tzinfo is None else t0.tz_convert(timezone)
    return pd.date_range(t0, periods=int(weeks) * 7 * 1440, freq="min")


@dataclasses.dataclass
class PlantCore:
    """Matrices and schedules shared by the dataset simulation and :class:`Plant`."""

    zones: tuple
    vavs: tuple
    m_min: np.ndarray
    m_max: np.ndarray
    box_zone: np.ndarray  # zone index of each box
    Mzb: np.ndarray  # (nz, nb) 0/1
    Ad: np.ndarray
    Bw: np.ndarray  # (nx, 6 + nz) columns T_out, T_fl, I_N..I_W, Q_ig
    BQ: np.ndarray  # (nx, nz) Q_hvac columns
    node_names: tuple
    node_zones: list  # zone indices each node belongs to (for initial states)
    Q_ig: np.ndarray  # (n, nz) [W]
    T_fl: np.ndarray  # (n,) [°C]
    delay_zone: int | None
    delay_minutes: int
    delay_boxes: np.ndarray
    reheat_effect: dict | None

    @classmethod
    def from_truth(cls, truth: dict) -> "PlantCore":
        base = truth["baseline"]
        bld = base["building"]
        zones = tuple(z["name"] for z in bld["zones"])
        vavs = tuple(v["name"] for v in bld["vavs"])
        zidx = {z: i for i, z in enumerate(zones)}
        box_zone = np.array([zidx[v["zone"]] for v in bld["vavs"]])
        Mzb = np.zeros((len(zones), len(vavs)))
        Mzb[box_zone, np.arange(len(vavs))] = 1.0
        effects = truth.get("effects", [])
        net = build_network(bld, base["parameters"], base["extras"], effects)
        Ad, Bd = net.discretize(DT)
        nz = len(zones)
        k_hvac = [net.input_index(f"Q_hvac_{z}") for z in zones]
        k_w = [net.input_index(n) for n in ["T_out", "T_fl"] + [f"I_{o}" for o in ORIENTATIONS] + [f"Q_ig_{z}" for z in zones]]
        index = dataset_index(truth["start"], truth["weeks"], truth["timezone"])
        areas = [z["area"] for z in bld["zones"]]
        gains = internal_gains(index, zones, areas, stream(truth["seed"], "occupancy"), base["occupancy"], effects)
        # zone membership of every node (initial states)
        elements = {e["name"]: e for e in bld["elements"]}
        node_zones = []
        for name in net.node_names:
            if ":" in name:
                el = elements[name.split(":")[0]]
                node_zones.append([zidx[s] for s in (el["side1"], el["side2"]) if s in zidx])
            else:
                node_zones.append([zidx[name.rsplit("_", 1)[1]]])
        delay = [e for e in effects if e["name"] == "actuation_delay"]
        dz = zidx[delay[0]["zone"]] if delay else None
        reheat = [e for e in effects if e["name"] == "reheat"]
        rh = None
        if reheat:
            rh = {"zone": zidx[reheat[0]["zone"]], "power": float(reheat[0]["power"]), "below": float(reheat[0]["below"])}
            rh["boxes"] = np.flatnonzero(box_zone == rh["zone"])
        return cls(
            zones=zones,
            vavs=vavs,
            m_min=np.array([v["m_min"] for v in bld["vavs"]], dtype=float),
            m_max=np.array([v["m_max"] for v in bld["vavs"]], dtype=float),
            box_zone=box_zone,
            Mzb=Mzb,
            Ad=Ad,
            Bw=Bd[:, k_w].copy(),
            BQ=Bd[:, k_hvac].copy(),
            node_names=net.node_names,
            node_zones=node_zones,
            Q_ig=gains["Q_ig"],
            T_fl=gains["T_fl"],
            delay_zone=dz,
            delay_minutes=int(round(delay[0]["minutes"])) if delay else 0,
            delay_boxes=np.flatnonzero(box_zone == dz) if delay else np.zeros(0, dtype=int),
            reheat_effect=rh,
        )

    @property
    def n_thermal(self) -> int:
        return self.Ad.shape[0]

    @property
    def n_buffer(self) -> int:
        return 2 * self.delay_minutes * len(self.delay_boxes)

    def w_rows(self, k0, k1, T_out, irradiance):
        """Disturbance rows [T_out, T_fl, I_N..I_W, Q_ig] for minutes k0..k1-1."""
        n = k1 - k0
        w = np.empty((n, self.Bw.shape[1]))
        w[:, 0] = T_out
        w[:, 1] = self.T_fl[k0:k1]
        w[:, 2:6] = irradiance
        w[:, 6:] = self.Q_ig[k0:k1]
        return w


class Plant:
    """The emulated building, steppable from outside (airflows commanded directly).

    Create it with :meth:`from_truth` from a ``truth.json`` mapping. The state
    ``x`` is a flat float array: the thermal nodes followed by the airflow
    history of a delayed zone (``actuation_delay`` effect), so it can be
    saved and restored exactly.

    Examples
    --------
    >>> plant = Plant.from_truth(json.load(open("truth.json")))      # doctest: +SKIP
    >>> x = plant.initial_state([22.0] * 6)                           # doctest: +SKIP
    >>> x, T = plant.advance(x, 0.0, 900.0, m, 15.0, 14.0, [0, 0, 0, 0])  # doctest: +SKIP
    """

    def __init__(self, core: PlantCore, truth: dict):
        self.core = core
        self.truth = truth

    @classmethod
    def from_truth(cls, truth: dict) -> "Plant":
        """Build the plant from a ``truth.json`` mapping (everything needed is in it)."""
        return cls(PlantCore.from_truth(truth), truth)

    @property
    def zones(self) -> tuple:
        return self.core.zones

    @property
    def vavs(self) -> tuple:
        return self.core.vavs

    @property
    def n_states(self) -> int:
        return self.core.n_thermal + self.core.n_buffer

    @property
    def horizon(self) -> float:
        """Seconds from the dataset start for which internal gains are defined."""
        return len(self.core.T_fl) * DT

    def initial_state(self, T_zones, T_out=None) -> np.ndarray:
        """A state with every node at the temperature of its zone(s).

        Parameters
        ----------
        T_zones : array (n_zones,) [°C]
        T_out : float [°C], optional
            Not needed; exterior wall nodes start at their zone's temperature.

        Returns
        -------
        ndarray (n_states,)
            Thermal nodes, then the delay buffer filled with minimum airflows.
        """
        T = np.asarray(T_zones, dtype=float)
        if T.shape != (len(self.zones),):
            raise EmulatorError(f"T_zones must have {len(self.zones)} values ({', '.join(self.zones)}), got shape {T.shape}")
        x = np.array([T[z].mean() for z in self.core.node_zones])
        c = self.core
        if c.delay_minutes:
            buf = np.zeros((c.delay_minutes, len(c.delay_boxes), 2))
            buf[:, :, 0] = c.m_min[c.delay_boxes]
            x = np.concatenate([x, buf.ravel()])
        return x

    def zone_temperatures(self, x) -> np.ndarray:
        """Zone air temperatures [°C] of state ``x``."""
        return np.asarray(x)[: len(self.zones)].copy()

    def advance(self, x, t, dt, m_vav, T_out, T_supply, irradiance, reheat=None):
        """Advance the plant by ``dt`` seconds with inputs held constant.

        Parameters
        ----------
        x : array (n_states,)
        t : float [s]
            Time since the dataset start (multiple of 60 s).
        dt : float [s]
            Multiple of 60 s.
        m_vav : array (n_vav,) [kg/s]
            Airflow of every box, in the order of :attr:`vavs`.
        T_out : float [°C]
        T_supply : float [°C]
        irradiance : array (4,) [W/m2]
            Facade irradiance ``I_N, I_E, I_S, I_W``.
        reheat : array (n_vav,) [W], optional
            Reheat power added to each box's supply air (default none).

        Returns
        -------
        x : ndarray (n_states,)
        T_zones : ndarray (n_zones,) [°C]
            Zone air temperatures at ``t + dt``.
        """
        c = self.core
        problems = []
        k0 = t / DT
        nsub = dt / DT
        if abs(k0 - round(k0)) > 1e-6 or k0 < 0:
            problems.append(f"t = {t} s must be a non-negative multiple of {DT:g} s")
        if abs(nsub - round(nsub)) > 1e-6 or nsub < 1:
            problems.append(f"dt = {dt} s must be a positive multiple of {DT:g} s")
        m = np.asarray(m_vav, dtype=float)
        if m.shape != c.m_min.shape:
            problems.append(f"m_vav must have {len(c.m_min)} values, got shape {m.shape}")
        elif not np.all(np.isfinite(m)) or np.any(m < 0):
            problems.append("m_vav must be finite and >= 0 kg/s")
        irr = np.asarray(irradiance, dtype=float)
        if irr.shape != (4,):
            problems.append(f"irradiance must be [I_N, I_E, I_S, I_W], got shape {irr.shape}")
        if not (np.isfinite(T_out) and np.isfinite(T_supply)) or not np.all(np.isfinite(irr)):
            problems.append("T_out, T_supply and irradiance must be finite")
        x = np.asarray(x, dtype=float)
        if x.shape != (self.n_states,):
            problems.append(f"state must have {self.n_states} values, got shape {x.shape}")
        p = np.zeros_like(c.m_min) if reheat is None else np.asarray(reheat, dtype=float)
        if p.shape != c.m_min.shape:
            problems.append(f"reheat must have {len(c.m_min)} values, got shape {p.shape}")
        if not problems:
            k0, nsub = int(round(k0)), int(round(nsub))
            if k0 + nsub > len(c.T_fl):
                problems.append(
                    f"t + dt = {t + dt} s is beyond the emulated span ({self.horizon:g} s); "
                    "internal gains are only defined there"
                )
        if problems:
            from ..errors import problems_message

            raise EmulatorError(problems_message("Plant.advance", problems))
        nth = c.n_thermal
        xt = x[:nth].copy()
        buf = x[nth:].reshape(c.delay_minutes, len(c.delay_boxes), 2).copy() if c.delay_minutes else None
        W = self.core.w_rows(k0, k0 + nsub, T_out, irr) @ c.Bw.T
        nz = len(self.zones)
        for j in range(nsub):
            m_app, p_app = m, p
            if buf is not None:
                m_app, p_app = m.copy(), p.copy()
                m_app[c.delay_boxes] = buf[0, :, 0]
                p_app[c.delay_boxes] = buf[0, :, 1]
                buf = np.roll(buf, -1, axis=0)
                buf[-1, :, 0] = m[c.delay_boxes]
                buf[-1, :, 1] = p[c.delay_boxes]
            mcp_z = c.Mzb @ (CP_AIR * m_app)
            h_z = c.Mzb @ p_app
            rh = c.reheat_effect
            if rh is not None and T_out < rh["below"] and np.all(m_app[rh["boxes"]] <= c.m_min[rh["boxes"]] + 1e-9):
                h_z = h_z.copy()
                h_z[rh["zone"]] += rh["power"]
            Q = mcp_z * (T_supply - xt[:nz]) + h_z
            xt = c.Ad @ xt + W[j] + c.BQ @ Q
        out = xt if buf is None else np.concatenate([xt, buf.ravel()])
        return out, xt[:nz].copy()
