"""Internal heat gains from occupancy, lights and equipment, and the floors above/below.

Per zone the gain is ``area * (base + peak * occupancy)`` [W], where
``occupancy`` in [0, ~1.2] follows a daily profile (smooth arrival and
departure with random times per day, a lunch dip), a level that depends on the
academic calendar (semesters vs winter break and summer, i.e. the building's
seasons), weekday vs weekend, and day-to-day and minute-to-minute randomness.
The core zone ``C`` has conference rooms: random one-hour meetings on
weekdays. Baseline schedules follow the local wall clock (daylight saving
included) and contain no public holidays; the ``internal_gain_schedule``
effect adds holiday weeks or a daylight-saving shift.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import scipy.signal

DEFAULT_OCCUPANCY = {
    "base_gain": 5.0,  # [W/m2] always-on equipment and lights
    "peak_gain": {"NW": 12.0, "W": 16.0, "S": 16.0, "E": 16.0, "NE": 12.0, "C": 13.0},  # [W/m2]
    "season_level": {"fall": 1.0, "winter": 0.45, "spring": 1.0, "summer": 0.6},
    "weekend_level": {"Sat": 0.14, "Sun": 0.08},
    "arrival": [8.3, 0.35],  # weekday arrival hour: mean, std [h]
    "departure": [17.6, 0.5],  # weekday departure hour: mean, std [h]
    "day_factor_std": 0.10,  # lognormal std of the day-to-day level, common to all zones
    "zone_factor_std": 0.10,  # lognormal std of the day-to-day level per zone
    "minute_noise_std": 0.08,  # relative AR(1) noise, 15-min time constant
    "meeting_zone": "C",
    "meeting_probability": 0.35,  # per weekday hour 9..17
    "meeting_gain": 2500.0,  # [W]
    "adjacent_floor": {"mean": 21.8, "workday_rise": 0.7, "noise_std": 0.25},  # [°C]
}


def _season_of_day(month, day):
    md = (month, day)
    if (9, 1) <= md <= (12, 15):
        return "fall"
    if md >= (12, 16) or md <= (1, 25):
        return "winter"
    if (1, 26) <= md <= (5, 15):
        return "spring"
    return "summer"


def _clock(index, standard_time):
    """Days (float) of the local clock since 1970; standard time (UTC-8 style) if asked."""
    if standard_time:
        off = index[0].utcoffset()
        dst = index[0].dst() or pd.Timedelta(0)
        std_offset = (off - dst).total_seconds()
        secs = index.as_unit("s").asi8 + int(std_offset)
    else:
        secs = index.tz_localize(None).as_unit("s").asi8
    return secs / 86400.0


def _profile(hour, arrive, depart):
    rise = 1.0 / (1.0 + np.exp(-(hour - arrive) / 0.35))
    fall = 1.0 / (1.0 + np.exp(-(depart - hour) / 0.5))
    lunch = 1.0 - 0.2 * np.exp(-(((hour - 12.4) / 0.5) ** 2))
    return rise * fall * lunch


def internal_gains(index: pd.DatetimeIndex, zones, areas, rng: np.random.Generator, params=None, effects=()):
    """Internal gains per zone and the temperature of the floors above and below.

    Parameters
    ----------
    index : DatetimeIndex
        Tz-aware one-minute index (local time zone of the building).
    zones : sequence of str
    areas : sequence of float [m2]
    rng : numpy Generator
        Dedicated stream: the same stream gives the same gains.
    params : dict, optional
        Defaults :data:`DEFAULT_OCCUPANCY`.
    effects : sequence of dict
        Resolved effects; ``internal_gain_schedule`` changes the gains.

    Returns
    -------
    dict
        ``Q_ig`` (n, n_zones) [W], ``occupancy`` (n,) floor-average occupancy [-],
        ``T_fl`` (n,) [°C] air temperature of the floors above and below,
        ``holiday_weeks`` list of int.
    """
    p = dict(DEFAULT_OCCUPANCY)
    p.update(params or {})
    n = len(index)
    zones = list(zones)
    areas = np.asarray(areas, dtype=float)
    nz = len(zones)
    sched = [e for e in effects if e["name"] == "internal_gain_schedule"]
    dst_shift = any(e.get("kind") == "dst" for e in sched)
    holiday_weeks = sorted({int(w) for e in sched if e.get("kind") == "holiday" for w in e["weeks"]})

    wall_days = _clock(index, False)
    base_day = np.floor(wall_days[0])
    n_days = int(np.ceil(wall_days[-1] - base_day)) + 3
    # random draws: fixed order and sizes, independent of effects
    arrive = rng.normal(p["arrival"][0], p["arrival"][1], n_days)
    depart = rng.normal(p["departure"][0], p["departure"][1], n_days)
    arrive_we = rng.normal(10.5, 0.8, n_days)
    depart_we = rng.normal(16.0, 1.0, n_days)
    f_day = np.exp(rng.normal(0.0, p["day_factor_std"], n_days))
    f_zone = np.exp(rng.normal(0.0, p["zone_factor_std"], (n_days, nz)))
    meetings = rng.random((n_days, 24)) < p["meeting_probability"]
    a = float(np.exp(-1.0 / 15.0))
    e = rng.standard_normal((n, nz)) * p["minute_noise_std"] * np.sqrt(1 - a * a)
    noise = scipy.signal.lfilter([1.0], [1.0, -a], e, axis=0)
    fl_noise_e = rng.standard_normal(n) * p["adjacent_floor"]["noise_std"] * np.sqrt(1 - np.exp(-2 / 360.0))
    fl_noise = scipy.signal.lfilter([1.0], [1.0, -np.exp(-1 / 360.0)], fl_noise_e)

    dates = pd.to_datetime((base_day + np.arange(n_days)) * 86400, unit="s")
    dow = np.asarray(dates.day_of_week)
    # a public holiday the building closes on (make_truth's ``holidays``) is a Sunday
    dow = np.where(np.isin(dates.strftime("%Y-%m-%d"), list(p.get("holidays", ()))), 6, dow)
    level = np.array([p["season_level"][_season_of_day(m, d)] for m, d in zip(dates.month, dates.day)])
    weekday = dow < 5
    level = np.where(dow == 5, p["weekend_level"]["Sat"], np.where(dow == 6, p["weekend_level"]["Sun"], level))
    level_base = level.copy()
    week_of_day = np.arange(n_days) // 7  # weeks counted from the first local midnight
    for w in holiday_weeks:
        mask = (week_of_day == w) & weekday
        level = np.where(mask, 0.2 * level, level)

    def occupancy_of(days, lev):
        d = np.clip((np.floor(days) - base_day).astype(int), 0, n_days - 1)
        hour = (days - np.floor(days)) * 24.0
        prof = np.where(weekday[d], _profile(hour, arrive[d], depart[d]), _profile(hour, arrive_we[d], depart_we[d]))
        return d, hour, lev[d] * f_day[d] * prof

    _, _, occ_base = occupancy_of(wall_days, level_base)
    if dst_shift:
        days = _clock(index, True)
    else:
        days = wall_days
    d, hour, occ = occupancy_of(days, level)
    occ_z = occ[:, None] * f_zone[d] * (1.0 + noise)
    peak = np.array([p["peak_gain"][z] for z in zones])
    Q = areas[None, :] * (p["base_gain"] + peak[None, :] * np.clip(occ_z, 0.0, None))
    if p["meeting_zone"] in zones:
        k = zones.index(p["meeting_zone"])
        hi = np.clip(hour.astype(int), 0, 23)
        in_meeting = meetings[d, hi] & weekday[d] & (hi >= 9) & (hi < 17)
        # meetings during semesters and summer only, scaled down in holiday weeks
        scale = np.where(level_base[d] > 0.5, level[d] / np.maximum(level_base[d], 1e-9), 0.0)
        Q[:, k] += p["meeting_gain"] * in_meeting * scale
    af = p["adjacent_floor"]
    T_fl = af["mean"] + af["workday_rise"] * np.clip(occ_base, 0, 1) + fl_noise
    return {"Q_ig": Q, "occupancy": occ, "T_fl": T_fl, "holiday_weeks": holiday_weeks}
