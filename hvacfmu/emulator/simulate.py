"""Closed-loop simulation of the emulated floor: weather, occupancy, VAV controllers, RC network.

The loop runs the controllers every ``control_interval`` (5 minutes) and the
thermal model every minute. Within a control interval the airflows are fixed,
so the bilinear airflow term folds into a per-interval matrix
``A_k = Ad - BQ diag(m_z c_p) S`` (S selects the zone air nodes) and the
per-minute work is one dense mat-vec; disturbance terms are precomputed as
arrays one week at a time. The arithmetic is the same as
:meth:`hvacfmu.emulator.plant.Plant.advance` with 60 s steps.
"""

from __future__ import annotations

import numpy as np

from .controllers import (
    DEFAULT_CONTROLLERS,
    VavControllers,
    excitation_schedule,
    idle_supply_temperature,
    occupied_mode,
    supply_air_temperatures,
    system_on,
)
from .plant import DT, PlantCore, dataset_index, site_wind, stream
from .thermal import CP_AIR
from .weather import synthetic_weather

SPIN_UP_DAYS = 7


def simulate(truth: dict) -> dict:
    """Simulate the dataset described by ``truth`` (noise-free "true" signals).

    Parameters
    ----------
    truth : dict
        The truth mapping (see :func:`hvacfmu.emulator.generate`); its
        ``baseline.controllers.box_offsets`` must be set.

    Returns
    -------
    dict
        ``index`` (DatetimeIndex), ``T_zone`` (n, nz) [°C], ``m_vav`` (n, nb)
        logged airflow [kg/s], ``m_applied`` (n, nb) airflow delivered [kg/s],
        ``reheat`` (n, nb) reheat power delivered [W], ``reheat_command`` (n, nb)
        reheat power commanded [W], ``T_supply`` (n,) or, with several air handlers
        (``reheat`` mode), (n, n_ahu) in the order of ``ahus``, ``ahus`` (tuple of names),
        ``box_ahu`` (n_vav,) unit index of every box, ``system_on`` (n,) bool: the air handlers run
        (always, unless the ``night-off`` schedule shut them; then ``T_supply`` reads the idle duct),
        ``T_out`` (n,) [°C], ``ghi`` (n,), ``wind`` (n,) [m/s], ``I`` (n, 4) [W/m2], ``Q_ig`` (n, nz) [W],
        ``T_fl`` (n,) [°C], ``excitation`` (n,) bool, ``segments`` (excitation
        segments), ``x0`` initial state in :class:`Plant` layout, ``weather`` (dict).
    """
    base = truth["baseline"]
    seed = truth["seed"]
    core = PlantCore.from_truth(truth)
    index = dataset_index(truth["start"], truth["weeks"], truth["timezone"])
    bld = base["building"]
    weather = synthetic_weather(
        index, stream(seed, "weather"), bld["latitude"], bld["longitude"], base["altitude"], base.get("climate")
    )
    cp = base["controllers"]
    T_supply = supply_air_temperatures(weather["T_out"], lambda name: stream(seed, name), cp, core.ahus)
    segments = excitation_schedule(index, stream(seed, "excitation"), len(core.zones), cp)
    weather["wind"] = site_wind(truth, index)  # its own stream: the series above are unchanged
    sim = _ClosedLoop(core, cp, index, weather, T_supply, segments)

    x = np.full(core.n_thermal, 22.0)
    x = sim.run(0, min(sim.n, SPIN_UP_DAYS * 1440), x, record=False)
    x0 = np.concatenate([x, sim.delay_buffer()]) if sim.d_blocks else x.copy()
    sim.run(0, sim.n, x, record=True)
    per = sim.per
    unit_on = np.repeat(sim.unit_on, per)
    T_logged = T_supply
    if not unit_on.all():  # night-off: the supply-air sensor of a unit that is off reads its idle duct
        T_logged = idle_supply_temperature(T_supply, unit_on, _unit_rooms(sim.Y, core), DT, _idle_hours(cp))
    return {
        "index": index,
        "T_zone": sim.Y,
        "m_vav": np.repeat(sim.m_log, per, axis=0),
        "m_applied": np.repeat(sim.m_app_log, per, axis=0),
        "reheat": np.repeat(sim.p_app_log, per, axis=0),
        "reheat_command": np.repeat(sim.p_log, per, axis=0),
        "T_supply": T_logged,
        "system_on": unit_on,
        "ahus": core.ahus,
        "box_ahu": core.box_ahu,
        "T_out": weather["T_out"],
        "ghi": weather["ghi"],
        "wind": weather["wind"],
        "I": sim.irr,
        "Q_ig": core.Q_ig,
        "T_fl": core.T_fl,
        "excitation": sim.exc_flag,
        "segments": segments,
        "x0": x0,
        "weather": weather,
        "core": core,
    }


class _ClosedLoop:
    """The building under its box controllers, minute by minute, one control interval at a time.

    Holds the plant matrices, the controllers, the actuation-delay ring buffer and, for a recorded
    run, the logs of commanded and delivered airflow and reheat per control interval and the zone
    temperatures per minute.
    """

    chunk = 7 * 1440  # minutes of disturbance rows computed at once

    def __init__(self, core: PlantCore, cp: dict, index, weather: dict, T_supply: np.ndarray, segments: list):
        self.core, self.weather, self.T_supply = core, weather, T_supply
        self.n = n = len(index)
        self.multi = T_supply.ndim == 2
        self.irr = np.column_stack([weather[f"I_{o}"] for o in ("N", "E", "S", "W")])
        self.per = per = int(round(cp["control_interval"] / DT))
        if n % per:
            raise ValueError("dataset length must be a multiple of the control interval")
        self._excitation(segments, n // per)
        self.occ_block = occupied_mode(index, cp)[::per]
        self.on_block = system_on(index, cp)[::per]  # night-off schedule: False while the system is off
        self.unit_on = self.on_block | (self.exc_block >= 0)  # an experiment runs the system
        he = core.heater_effect
        self.heater_minute = None if he is None else he["power"] * (weather["T_out"] < he["below"])
        self.ctrl = VavControllers(core.m_min, core.m_max, core.box_zone, cp["box_offsets"], cp)
        rh = core.reheat_effect
        self.rh_minute = None if rh is None else rh["power"] * (weather["T_out"] < rh["below"])
        # delay ring buffer in control intervals
        self.d_blocks = core.delay_minutes // per if core.delay_minutes else 0
        self.ring_m = np.tile(core.m_min[core.delay_boxes], (max(self.d_blocks, 1), 1))
        self.ring_p = np.zeros_like(self.ring_m)
        nz, nb, n_blocks = len(core.zones), len(core.vavs), n // per
        self.m_log = np.empty((n_blocks, nb))
        self.m_app_log = np.empty((n_blocks, nb))
        self.p_log = np.empty((n_blocks, nb))
        self.p_app_log = np.empty((n_blocks, nb))
        self.Y = np.empty((n, nz))
        self.A_b = core.Ad.copy()  # per control interval: Ad - BQ diag(m_z c_p) on the air-node columns
        self.Ad_air = core.Ad[:, :nz].copy()
        self.Mzb_cp = core.Mzb * CP_AIR
        self.X = np.empty((per + 1, core.n_thermal))  # states of one control interval

    def _excitation(self, segments: list, n_blocks: int) -> None:
        """Control intervals forced by an excitation segment, and each segment's airflows."""
        core, per = self.core, self.per
        self.exc_block = np.full(n_blocks, -1)
        self.exc_flag = np.zeros(self.n, dtype=bool)
        self.exc_m = []
        for s_i, seg in enumerate(segments):
            b0, b1 = seg["start"] // per, -(-seg["end"] // per)
            self.exc_block[b0:b1] = s_i
            self.exc_flag[b0 * per : b1 * per] = True
            frac = np.asarray(seg["levels"])[core.box_zone]
            self.exc_m.append(core.m_min + frac * (core.m_max - core.m_min))

    def _commands(self, b: int, x: np.ndarray) -> tuple:
        """Commanded ``(m, p)`` of control interval ``b`` and what the boxes deliver ``(m_a, p_a)`` after the delay."""
        core, nz = self.core, len(self.core.zones)
        e = self.exc_block[b]
        if e >= 0:
            m, p = self.exc_m[e], np.zeros(len(core.vavs))
            self.ctrl.reset()
        elif not self.on_block[b]:  # night-off: boxes shut, no reheat; the loops restart from zero
            m, p = np.zeros(len(core.vavs)), np.zeros(len(core.vavs))
            self.ctrl.reset()
        else:
            k0 = b * self.per
            m, p = self.ctrl.step(x[:nz], self.occ_block[b], self.T_supply[k0, core.box_ahu] if self.multi else None)
        if not self.d_blocks:
            return m, p, m, p
        db, slot = core.delay_boxes, b % self.d_blocks
        m_a, p_a = m.copy(), p.copy()
        m_a[db] = self.ring_m[slot]
        p_a[db] = self.ring_p[slot]
        self.ring_m[slot] = m[db]
        self.ring_p[slot] = p[db]
        return m, p, m_a, p_a

    def _forcing(self, k0: int, Wk: np.ndarray, m_a: np.ndarray, p_a: np.ndarray) -> np.ndarray:
        """Set ``A_b`` for the delivered airflow and return the per-minute forcing of one control interval."""
        core, per, BQ = self.core, self.per, self.core.BQ
        mcp_z = self.Mzb_cp @ m_a
        h_z = core.Mzb @ p_a
        np.subtract(self.Ad_air, BQ * mcp_z, out=self.A_b[:, : len(core.zones)])
        if self.multi:  # per-box supply temperature: sum_i m_i c_p T_supply,i per zone
            sup = (self.T_supply[k0 : k0 + per][:, core.box_ahu] * (CP_AIR * m_a)) @ core.Mzb.T
            D = Wk + BQ @ h_z + sup @ BQ.T
        else:
            D = Wk + BQ @ h_z + self.T_supply[k0 : k0 + per, None] * (BQ @ mcp_z)
        rh = core.reheat_effect
        if rh is not None and np.all(m_a[rh["boxes"]] <= core.m_min[rh["boxes"]] + 1e-9):
            D += np.outer(self.rh_minute[k0 : k0 + per], BQ[:, rh["zone"]])
        he = core.heater_effect
        hm = self.heater_minute
        if he is not None and hm is not None and np.all(m_a[he["boxes"]] <= 0.0):  # off_hours_heater: boxes shut
            D += np.outer(hm[k0 : k0 + per], BQ[:, he["zone"]])
        we = core.wind_effect
        if we is not None:  # g (T_out - T_z) into the zone air: g of this control interval
            z = we["zone"]
            g = we["g"][min(k0 // we["per"], len(we["g"]) - 1)]
            self.A_b[:, z] -= BQ[:, z] * g
            D += np.outer(self.weather["T_out"][k0 : k0 + per] * g, BQ[:, z])
        return D

    def run(self, k_start: int, k_end: int, x: np.ndarray, record: bool) -> np.ndarray:
        """Advance from minute ``k_start`` to ``k_end`` (multiples of the control interval); returns the state."""
        core, per, X, nz = self.core, self.per, self.X, len(self.core.zones)
        W = None
        w0 = -1
        for b in range(k_start // per, k_end // per):
            k0 = b * per
            if W is None or k0 >= w0 + self.chunk:
                w0, w1 = k0, min(k0 + self.chunk, self.n)
                W = core.w_rows(w0, w1, self.weather["T_out"][w0:w1], self.irr[w0:w1]) @ core.Bw.T
            m, p, m_a, p_a = self._commands(b, x)
            D = self._forcing(k0, W[k0 - w0 : k0 - w0 + per], m_a, p_a)
            X[0] = x
            for j in range(per):
                np.dot(self.A_b, X[j], out=X[j + 1])
                X[j + 1] += D[j]
            x = X[per].copy()
            if record:
                self.m_log[b], self.p_log[b], self.m_app_log[b], self.p_app_log[b] = m, p, m_a, p_a
                self.Y[k0 : k0 + per] = X[:per, :nz]
        return x

    def delay_buffer(self) -> np.ndarray:
        """The delay ring buffer per minute, oldest first, flattened (the tail of :class:`Plant`'s state)."""
        core, per = self.core, self.per
        # block b of the recorded run reads slot b % d_blocks: slots 0, 1, ... are oldest first
        buf = np.zeros((core.delay_minutes, len(core.delay_boxes), 2))
        for slot in range(self.d_blocks):
            buf[slot * per : (slot + 1) * per, :, 0] = self.ring_m[slot]
            buf[slot * per : (slot + 1) * per, :, 1] = self.ring_p[slot]
        return buf.ravel()


def _idle_hours(cp: dict) -> float:
    return float((cp.get("schedule") or {}).get("idle_hours", 1.0))


def _unit_rooms(T_zone: np.ndarray, core: PlantCore) -> np.ndarray:
    """Mean room air [°C] of every air handler's zones per row: (n,) with one unit, else (n, n_ahu)."""
    if not core.ahus:
        return T_zone.mean(axis=1)
    cols = [T_zone[:, np.unique(core.box_zone[core.box_ahu == i])].mean(axis=1) for i in range(len(core.ahus))]
    return np.column_stack(cols)


def controller_defaults(seed: int, n_vav: int) -> dict:
    """Controller settings of the dataset, with the per-box room offsets drawn from the seed."""
    p = {k: (dict(v) if isinstance(v, dict) else v) for k, v in DEFAULT_CONTROLLERS.items()}
    rng = stream(seed, "controllers")
    p["box_offsets"] = [round(float(v), 4) for v in rng.normal(0.0, p["box_offset_std"], n_vav)]
    return p


def discharge_temperature(sim: dict) -> np.ndarray:
    """Discharge air temperature of every box [°C], (n, n_vav): supply of its unit plus the reheat rise.

    ``Td = T_supply,box + P_delivered / (m_delivered c_p)``, the air the box actually
    delivers (after an actuation delay).
    """
    Ts = sim["T_supply"]
    Ts_box = Ts[:, sim["box_ahu"]] if Ts.ndim == 2 else Ts[:, None]
    return Ts_box + sim["reheat"] / (np.maximum(sim["m_applied"], 1e-6) * CP_AIR)
