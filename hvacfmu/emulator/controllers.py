"""Local VAV box controllers, supply-air temperature reset and excitation experiments.

Each VAV box runs a single-maximum reheat sequence on its room temperature
(the zone temperature plus a per-box offset, rooms of a zone are not
identical):

- a cooling PI loop raises the airflow from ``m_min`` to ``m_max`` when the
  room is above the cooling setpoint;
- a heating PI loop keeps the airflow at ``m_min`` and raises the discharge
  temperature with the reheat coil (up to ``reheat_rise`` above the supply air)
  when the room is below the heating setpoint;
- between the two setpoints (dead band) the box sits at ``m_min`` without reheat.

Occupied setpoints apply on weekdays 06:00-20:00 local time, unoccupied
(set-back) setpoints otherwise. Integrators are clamped to [0, 1] (anti-windup).
The controllers run every ``control_interval`` [s] (default 300 s, a typical
BMS trim rate); the thermal model below runs at 60 s.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .weather import _ar1

DEFAULT_CONTROLLERS = {
    "control_interval": 300.0,  # [s]
    "occupied_hours": [6.0, 20.0],  # local time, weekdays
    "heating_setpoint": {"occupied": 21.0, "unoccupied": 20.0},  # [°C]
    "cooling_setpoint": {"occupied": 23.0, "unoccupied": 25.0},  # [°C]
    "box_offset_std": 0.25,  # [K] room vs zone temperature, per box
    "kp": 0.6,  # [1/K] loop output per kelvin
    "integral_time": 900.0,  # [s]
    "reheat_rise": 17.0,  # [K] maximum discharge temperature rise of the reheat coil
    "supply_reset": {"T_out": [12.0, 20.0], "T_supply": [16.0, 13.0], "filter_hours": 2.0, "noise_std": 0.2},
    "excitation": {"probability": 0.4, "start_hour": 8.0, "end_hour": 16.0, "segment_minutes": [45, 120]},
}


def occupied_mode(index: pd.DatetimeIndex, params=None) -> np.ndarray:
    """Occupied mode of the BMS schedule (weekdays, local wall clock) for each timestamp."""
    p = params or DEFAULT_CONTROLLERS
    h0, h1 = p["occupied_hours"]
    hour = np.asarray(index.hour) + np.asarray(index.minute) / 60.0
    workday = np.asarray(index.day_of_week) < 5
    if p.get("holidays"):  # closed on the building's holidays (make_truth's ``holidays``)
        workday &= ~np.isin(np.asarray(index.strftime("%Y-%m-%d")), list(p["holidays"]))
    return workday & (hour >= h0) & (hour < h1)


#: ``generate(schedule=...)``: ``always-on`` (default: the boxes never go below ``m_min``, unoccupied hours only
#: set back the set points) or ``night-off`` (the system is off outside the occupied hours: every box at zero
#: airflow without reheat, the air handlers off; it restarts ``startup_hours`` before occupancy).
SCHEDULES = ("always-on", "night-off")

#: Settings of the ``night-off`` schedule (``truth["baseline"]["controllers"]["schedule"]``).
NIGHT_OFF = {
    "mode": "night-off",
    "startup_hours": 1.0,  # [h] the system starts this long before the occupied hours (morning warm-up/cool-down)
    "idle_hours": 1.0,  # [h] time constant of the idle duct: T_supply relaxes to the mean room air of its unit
}


def system_on(index: pd.DatetimeIndex, params=None) -> np.ndarray:
    """Whether the HVAC system runs at each timestamp: always, or (``night-off``) the occupied hours
    of :func:`occupied_mode` started ``startup_hours`` early."""
    p = params or DEFAULT_CONTROLLERS
    sched = p.get("schedule")
    if not isinstance(sched, dict) or sched.get("mode", "always-on") == "always-on":
        return np.ones(len(index), dtype=bool)
    early = index + pd.Timedelta(hours=float(sched.get("startup_hours", 0.0)))
    return occupied_mode(index, p) | occupied_mode(early, p)


def idle_supply_temperature(T_supply, on, T_room, dt=60.0, hours=1.0):
    """The supply-air sensor of a unit that is off part of the time [°C], same shape as ``T_supply``.

    While ``on`` (per row) it reads the unit's supply air; while off, the still duct relaxes from
    its last value toward the mean room air ``T_room`` (per row, or per row and unit) with the time
    constant ``hours``.
    """
    Ts = np.array(T_supply, dtype=float, copy=True)
    two = Ts.ndim == 2
    Ts2 = Ts if two else Ts[:, None]
    room = np.asarray(T_room, dtype=float)
    room = room if room.ndim == 2 else np.repeat(room[:, None], Ts2.shape[1], axis=1)
    a = float(np.exp(-dt / (hours * 3600.0)))
    off = np.flatnonzero(~np.asarray(on, dtype=bool))
    for k in off:
        prev = Ts2[k - 1] if k > 0 else room[k]
        Ts2[k] = a * prev + (1.0 - a) * room[k]
    return Ts2 if two else Ts2[:, 0]


def supply_air_temperature(T_out, rng, params=None, dt=60.0):
    """Supply-air temperature [°C] of the air handler from its outdoor-air reset schedule.

    The set point is linear in the (low-pass filtered) outdoor temperature, from
    16 °C at 12 °C outdoor to 13 °C at 20 °C outdoor (clamped), plus a slow
    AR(1) control error.
    """
    import scipy.signal

    p = (params or DEFAULT_CONTROLLERS)["supply_reset"]
    a = float(np.exp(-dt / (p["filter_hours"] * 3600.0)))
    filt, _ = scipy.signal.lfilter([1 - a], [1.0, -a], T_out, zi=[a * T_out[0]])
    setpoint = np.interp(filt, p["T_out"], p["T_supply"])
    return setpoint + _ar1(rng, len(T_out), 30.0, p["noise_std"])


#: Supply-air reset of the two air handlers of the ``reheat`` HVAC mode (perimeter unit AHU1 warmer in
#: cold weather, interior unit AHU2 nearly constant: the core needs cooling all year).
REHEAT_MODE_AHUS = {
    "AHU1": {"T_out": [0.0, 20.0], "T_supply": [15.5, 13.0], "filter_hours": 2.0, "noise_std": 0.2},
    "AHU2": {"T_out": [10.0, 24.0], "T_supply": [13.8, 12.8], "filter_hours": 4.0, "noise_std": 0.15},
}


def supply_air_temperatures(T_out, seed_stream, params, ahus=()):
    """Supply-air temperature of every air handler [°C], shape (n,) with one implicit unit or (n, n_ahu).

    ``params["ahus"]`` maps unit names to their own ``supply_reset`` tables; the
    first unit uses the random stream ``"supply"`` (as the single unit does),
    the others ``"supply_<name>"``. ``seed_stream(name)`` returns a generator.
    """
    if not ahus:
        return supply_air_temperature(T_out, seed_stream("supply"), params)
    cols = []
    for i, name in enumerate(ahus):
        p = {"supply_reset": params["ahus"][name]}
        cols.append(supply_air_temperature(T_out, seed_stream("supply" if i == 0 else f"supply_{name}"), p))
    return np.column_stack(cols)


def excitation_schedule(index: pd.DatetimeIndex, rng, n_zones, params=None):
    """Forced-response experiments on some Saturdays.

    Returns
    -------
    list of dict
        ``start``, ``end`` (minute indices, end exclusive) and ``levels``
        (n_zones,) airflow fractions in [0, 1] between ``m_min`` and ``m_max``,
        one dict per segment.
    """
    p = (params or DEFAULT_CONTROLLERS)["excitation"]
    local = index.tz_localize(None)
    day = local.as_unit("s").asi8 // 86400
    dow = np.asarray(local.day_of_week)
    hour = np.asarray(local.hour) + np.asarray(local.minute) / 60.0
    saturdays = np.unique(day[dow == 5])
    chosen = saturdays[rng.random(len(saturdays)) < p["probability"]]
    if len(chosen) == 0 and len(saturdays) > 0:
        chosen = saturdays[[rng.integers(len(saturdays))]]
    segments = []
    lo, hi = p["segment_minutes"]
    for d in chosen:
        idx = np.flatnonzero((day == d) & (hour >= p["start_hour"]) & (hour < p["end_hour"]))
        if len(idx) == 0:
            continue
        k, end = int(idx[0]), int(idx[-1]) + 1
        while k < end:
            length = int(rng.integers(lo, hi + 1))
            levels = rng.choice([0.0, 0.5, 1.0], size=n_zones, p=[0.4, 0.2, 0.4])
            segments.append({"start": k, "end": min(k + length, end), "levels": levels})
            k += length
    return segments


class VavControllers:
    """Vectorised PI controllers of all VAV boxes (see the module docstring).

    Parameters
    ----------
    m_min, m_max : array (n_vav,) [kg/s]
    box_zone : array of int (n_vav,)
        Zone index of each box.
    offsets : array (n_vav,) [K]
        Room-minus-zone temperature of each box.
    params : dict
        With ``T_discharge_max`` [°C] (``reheat`` mode) the heating loop output
        sets the discharge temperature between the box's supply temperature and
        that limit (``step(..., T_supply_box)``); otherwise it scales the fixed
        coil power ``m_min c_p reheat_rise``. With ``heating_sequence = "dual"``
        the first half of the heating output raises the discharge air to its
        limit, the second half the airflow up to ``heating_max_fraction * m_max``.
    """

    def __init__(self, m_min, m_max, box_zone, offsets, params=None):
        p = params or DEFAULT_CONTROLLERS
        self.m_min = np.asarray(m_min, dtype=float)
        self.m_span = np.asarray(m_max, dtype=float) - self.m_min
        self.box_zone = np.asarray(box_zone, dtype=int)
        self.offsets = np.asarray(offsets, dtype=float)
        self.kp = float(p["kp"])
        self.ki_dt = self.kp * float(p["control_interval"]) / float(p["integral_time"])
        self.sp = {
            True: (float(p["heating_setpoint"]["occupied"]), float(p["cooling_setpoint"]["occupied"])),
            False: (float(p["heating_setpoint"]["unoccupied"]), float(p["cooling_setpoint"]["unoccupied"])),
        }
        self.rh_max = self.m_min * 1005.0 * float(p["reheat_rise"])  # [W] per box at m_min
        self.T_discharge_max = p.get("T_discharge_max")
        self.dual = p.get("heating_sequence", "single") == "dual"
        self.m_heat = np.maximum(float(p.get("heating_max_fraction", 0.0)) * np.asarray(m_max, dtype=float), self.m_min)
        n = len(self.m_min)
        self.Ic = np.zeros(n)
        self.Ih = np.zeros(n)

    def step(self, T_zone, occupied: bool, T_supply_box=None):
        """One control interval: zone temperatures [°C] -> (airflow [kg/s], reheat power [W]) per box.

        ``T_supply_box`` [°C] (per box) is needed with ``T_discharge_max``.
        """
        sph, spc = self.sp[bool(occupied)]
        Tb = T_zone[self.box_zone] + self.offsets
        ec = Tb - spc
        eh = sph - Tb
        mn, mx = np.minimum, np.maximum
        self.Ic = mn(mx(self.Ic + self.ki_dt * ec, 0.0), 1.0)
        self.Ih = mn(mx(self.Ih + self.ki_dt * eh, 0.0), 1.0)
        yc = mn(mx(self.kp * ec + self.Ic, 0.0), 1.0)
        yh = mn(mx(self.kp * eh + self.Ih, 0.0), 1.0)
        if self.T_discharge_max is None:
            return self.m_min + yc * self.m_span, yh * self.rh_max
        rise = np.maximum(float(self.T_discharge_max) - np.asarray(T_supply_box, dtype=float), 0.0)
        if not self.dual:
            return self.m_min + yc * self.m_span, yh * self.m_min * 1005.0 * rise
        # dual maximum: first half of the heating output raises the discharge air, second half the airflow
        stage1, stage2 = mn(2.0 * yh, 1.0), mx(2.0 * yh - 1.0, 0.0)
        m = mx(self.m_min + yc * self.m_span, self.m_min + stage2 * (self.m_heat - self.m_min))
        return m, stage1 * m * 1005.0 * rise

    def reset(self):
        self.Ic[:] = 0.0
        self.Ih[:] = 0.0
