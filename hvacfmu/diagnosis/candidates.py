"""The catalogue of physical causes: candidate extension terms and their evidence from the data.

Each candidate is an extension term of :mod:`hvacfmu.models.extended` at a named
location, with *evidence* computed from the current model's one-step residuals
before any refit: the correlation of the residual with the candidate's regressor
(both with the season × time-of-week means removed, as the internal-gain profile
does), conditional means of the residual in the regime the cause acts in, and
cause-specific quantities (cross-correlation lags for a delay, the best time
constant of a slow mass, the days that depart from the gain profile). The
confirmation (likelihood-ratio / BIC test, held-out gain) is in
:mod:`hvacfmu.diagnosis.selection`.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import scipy.ndimage

from ..models.extended import (
    ActuationDelay,
    InternalGainSchedule,
    Reheat,
    SolarGain,
    SupplyAirBilinear,
    ThermalMass,
    ZoneCoupling,
    dst_active,
    reheat_feature,
)
from .design import MAX_DELAY, Signals, Within, base_solar, effective_inputs, term_features

#: Thermal-mass filter constants tried [1/step] (time constants 125 h ... 2.5 h at 15 min).
ALPHAS = (0.002, 0.005, 0.01, 0.02, 0.05, 0.1)
#: Outdoor-temperature thresholds tried for reheat [°C].
REHEAT_THRESHOLDS = (8.0, 10.0, 12.0, 14.0, 16.0)
#: Minimum rows in a regime for a reheat candidate to be testable.
MIN_REGIME_ROWS = 50


@dataclasses.dataclass
class Candidate:
    """One candidate cause at one location.

    Attributes
    ----------
    cause : str
        Cause id (``solar_gain``, ``supply_air_bilinear``, ``zone_coupling``,
        ``thermal_mass``, ``internal_gain_schedule``, ``actuation_delay``, ``reheat``).
    location : dict
        Zones, facade, pair, delay ... (JSON-ready).
    variants : list of Term
        Terms to try (e.g. several time constants); the best one is kept.
    hyper : int
        Number of searched hyper-parameters charged in the information criterion.
    status : str
        ``"found"``, ``"not significant"``, ``"no held-out gain"``, ``"untestable"``, ``"not tested"``.
    reason : str
    evidence : dict
        Numbers from the data (correlations, conditional means, lags ...).
    test : dict
        Likelihood-ratio test: ``lr``, ``lr_adjusted``, ``dof``, ``delta_bic``, ``n``, ``p_value``.
    term : Term or None
        The fitted term (best variant).
    heldout : dict or None
        Held-out RMS before/after per affected zone and ``gain_percent``.
    """

    cause: str
    location: dict
    variants: list = dataclasses.field(default_factory=list)
    hyper: int = 0
    status: str = "not tested"
    reason: str = ""
    evidence: dict = dataclasses.field(default_factory=dict)
    test: dict = dataclasses.field(default_factory=dict)
    term: object = None
    heldout: dict | None = None
    #: gain profiles (season -> (n_tow, nz)) the candidate's features use, per variant key (DST shift)
    profiles: dict | None = None

    @property
    def key(self) -> str:
        loc = ",".join(f"{k}={v}" for k, v in sorted(self.location.items()) if k not in ("dates",))
        return f"{self.cause}({loc})"

    def to_dict(self) -> dict:
        return {
            "cause": self.cause,
            "location": self.location,
            "status": self.status,
            "reason": self.reason,
            "evidence": self.evidence,
            "test": self.test,
            "parameters": None if self.term is None else _params(self.term),
            "heldout": self.heldout,
        }


def _params(term) -> dict:
    out = {}
    std = term.std or {}
    for k, v in term.coefficients().items():
        if isinstance(v, dict):
            out[k] = {z: {"value": float(c), "std": float(std.get(k, {}).get(z, 0.0))} for z, c in v.items()}
        elif k in std:
            out[k] = {"value": float(v), "std": float(std[k])}
        else:
            out[k] = {"value": float(v), "std": None}
    return out


# ----------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------
def _corr(a, b) -> float:
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < 10:
        return float("nan")
    a, b = a[ok] - a[ok].mean(), b[ok] - b[ok].mean()
    d = np.sqrt((a @ a) * (b @ b))
    return float(a @ b / d) if d > 0 else float("nan")


def _cond_mean(r, mask) -> dict:
    mask = np.asarray(mask, bool)
    n = int(mask.sum())
    return {"mean": float(np.mean(r[mask])) if n else None, "n": n}


# ----------------------------------------------------------------------------
# candidate generation with evidence
# ----------------------------------------------------------------------------
def generate(sig: Signals, terms, W: Within, resid: np.ndarray, options: dict) -> list:
    """All candidates not yet in ``terms``, each with its evidence.

    Parameters
    ----------
    sig : Signals
    terms : list of Term
        The current extension terms.
    W : Within
        Within transform over the training rows.
    resid : array (n_train_rows, nz) [K]
        Current one-step within residuals on ``W.rows``.
    options : dict
        Diagnosis options (see :func:`hvacfmu.diagnosis.diagnose`).
    """
    rows = W.rows
    zones = sig.zones
    U_eff = effective_inputs(sig, terms)
    have = {(t.cause, tuple(t.zones()) if not isinstance(t, SolarGain) else (t.zone, t.facade)) for t in terms}
    have_causes_zone = {(t.cause, z) for t in terms for z in t.zones()}
    out = []

    def wfeat(col):
        return W(np.asarray(col, float))

    # --- solar_gain -------------------------------------------------------------------
    for zi, z in enumerate(zones):
        for o in sig.facades[zi]:
            loc = {"zone": z, "facade": o}
            if not sig.has_solar:
                out.append(Candidate("solar_gain", loc, status="untestable",
                                     reason="no solar data (ghi or facade irradiance) in the dataset"))
                continue
            if ("solar_gain", (z, o)) in have or base_solar(sig, zi, o) != 0.0:
                continue  # already a solar path of the model
            I = sig.V[f"I_{o}"]
            r = resid[:, zi]
            Ir = I[rows]
            day = Ir > 20.0
            hi = day & (Ir >= np.quantile(Ir[day], 0.75)) if day.any() else day
            lo = day & (Ir <= np.quantile(Ir[day], 0.25)) if day.any() else day
            ev = {"corr": _corr(r, wfeat(I)),
                  "resid_sunny": _cond_mean(r, hi), "resid_cloudy": _cond_mean(r, lo)}
            out.append(Candidate("solar_gain", loc, [SolarGain(zone=z, facade=o)], 0, evidence=ev))
    # --- supply_air_bilinear ----------------------------------------------------------
    for zi, z in enumerate(zones):
        if ("supply_air_bilinear", z) in have_causes_zone:
            continue
        t = SupplyAirBilinear(zone=z)
        f = term_features(sig, t, U_eff)[0][2]
        r = resid[:, zi]
        u = U_eff[rows, zi]
        umin = sig.u_min[zi]
        ev = {"corr": _corr(r, wfeat(f)),
              "resid_airflow_min": _cond_mean(r, u <= umin * 1.05 + 1e-6),
              "resid_airflow_high": _cond_mean(r, u >= np.nanquantile(u, 0.9))}
        out.append(Candidate("supply_air_bilinear", {"zone": z}, [t], 0, evidence=ev))
    # --- zone_coupling (pairs not coupled in the base structure) --------------------
    for a in range(len(zones)):
        for b in range(a + 1, len(zones)):
            if b in sig.neighbours[a] or a in sig.neighbours[b]:
                continue
            if ("zone_coupling", (zones[a], zones[b])) in have:
                continue
            d = sig.Y[:, b] - sig.Y[:, a]
            dw = wfeat(d)
            ev = {"corr_a": _corr(resid[:, a], dw), "corr_b": _corr(resid[:, b], -dw)}
            out.append(Candidate("zone_coupling", {"zones": [zones[a], zones[b]]},
                                 [ZoneCoupling(zone_a=zones[a], zone_b=zones[b])], 0, evidence=ev))
    # --- thermal_mass ---------------------------------------------------------------
    for zi, z in enumerate(zones):
        if ("thermal_mass", z) in have_causes_zone:
            continue
        cors = {}
        for al in ALPHAS:
            f = term_features(sig, ThermalMass(zone=z, alpha=al), U_eff)[0][2]
            cors[f"{al:g}"] = _corr(resid[:, zi], wfeat(f))
        ev = {"corr_by_alpha": cors}
        out.append(Candidate("thermal_mass", {"zone": z}, [ThermalMass(zone=z, alpha=al) for al in ALPHAS], 1,
                             evidence=ev))
    # --- actuation_delay --------------------------------------------------------------
    for zi, z in enumerate(zones):
        if ("actuation_delay", z) in have_causes_zone:
            continue
        u = sig.U[:, zi]
        xc = {}
        for lag in range(0, MAX_DELAY + 3):
            ul = np.full(len(u), np.nan)
            ul[lag:] = u[: len(u) - lag] if lag else u
            xc[str(lag)] = _corr(resid[:, zi], wfeat(np.nan_to_num(ul, nan=np.nanmean(u))))
        ev = {"xcorr_resid_airflow_by_lag": xc}
        out.append(Candidate("actuation_delay", {"zone": z},
                             [ActuationDelay(zone=z, delay=d) for d in range(1, MAX_DELAY + 1)], 0, evidence=ev))
    # --- reheat ---------------------------------------------------------------------------
    T_out = sig.V["T_out"]
    for zi, z in enumerate(zones):
        if ("reheat", z) in have_causes_zone:
            continue
        umin = float(sig.u_min[zi] * 1.05 + 1e-6)
        u = U_eff[:, zi]
        variants = []
        regime = {}
        for th in REHEAT_THRESHOLDS:
            f = reheat_feature(u[rows], T_out[rows], umin, th)
            n = int((f > 0).sum())
            regime[f"{th:g}"] = {**_cond_mean(resid[:, zi], f > 0), "corr": _corr(resid[:, zi], wfeat(
                reheat_feature(u, T_out, umin, th)))}
            if n >= MIN_REGIME_ROWS:
                variants.append(Reheat(zone=z, u_min=umin, T_threshold=th))
        ev = {"u_min": umin, "resid_in_regime_by_threshold": regime}
        if not variants:
            out.append(Candidate("reheat", {"zone": z}, status="untestable", evidence=ev,
                                 reason=f"fewer than {MIN_REGIME_ROWS} training rows at minimum airflow in cold "
                                        f"weather (T_out < {max(REHEAT_THRESHOLDS):g} °C)"))
        else:
            out.append(Candidate("reheat", {"zone": z}, variants, 1, evidence=ev))
    # --- internal_gain_schedule ----------------------------------------------------------
    if not any(isinstance(t, InternalGainSchedule) and t.variant == "holiday" for t in terms):
        out.append(_holiday_candidate(sig, terms, options))
    if not any(isinstance(t, InternalGainSchedule) and t.variant == "dst_shift" for t in terms):
        out.append(_dst_candidate(sig, W, options))
    return out


def day_departures(sig: Signals, resid_all: np.ndarray, ref_weekday: int = 6) -> list:
    """Per weekday date: the scale ``gamma`` of the departure of the residual toward ``ref_weekday``'s profile.

    For each weekday (Monday–Friday) with data, the one-step residuals of all zones over
    the day are regressed on ``q_ref − q_day`` (the reference day's gain profile minus
    the day's own, from the season's profile): ``gamma ≈ 1`` means the day's gains
    looked like the reference day (a holiday), ``gamma ≈ 0`` an ordinary day.

    Returns
    -------
    list of dict with ``date``, ``gamma``, ``t``, ``n``.
    """
    idx = sig.index
    per_day = sig.n_tow // 7
    tow = np.zeros(len(idx), dtype=int)
    from ..timeutil import time_of_week

    tow = time_of_week(idx, sig.step) % sig.n_tow
    dates = np.array(idx.date)
    wd = idx.day_of_week.to_numpy()
    out = []
    ok_rows = np.isfinite(resid_all).all(axis=1) & (sig.week >= 0)
    h_all = np.zeros_like(resid_all)
    for s in sig.seasons:
        m = sig.season == s
        prof = sig.base_profiles[s]
        h_all[m] = prof[ref_weekday * per_day + tow[m] % per_day] - prof[tow[m]]
    for d in np.unique(dates[ok_rows & (wd < 5)]):
        m = ok_rows & (dates == d)
        if m.sum() < per_day // 2:
            continue
        h = h_all[m].ravel()
        r = resid_all[m].ravel()
        hh = h @ h
        if hh <= 0:
            continue
        g = (h @ r) / hh
        e = r - g * h
        s2 = (e @ e) / max(len(r) - 1, 1)
        out.append({"date": d.isoformat(), "gamma": float(g), "t": float(g / np.sqrt(s2 / hh)), "n": int(m.sum())})
    return out


def _holiday_candidate(sig: Signals, terms, options) -> Candidate:
    """Weekdays whose gains looked like a weekend day: single days and whole weeks.

    A weekday is picked when its departure scale ``gamma`` (see :func:`day_departures`)
    reaches ``holiday_gamma`` and lies ``holiday_z`` robust standard deviations above the
    median of all weekdays; the weekdays of a week are picked together when the week's
    mean ``gamma`` reaches ``holiday_week_gamma`` (holiday weeks: the building's mass
    makes the first days of a quiet week look less quiet). Dates are a calendar: they
    are screened on every week, while coefficients are fitted on training weeks only.
    """
    resid_all = options.get("_resid_all")
    if resid_all is None or sig.n_tow % 7:
        return Candidate("internal_gain_schedule", {"variant": "holiday"}, status="untestable",
                         reason="no one-step residuals")
    deps = day_departures(sig, resid_all)
    gam = np.array([d["gamma"] for d in deps]) if deps else np.zeros(0)
    med = float(np.median(gam)) if len(gam) else 0.0
    mad = float(1.4826 * np.median(np.abs(gam - med))) if len(gam) else 0.0
    scale = max(mad, 0.05)
    for d in deps:
        d["z"] = (d["gamma"] - med) / scale
    g_min, z_min, gw_min = options["holiday_gamma"], options["holiday_z"], options["holiday_week_gamma"]
    picked = {d["date"] for d in deps if d["gamma"] >= g_min and d["z"] >= z_min}
    by_week = {}
    for d in deps:
        wk = int(sig.week[sig.index.searchsorted(pd.Timestamp(d["date"]).tz_localize(sig.index.tz))])
        by_week.setdefault(wk, []).append(d)
    weeks = []
    for wk, ds in by_week.items():
        g = float(np.mean([d["gamma"] for d in ds]))
        if len(ds) >= 3 and g >= gw_min and (g - med) / scale >= z_min / 2:
            weeks.append({"week": wk, "gamma": g})
            picked |= {d["date"] for d in ds}
    ev = {"weekdays_checked": len(deps), "gamma_median": med, "gamma_robust_std": mad,
          "days": sorted([d for d in deps if d["date"] in picked], key=lambda d: d["date"])[:40],
          "weeks": weeks,
          "rule": f"weekday gamma >= {g_min:g} and z >= {z_min:g}, or week mean gamma >= {gw_min:g}"}
    if len(deps) < 10:
        return Candidate("internal_gain_schedule", {"variant": "holiday"}, status="untestable", evidence=ev,
                         reason=f"only {len(deps)} weekdays with data")
    if not picked:
        return Candidate("internal_gain_schedule", {"variant": "holiday"}, status="not significant", evidence=ev,
                         reason="no weekday departs from the seasonal profile toward a weekend day")
    dates = tuple(sorted(picked))
    term = InternalGainSchedule(variant="holiday", zone_names=sig.zones, coef=tuple(0.0 for _ in sig.zones),
                                dates=dates, ref_weekday=6)
    n_choices = len(weeks) + len([d for d in dates if not any(d in {x["date"] for x in by_week[w["week"]]}
                                                              for w in weeks)])
    return Candidate("internal_gain_schedule", {"variant": "holiday", "dates": list(dates)}, [term],
                     max(n_choices, 1), evidence=ev)


#: Lags [steps] searched when aligning the daylight-saving and standard-time weekday gain profiles.
DST_MAX_LAG_H = 2.0
#: Minimum weekdays with data on each side (daylight saving on / off) within a season.
DST_MIN_DAYS = 5
#: Local hours [h] of the morning occupancy ramp-up compared (the afternoon ramp-down moves with
#: the season's weather, cooling vs heating, and is left out).
DST_WINDOW_H = (6.0, 12.0)
#: Minimum weekend days with data on each side.
DST_MIN_WEEKEND_DAYS = 4


def apparent_gains(sig: Signals, resid_all: np.ndarray) -> np.ndarray:
    """One-step residual plus the current gain profile (n, nz) [K/step]: the gains the data imply."""
    q = np.full_like(resid_all, np.nan)
    for s in sig.seasons:
        m = sig.season == s
        if m.any() and s in sig.base_profiles:
            q[m] = np.asarray(sig.base_profiles[s])[sig.tow[m]]
    return resid_all + q


def dst_profile_lag(sig: Signals, gains: np.ndarray, rows: np.ndarray) -> dict:
    """Lag between the weekday gain profiles of daylight-saving and standard-time days of a season.

    Within each season whose ``rows`` contain at least :data:`DST_MIN_DAYS` weekdays and
    :data:`DST_MIN_WEEKEND_DAYS` weekend days on each side of a daylight-saving change, the
    floor-total apparent gain is averaged by time of day over weekdays minus weekend days
    (weather and sun are the same on both and cancel; occupancy stays), separately for
    daylight-saving and standard-time days, and smoothed by a 75-min running median (the
    short spikes of the HVAC schedule follow the local clock on both sides). On the morning
    ramp-up (:data:`DST_WINDOW_H`), the difference of the two profiles is regressed on the
    standard-time profile shifted by ``L`` steps minus itself; the lag ``L`` with the
    largest R² (``|L| ≤`` :data:`DST_MAX_LAG_H`, positive coefficient) is the shift: the
    daylight-saving profile is the standard-time one ``L`` steps later (``L > 0``: gains
    one hour late on the local clock because they stay on standard time). The regression
    coefficient (``scale_at_lag``) is the shifted share: ~1 when the whole occupancy jumps
    by an hour at the change. (Per-zone profiles were tried: too noisy.)

    Returns
    -------
    dict
        ``lag_steps``, ``lag_h``, ``r2_at_lag``, ``scale_at_lag``, ``r2_by_lag``,
        ``seasons`` (day counts) — or only ``seasons`` (empty) when no season has both sides.
    """
    per_day = sig.n_tow // 7
    wd = sig.index.day_of_week.to_numpy()
    dates = np.array(sig.index.date)
    total = np.nansum(gains, axis=1)
    ok = np.zeros(len(total), bool)
    ok[rows] = True
    ok &= np.isfinite(gains).all(axis=1)
    max_lag = int(round(DST_MAX_LAG_H * 3600 / sig.step))
    lags = np.arange(-max_lag, max_lag + 1)
    num, den, dd = np.zeros(len(lags)), np.zeros(len(lags)), np.zeros(len(lags))
    seasons = {}
    slot = sig.tow % per_day
    weekday = wd < 5

    def day_profile(sel):
        cnt = np.bincount(slot[sel], minlength=per_day)
        val = np.bincount(slot[sel], weights=total[sel], minlength=per_day)
        return None if (cnt == 0).any() else val / cnt

    for s in sig.seasons:
        m = ok & (sig.season == s)
        prof, counts = [], []
        for side in (sig.dst, ~sig.dst):
            wk, we = m & side & weekday, m & side & ~weekday
            counts.append((len(np.unique(dates[wk])), len(np.unique(dates[we]))))
            if counts[-1][0] < DST_MIN_DAYS or counts[-1][1] < DST_MIN_WEEKEND_DAYS:
                break
            p_wk, p_we = day_profile(wk), day_profile(we)
            if p_wk is None or p_we is None:
                break
            # weekday minus weekend: occupancy stays, weather and sun (the same on every day) cancel
            prof.append(p_wk - p_we)
        if len(prof) < 2:
            continue
        (n_on, n_on_we), (n_off, n_off_we) = counts
        # a 75-min running median removes the short spikes of the HVAC schedule (which follows the
        # local clock on both sides) and keeps the occupancy ramps
        prof = [scipy.ndimage.median_filter(p, size=5, mode="wrap") for p in prof]
        hours = np.arange(per_day) * sig.step / 3600.0
        win = (hours >= DST_WINDOW_H[0]) & (hours < DST_WINDOW_H[1])
        delta = (prof[0] - prof[1])[win]
        delta = delta - delta.mean()
        w = min(n_on, n_off)
        for i, L in enumerate(lags):
            x = (np.roll(prof[1], L) - prof[1])[win]
            x = x - x.mean()
            num[i] += w * float(delta @ x)
            den[i] += w * float(x @ x)
            dd[i] += w * float(delta @ delta)
        seasons[s] = {"weekdays_dst": int(n_on), "weekdays_standard": int(n_off),
                      "weekend_days_dst": int(n_on_we), "weekend_days_standard": int(n_off_we)}
    if not seasons:
        return {"seasons": {}}
    gamma = num / np.maximum(den, 1e-300)
    r2 = np.where(gamma > 0, gamma * num / np.maximum(dd, 1e-300), 0.0)
    i = int(np.argmax(r2))
    return {"lag_steps": int(lags[i]), "lag_h": float(lags[i] * sig.step / 3600.0),
            "r2_at_lag": float(r2[i]), "scale_at_lag": float(gamma[i]),
            "r2_by_lag": {str(int(L)): round(float(c), 4) for L, c in zip(lags, r2)}, "seasons": seasons}


def shifted_clock_profiles(sig: Signals, gains: np.ndarray, rows: np.ndarray, shift: int) -> dict:
    """Season profiles (n_tow, nz) of the apparent gains on a clock read ``shift`` steps later under DST.

    Slot ``(tow + shift) mod n_tow`` on daylight-saving rows, ``tow`` otherwise: with
    ``shift = −L`` the profile of the standard-time clock the gains really follow, which
    the ``dst_shift`` term then reads ``shift`` steps later while daylight saving is on.
    Slots without data keep the current profile.
    """
    out = {}
    ok = np.zeros(len(gains), bool)
    ok[rows] = True
    ok &= np.isfinite(gains).all(axis=1)
    clock = np.where(sig.dst, (sig.tow + shift) % sig.n_tow, sig.tow)
    for s in sig.seasons:
        prof = np.array(sig.base_profiles[s], dtype=float, copy=True)
        m = ok & (sig.season == s)
        cnt = np.bincount(clock[m], minlength=sig.n_tow)
        for j in range(sig.nz):
            val = np.bincount(clock[m], weights=gains[m, j], minlength=sig.n_tow)
            has = cnt > 0
            prof[has, j] = val[has] / cnt[has]
        out[s] = prof
    return out


def _dst_candidate(sig: Signals, W: Within, options: dict) -> Candidate:
    """Daylight-saving shift of the gain schedule: a one-hour jump of the weekday profile at the change.

    Evidence: the lag aligning the weekday gain profiles of daylight-saving and
    standard-time weekdays of the same season (:func:`dst_profile_lag`). A lag of at
    least half an hour is confirmed by fitting the ``dst_shift`` term (the profile read one
    hour earlier while daylight saving is on for ``L > 0``, later for ``L < 0``), with the
    profile re-estimated on the clock the gains follow.
    """
    on = dst_active(sig.index)
    onw = W(on.astype(float))
    loc = {"variant": "dst_shift"}
    if np.var(onw) < 1e-3:
        return Candidate("internal_gain_schedule", loc, status="untestable",
                         reason="daylight-saving time does not change within any season's training weeks")
    resid_all = options.get("_resid_all")
    ev = {"dst_fraction_of_training_rows": float(on[W.rows].mean())}
    if resid_all is None:
        return Candidate("internal_gain_schedule", loc, status="untestable", evidence=ev,
                         reason="no one-step residuals")
    gains = apparent_gains(sig, resid_all)
    ev.update(dst_profile_lag(sig, gains, W.rows))
    if not ev["seasons"]:
        return Candidate("internal_gain_schedule", loc, status="untestable", evidence=ev,
                         reason=f"no season has {DST_MIN_DAYS} training weekdays both with and without daylight "
                                f"saving")
    steps = int(round(3600 / sig.step))
    L = ev["lag_steps"]
    if 2 * abs(L) < steps:
        return Candidate("internal_gain_schedule", loc, status="not significant", evidence=ev,
                         reason=f"the weekday gain profiles with and without daylight saving align at lag "
                                f"{L * sig.step / 60:+.0f} min (under half an hour)")
    r2_min, g_min = options["dst_min_r2"], options["dst_min_scale"]
    if ev["r2_at_lag"] < r2_min or ev["scale_at_lag"] < g_min:
        return Candidate("internal_gain_schedule", loc, status="not significant", evidence=ev,
                         reason=f"a {L * sig.step / 60:+.0f}-min shift explains {100 * ev['r2_at_lag']:.0f} % of the "
                                f"morning difference between daylight-saving and standard-time weekdays at scale "
                                f"{ev['scale_at_lag']:.2f} (needs {100 * r2_min:.0f} % and {g_min:g}): no "
                                f"schedule jump at the change")
    # the clock moves by the legal hour; the estimated lag (often 60-90 min: the ramp of a
    # partly shifted profile looks wider) gives the direction and is reported as evidence
    shifts = [-int(np.sign(L)) * steps]
    variants = []
    for sh in shifts:
        t = InternalGainSchedule(variant="dst_shift", zone_names=sig.zones, coef=tuple(0.0 for _ in sig.zones),
                                 shift=sh)
        variants.append(t)
    c = Candidate("internal_gain_schedule", loc, variants, 1, evidence=ev)
    c.profiles = {sh: shifted_clock_profiles(sig, gains, W.rows, sh) for sh in shifts}
    return c
