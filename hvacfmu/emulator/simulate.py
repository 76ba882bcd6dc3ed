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
    occupied_mode,
    supply_air_temperatures,
)
from .plant import DT, PlantCore, dataset_index, stream
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
        ``box_ahu`` (n_vav,) unit index of every box,
        ``T_out`` (n,) [°C], ``ghi`` (n,), ``I`` (n, 4) [W/m2], ``Q_ig`` (n, nz) [W],
        ``T_fl`` (n,) [°C], ``excitation`` (n,) bool, ``segments`` (excitation
        segments), ``x0`` initial state in :class:`Plant` layout, ``weather`` (dict).
    """
    base = truth["baseline"]
    seed = truth["seed"]
    core = PlantCore.from_truth(truth)
    index = dataset_index(truth["start"], truth["weeks"], truth["timezone"])
    n = len(index)
    bld = base["building"]
    weather = synthetic_weather(
        index, stream(seed, "weather"), bld["latitude"], bld["longitude"], base["altitude"], base.get("climate")
    )
    cp = base["controllers"]
    T_supply = supply_air_temperatures(weather["T_out"], lambda name: stream(seed, name), cp, core.ahus)
    multi = T_supply.ndim == 2
    irr = np.column_stack([weather[f"I_{o}"] for o in ("N", "E", "S", "W")])
    occupied = occupied_mode(index, cp)
    nz, nb = len(core.zones), len(core.vavs)
    segments = excitation_schedule(index, stream(seed, "excitation"), nz, cp)

    per = int(round(cp["control_interval"] / DT))
    if n % per:
        raise ValueError("dataset length must be a multiple of the control interval")
    n_blocks = n // per
    exc_block = np.full(n_blocks, -1)
    exc_flag = np.zeros(n, dtype=bool)
    exc_m = []
    for s_i, seg in enumerate(segments):
        b0, b1 = seg["start"] // per, -(-seg["end"] // per)
        exc_block[b0:b1] = s_i
        exc_flag[b0 * per : b1 * per] = True
        frac = np.asarray(seg["levels"])[core.box_zone]
        exc_m.append(core.m_min + frac * (core.m_max - core.m_min))
    occ_block = occupied[::per]

    ctrl = VavControllers(core.m_min, core.m_max, core.box_zone, cp["box_offsets"], cp)
    rh = core.reheat_effect
    rh_minute = None
    if rh is not None:
        rh_minute = rh["power"] * (weather["T_out"] < rh["below"])
    # delay ring buffer in control intervals
    d_blocks = core.delay_minutes // per if core.delay_minutes else 0
    db = core.delay_boxes
    ring_m = np.tile(core.m_min[db], (max(d_blocks, 1), 1))
    ring_p = np.zeros_like(ring_m)

    m_log = np.empty((n_blocks, nb))
    m_app_log = np.empty((n_blocks, nb))
    p_log = np.empty((n_blocks, nb))
    p_app_log = np.empty((n_blocks, nb))
    Y = np.empty((n, nz))
    Ad, BQ, Bw = core.Ad, core.BQ, core.Bw
    A_b = Ad.copy()  # per control interval: Ad - BQ diag(m_z c_p) on the air-node columns
    A_air = A_b[:, :nz]  # view
    Mzb_cp = core.Mzb * CP_AIR
    X = np.empty((per + 1, core.n_thermal))  # states of one control interval
    Ad_air = Ad[:, :nz].copy()
    chunk = 7 * 1440

    def run(k_start, k_end, x, record):
        nonlocal ring_m, ring_p
        W = None
        w0 = -1
        for b in range(k_start // per, k_end // per):
            k0 = b * per
            if W is None or k0 >= w0 + chunk:
                w0 = k0
                w1 = min(k0 + chunk, n)
                W = core.w_rows(w0, w1, weather["T_out"][w0:w1], irr[w0:w1]) @ Bw.T
            Tz = x[:nz]
            e = exc_block[b]
            if e >= 0:
                m = exc_m[e]
                p = np.zeros(nb)
                ctrl.reset()
            else:
                m, p = ctrl.step(Tz, occ_block[b], T_supply[k0, core.box_ahu] if multi else None)
            m_a, p_a = m, p
            if d_blocks:
                slot = b % d_blocks
                m_a, p_a = m.copy(), p.copy()
                m_a[db] = ring_m[slot]
                p_a[db] = ring_p[slot]
                ring_m[slot] = m[db]
                ring_p[slot] = p[db]
            mcp_z = Mzb_cp @ m_a
            h_z = core.Mzb @ p_a
            np.subtract(Ad_air, BQ * mcp_z, out=A_air)
            if multi:  # per-box supply temperature: sum_i m_i c_p T_supply,i per zone
                sup = (T_supply[k0 : k0 + per][:, core.box_ahu] * (CP_AIR * m_a)) @ core.Mzb.T
                D = W[k0 - w0 : k0 - w0 + per] + BQ @ h_z + sup @ BQ.T
            else:
                D = W[k0 - w0 : k0 - w0 + per] + BQ @ h_z + T_supply[k0 : k0 + per, None] * (BQ @ mcp_z)
            if rh is not None and np.all(m_a[rh["boxes"]] <= core.m_min[rh["boxes"]] + 1e-9):
                D += np.outer(rh_minute[k0 : k0 + per], BQ[:, rh["zone"]])
            X[0] = x
            for j in range(per):
                np.dot(A_b, X[j], out=X[j + 1])
                X[j + 1] += D[j]
            x = X[per].copy()
            if record:
                m_log[b] = m
                p_log[b] = p
                m_app_log[b] = m_a
                p_app_log[b] = p_a
                Y[k0 : k0 + per] = X[:per, :nz]
        return x

    x = np.full(core.n_thermal, 22.0)
    x = run(0, min(n, SPIN_UP_DAYS * 1440), x, record=False)
    x0 = x.copy()
    if d_blocks:
        # block b of the recorded run reads slot b % d_blocks: slots 0, 1, ... are oldest first
        buf = np.zeros((core.delay_minutes, len(db), 2))
        for i, slot in enumerate(range(d_blocks)):
            buf[i * per : (i + 1) * per, :, 0] = ring_m[slot]
            buf[i * per : (i + 1) * per, :, 1] = ring_p[slot]
        x0 = np.concatenate([x0, buf.ravel()])
    run(0, n, x, record=True)

    return {
        "index": index,
        "T_zone": Y,
        "m_vav": np.repeat(m_log, per, axis=0),
        "m_applied": np.repeat(m_app_log, per, axis=0),
        "reheat": np.repeat(p_app_log, per, axis=0),
        "reheat_command": np.repeat(p_log, per, axis=0),
        "T_supply": T_supply,
        "ahus": core.ahus,
        "box_ahu": core.box_ahu,
        "T_out": weather["T_out"],
        "ghi": weather["ghi"],
        "I": irr,
        "Q_ig": core.Q_ig,
        "T_fl": core.T_fl,
        "excitation": exc_flag,
        "segments": segments,
        "x0": x0,
        "weather": weather,
        "core": core,
    }


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
