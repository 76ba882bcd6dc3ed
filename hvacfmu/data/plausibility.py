"""Physical plausibility of measured columns: airflow against the box, outdoor air against the climate, stuck sensors.

Each check takes a converted SI column and either appends a *problem* (the file
cannot be used as declared: a wrong unit, most values impossible) or a
*warning* (a few impossible samples masked, a suspicious but possible pattern).
Every message names the file, the column, the rows and the fix.

Thresholds (module constants) and why:

- :data:`SPIKE_FACTOR`: a VAV box cannot deliver more than about its design
  airflow ``m_max``, which its inlet duct is sized for; readings above
  ``SPIKE_FACTOR * m_max`` are physically impossible. Up to
  :data:`SPIKE_SHARE_MAX` of the samples of a column are masked (set missing)
  with a warning; more than that is a problem (the column or its unit is wrong).
- Unit plausibility of airflow: the 99th percentile must not exceed
  :data:`UNIT_HIGH_FACTOR` ``* m_max``, and while the box runs (above 0.2
  ``m_min``) its median must not fall below :data:`UNIT_LOW_FACTOR` ``* m_min``;
  a violation names the airflow units that would fit (cfm read as L/s is 2.1 times
  too much, L/s read as cfm 2.1 times too little). Far from the limits, the
  minimum plateau decides: a box rests at ``m_min`` for much of any record; when
  under :data:`PLATEAU_ABSENT` of its samples lie within :data:`PLATEAU_TOL` of
  ``m_min`` in the declared unit but at least :data:`PLATEAU_SHARE` do in another
  airflow unit, the unit is wrong.
- Outdoor air: monthly means of ``T_out`` must lie in a climate envelope that
  depends on latitude, on the half of the year and on midwinter
  (:func:`outdoor_envelope`); °C declared as °F shows as a month at about
  -10 °C in the warm season, °F declared as °C as a January above 15 °C at
  Chicago's latitude. In a cold month °C declared as °F can still fit (-5 °C
  reads -20.5 °C); a ``T_out`` declared in another unit than the zone
  temperatures that would fit in their unit too is flagged
  (:func:`check_outdoor_unit_mix`).
- Stuck sensors: a temperature column repeating one exact value for
  :data:`STUCK_DAYS` days or longer is masked over that run with a warning.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .units import to_si

#: Airflow units a wrong declaration is compared with (m3/h is accepted when declared, never guessed).
GUESSED_AIRFLOW_UNITS = ("kg/s", "m3/s", "L/s", "cfm")

#: Airflow above this multiple of the box's m_max is impossible (masked or refused).
SPIKE_FACTOR = 2.0
#: Largest share of impossible airflow samples that is masked rather than refused.
SPIKE_SHARE_MAX = 0.01
#: 99th percentile of airflow above this multiple of m_max: the unit is wrong.
UNIT_HIGH_FACTOR = 1.5
#: Median airflow while the box runs below this multiple of m_min: the unit is wrong.
UNIT_LOW_FACTOR = 0.6
#: Relative tolerance around m_min of the minimum-airflow plateau.
PLATEAU_TOL = 0.05
#: The box is "never at its minimum" below this share of its positive samples near m_min ...
PLATEAU_ABSENT = 0.02
#: ... while read in another airflow unit at least this share sits at m_min: the unit is wrong.
PLATEAU_SHARE = 0.2
#: A temperature sensor repeating one value this long [days] is stuck.
STUCK_DAYS = 2.0
#: Canonical prefixes checked for stuck values.
STUCK_PREFIXES = ("T_", "Td_")


def _pct(x: float) -> str:
    return f"{100 * x:.2g} %"


def airflow_unit_candidates(value_si: float, unit: str, lo: float, hi: float) -> list[str]:
    """Airflow units other than ``unit`` under which ``value_si`` [kg/s] would lie in ``lo..hi`` [kg/s]."""
    one = float(to_si(1.0, unit))
    return [u for u in GUESSED_AIRFLOW_UNITS if u != unit and lo <= value_si * float(to_si(1.0, u)) / one <= hi]


def check_airflow(si, unit, box, desc, where, problems, warnings):
    """Airflow of one box [kg/s] against its limits; returns the column with impossible spikes masked.

    Parameters
    ----------
    si : ndarray [kg/s]
        Converted airflow (NaN where missing).
    unit : str
        Declared unit of the file.
    box : Vav or None
        The box (``m_min``, ``m_max`` [kg/s]); None skips the checks.
    desc : str
        ``"file: column 'x'"`` prefix of messages.
    where : callable
        ``where(positions, values) -> str`` formats example rows.
    problems, warnings : list of str
        Appended to.
    """
    if box is None or not box.m_max > 0:
        return si
    valid = si[np.isfinite(si)]
    if not len(valid):
        return si
    spikes = np.flatnonzero(np.isfinite(si) & (si > SPIKE_FACTOR * box.m_max))
    share = len(spikes) / len(valid)
    if len(spikes) and share <= SPIKE_SHARE_MAX:
        warnings.append(
            f"{desc}: {len(spikes)} value(s) ({_pct(share)} of its samples) above {SPIKE_FACTOR:g} x m_max = "
            f"{SPIKE_FACTOR * box.m_max:g} kg/s, more than box {box.name} can deliver, masked as missing: "
            f"{where(spikes, si)}"
        )
        si = si.copy()
        si[spikes] = np.nan
        valid = si[np.isfinite(si)]
    p99 = float(np.percentile(valid, 99))
    running = valid[valid > max(0.005, 0.2 * box.m_min)]
    low = float(np.median(running)) if len(running) else None
    possible = valid[valid <= SPIKE_FACTOR * box.m_max]
    rest_fine = len(possible) > 0 and float(np.percentile(possible, 99)) <= UNIT_HIGH_FACTOR * box.m_max
    if len(spikes) and share > SPIKE_SHARE_MAX and rest_fine:
        problems.append(
            f"{desc}: {len(spikes)} value(s) ({_pct(share)} of its samples, more than the {_pct(SPIKE_SHARE_MAX)} "
            f"that are masked as spikes) above {SPIKE_FACTOR:g} x m_max = {SPIKE_FACTOR * box.m_max:g} kg/s of box "
            f"{box.name}, e.g. {where(spikes, si)}; check the column, its unit and m_max"
        )
    elif p99 > UNIT_HIGH_FACTOR * box.m_max:
        fits = airflow_unit_candidates(p99, unit, box.m_min, UNIT_HIGH_FACTOR * box.m_max)
        hint = f"the data look like {' or '.join(fits)}" if fits else "check the column and its unit"
        problems.append(
            f"{desc}: the 99th percentile of the airflow is {p99:.4g} kg/s (declared {unit}), above "
            f"{UNIT_HIGH_FACTOR:g} x m_max = {UNIT_HIGH_FACTOR * box.m_max:g} kg/s of box {box.name}, and "
            f"{len(spikes)} sample(s) exceed {SPIKE_FACTOR:g} x m_max: the unit cannot be right; {hint}: "
            "declare the unit in the building's [units] table (or correct m_max)"
        )
    elif box.m_min > 0 and low is not None and low < UNIT_LOW_FACTOR * box.m_min:
        fits = airflow_unit_candidates(low, unit, (1 - PLATEAU_TOL) * box.m_min, box.m_max)  # median at m_min
        hint = f"the data look like {' or '.join(fits)}" if fits else "check the column and its unit"
        problems.append(
            f"{desc}: while the box runs, its median airflow is {low:.4g} kg/s (declared {unit}), below "
            f"{UNIT_LOW_FACTOR:g} x m_min = {UNIT_LOW_FACTOR * box.m_min:g} kg/s of box {box.name}: the unit cannot "
            f"be right; {hint}: declare the unit in the building's [units] table (or correct m_min)"
        )
    else:
        _check_minimum_plateau(valid, unit, box, desc, problems)
    return si


def minimum_share(values_si, m_min: float) -> float:
    """Share of the positive samples within ``PLATEAU_TOL`` of ``m_min`` [kg/s] (the box held at its minimum)."""
    pos = values_si[values_si > 0]
    return float(np.mean(np.abs(pos - m_min) <= PLATEAU_TOL * m_min)) if len(pos) else 0.0


def _check_minimum_plateau(valid, unit, box, desc, problems):
    """A VAV box rests at its minimum airflow for much of the record; if it never does in the declared unit but
    does in another airflow unit, the unit is wrong (catches a cfm/L/s mix-up far from the box limits)."""
    if not box.m_min > 0:
        return
    declared = minimum_share(valid, box.m_min)
    if declared >= PLATEAU_ABSENT:
        return
    one = float(to_si(1.0, unit))
    shares = {
        u: minimum_share(valid * float(to_si(1.0, u)) / one, box.m_min) for u in GUESSED_AIRFLOW_UNITS if u != unit
    }
    best = max(shares, key=lambda u: shares[u]) if shares else None
    if best is None or shares[best] < PLATEAU_SHARE:
        return
    problems.append(
        f"{desc}: box {box.name} never rests at its minimum airflow m_min = {box.m_min:g} kg/s in the declared "
        f"unit {unit} ({_pct(declared)} of the samples within {_pct(PLATEAU_TOL)} of it), but read as {best} "
        f"{_pct(shares[best])} of them sit at m_min, as a VAV box at minimum does: the data look like {best}; "
        "declare the unit in the building's [units] table (or correct m_min)"
    )


def outdoor_envelope(latitude: float, warm_half: bool, midwinter: bool = False) -> tuple[float, float]:
    """Plausible range of a monthly mean outdoor air temperature [°C] at ``latitude`` [deg].

    A deliberately wide envelope around the observed climate extremes (monthly
    means of weather stations below 2000 m): the warm half of the year
    (April-September in the northern hemisphere) never has a monthly mean below
    0 °C equatorward of 45°, -5 °C up to 60° or -20 °C beyond; the cold half
    never below 5 °C within 25° of the equator, -10 °C to 35°, -25 °C to 45°,
    -50 °C beyond. No monthly mean exceeds 40 °C; in the three midwinter months
    (December-February north, June-August south) none exceeds 15 °C poleward of
    40° (Lisbon, Naples: 9-12 °C), 20 °C poleward of 30° (Cairo, Houston, Perth:
    11-14 °C) or 26 °C poleward of 23.5° (Miami, Key West: 20-21 °C).
    """
    a = abs(latitude)
    if warm_half:
        lo = 0.0 if a <= 45 else (-5.0 if a <= 60 else -20.0)
    else:
        lo = 5.0 if a <= 25 else (-10.0 if a <= 35 else (-25.0 if a <= 45 else -50.0))
    hi = 40.0
    if midwinter:
        hi = 15.0 if a >= 40 else (20.0 if a >= 30 else (26.0 if a >= 23.5 else 40.0))
    return lo, hi


def outdoor_months(si, index, latitude) -> list[tuple[int, float, float, float]]:
    """``(month, mean [°C], lo, hi)`` of every month with at least 5 days of outdoor temperatures."""
    if index is None or not np.isfinite(si).any():
        return []
    s = pd.Series(si, index=pd.DatetimeIndex(index))
    s = s[~s.index.isna() & np.isfinite(s.to_numpy())]
    month = s.index.month.to_numpy()
    out = []
    for m in np.unique(month):
        vals = s.to_numpy()[month == m]
        if len(vals) < 2 or (s.index[month == m][-1] - s.index[month == m][0]) < pd.Timedelta(days=5):
            continue
        north = latitude >= 0
        warm = (4 <= m <= 9) if north else not (4 <= m <= 9)
        midwinter = m in ((12, 1, 2) if north else (6, 7, 8))
        lo, hi = outdoor_envelope(latitude, warm, midwinter)
        out.append((int(m), float(np.mean(vals)), lo, hi))
    return out


def _months_text(months) -> str:
    return ", ".join(f"{pd.Timestamp(2001, mm, 1):%b} {mu:.1f} °C" for mm, mu, _, _ in months[:4])


def check_outdoor(si, unit, index, latitude, desc, problems):
    """Monthly means of the outdoor temperature [°C] against :func:`outdoor_envelope`."""
    months = outdoor_months(si, index, latitude)
    bad = [x for x in months if not x[2] <= x[1] <= x[3]]
    if not bad:
        return
    m, mean, lo, hi = bad[0]
    others = {"degC": "degF", "degF": "degC", "K": "degC"}
    alt = others.get(unit)
    hint = ""
    if alt is not None:
        from .units import from_si

        as_alt = float(to_si(from_si(mean, unit), alt))
        if lo <= as_alt <= hi:
            hint = f"; read as {alt} it would be {as_alt:.1f} °C, which fits: the data look like {alt}"
    problems.append(
        f"{desc}: monthly mean outdoor temperature ({_months_text(bad)}; declared {unit}) is outside {lo:g}..{hi:g} "
        f"°C, the plausible range at latitude {latitude:g}° in that season{hint}: declare the unit in the "
        "building's [units] table"
    )


def shoulder_low(latitude: float) -> float:
    """Lowest plausible monthly mean outdoor temperature [°C] in a cold-half month outside midwinter.

    October, November and March in the north (April, May and September in the south), at stations below 2000 m:
    none colder than -2 °C within 35° of the equator (Kabul, 1790 m: November 3.5 °C), -10 °C to 45° (the
    coldest, Hohhot and Urumqi, about -4 °C in November), -20 °C to 60° (Ulaanbaatar, 1350 m: November -13 °C).
    """
    a = abs(latitude)
    return -2.0 if a <= 35 else (-10.0 if a <= 45 else (-20.0 if a <= 60 else -50.0))


def check_outdoor_shoulder(raw, unit, si, index, latitude, desc, warnings):
    """Flag ``T_out`` whose autumn or spring months are colder than any station's while another unit fits.

    °C declared as °F (the zones' unit) reads 10 °C as -12.2 °C: inside the wide cold-half envelope of
    :func:`outdoor_envelope` that must admit midwinter, but colder than any October, November or March below
    60° (:func:`shoulder_low`). Said only when the other reading of the same numbers fits that month.
    """
    alt = {"degF": "degC", "degC": "degF"}.get(unit)
    if alt is None or index is None:
        return
    north = latitude >= 0
    months = [x for x in outdoor_months(si, index, latitude) if x[0] in ((10, 11, 3) if north else (4, 5, 9))]
    lo = shoulder_low(latitude)
    cold = [x for x in months if x[1] < lo]
    if not cold:
        return
    as_alt = outdoor_months(to_si(raw, alt), index, latitude)
    fits = {m: mu for m, mu, a, b in as_alt if max(a, lo) <= mu <= b}
    if not all(m in fits for m, *_ in cold):
        return
    alt_text = ", ".join(f"{pd.Timestamp(2001, m, 1):%b} {fits[m]:.1f} °C" for m, *_ in cold[:4])
    warnings.append(
        f"{desc}: monthly mean outdoor temperature ({_months_text(cold)}; declared {unit}) is below {lo:g} °C, "
        f"colder than any weather station below 2000 m at latitude {latitude:g}° in that month; read as {alt} it "
        f"would be {alt_text}: is the outdoor air in {alt} (a weather feed in another unit than the BMS)? declare "
        f'its unit in the building\'s [units] table (T_out = "{alt}")'
    )


def check_outdoor_unit_mix(raw, unit, zone_unit, index, latitude, desc, warnings):
    """Flag ``T_out`` declared in another temperature unit than the zones when the zones' unit fits it too.

    A BMS exports every temperature in one unit; outdoor air declared apart (e.g.
    ``T_out = "degF"`` beside ``T_* = "degC"``) is a likely slip that the climate
    envelope cannot see in a cold month (-5 °C read as °F is -20.5 °C, still a
    possible Chicago January). Nothing is said when the zones' unit would put
    the outdoor air outside the envelope (the declaration is then evidently right).
    """
    if zone_unit is None or zone_unit == unit:
        return
    as_zone = to_si(raw, zone_unit)
    months = outdoor_months(as_zone, index, latitude)
    if not months or any(not lo <= mu <= hi for _, mu, lo, hi in months):
        return
    declared = outdoor_months(to_si(raw, unit), index, latitude)
    warnings.append(
        f"{desc}: declared {unit} while the zone temperatures are declared {zone_unit}; read as {zone_unit} its "
        f"monthly means ({_months_text(months)}) fit the climate at latitude {latitude:g}° as well as the declared "
        f"reading ({_months_text(declared)}): a BMS exports one unit for all temperatures, check the building's "
        "[units] table"
    )


def stuck_runs(values, times_ns, min_seconds):
    """``(start, stop)`` positions of runs of one repeated finite value lasting ``min_seconds`` or more.

    NaN samples inside a run neither break nor extend it.
    """
    pos = np.flatnonzero(np.isfinite(values))
    if len(pos) < 2:
        return []
    v = values[pos]
    change = np.flatnonzero(np.diff(v) != 0) + 1
    starts = np.concatenate(([0], change))
    stops = np.concatenate((change, [len(v)]))
    t = times_ns[pos]
    long = ((stops - starts) >= 2) & ((t[stops - 1] - t[starts]) / 1e9 >= min_seconds)  # vectorised: noisy data
    return [(int(pos[a]), int(pos[b - 1]) + 1) for a, b in zip(starts[long], stops[long])]


def check_stuck(canonical, si, times_ns, desc, where, warnings, ok=None):
    """Mask temperature runs repeating one value for :data:`STUCK_DAYS` or longer; returns the column.

    ``ok`` (optional) marks the rows with a valid time; the others are ignored.
    """
    if times_ns is None or not canonical.startswith(STUCK_PREFIXES):
        return si
    found = stuck_runs(si if ok is None else np.where(ok, si, np.nan), times_ns, STUCK_DAYS * 86400)
    if not found:
        return si
    si = si.copy()
    parts = []
    total = 0
    for a, b in found:
        days = (times_ns[b - 1] - times_ns[a]) / 86400e9
        parts.append(f"{si[a]:.6g} for {days:.1f} days from {where([a], None)}")
        total += int(np.isfinite(si[a:b]).sum())
        si[a:b] = np.nan
    more = f" and {len(parts) - 3} more run(s)" if len(parts) > 3 else ""
    warnings.append(
        f"{desc}: a stuck sensor? the value repeats exactly for {STUCK_DAYS:g} days or more: "
        f"{'; '.join(parts[:3])}{more}; {total} sample(s) masked as missing (fix or drop the sensor)"
    )
    return si


#: Outdoor air whose daily range stays under this [K] on :data:`FROZEN_DAYS` consecutive days is frozen ...
FROZEN_RANGE_K = 0.5
#: ... (a run of at least this many full local days) ...
FROZEN_DAYS = 3
#: ... while its other full days swing a median of at least this [K] (the column holds real outdoor air).
FROZEN_OTHER_RANGE_K = 2.0


def check_outdoor_frozen(si, local, ok, desc, where, warnings):
    """Mask runs of full local days on which ``T_out`` barely moves (a frozen sensor with noise); returns the column.

    A day is full when it holds at least 80 % of the samples of the fullest day. A run of
    :data:`FROZEN_DAYS` or more consecutive full days, each with a range (max - min) under
    :data:`FROZEN_RANGE_K`, is masked and named, when the other full days (7 or more) swing a median of
    :data:`FROZEN_OTHER_RANGE_K` or more. Outdoor air moves by more than that on nearly every day (no day of
    the 16 typical-year weather files of EnergyPlus has a range under 1 K); an exact repeat is
    :func:`check_stuck`'s.
    """
    if local is None or not len(si):
        return si
    good = np.isfinite(si) & (ok if ok is not None else True)
    if good.sum() < 96:
        return si
    day = np.asarray(local[good].normalize().asi8)
    v = si[good]
    days, inv, counts = np.unique(day, return_inverse=True, return_counts=True)
    hi = np.full(len(days), -np.inf)
    lo = np.full(len(days), np.inf)
    np.maximum.at(hi, inv, v)
    np.minimum.at(lo, inv, v)
    rng = hi - lo
    full = counts >= 0.8 * counts.max()
    flat = (counts >= 0.25 * counts.max()) & (rng < FROZEN_RANGE_K)  # a day with an outage may bridge a run
    consecutive = np.diff(days) <= 86400e9 * 1.1  # days are local midnights (23-25 h apart across clock changes)
    runs, a = [], None
    for i in range(len(days) + 1):
        go_on = i < len(days) and flat[i] and a is not None and consecutive[i - 1]
        if a is not None and not go_on:
            if full[a:i].sum() >= FROZEN_DAYS:
                runs.append((a, i - 1))
            a = None
        if a is None and i < len(days) and flat[i]:
            a = i
    other = full & (rng >= FROZEN_RANGE_K)
    if not runs or other.sum() < 7 or float(np.median(rng[other])) < FROZEN_OTHER_RANGE_K:
        return si
    si = si.copy()
    pos = np.flatnonzero(good)
    parts, total = [], 0
    for a, b in runs:
        inside = (day >= days[a]) & (day <= days[b])
        band = (v[inside].min(), v[inside].max())
        i, j = np.flatnonzero(inside)[[0, -1]]
        while i > 0 and band[0] <= v[i - 1] <= band[1]:  # the partial days at its ends, as long as it stays frozen
            i -= 1
        while j + 1 < len(v) and band[0] <= v[j + 1] <= band[1]:
            j += 1
        rows = pos[i : j + 1]
        parts.append(
            f"{(local[rows[-1]] - local[rows[0]]).total_seconds() / 86400:.1f} days from {where(rows[:1], None)} to "
            f"{where(rows[-1:], None)} "
            f"(daily range {float(rng[a : b + 1].min()):.2g}..{float(rng[a : b + 1].max()):.2g} K)"
        )
        total += len(rows)
        si[rows[0] : rows[-1] + 1] = np.nan
    more = f" and {len(parts) - 3} more run(s)" if len(parts) > 3 else ""
    warnings.append(
        f"{desc}: a frozen outdoor sensor? the outdoor air barely moves for {FROZEN_DAYS} days or more: "
        f"{'; '.join(parts[:3])}{more}, while on its other {int(other.sum())} full days it swings a median "
        f"{float(np.median(rng[other])):.2g} K from night to afternoon; {total} sample(s) masked as missing "
        "(fix the sensor or its trend log, or blank those rows)"
    )
    return si


#: A zone temperature this far [K] from its running median is an error code or a dropout, not air.
ZONE_SPIKE_K = 12.0
#: Width [h] of the running median zone temperatures are compared with.
ZONE_SPIKE_WINDOW_H = 12.0


def check_zone_spikes(si, times_ns, ok, desc, where, problems, warnings):
    """Mask zone temperatures [°C] more than :data:`ZONE_SPIKE_K` from their running median; returns the column.

    Zone air moves a few kelvin in hours; a sample 12 K or more away from the
    median of the surrounding :data:`ZONE_SPIKE_WINDOW_H` hours is an error code
    or a dropout (0, 0 °F, 999 ...) that the -50..80 °C range lets through. Up to
    :data:`SPIKE_SHARE_MAX` of the samples are masked with a warning; more is a
    problem (the column or its mapping is wrong).
    """
    if times_ns is None:
        return si
    sel = np.flatnonzero(np.isfinite(si) & ok)
    if len(sel) < 20:
        return si
    v = si[sel]
    bin_ns = 900 * 10**9
    bins = (times_ns[sel] - times_ns[sel].min()) // bin_ns
    per_bin = pd.Series(v).groupby(bins).median()
    width = int(round(ZONE_SPIKE_WINDOW_H * 3600e9 / bin_ns)) | 1
    full = per_bin.reindex(np.arange(int(bins.max()) + 1))
    local = full.rolling(width, center=True, min_periods=max(3, width // 8)).median().to_numpy()[bins]
    far = np.isfinite(local) & (np.abs(v - local) > ZONE_SPIKE_K)
    far &= ~_air_excursions(v, local, far)
    held = _dropout_runs(v, times_ns[sel]) & ~far
    spikes = sel[far | held]
    if not len(spikes):
        return si
    runs = (
        f" or, {held.sum()} of them held at one value, from the zone air before and after that run"
        if held.any()
        else ""
    )
    share = len(spikes) / len(sel)
    text = (
        f"{desc}: {len(spikes)} value(s) ({_pct(share)} of its samples) more than {ZONE_SPIKE_K:g} K away from the "
        f"median of the surrounding {ZONE_SPIKE_WINDOW_H:g} h{runs}, which zone air does not do (an error code or a "
        f"sensor dropout such as 0 or -999?)"
    )
    if share > SPIKE_SHARE_MAX:
        problems.append(
            f"{text}, more than the {_pct(SPIKE_SHARE_MAX)} that are masked: {where(spikes, si)}; check the column, "
            "its mapping and the error codes of the export"
        )
        return si
    warnings.append(f"{text}, masked as missing: {where(spikes, si)}")
    si = si.copy()
    si[spikes] = np.nan
    return si


#: Fewest samples of an excursion from the running median that can be zone air rather than an error code.
AIR_EXCURSION_MIN = 3


def _air_excursions(v, local, far) -> np.ndarray:
    """Mask of the ``far`` samples that belong to a smooth excursion of the zone air, not to an error code.

    An excursion is a run of consecutive samples more than half of :data:`ZONE_SPIKE_K` from the running median
    ``local`` that holds a ``far`` one. It is air when it lasts :data:`AIR_EXCURSION_MIN` samples or more, its
    values are not one repeated value, every step inside it is under :data:`ZONE_SPIKE_K`, and it enters or
    leaves the air around it gradually (on at least one side a step under half its largest distance from the
    median, so the air comes back, or goes, in two steps or more): a school
    lobby in January falls 15 K in a quarter of an hour when its air handler starts on cold outdoor air and its
    doors open, stays down an hour and climbs back over the next two (EnergyPlus 90.1 primary and secondary
    schools, Denver). An error code or a dropout jumps away and back (a step of about its distance from the air
    on both sides) or holds one value.
    """
    out = np.zeros(len(v), dtype=bool)
    half = 0.5 * ZONE_SPIKE_K
    wide = np.isfinite(local) & (np.abs(v - local) > half)
    if not far.any():
        return out
    idx = np.flatnonzero(wide)
    for run in np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1):
        a, b = int(run[0]), int(run[-1]) + 1
        if not far[a:b].any() or b - a < AIR_EXCURSION_MIN:
            continue
        seg = v[a:b]
        if np.all(seg == seg[0]) or np.abs(np.diff(seg)).max(initial=0.0) >= ZONE_SPIKE_K:
            continue
        steps = [abs(v[a] - v[a - 1])] if a > 0 else []
        steps += [abs(v[b] - v[b - 1])] if b < len(v) else []
        if steps and min(steps) < 0.5 * float(np.abs(seg - local[a:b]).max()):
            out[a:b] = True
    return out


def _dropout_runs(v, t_ns) -> np.ndarray:
    """Mask of runs of one repeated value :data:`ZONE_SPIKE_K` or more from the zone air on both sides of the run.

    A sensor that drops out for hours writes its default (0 °C, 32 °F, -40, 85) over and over; a run as long as
    the running median's window moves the median with it, so :func:`check_zone_spikes` compares such a run with
    the medians of the :data:`ZONE_SPIKE_WINDOW_H` hours before it and after it instead (one side at the ends of
    the record). Zone air never holds one exact value that far from what it read before and after.
    """
    out = np.zeros(len(v), dtype=bool)
    if len(v) < 3:
        return out
    change = np.flatnonzero(np.diff(v) != 0) + 1
    starts = np.concatenate(([0], change))
    stops = np.concatenate((change, [len(v)]))
    jump_in = np.abs(v[starts] - v[np.maximum(starts - 1, 0)]) > ZONE_SPIKE_K
    jump_out = np.abs(v[stops - 1] - v[np.minimum(stops, len(v) - 1)]) > ZONE_SPIKE_K
    keep = (stops - starts >= 2) & (jump_in | jump_out)  # a dropout jumps away from the air on one side at least
    window = int(ZONE_SPIKE_WINDOW_H * 3600e9)
    for a, b in zip(starts[keep], stops[keep]):
        before = v[np.searchsorted(t_ns, t_ns[a] - window) : a]
        after = v[b : np.searchsorted(t_ns, t_ns[b - 1] + window, side="right")]
        sides = [float(np.median(s)) for s in (before, after) if len(s) >= 4]
        if sides and all(abs(v[a] - m) > ZONE_SPIKE_K for m in sides):
            out[a:b] = True
    return out


#: Days of data before a column's day-to-day behaviour is judged (setpoints, constant airflow).
BEHAVIOUR_DAYS = 7.0
#: A zone temperature changing value at most this many times on a median day is a setpoint, not a sensor.
SETPOINT_CHANGES_PER_DAY = 2


#: A zone temperature repeating one value this long [h] (and under :data:`STUCK_DAYS`) is held, ...
HELD_HOURS = 6.0
#: ... when it then jumps by at least this much [K] and this multiple of the column's median change ...
HELD_JUMP_K, HELD_JUMP_FACTOR = 0.5, 5.0
#: ... on at least this many days, holding at least this many distinct values (a simulated zone resting at one
#: setpoint repeats that value each night: 2 days at most in 55 EnergyPlus exports).
HELD_RUNS = 5
#: Held values closer than this [K] are one value: EnergyPlus writes one setpoint as 23.8889, 23.889 and 23.89
#: (the 90.1 small hotel's front office, 75 °F, 48 runs on 40 days counted as 5+ values and flagged before session 21)
HELD_VALUE_RESOLUTION = 0.01


def check_zone_held(si, times_ns, ok, desc, where, warnings):
    """Flag held stretches of a zone temperature (a controller offline that repeats its last reading).

    A run of one exact value lasting :data:`HELD_HOURS` or more that ends with a jump (the sensor's real
    value after hours of silence) is not air: the zone's temperature moves every hour. Flagged when such
    runs occur on :data:`HELD_RUNS` days or more with as many distinct held values, told apart at
    :data:`HELD_VALUE_RESOLUTION` (a zone resting at its setpoint holds the same value every night and leaves it
    smoothly; a simulation writes that value with float noise in its last digits). The samples are kept: masking them
    leaves the zone without its nights, and the red team's model got worse (1.44 K on the clean data
    against 0.25 K with the held values, 0.20 K clean). Returns the column unchanged.
    """
    if times_ns is None:
        return si
    v = np.where(ok, si, np.nan)
    fin = np.flatnonzero(np.isfinite(v))
    if len(fin) < 2:
        return si
    steps = np.abs(np.diff(v[fin]))
    steps = steps[steps > 0]
    if not len(steps):
        return si
    jump_min = max(HELD_JUMP_K, HELD_JUMP_FACTOR * float(np.median(steps)))
    held = []
    for a, b in stuck_runs(v, times_ns, HELD_HOURS * 3600):
        if (times_ns[b - 1] - times_ns[a]) >= STUCK_DAYS * 86400e9:
            continue  # a stuck sensor: check_stuck's
        after = fin[fin >= b]
        if len(after) and abs(v[after[0]] - v[a]) >= jump_min:
            held.append((a, b))
    days = {int(times_ns[a] // 86400e9) for a, _ in held}
    values = {round(float(v[a]) / HELD_VALUE_RESOLUTION) for a, _ in held}
    if min(len(days), len(values)) < HELD_RUNS:
        return si
    total = sum(int(np.isfinite(si[a + 1 : b]).sum()) for a, b in held)
    hours = [(times_ns[b - 1] - times_ns[a]) / 3600e9 for a, b in held]
    a0, b0 = held[0]
    warnings.append(
        f"{desc}: a held sensor? the value repeats exactly for {HELD_HOURS:g} h or more and then jumps by "
        f"{jump_min:.2g} K or more, {len(held)} times on {len(days)} days ({min(hours):.0f}-{max(hours):.0f} h; "
        f"first: {v[a0]:.4g} from {where([a0], None)} to {where([b0 - 1], None)}): zone air moves every hour, "
        "so the controller repeated its last reading (offline, or trend-logged on change of value with a "
        f"coarse threshold); {total} held sample(s), kept as read: the models learn those flat stretches as "
        "zone air, and blanking them would leave the zone without those hours; fix the trend log (poll the "
        "sensor, or log on a finer change of value) and export again"
    )
    return si


def check_setpoint_like(si, times_ns, ok, desc, warnings):
    """Flag a zone temperature that changes value only a few times a day (a setpoint exported as the sensor)."""
    if times_ns is None:
        return
    sel = np.flatnonzero(np.isfinite(si) & ok)
    if len(sel) < 2 or (times_ns[sel[-1]] - times_ns[sel[0]]) < BEHAVIOUR_DAYS * 86400e9:
        return
    v = si[sel]
    day = times_ns[sel][1:] // (86400 * 10**9)
    per_day = pd.DataFrame({"changes": np.diff(v) != 0, "day": day}).groupby("day")["changes"].agg(["sum", "count"])
    per_day = per_day[per_day["count"] >= 24]
    if len(per_day) < BEHAVIOUR_DAYS or float(per_day["sum"].median()) > SETPOINT_CHANGES_PER_DAY:
        return
    values = np.unique(v)
    warnings.append(
        f"{desc}: the value changes only {float(per_day['sum'].median()):g} time(s) on a median day over "
        f"{len(per_day)} days ({len(values)} distinct value(s), e.g. {', '.join(f'{x:g}' for x in values[:4])}): "
        "a sensor in moving air changes many times a day; is it a setpoint exported as the zone temperature? "
        "map the measured zone air temperature"
    )


def check_airflow_constant(si, times_ns, ok, box, desc, warnings):
    """Flag an airflow column holding one value over the whole record (a dead sensor, a setpoint, a box never moved)."""
    if times_ns is None or box is None:
        return
    sel = np.flatnonzero(np.isfinite(si) & ok)
    if len(sel) < 2 or (times_ns[sel[-1]] - times_ns[sel[0]]) < BEHAVIOUR_DAYS * 86400e9:
        return
    v = si[sel]
    if float(np.ptp(v)) > 0:
        return
    if box.m_max - box.m_min <= 0.01 * box.m_max and abs(v[0] - box.m_max) <= 0.01 * box.m_max:
        return  # a constant-volume box (m_min = m_max, the 90.1 hospital's lab) delivering its one flow
    days = (times_ns[sel[-1]] - times_ns[sel[0]]) / 86400e9
    if box.m_min > 0 and abs(v[0] - box.m_min) <= 0.01 * box.m_max:
        # a VAV box at its (ventilation) minimum the whole record: what a reheat box does all winter (the 90.1
        # outpatient clinic's exam rooms in Colorado Springs, January-March), not a fault to fix before fitting
        warnings.append(
            f"{desc}: reads its minimum m_min = {box.m_min:g} kg/s in every one of its {len(v)} samples over "
            f"{days:.1f} days (box {box.name} may reach m_max = {box.m_max:g} kg/s): a VAV box that stayed at its "
            "minimum flow, as one does when it only reheats (a heating season); its heat still moves with its "
            f"discharge temperature Td_{box.name}, but its airflow response is not seen in these data. If the box "
            "did move, the column is a setpoint, not the measured flow"
        )
        return
    if abs(v[0] - box.m_max) <= 0.01 * box.m_max:
        # a box at its maximum all along (the 90.1 large office's data centre) is how that zone runs, not a fault
        warnings.append(
            f"{desc}: box {box.name} delivers its m_max = {v[0]:.4g} kg/s in every one of its {len(v)} samples over "
            f"{days:.1f} days: its airflow never changes, so the models cannot learn its effect from these data"
        )
        return
    warnings.append(
        f"{desc}: reads {v[0]:.4g} kg/s in every one of its {len(v)} samples over {days:.1f} days, while box "
        f"{box.name} may move between m_min = {box.m_min:g} and m_max = {box.m_max:g} kg/s: a dead flow sensor, a "
        "setpoint exported as the flow, or a box that never moves; the models learn nothing from it: check the column"
    )


#: Span [days] of ghi needed before its level is compared with the clear sky.
GHI_LEVEL_DAYS = 7.0
#: Days whose clear-sky peak is below this [W/m²] (low winter sun at high latitude) are not compared.
GHI_LEVEL_SKY = 300.0
#: The sunniest day's peak ghi below this share of the clear-sky peak is flagged.
GHI_LEVEL_SHARE = 0.4


def clear_sky_ghi(times_ns, latitude: float, longitude: float) -> np.ndarray:
    """Clear-sky global horizontal irradiance [W/m²] at UTC instants [ns] (Haurwitz 1945; Spencer's sun)."""
    t = pd.DatetimeIndex(np.asarray(times_ns).view("M8[ns]"))
    doy = t.day_of_year.to_numpy()
    g = 2 * np.pi * (doy - 1) / 365.0
    decl = (
        0.006918
        - 0.399912 * np.cos(g)
        + 0.070257 * np.sin(g)
        - 0.006758 * np.cos(2 * g)
        + 0.000907 * np.sin(2 * g)
        - 0.002697 * np.cos(3 * g)
        + 0.00148 * np.sin(3 * g)
    )
    eot = 229.18 * (
        0.000075 + 0.001868 * np.cos(g) - 0.032077 * np.sin(g) - 0.014615 * np.cos(2 * g) - 0.040849 * np.sin(2 * g)
    )  # [min]
    hours = t.hour.to_numpy() + t.minute.to_numpy() / 60 + t.second.to_numpy() / 3600
    solar = hours + longitude / 15.0 + eot / 60.0
    ha = np.deg2rad(15.0 * (solar - 12.0))
    lat = np.deg2rad(latitude)
    cosz = np.sin(lat) * np.sin(decl) + np.cos(lat) * np.cos(decl) * np.cos(ha)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        ghi = np.where(cosz > 0.01, 1098.0 * cosz * np.exp(-0.057 / np.maximum(cosz, 0.01)), 0.0)
    return ghi


#: The median of the nightly minima of ghi above this [W/m²] is an offset (irradiance is 0 at night).
GHI_NIGHT_MAX = 20.0


def _night_offset(ghi, clear, day, desc, unit, warnings) -> None:
    """Flag ghi that never falls to 0 at night (an offset, or another quantity), on days when the sun sets."""
    night = pd.Series(np.where(clear <= 0, ghi, np.nan)).groupby(day).agg(["min", "count"])
    night = night[night["count"] >= 3]
    if len(night) < 2:
        return
    floor = float(night["min"].median())
    if floor > GHI_NIGHT_MAX:
        warnings.append(
            f"{desc}: never falls below {floor:.3g} W/m² at night (median of the nightly minima over {len(night)} "
            f"nights, declared {unit}): an irradiance sensor reads 0 after sunset, so this is an offset or another "
            "quantity; subtract the offset or fix the sensor"
        )


def check_irradiance_level(si, times_ns, ok, latitude, longitude, desc, unit, warnings):
    """Flag ghi whose sunniest day peaks far below the clear sky (energy per interval, a shaded sensor)."""
    if times_ns is None:
        return
    sel = np.flatnonzero(np.isfinite(si) & ok)
    if len(sel) < 2 or (times_ns[sel[-1]] - times_ns[sel[0]]) < GHI_LEVEL_DAYS * 86400e9:
        return
    clear = clear_sky_ghi(times_ns[sel], latitude, longitude)
    day = times_ns[sel] // (86400 * 10**9)
    _night_offset(si[sel], clear, day, desc, unit, warnings)
    measured = pd.Series(si[sel]).groupby(day).max()
    sky = pd.Series(clear).groupby(day).max()
    good = sky > GHI_LEVEL_SKY  # a sun high enough that a week without one sunny hour is rare
    if good.sum() < GHI_LEVEL_DAYS * 0.7:
        return
    ratio = (measured[good] / sky[good]).max()
    if ratio >= GHI_LEVEL_SHARE:
        return
    peak = float(measured[good].max())
    per_ft2 = ""
    for name, factor in (("W/ft2", 1 / 0.3048**2), ("Btu/h/ft2", 1055.05585262 / 3600 / 0.3048**2)):
        if unit == "W/m2" and GHI_LEVEL_SHARE <= ratio * factor <= 1.3:
            per_ft2 = (
                f"; read as {name} (x {factor:.2f} W/m²) its highest peak would be {peak * factor:.0f} W/m², "
                f'{100 * ratio * factor:.0f} % of the clear sky: declare ghi = "{name}" in the building\'s '
                "[units] table if the station reports per square foot"
            )
            break
    warnings.append(
        f"{desc}: its highest daily peak over {int(good.sum())} days is {peak:.4g} W/m² (declared {unit}), only "
        f"{100 * ratio:.0f} % of the clear-sky peak that day at latitude {latitude:g}°, longitude {longitude:g}°: "
        "an irradiance this low on every day is not W/m²; energy per trend interval (Wh/m² per 15 min reads "
        "a quarter of W/m²)? a shaded or dirty sensor? convert the column to W/m² (average power) or fix the sensor"
        + per_ft2
    )


#: Two temperature columns equal in at least this share of their common rows are one sensor twice.
IDENTICAL_SHARE = 0.98
#: ... when they have at least this many common rows.
IDENTICAL_MIN_ROWS = 100


def identical_columns(columns: dict, names: dict, where, label: str) -> list[str]:
    """Problems for temperature columns (zones, outdoor, supply air) that are copies of each other.

    ``columns`` maps canonical names to SI arrays, ``names`` to their file columns.
    Two sensors never agree to the last digit row after row; equal values in
    :data:`IDENTICAL_SHARE` of the common rows mean one point exported, or mapped
    in ``[columns]``, under two names. Columns mapped to the same file column
    (one declared air handler's ``T_supply``) and constant columns are skipped.
    """
    temps = [c for c in columns if c.startswith("T_")]
    out = []
    for i, a in enumerate(temps):
        for b in temps[i + 1 :]:
            if names.get(a) == names.get(b) or _unit_and_mean(a, b, temps):
                continue
            x, y = columns[a], columns[b]
            both = np.isfinite(x) & np.isfinite(y)
            n = int(both.sum())
            if n < IDENTICAL_MIN_ROWS or np.nanstd(x[both]) < 0.01:
                continue
            same = both & (x == y)
            share = float(same.sum()) / n
            if share >= IDENTICAL_SHARE:
                first = np.flatnonzero(same)[:1]
                out.append(
                    f"{label}: columns {names.get(a, a)!r} ({a}) and {names.get(b, b)!r} ({b}) hold the same value in "
                    f"{100 * share:.1f} % of the {n} rows where both have one (from {where(first, None)}): two sensors "
                    "never agree that closely, so one point is exported or mapped twice; map each column to its own "
                    "point in the building's [columns] table, or fix the export"
                )
    return out


def _unit_and_mean(a: str, b: str, temps) -> bool:
    """True for ``T_supply`` beside the only unit's ``T_supply_<ahu>``: the units' airflow-weighted mean of one unit
    is that unit's temperature (an EnergyPlus export of a floor with one air handler writes both)."""
    if "T_supply" not in (a, b):
        return False
    other = b if a == "T_supply" else a
    units = [c for c in temps if c.startswith("T_supply_")]
    return other.startswith("T_supply_") and units == [other]


#: Median daily range [K] of an outdoor air temperature below which it is flagged as indoor air ...
OUTDOOR_MIN_DAILY_RANGE = 2.0
#: ... when its mean also lies within this many kelvin of the zones' mean.
INDOOR_LIKE_K = 2.0
#: Supply air within this many kelvin of the zone mean in most steps looks like return or room air.
SUPPLY_LIKE_ZONE_K = 1.5
#: Excitation 1 in more than this share of the rows is flagged (experiments are the exception).
EXCITATION_SHARE_MAX = 0.5


def check_roles(frame: pd.DataFrame, building) -> list[str]:
    """Warnings where a column does not behave as the quantity it is mapped to (on the model step, SI).

    - ``T_out`` with a median daily range under :data:`OUTDOOR_MIN_DAILY_RANGE` K and a
      mean within :data:`INDOOR_LIKE_K` K of the zones' mean: indoor air mapped as outdoor;
    - a supply air column (``T_supply`` or ``T_supply_<ahu>``) within
      :data:`SUPPLY_LIKE_ZONE_K` K of the zones' mean in 90 % of the steps: return or
      room air (a VAV supply is colder, or hotter when it heats);
    - ``excitation`` 1 in more than :data:`EXCITATION_SHARE_MAX` of the rows: the flag is inverted.
    """
    notes = []
    zones = [f"T_{z}" for z in building.zone_names if f"T_{z}" in frame.columns]
    if not zones or not len(frame):
        return notes
    zone_mean = frame[zones].mean(axis=1).to_numpy(dtype=float)

    def desc(c):
        name = building.column_for(c)
        return f"column {name!r}" + (f" ({c})" if name != c else "")

    if "T_out" in frame.columns:
        t = frame["T_out"]
        day = t.index.normalize()
        counts = t.notna().groupby(day).sum()
        full = counts[counts >= 0.8 * counts.max()].index
        if len(full) >= 7:
            rng = (t.groupby(day).max() - t.groupby(day).min())[full]
            both = np.isfinite(zone_mean) & np.isfinite(t.to_numpy(dtype=float))
            gap = float(np.mean(t.to_numpy(dtype=float)[both] - zone_mean[both])) if both.any() else np.inf
            if float(rng.median()) < OUTDOOR_MIN_DAILY_RANGE and abs(gap) < INDOOR_LIKE_K:
                notes.append(
                    f"{desc('T_out')}: outdoor air with a median daily range of {float(rng.median()):.2g} K over "
                    f"{len(full)} days, {gap:+.2g} K from the zones on average: it behaves like indoor air "
                    "(outdoor air swings several kelvin from night to afternoon); is the column mapped to the "
                    "outdoor air sensor?"
                )
    for c in dict.fromkeys(["T_supply", *building.supply_columns()]):
        if c not in frame.columns or (c == "T_supply" and building.ahus and c not in building.supply_columns()):
            continue
        ts = frame[c].to_numpy(dtype=float)
        both = np.isfinite(ts) & np.isfinite(zone_mean)
        if both.sum() < 96:
            continue
        near = float(np.mean(np.abs(ts[both] - zone_mean[both]) < SUPPLY_LIKE_ZONE_K))
        if near >= 0.9:
            notes.append(
                f"{desc(c)}: supply air within {SUPPLY_LIKE_ZONE_K:g} K of the zones' mean temperature in "
                f"{100 * near:.0f} % of the {int(both.sum())} steps: it behaves like return or room air, and air at "
                "room temperature carries no heat to the zones; is the column mapped to the supply (discharge) air "
                "sensor of the air handler? (a unit that really supplies neutral air cannot be identified from "
                "airflow)"
            )
    if "excitation" in frame.columns:
        e = frame["excitation"].to_numpy(dtype=float)
        e = e[np.isfinite(e)]
        if len(e) and float(np.mean(e > 0.5)) > EXCITATION_SHARE_MAX:
            notes.append(
                f"{desc('excitation')}: 1 in {100 * float(np.mean(e > 0.5)):.0f} % of the steps; excitation marks the "
                "experiments (the exception, e.g. a few hours a week), so the flag looks inverted: 1 during the "
                "experiments, 0 otherwise"
            )
    return notes


#: Discharge air colder than its unit's supply air by more than this [K] is impossible (reheat only heats).
DISCHARGE_MARGIN = 3.0
#: Share of a box's running steps that may break a discharge rule before it is flagged.
DISCHARGE_SHARE = 0.1


def check_discharge(frame: pd.DataFrame, building) -> list[str]:
    """Warnings where a box's discharge air ``Td_<vav>`` [°C] contradicts its air handler.

    While the box runs (airflow above half its ``m_min``), its discharge air
    cannot be colder than the unit's supply air by more than
    :data:`DISCHARGE_MARGIN` (a reheat coil only heats), nor hotter than the
    unit's ``T_supply_max`` by more than 5 K; each rule broken in more than
    :data:`DISCHARGE_SHARE` of those steps is a warning naming the box, the
    column, the share and the likely mapping mistake.
    """
    notes = []
    for v in building.vavs:
        td_col, m_col, s_col = f"Td_{v.name}", f"m_{v.name}", building.supply_column(v.name)
        if td_col not in frame.columns or m_col not in frame.columns or s_col not in frame.columns:
            continue
        td, m, ts = (frame[c].to_numpy(dtype=float) for c in (td_col, m_col, s_col))
        running = np.isfinite(td) & np.isfinite(ts) & (m > max(0.005, 0.5 * v.m_min))
        n = int(running.sum())
        if n == 0:
            continue
        name = building.column_for(td_col)
        desc = f"column {name!r}" + (f" ({td_col})" if name != td_col else "")
        cold = float(np.mean(td[running] < ts[running] - DISCHARGE_MARGIN))
        if cold > DISCHARGE_SHARE:
            notes.append(
                f"{desc}: discharge air below its unit's supply air "
                f"{s_col} - {DISCHARGE_MARGIN:g} K in {100 * cold:.0f} % of the {n} steps where box {v.name} runs; "
                "a reheat coil only heats: is the column mapped to the right box and unit?"
            )
        notes += _reheat_response(frame, building, v, running, td - ts, desc)
        ahu = building.ahu_of(v.name)
        if ahu is not None and ahu.T_supply_max is not None:
            hot = float(np.mean(td[running] > ahu.T_supply_max + 5.0))
            if hot > DISCHARGE_SHARE:
                notes.append(
                    f"{desc}: discharge air above T_supply_max = "
                    f"{ahu.T_supply_max:g} °C of {ahu.name} + 5 K in {100 * hot:.0f} % of the {n} steps where box "
                    f"{v.name} runs: is T_supply_max (or the unit of the column) right?"
                )
    return notes


#: Reheat command above this share is "reheating", below IDLE_REHEAT "not reheating" [1].
REHEATING, IDLE_REHEAT = 0.3, 0.02
#: Share of the steps without reheat where warm discharge air is flagged (a coil cooling down warms a few).
IDLE_WARM_SHARE = 0.25
#: Steps of each kind needed before a box's discharge air is compared with its reheat command.
MIN_REHEAT_STEPS = 20


def _reheat_response(frame, building, v, running, rise, desc) -> list[str]:
    """Warnings where a box's discharge air does not follow its own reheat command ``rh_<vav>``.

    Without reheat the discharge air is the unit's supply air (within
    :data:`DISCHARGE_MARGIN`); while the coil heats it is warmer. A ``Td_`` column
    that warms while its box's reheat is off, or stays at supply air while it is
    on, belongs to another box (or the ``rh_`` column does, or the coil failed).
    """
    rh_col = f"rh_{v.name}"
    if rh_col not in frame.columns:
        return []
    rh = frame[rh_col].to_numpy(dtype=float)
    ok = running & np.isfinite(rh)
    idle, heating = ok & (rh < IDLE_REHEAT), ok & (rh > REHEATING)
    rh_name = building.column_for(rh_col)
    notes = []
    if idle.sum() >= MIN_REHEAT_STEPS:
        warm = float(np.mean(rise[idle] > DISCHARGE_MARGIN))
        if warm > IDLE_WARM_SHARE:
            notes.append(
                f"{desc}: discharge air more than {DISCHARGE_MARGIN:g} K above its unit's supply air in "
                f"{100 * warm:.0f} % of the {int(idle.sum())} steps where box {v.name} runs with its reheat "
                f"{rh_name!r} off: does not follow its own reheat; is the column (or {rh_name!r}) the one of "
                "another box?"
            )
    if heating.sum() >= MIN_REHEAT_STEPS:
        flat = float(np.mean(rise[heating] < 1.0))
        if flat > 0.5:
            notes.append(
                f"{desc}: discharge air within 1 K of its unit's supply air in {100 * flat:.0f} % of the "
                f"{int(heating.sum())} steps where box {v.name} reheats ({rh_name!r} above {100 * REHEATING:g} %): "
                f"does not follow its own reheat; is the column (or {rh_name!r}) the one of another box, or has "
                "the coil failed?"
            )
    return notes


def check_supply_assignment(frame: pd.DataFrame, building) -> list[str]:
    """Warnings for boxes whose discharge air at rest matches another air handler's supply air, not their own.

    A box that does not reheat discharges its unit's supply air, plus a steady
    duct gain. When ``Td_<vav>`` follows another unit's supply column: the spread
    (interquartile range / 1.349, blind to a constant offset) of its difference
    to that column is under half the spread to its own column, which is over
    0.3 K, the units' columns are swapped or the box names the wrong ``ahu``.
    """
    cols = building.supply_columns()
    if len(building.ahus) < 2 or any(c not in frame.columns for c in cols):
        return []
    wrong = []
    for v in building.vavs:
        td_col, m_col = f"Td_{v.name}", f"m_{v.name}"
        own = building.supply_column(v.name)
        if td_col not in frame.columns or m_col not in frame.columns:
            continue
        td = frame[td_col].to_numpy(dtype=float)
        rest = np.isfinite(td) & (frame[m_col].to_numpy(dtype=float) > max(0.005, 0.5 * v.m_min))
        if f"rh_{v.name}" in frame.columns:
            rest &= frame[f"rh_{v.name}"].to_numpy(dtype=float) < IDLE_REHEAT
        if rest.sum() < MIN_REHEAT_STEPS * 5:
            continue
        dist = {}
        for c in cols:
            diff = td[rest] - frame[c].to_numpy(dtype=float)[rest]
            diff = diff[np.isfinite(diff)]
            if len(diff) >= MIN_REHEAT_STEPS:
                q1, q3 = np.percentile(diff, [25, 75])
                dist[c] = float(q3 - q1) / 1.349
        if own not in dist or len(dist) < 2:
            continue
        best = min(dist, key=lambda c: dist[c])
        if best != own and dist[own] > 0.3 and dist[best] < 0.5 * dist[own]:
            wrong.append((v.name, own, best, dist[own], dist[best]))
    if not wrong:
        return []
    parts = "; ".join(f"{n}: {o} {do:.2g} K, {b} {db:.2g} K" for n, o, b, do, db in wrong[:6])
    more = f" and {len(wrong) - 6} more" if len(wrong) > 6 else ""
    return [
        f"{len(wrong)} box(es) discharge, when not reheating, the supply air of another air handler than the one "
        f"the building file gives them (spread of Td_<vav> minus each supply column: {parts}{more}): are the "
        "air handlers' supply columns swapped, or do these boxes name the wrong ahu in [[vavs]]?"
    ]
