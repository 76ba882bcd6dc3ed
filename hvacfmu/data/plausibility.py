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

from .units import KINDS, to_si

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
    return [u for u in KINDS["airflow"][1] if u != unit and lo <= value_si * float(to_si(1.0, u)) / one <= hi]


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
    shares = {u: minimum_share(valid * float(to_si(1.0, u)) / one, box.m_min) for u in KINDS["airflow"][1] if u != unit}
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


def check_stuck(canonical, si, times_ns, desc, where, warnings):
    """Mask temperature runs repeating one value for :data:`STUCK_DAYS` or longer; returns the column."""
    if times_ns is None or not canonical.startswith(STUCK_PREFIXES):
        return si
    found = stuck_runs(si, times_ns, STUCK_DAYS * 86400)
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
