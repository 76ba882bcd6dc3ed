"""Does the data's clock match the sun? Finding timestamps in the wrong time zone.

Naive timestamps are read in the data's clock zone (``--timezone``, the
building's ``data_timezone``, else its ``timezone``). If that zone is wrong,
every sample sits hours away from its true instant, and nothing else notices.
The sun does: :func:`clock_check` compares the daily cycle of the data with the
one the declared clock implies, at the building's longitude.

- With ``ghi``: the *measured solar noon* is the ghi-weighted circular mean of
  the local apparent solar time of the samples (instant in UTC + longitude/15 h +
  equation of time); the computed solar noon is 12:00 apparent solar time by
  definition, so the difference is the clock offset. Clouds make the daily
  hump asymmetric by minutes, rarely more than half an hour over a week: an
  offset of :data:`GHI_TOLERANCE` h or more is reported.
- Without ``ghi``: the first harmonic of the outdoor temperature's daily cycle
  (each day's mean removed) peaks in mid-afternoon, about
  :data:`T_OUT_PEAK_SOLAR_HOUR` h apparent solar time, with its minimum near
  sunrise; the spread between climates and seasons is about ±1.5 h, so only an
  offset of :data:`T_OUT_TOLERANCE` h or more is reported.

The offset is positive when the data look *late* (an event appears later on
the data's clock than it happened): naive UTC timestamps read as
America/Los_Angeles look 7 h late in summer and 8 h late in winter.

References
----------
.. [1] J. W. Spencer, "Fourier series representation of the position of the
   sun", Search 2(5), 1971 (equation of time, as in pvlib).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

#: Smallest |offset| [h] reported when ghi is available.
GHI_TOLERANCE = 0.75
#: Smallest |offset| [h] reported from the outdoor temperature alone.
T_OUT_TOLERANCE = 3.0
#: Apparent solar time [h] at which the first harmonic of the daily outdoor temperature peaks (typical).
T_OUT_PEAK_SOLAR_HOUR = 15.5
#: Minimum days of data for a verdict.
MIN_DAYS = 3


@dataclasses.dataclass(frozen=True)
class ClockCheck:
    """Result of :func:`clock_check`.

    Attributes
    ----------
    method : str or None
        ``"ghi"`` (measured solar noon), ``"T_out"`` (outdoor temperature cycle)
        or None (not enough data).
    offset : float or None [h]
        Measured minus expected time of the daily cycle; positive: the data look late.
    days : float
        Days of data used.
    detail : str
        What was measured, in words (times on the data's clock).
    warning : str or None
        The message when the clock looks offset.
    """

    method: str | None
    offset: float | None
    days: float
    detail: str
    warning: str | None = None


def _solar_hours(index: pd.DatetimeIndex, longitude: float) -> np.ndarray:
    """Local apparent solar time [h, 0..24) of tz-aware instants at ``longitude`` [deg, east positive]."""
    import pvlib

    utc = index.tz_convert("UTC")
    hours = utc.hour.to_numpy() + utc.minute.to_numpy() / 60 + utc.second.to_numpy() / 3600
    eot = pvlib.solarposition.equation_of_time_spencer71(utc.day_of_year.to_numpy())  # [min]
    return np.mod(hours + longitude / 15.0 + eot / 60.0, 24.0)


def _circular_mean_hour(hours: np.ndarray, weights: np.ndarray) -> tuple[float, float]:
    """Weighted circular mean [h, -12..12) of clock hours and its resultant length (0..1)."""
    theta = 2 * np.pi * hours / 24.0
    c, s = np.sum(weights * np.cos(theta)), np.sum(weights * np.sin(theta))
    total = np.sum(np.abs(weights))
    mean = np.arctan2(s, c) * 24.0 / (2 * np.pi)
    return float(mean), float(np.hypot(c, s) / total) if total > 0 else 0.0


def _wrap(h: float) -> float:
    """Hours wrapped into (-12, 12]."""
    return float(-((-h + 12.0) % 24.0 - 12.0))


def _clock_of_solar(solar_hour: float, index: pd.DatetimeIndex, longitude: float) -> str:
    """Clock time (HH:MM, in the index's zone) at which the apparent solar time is ``solar_hour``, mid-data."""
    mid = index[len(index) // 2]
    day = mid.normalize()
    grid = pd.date_range(day, periods=24 * 60, freq="1min")
    solar = _solar_hours(grid, longitude)
    k = int(np.argmin(np.abs(((solar - solar_hour) + 12) % 24 - 12)))
    return f"{grid[k]:%H:%M}"


def _from_ghi(frame, step, longitude):
    ghi = frame["ghi"].to_numpy(dtype=float)
    ok = np.isfinite(ghi) & (ghi > 0)
    if ok.sum() * step < MIN_DAYS * 86400 / 3:  # about MIN_DAYS days of daylight
        return None
    mid = frame.index[ok] + pd.Timedelta(seconds=step / 2)
    solar = _solar_hours(mid, longitude)
    mean, strength = _circular_mean_hour(solar, ghi[ok])
    if strength < 0.3:  # ghi without a daily cycle: nothing to compare
        return None
    offset = _wrap(mean - 12.0)
    peak = _clock_of_solar(12.0 + offset, frame.index, longitude)
    noon = _clock_of_solar(12.0, frame.index, longitude)
    detail = f"measured solar noon (ghi-weighted mean time) {peak}, computed {noon} on the data's clock"
    return offset, detail


def _from_t_out(frame, step, longitude, column="T_out"):
    t = frame[column]
    t = t[np.isfinite(t.to_numpy(dtype=float))]
    if len(t) * step < MIN_DAYS * 86400:
        return None
    local_day = t.index.tz_convert("UTC").floor("D")
    anomaly = t.to_numpy(dtype=float) - t.groupby(local_day).transform("mean").to_numpy(dtype=float)
    solar = _solar_hours(t.index + pd.Timedelta(seconds=step / 2), longitude)
    theta = 2 * np.pi * solar / 24.0
    a, b = 2 * np.mean(anomaly * np.cos(theta)), 2 * np.mean(anomaly * np.sin(theta))
    if np.hypot(a, b) < 0.5:  # less than 0.5 K of daily swing: no verdict
        return None
    peak_solar = np.mod(np.arctan2(b, a) * 24 / (2 * np.pi), 24.0)
    offset = _wrap(peak_solar - T_OUT_PEAK_SOLAR_HOUR)
    hours = t.index.hour.to_numpy()
    profile = pd.Series(t.to_numpy(dtype=float)).groupby(hours).mean()
    detail = (
        f"outdoor temperature lowest at {int(profile.idxmin()):02d}:00 and highest at {int(profile.idxmax()):02d}:00 "
        f"on the data's clock (expected lowest near sunrise, highest about "
        f"{_clock_of_solar(T_OUT_PEAK_SOLAR_HOUR, frame.index, longitude)})"
    )
    return offset, detail


def _utc_offset_hours(zone: str, when: pd.Timestamp) -> float:
    off = when.tz_convert(zone).utcoffset()
    return off.total_seconds() / 3600 if off is not None else 0.0


def _advice(offset: float, building, has_offsets: bool, when: pd.Timestamp, slack: float) -> str:
    """The likely cause and fix of a clock offset [h] known within ``slack`` [h]."""
    if has_offsets:
        return (
            "the timestamps carry UTC offsets, so the export wrote wrong offsets (or the building's longitude is wrong)"
        )
    clock = building.clock_timezone
    clock_off = _utc_offset_hours(clock, when)
    if clock_off != 0 and abs(offset + clock_off) < slack:
        return 'naive timestamps in UTC? use --timezone UTC (or data_timezone = "UTC" in the building file)'
    local_off = _utc_offset_hours(building.timezone, when)
    if clock_off == 0 and local_off != 0 and abs(offset - local_off) < slack:
        return (
            f"naive timestamps in the building's local time? use --timezone {building.timezone} "
            "(or remove data_timezone from the building file)"
        )
    return (
        f"naive timestamps are read in {clock}; find the zone the export's clock is in and pass it with "
        "--timezone (or data_timezone in the building file), or check the building's longitude"
    )


def _ghi_alone(frame, step, building, offset: float, n: float, advice: str) -> str:
    """The advice for an offset measured on ``ghi``: that column alone, both weather columns, or every timestamp.

    ``T_out``'s daily cycle varies by about ±1.5 h between climates, so it tells whether the outdoor air moved
    with ``ghi`` only for offsets of :data:`T_OUT_TOLERANCE` h or more.
    """
    way = "earlier" if offset > 0 else "later"
    t_out = _from_t_out(frame, step, building.longitude) if "T_out" in frame.columns else None
    to = None if t_out is None else t_out[0]
    if to is not None and abs(to) >= T_OUT_TOLERANCE and abs(to - offset) < T_OUT_TOLERANCE:
        return (
            f"{advice}; T_out's daily cycle is off too ({to:+.1f} h from its typical time): if the zone and airflow "
            "columns are on the building's clock, both weather columns come from a feed on another clock (e.g. UTC) "
            f"joined to the building's rows: shift ghi and T_out {abs(n):g} h {way}"
        )
    if to is not None and abs(to) < T_OUT_TOLERANCE <= min(abs(offset), abs(to - offset)):
        return (
            f"only the ghi column is offset: T_out's daily cycle is on time ({to:+.1f} h from its typical time): a "
            f"pyranometer logger or a weather feed on another clock; shift the ghi column {abs(n):g} h {way}"
        )
    tout = (
        ""
        if to is None
        else f" (T_out's daily cycle, {to:+.1f} h from its typical time, varies too much between climates to tell)"
    )
    return (
        f"measured on the ghi column alone{tout}: if the other columns are on the building's clock, the ghi column "
        f"is offset (a pyranometer logger or a weather feed on another clock): shift ghi {abs(n):g} h {way}; "
        f"if every column is off, {advice}"
    )


def clock_check(frame: pd.DataFrame, building, step: float, has_offsets: bool = False) -> ClockCheck:
    """Compare the data's daily cycle with the declared clock (see the module docstring).

    Parameters
    ----------
    frame : DataFrame
        Data on the model step (tz-aware index, bin starts) with ``ghi`` [W/m²]
        and/or ``T_out`` [°C].
    building : Building
        Gives the longitude [deg] and the time zones named in the advice.
    step : float [s]
        Model step (samples are taken at the bin midpoints).
    has_offsets : bool
        True if the file's timestamps carried UTC offsets (changes the advice).

    Returns
    -------
    ClockCheck
    """
    days = len(frame) * step / 86400
    found, method = None, None
    if "ghi" in frame.columns:
        found, method = _from_ghi(frame, step, building.longitude), "ghi"
    if found is None and "T_out" in frame.columns:
        found, method = _from_t_out(frame, step, building.longitude), "T_out"
    if found is None:
        return ClockCheck(None, None, days, "not enough daily cycle in ghi or T_out to check the clock")
    offset, detail = found
    tolerance = GHI_TOLERANCE if method == "ghi" else T_OUT_TOLERANCE
    warning = None
    if abs(offset) >= tolerance:
        n = round(offset) if abs(offset) >= 1.5 else round(offset * 2) / 2
        late = "late" if offset > 0 else "early"
        advice = _advice(offset, building, has_offsets, frame.index[len(frame) // 2], 1.0 if method == "ghi" else 2.0)
        if method == "ghi":
            advice = _ghi_alone(frame, step, building, offset, n, advice)
        warning = f"the data look {abs(n):g} h {late}: {detail}; {advice}"
    return ClockCheck(method, float(offset), days, detail, warning)


def outdoor_phase_warning(frame: pd.DataFrame, building, step: float, clock: ClockCheck) -> str | None:
    """A warning when ``T_out``'s daily cycle is shifted against the sun that ``ghi`` puts on time.

    When a supply air column carries the outdoor air's daily cycle on time
    instead (and swings more than ``T_out``), the two columns are named as
    swapped rather than ``T_out`` as shifted.

    With the clock confirmed by ``ghi``, the outdoor temperature's first daily
    harmonic must still peak about :data:`T_OUT_PEAK_SOLAR_HOUR` apparent solar
    time; :data:`T_OUT_TOLERANCE` hours or more off is a weather feed joined on
    another clock (a UTC feed read as local time), which the models would learn.
    """
    if clock.method != "ghi" or clock.offset is None or abs(clock.offset) >= GHI_TOLERANCE or "T_out" not in frame:
        return None
    found = _from_t_out(frame, step, building.longitude)
    if found is not None and abs(found[0] - clock.offset) < T_OUT_TOLERANCE:
        return None
    if found is None:
        cycle = "is under 0.5 K"
    else:
        n = round(found[0] - clock.offset)
        cycle = f"is {abs(n):g} h {'late' if n > 0 else 'early'} against the sun that ghi puts on time ({found[1]})"
    swapped = _outdoor_in_supply(frame, step, building.longitude, clock.offset)
    if swapped:
        return (
            f"column T_out: its daily cycle {cycle}, while column {swapped} has the outdoor air's daily cycle on "
            f"time: {swapped} and T_out look swapped (the outdoor and supply air points mapped to each other's "
            "columns); fix the column mapping of the export"
        )
    if found is None:
        return None
    return (
        f"column T_out: its daily cycle {cycle}: "
        "outdoor air joined from a weather feed on another clock (UTC?); shift the T_out column to the data's clock"
    )


def _outdoor_in_supply(frame: pd.DataFrame, step: float, longitude: float, clock_offset: float) -> str | None:
    """The supply air column whose daily cycle peaks when outdoor air does, if ``T_out``'s does not.

    Supply air is held at a set point (or reset slowly); a daily cycle that
    peaks in mid-afternoon apparent solar time, on the clock ``ghi`` confirmed,
    is outdoor air exported under the supply air's name. It must also swing
    more within the day than ``T_out`` does (a mixed-air supply that follows
    the outdoor air through an economiser swings less than the outdoor air).
    """
    units = [c for c in frame.columns if c.startswith("T_supply_")]  # the derived T_supply mixes them: name the unit's
    for column in units or [c for c in frame.columns if c == "T_supply"]:
        found = _from_t_out(frame, step, longitude, column)
        if (
            found is not None
            and abs(found[0] - clock_offset) < T_OUT_TOLERANCE
            and _daily_swing(frame[column]) > _daily_swing(frame["T_out"])
        ):
            return column
    return None


def _daily_swing(t: pd.Series) -> float:
    """Standard deviation [K] of a temperature about each UTC day's mean."""
    t = t[np.isfinite(t.to_numpy(dtype=float))]
    day = t.index.tz_convert("UTC").floor("D")
    return float(np.std(t.to_numpy(dtype=float) - t.groupby(day).transform("mean").to_numpy(dtype=float)))
