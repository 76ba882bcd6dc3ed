"""Synthetic but realistic weather at one-minute resolution (Berkeley by default, or another climate).

Outdoor temperature: monthly climate normals (Berkeley by default, see
:data:`hvacfmu.emulator.layouts.CLIMATES`) (daily mean and
diurnal range), a daily AR(1) anomaly, cooler and flatter cloudy days, a
skewed diurnal shape (minimum near sunrise, maximum mid-afternoon) and a fast
AR(1) fluctuation. Solar: clear-sky irradiance from pvlib (Ineichen, sun
position by ``ephemeris``) times a cloud transmittance built from a persistent
daily clearness (Markov chain, cloudier in winter) and intra-day AR(1)
variability on partly cloudy days. Facade irradiance from the true GHI with
pvlib: Erbs decomposition and Perez transposition on vertical N/E/S/W surfaces.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import scipy.signal

#: Approximate Berkeley climate normals by month: daily mean [°C], diurnal range [K],
#: probability of an overcast day [-], Linke turbidity [-].
MONTHLY_MEAN = np.array([10.3, 11.5, 12.6, 13.7, 15.2, 16.8, 17.2, 17.8, 18.4, 16.8, 13.1, 10.3])
MONTHLY_RANGE = np.array([7.5, 8.0, 8.5, 9.0, 9.5, 10.0, 10.0, 10.0, 11.0, 10.5, 9.0, 7.5])
MONTHLY_CLOUDY = np.array([0.55, 0.50, 0.45, 0.35, 0.25, 0.15, 0.10, 0.10, 0.15, 0.25, 0.40, 0.55])
MONTHLY_LINKE = np.array([2.8, 2.9, 3.1, 3.3, 3.5, 3.6, 3.6, 3.5, 3.3, 3.1, 2.9, 2.8])
FACADE_AZIMUTH = {"N": 0.0, "E": 90.0, "S": 180.0, "W": 270.0}


def _ar1(rng, n, tau_steps, sigma):
    """Stationary AR(1) series of length ``n`` with time constant ``tau_steps`` and std ``sigma``."""
    a = float(np.exp(-1.0 / tau_steps))
    e = rng.standard_normal(n) * sigma * np.sqrt(1.0 - a * a)
    zi = np.array([a * rng.standard_normal() * sigma])
    y, _ = scipy.signal.lfilter([1.0], [1.0, -a], e, zi=zi)
    return y


def _monthly_interp(doy, table):
    """Periodic interpolation of a 12-month table at day-of-year ``doy`` (mid-month anchors)."""
    anchors = (np.arange(12) + 0.5) * 365.0 / 12.0
    return np.interp(doy, anchors, table, period=365.0)


def _diurnal_shape(hour):
    """Diurnal temperature shape in [-1, 1]: minimum at 06:30, maximum at 15:00 (standard time)."""
    tmin, tmax = 6.5, 15.0
    h = np.asarray(hour)
    rising = (h >= tmin) & (h < tmax)
    out = np.empty_like(h, dtype=float)
    out[rising] = -np.cos(np.pi * (h[rising] - tmin) / (tmax - tmin))
    fall_len = 24.0 - (tmax - tmin)
    hf = np.mod(h[~rising] - tmax, 24.0)
    out[~rising] = np.cos(np.pi * hf / fall_len)
    return out


def synthetic_weather(
    index: pd.DatetimeIndex, rng: np.random.Generator, latitude, longitude, altitude=60.0, climate=None
) -> dict:
    """Generate weather for a tz-aware one-minute index.

    Parameters
    ----------
    index : DatetimeIndex
        Tz-aware, regular.
    rng : numpy Generator
    latitude, longitude : float [deg]
    altitude : float [m]
    climate : dict, optional
        Monthly tables ``monthly_mean``, ``monthly_range``, ``monthly_cloudy``,
        ``monthly_linke`` and ``anomaly_std`` [K] (see
        :data:`hvacfmu.emulator.layouts.CLIMATES`); default Berkeley.

    Returns
    -------
    dict of arrays (length ``len(index)``)
        ``T_out`` [°C], ``ghi`` (true) [W/m2], ``ghi_clear`` [W/m2],
        ``I_N``, ``I_E``, ``I_S``, ``I_W`` [W/m2] and per-day arrays
        ``day_clearness`` [-], ``day_mean`` [°C].
    """
    with warnings.catch_warnings():  # pandas deprecations raised inside pvlib
        warnings.simplefilter("ignore", DeprecationWarning)
        warnings.simplefilter("ignore", FutureWarning)
        return _synthetic_weather(index, rng, latitude, longitude, altitude, climate or {})


def _standard_offset(index) -> float:
    """UTC offset [s] of local standard time (daylight saving removed) of a tz-aware index."""
    t0 = index[0]
    dst = t0.dst() or pd.Timedelta(0)
    return (t0.utcoffset() - dst).total_seconds()


def _synthetic_weather(index, rng, latitude, longitude, altitude, climate):
    import pvlib

    n = len(index)
    utc_s = index.as_unit("s").asi8
    # local standard time (e.g. PST = UTC-8) drives the diurnal shape
    std_days = (utc_s + int(_standard_offset(index))) / 86400.0
    day0 = np.floor(std_days[0])
    dfl = std_days - day0
    n_days = int(np.ceil(dfl[-1])) + 2
    first_day = pd.Timestamp(int(day0) * 86400, unit="s")
    doy_days = ((first_day.day_of_year - 1) + np.arange(n_days)) % 365 + 0.5

    table = {
        key: np.asarray(climate.get(f"monthly_{key}", default), dtype=float)
        for key, default in (
            ("mean", MONTHLY_MEAN),
            ("range", MONTHLY_RANGE),
            ("cloudy", MONTHLY_CLOUDY),
            ("linke", MONTHLY_LINKE),
        )
    }
    clim_mean = _monthly_interp(doy_days, table["mean"])
    clim_range = _monthly_interp(doy_days, table["range"])
    p_cloudy = _monthly_interp(doy_days, table["cloudy"])
    # persistent cloudy/clear days
    u = rng.random(n_days)
    cloudy = np.zeros(n_days, dtype=bool)
    for d in range(n_days):
        p = p_cloudy[d] if d == 0 else (0.55 if cloudy[d - 1] else 0.0) + 0.45 * p_cloudy[d]
        cloudy[d] = u[d] < min(p, 0.95)
    clear_val = 0.93 + 0.07 * rng.random(n_days)
    cloud_val = rng.beta(2.0, 3.0, n_days) * 0.8 + 0.1
    clearness = np.where(cloudy, cloud_val, clear_val)
    anomaly = _ar1(rng, n_days, 2.5, float(climate.get("anomaly_std", 1.5)))
    day_mean = clim_mean + anomaly - 1.2 * (1.0 - clearness)
    day_range = clim_range * (0.45 + 0.55 * clearness)

    centres = np.arange(n_days) + 0.5
    mean_t = np.interp(dfl, centres, day_mean)
    range_t = np.interp(dfl, centres, day_range)
    hour = np.mod(dfl, 1.0) * 24.0
    T_out = mean_t + 0.5 * range_t * _diurnal_shape(hour) + _ar1(rng, n, 60.0, 0.45)

    # --- solar
    sp = pvlib.solarposition.ephemeris(index, latitude, longitude)
    app_zen = sp["apparent_zenith"].to_numpy()
    zen = sp["zenith"].to_numpy()
    azi = sp["azimuth"].to_numpy()
    dni_extra = pvlib.irradiance.get_extra_radiation(index).to_numpy()
    am_rel = pvlib.atmosphere.get_relative_airmass(app_zen)
    am_abs = pvlib.atmosphere.get_absolute_airmass(am_rel, pvlib.atmosphere.alt2pres(altitude))
    doy_min = np.asarray(index.day_of_year, dtype=float)
    linke = _monthly_interp(doy_min, table["linke"])
    with np.errstate(divide="ignore", invalid="ignore"):  # night-time: sun below the horizon
        cs = pvlib.clearsky.ineichen(app_zen, am_abs, linke, altitude=altitude, dni_extra=dni_extra)
    ghi_clear = np.nan_to_num(np.asarray(cs["ghi"], dtype=float), nan=0.0)

    day_idx = np.minimum(dfl.astype(int), n_days - 1)
    c_t = clearness[day_idx]
    spread = 0.9 * np.sqrt(c_t * (1.0 - c_t))
    tau = np.clip(c_t + spread * _ar1(rng, n, 20.0, 1.0), 0.05, 1.0)
    ghi = ghi_clear * tau

    erbs = pvlib.irradiance.erbs(ghi, zen, index)
    dni = np.nan_to_num(np.asarray(erbs["dni"], dtype=float), nan=0.0)
    dhi = np.nan_to_num(np.asarray(erbs["dhi"], dtype=float), nan=0.0)
    out = {"T_out": T_out, "ghi": ghi, "ghi_clear": ghi_clear}
    for o, az in FACADE_AZIMUTH.items():
        poa = pvlib.irradiance.get_total_irradiance(
            90.0, az, app_zen, azi, dni, ghi, dhi, dni_extra=dni_extra, airmass=am_rel, model="perez", albedo=0.2
        )
        out[f"I_{o}"] = np.clip(np.nan_to_num(np.asarray(poa["poa_global"], dtype=float), nan=0.0), 0.0, None)
    out["day_clearness"] = clearness
    out["day_mean"] = day_mean
    return out


#: Mean wind speed [m/s] at the site's weather station (10 m) by emulator climate: Berkeley (mild), a
#: Chicago-like (cold) and a Phoenix-like (hot) site, roughly their annual means.
CLIMATE_WIND_MEAN = {"mild": 3.5, "cold": 4.6, "hot": 3.1}
#: Weibull shape of the hourly wind speed (k = 2: the Rayleigh distribution of many sites).
WIND_WEIBULL_K = 2.0


def synthetic_wind(index: pd.DatetimeIndex, rng: np.random.Generator, mean: float = 3.5) -> np.ndarray:
    """Wind speed [m/s] at one-minute resolution, drawn from its own random stream ``rng``.

    A synoptic AR(1) anomaly (time constant 2 days: windy and calm spells), an hourly AR(1)
    component (3 h), mapped through the normal CDF onto a Weibull distribution (shape
    :data:`WIND_WEIBULL_K`, mean ``mean``), times a diurnal factor (calmest near sunrise, windiest
    mid-afternoon, ±25 %) and a gust factor (AR(1), 10 min, 12 %). The weather of
    :func:`synthetic_weather` does not depend on it (a dataset's other series stay as they were).

    Parameters
    ----------
    index : DatetimeIndex
        Tz-aware, regular one-minute index.
    rng : numpy Generator
        The wind's own stream (``stream(seed, "wind")``).
    mean : float [m/s]

    Returns
    -------
    ndarray (len(index),) [m/s], ≥ 0
    """
    from scipy.special import gamma as gamma_fn
    from scipy.stats import norm

    n = len(index)
    if n == 0:
        return np.zeros(0)
    synoptic = _ar1(rng, n // 60 + 2, 48.0, 0.85)  # hourly samples, time constant 2 days
    hourly = _ar1(rng, n // 60 + 2, 3.0, 0.53)
    z = synoptic + hourly  # unit variance
    hours = np.arange(n) / 60.0
    z_min = np.interp(hours, np.arange(len(z)), z)
    u = np.clip(norm.cdf(z_min), 1e-9, 1.0 - 1e-9)
    scale = mean / gamma_fn(1.0 + 1.0 / WIND_WEIBULL_K)
    speed = scale * (-np.log1p(-u)) ** (1.0 / WIND_WEIBULL_K)
    local_hour = (index.hour + index.minute / 60.0).to_numpy(dtype=float)
    diurnal = 1.0 + 0.25 * np.cos(2.0 * np.pi * (local_hour - 15.0) / 24.0)
    gust = 1.0 + _ar1(rng, n, 10.0, 0.12)
    return np.clip(speed * diurnal * gust, 0.0, None)
