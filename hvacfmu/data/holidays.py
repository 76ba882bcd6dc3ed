"""The dataset's holiday calendar: declared in the building file, or decided from the training weeks.

Every model kind reads Sunday's internal-gain profile on a holiday weekday
(:func:`hvacfmu.calendars.holiday_slots`) and leaves holidays out of the
weekday profile it estimates. Which days are holidays:

- the building file's ``[holidays]`` when it has one (its public holidays,
  dates and open days); declared holidays of the training weeks that ran like
  an ordinary weekday are named in a note;
- otherwise the public holidays of the country of the building's time zone
  (``America/Denver`` -> US), **if the training weeks show the building closes
  on them**: a public holiday on a weekday of a training week is *closed* when
  the day's operation (:func:`day_signature`: the boxes' total airflow, the mean
  zone temperature's course over the day and, where measured, the discharge
  air's heating) lies at least :data:`CLOSED_GAMMA` of the way from the
  neighbouring workdays' mean to the neighbouring Sundays' mean (``gamma``,
  :func:`day_gammas`), *worked* below :data:`WORKED_GAMMA`. The country's calendar
  applies when at least two thirds of the training public holidays were closed
  (at least :data:`MIN_CLOSED`, or a single one with ``gamma`` >= :data:`SINGLE_GAMMA`), a day counting as closed only at ``gamma`` >= :data:`CLOSED_SPREADS` times the
  workdays' spread too; the holidays worked on are left out by name in every year, and when every
  weekday of the training weeks observed in place of a weekend holiday (US ``New Year's Day (observed)``) was
  worked on, every such day is (the EnergyPlus prototypes keep their holidays on the date, a Saturday too);
- no other day is applied: an unlisted weekday that ran like a Sunday is not added to the calendar (on the
  emulator, whose buildings keep no holiday, ordinary workdays of a 16-week set reach ``gamma`` 0.78, where
  the EnergyPlus prototypes' holidays lie at 0.8-1.2: weather and faults move a day's operation almost as
  far as a holiday does). Such days are *named* instead (:attr:`HolidayCalendar.sunday_like`): every
  weekday of the data, held-out weeks included, outside the calendar with ``gamma`` at least
  :data:`SINGLE_GAMMA` and :data:`SINGLE_SPREADS` workday spreads (a closure between Christmas and New Year,
  a bridge day, a day the plant ran off schedule), in a ``check`` note and, for a zone-season a model loses,
  in the evaluation's verdict.

``gamma`` projects the day on the workday-to-Sunday direction weighted by the neighbouring workdays'
scatter per feature (a diagonal discriminant): on 32 cached emulator sets the robust spread of ordinary
workdays is 0.09-0.25, on six EnergyPlus prototypes 0.006-0.15.

Only training days are judged: the test weeks are predicted with the calendar a user could have known.

The decision needs Sundays that differ from workdays: where the spread of
``gamma`` over ordinary workdays is above :data:`MAX_WORKDAY_SPREAD` (a 24/7
building: a hospital, flats), the data cannot tell a holiday and no public
holiday is applied from them.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import math
import warnings

import numpy as np
import pandas as pd

from ..calendars import country_of_timezone, observed_days, public_holidays

#: A weekday at least this far (0 = workday mean, 1 = Sunday mean) toward Sunday ran closed.
CLOSED_GAMMA = 0.5
#: A listed holiday below this ran as a workday.
WORKED_GAMMA = 0.25
#: Public holidays of the training weeks that must have run closed before the country's calendar applies.
MIN_CLOSED = 2
#: ... unless the training weeks hold a single one, closed beyond doubt: ``gamma`` at least this and
#: :data:`SINGLE_SPREADS` workday spreads (the emulator's ordinary workdays reach 0.78 at most, the EnergyPlus
#: prototypes' holidays 0.8-1.2): a short winter export with New Year in its training weeks and Christmas held out
SINGLE_GAMMA = 0.85
SINGLE_SPREADS = 4.0
#: Robust spread (1.4826 MAD) of gamma over ordinary workdays above which Sundays and workdays are not told apart.
MAX_WORKDAY_SPREAD = 0.25
#: A day is closed (listed) or detected only this many spreads above the workdays' 0 as well.
CLOSED_SPREADS = 2.5
#: Share of a day's rows that must hold the signature's values.
MIN_DAY_COVERAGE = 0.75
#: A box airflow or zone column with values in fewer than this share of the rows is left out of the signature: the
#: signature sums the boxes and averages the zones per row, so one sparse box (`generate --fault sparse_box`, 5.6 %)
#: blanked every day and `check` said "too few training workdays and Sundays" (session 21)
MIN_SIGNATURE_COVERAGE = 0.5
#: Workdays and Sundays within this many days of a day form its reference.
NEIGHBOURHOOD_DAYS = 28
#: Years after the data's last one that a model's calendar covers (its FMU may forecast later).
YEARS_AHEAD = 10


@dataclasses.dataclass(frozen=True)
class HolidayCalendar:
    """The holidays the models of a dataset apply.

    Attributes
    ----------
    dates : tuple of str
        ISO dates (Monday to Friday) from the data's first year to :data:`YEARS_AHEAD` years after its
        last: the days whose internal gains follow Sunday's profile.
    source : str
        ``"declared"`` (building file), ``"public"`` (the country's holidays, decided from the data) or
        ``"none"``.
    country : str or None
    in_data : dict
        ``{date: name}`` of the calendar's weekdays inside the data.
    gammas : dict
        ``{date: gamma}`` of every listed or detected weekday the data could judge.
    sunday_like : dict
        ``{date: gamma}`` (ISO dates) of the weekdays outside the calendar, training or held-out, that ran
        like a Sunday beyond doubt (:func:`sunday_like_days`): named, never applied.
    notes : tuple of str
        What was decided and why, for ``check`` and the fits' warnings.
    """

    dates: tuple = ()
    source: str = "none"
    country: str | None = None
    in_data: dict = dataclasses.field(default_factory=dict)
    gammas: dict = dataclasses.field(default_factory=dict)
    notes: tuple = ()
    sunday_like: dict = dataclasses.field(default_factory=dict)

    def summary(self) -> str:
        """One line for ``check``: what the calendar holds inside the data."""
        if not self.in_data:
            return {"declared": "none in the data (building file's [holidays])"}.get(self.source, "none")
        days = ", ".join(f"{d} {n}" for d, n in list(self.in_data.items())[:6])
        more = f" and {len(self.in_data) - 6} more" if len(self.in_data) > 6 else ""
        return f"{len(self.in_data)} weekday(s) on Sunday's profile ({self.source}): {days}{more}"


def day_signature(frame: pd.DataFrame, building) -> tuple[pd.DatetimeIndex, np.ndarray, np.ndarray]:
    """Per local day, hourly means of the operation: (days, features (n_days, n_feat), coverage (n_days,)).

    Features, each block of 24 hourly values scaled by its spread over all days: the boxes' total airflow
    over their total ``m_max``; the area-weighted mean zone temperature minus the day's mean; and, where
    ``Td_<vav>`` columns exist, the mean of ``max(Td - T_supply, 0)`` over the boxes (reheat).
    """
    with warnings.catch_warnings():  # all-NaN rows and days (gaps) stay NaN, without a RuntimeWarning
        warnings.simplefilter("ignore", RuntimeWarning)
        return _day_signature(frame, building)


def _day_signature(frame: pd.DataFrame, building) -> tuple[pd.DatetimeIndex, np.ndarray, np.ndarray]:
    """The body of :func:`day_signature`."""
    idx = frame.index

    def covered(cols):  # a column with values in under half the rows would blank every hour it misses
        return [c for c in cols if frame[c].notna().mean() >= MIN_SIGNATURE_COVERAGE]

    blocks = []
    m_cols = covered([f"m_{v.name}" for v in building.vavs if f"m_{v.name}" in frame.columns])
    if m_cols:
        m_max = np.array([building.vav(c[2:]).m_max for c in m_cols], float)
        blocks.append(frame[m_cols].sum(axis=1, min_count=len(m_cols)).to_numpy(float) / max(m_max.sum(), 1e-9))
    t_cols = covered([f"T_{z}" for z in building.zone_names if f"T_{z}" in frame.columns])
    if t_cols:
        w = np.array([building.zone(c[2:]).area for c in t_cols], float)
        T = frame[t_cols].to_numpy(float)
        blocks.append(T @ (w / w.sum()))
    td_cols = [c for c in (f"Td_{v}" for v in building.vav_names) if c in frame.columns]
    if td_cols and "T_supply" in frame.columns:
        sup = frame["T_supply"].to_numpy(float)[:, None]
        blocks.append(np.nanmean(np.maximum(frame[td_cols].to_numpy(float) - sup, 0.0), axis=1))
    if not blocks or not len(idx):
        return pd.DatetimeIndex([]), np.zeros((0, 0)), np.zeros(0)
    day = idx.tz_localize(None).normalize() if idx.tz is not None else idx.normalize()
    hour = np.asarray(idx.hour)
    days = pd.DatetimeIndex(sorted(set(day)))
    pos = days.get_indexer(day)
    n_days = len(days)
    feats, cover = [], np.ones(n_days)
    for b, x in enumerate(blocks):
        ok = np.isfinite(x)
        cnt = np.zeros((n_days, 24))
        tot = np.zeros((n_days, 24))
        np.add.at(cnt, (pos[ok], hour[ok]), 1.0)
        np.add.at(tot, (pos[ok], hour[ok]), x[ok])
        rows = np.zeros(n_days)
        np.add.at(rows, pos, 1.0)
        cover = np.minimum(cover, cnt.sum(axis=1) / np.maximum(rows, 1))
        with np.errstate(invalid="ignore", divide="ignore"):
            h = np.where(cnt > 0, tot / np.maximum(cnt, 1), np.nan)
        if b == 1:  # temperature: the day's course, not its level (the weather sets that)
            h = h - np.nanmean(h, axis=1, keepdims=True) if h.size else h
        scale = np.nanstd(h)
        feats.append(h / scale if np.isfinite(scale) and scale > 0 else h * 0.0)
    return days, np.hstack(feats), cover


def day_gammas(days, X, cover, candidates, usable, exclude) -> tuple[dict, float]:
    """``gamma`` of each candidate day and the robust spread of ``gamma`` over ordinary workdays.

    ``gamma = (x_d - W)·(S - W) / |S - W|²`` with ``W``, ``S`` the means of the usable workdays (Monday
    to Friday, not in ``exclude``) and Sundays within :data:`NEIGHBOURHOOD_DAYS` of the day, ``d`` left out.
    ``usable``: days (Timestamps) that may serve as reference (training weeks, enough coverage).
    """
    days = pd.DatetimeIndex(days)
    wd = np.asarray(days.day_of_week)
    ok = np.array([d in usable for d in days]) & (cover >= MIN_DAY_COVERAGE) & np.isfinite(X).all(axis=1)
    excl = np.array([d in exclude for d in days])
    work = ok & (wd < 5) & ~excl
    sun = ok & (wd == 6)
    t = (days - days[0]).days.to_numpy() if len(days) else np.zeros(0)

    def gamma(i):
        near = np.abs(t - t[i]) <= NEIGHBOURHOOD_DAYS
        w = work & near
        w[i] = False
        s = sun & near
        if w.sum() < 3 or s.sum() < 2:
            return None
        W, S = X[w].mean(axis=0), X[s].mean(axis=0)
        # the workday-to-Sunday direction weighted by the workdays' scatter per feature (a diagonal
        # discriminant): hours whose operation differs steadily weigh more than noisy ones
        var = X[w].var(axis=0)
        var = var + 0.1 * (float(np.median(var)) if np.isfinite(np.median(var)) else 0.0) + 1e-12
        d = (S - W) / var
        den = float((S - W) @ d)
        return float((X[i] - W) @ d / den) if den > 0 else None

    out = {}
    for day in candidates:
        i = days.get_indexer([day])[0]
        if i >= 0 and ok[i] and wd[i] < 5:
            g = gamma(i)
            if g is not None:
                out[days[i]] = g
    ordinary = [g for i in np.flatnonzero(work) if (g := gamma(i)) is not None]
    if len(ordinary) < 5:
        return out, math.inf
    ordinary_arr = np.asarray(ordinary)
    spread = 1.4826 * float(np.median(np.abs(ordinary_arr - np.median(ordinary_arr))))
    return out, spread


def _train_days(weeks) -> set:
    """Local midnights (naive Timestamps) of the days of the training weeks."""
    out = set()
    for w in weeks:
        if w.train:
            s = pd.Timestamp(w.start)
            s = s.tz_localize(None) if s.tz is not None else s
            out.update(s.normalize() + pd.Timedelta(days=k) for k in range(7))
    return out


#: A holiday the diagnosis reads in the internal gains must show in the operation as well: the mean ``gamma`` of its
#: days on the day signature (:func:`day_gammas`, 0 = workday, 1 = Sunday) at least this, and at least
#: :data:`OPERATION_SES` standard errors of that mean (the workday spread over the square root of the days) above the
#: workdays. A building whose gains drop keeps its air handlers' schedule, yet its boxes and zone temperatures answer
#: the missing heat: the checked battery's injected holiday weeks (gains at 0.13-0.30 of a weekday's, HVAC schedule
#: kept) read 0.20-0.70; the weeks the residual screen proposed in the 90.1 small hotel (schedules that never change,
#: weather the model misses) read -0.05 ... 0.10 (``benchmarks/hotelhol_s21.md``)
OPERATION_MIN_GAMMA = 0.125
OPERATION_SES = 2.0


@dataclasses.dataclass(frozen=True, eq=False)
class OperationDays:
    """The day signature of a dataset's operation, for judging proposed holidays (:func:`operation_groups`).

    ``days``, ``X``, ``cover``: :func:`day_signature`; ``usable``: the training weeks' days (the references);
    ``calendar``: the dataset's holiday calendar in the data (left out of the workday references).
    """

    days: pd.DatetimeIndex
    X: np.ndarray
    cover: np.ndarray
    usable: frozenset
    calendar: frozenset


def operation_days(dataset) -> OperationDays:
    """The :class:`OperationDays` of a prepared dataset (its frame, building, weeks and holiday calendar)."""
    days, X, cover = day_signature(dataset.frame, dataset.building)
    cal = frozenset(pd.Timestamp(d) for d in getattr(dataset.holidays, "in_data", {}) or {})
    return OperationDays(days, X, cover, frozenset(_train_days(dataset.weeks)), cal)


def operation_groups(op: OperationDays, groups: dict, known=()) -> dict:
    """How the operation judges proposed holiday ``groups`` (``{key: [ISO dates]}``).

    Every group's days are left out of the workday references together (with the calendar's holidays and ``known``,
    the ISO dates of holidays already in a model) and each day's
    ``gamma`` is read (:func:`day_gammas`). Returns ``spread`` (the ordinary workdays' robust spread; above
    :data:`MAX_WORKDAY_SPREAD`, or infinite, the operation does not tell a Sunday from a workday) and ``groups``:
    ``{key: {"gamma": mean over the days it could judge (nan without one), "n", "floor", "ok"}}``, ``ok`` when the
    mean reaches ``floor`` = max(:data:`OPERATION_MIN_GAMMA`, :data:`OPERATION_SES` × spread / √n).
    """
    stamp = {k: [pd.Timestamp(d) for d in v] for k, v in groups.items()}
    cands = sorted({d for v in stamp.values() for d in v})
    exclude = set(cands) | set(op.calendar) | {pd.Timestamp(d) for d in known}
    gam, spread = day_gammas(op.days, op.X, op.cover, cands, op.usable, exclude)
    out = {}
    for k, v in stamp.items():
        g = [gam[d] for d in v if d in gam]
        mean = float(np.mean(g)) if g else float("nan")
        floor = max(OPERATION_MIN_GAMMA, OPERATION_SES * spread / math.sqrt(len(g))) if g else math.inf
        out[k] = {"gamma": mean, "n": len(g), "floor": float(floor), "ok": bool(mean >= floor)}
    return {"spread": float(spread), "groups": out}


def quiet_spread(op: OperationDays, known=()) -> float:
    """The ordinary workdays' spread on the day signature with the training week that ran most toward Sunday left out.

    Without a proposed holiday the spread (:func:`day_gammas`) counts every training weekday as ordinary, a holiday
    the screen did not propose among them: hold-out quad4 2034 case 15's holiday week 7 (γ 0.45) lifts it from 0.20
    to 0.27, over :data:`MAX_WORKDAY_SPREAD`, and the week-by-likelihood proposal that finds it would be refused.
    The calendar's holidays and ``known`` (ISO dates of holidays already in a model) are left out as well.
    """
    exclude = set(op.calendar) | {pd.Timestamp(d) for d in known}
    work = [d for d in op.days if d in op.usable and d.day_of_week < 5 and d not in exclude]
    gam, spread = day_gammas(op.days, op.X, op.cover, work, op.usable, exclude)
    weeks: dict = {}
    for d, g in gam.items():
        weeks.setdefault(d - pd.Timedelta(days=d.day_of_week), []).append(g)
    if not weeks:
        return spread
    top = max(weeks, key=lambda w: float(np.mean(weeks[w])))
    _, quiet = day_gammas(
        op.days, op.X, op.cover, [], op.usable, exclude | {top + pd.Timedelta(days=k) for k in range(7)}
    )
    return min(spread, quiet)


def decide_holidays(frame: pd.DataFrame, building, weeks) -> HolidayCalendar:
    """The :class:`HolidayCalendar` of a prepared frame (see the module docstring)."""
    spec = building.holidays
    idx = frame.index
    if not len(idx):
        return HolidayCalendar(source="declared" if spec.declared else "none")
    local = idx.tz_localize(None) if idx.tz is not None else idx
    first, last = local[0].date(), local[-1].date()
    horizon_end = _dt.date(last.year + YEARS_AHEAD, 12, 31)
    horizon_start = _dt.date(first.year, 1, 1)
    train_days = _train_days(weeks)
    days, X, cover = day_signature(frame, building)

    def weekdays(table: dict) -> dict:
        return {d: n for d, n in table.items() if d.weekday() < 5}

    notes: list[str] = []
    if spec.declared:
        table = weekdays(spec.between(horizon_start, horizon_end))
        in_data = {d: n for d, n in table.items() if first <= d <= last}
        gam, spread = day_gammas(days, X, cover, [pd.Timestamp(d) for d in in_data], train_days, set())
        worked = [d for d, g in gam.items() if g < WORKED_GAMMA] if spread <= MAX_WORKDAY_SPREAD else []
        if worked:
            notes.append(
                "declared holiday(s) "
                + ", ".join(f"{d.date()} ({in_data[d.date()]}, gamma {gam[d]:.2f})" for d in worked)
                + " ran like an ordinary workday in the training weeks (gamma: 0 = workday, 1 = Sunday); "
                "if the building works on them, list them in the building file's [holidays] open"
            )
        source, country = "declared", spec.country
        dates = set(table)
    else:
        country = country_of_timezone(building.timezone)
        dates = set()
        source = "none"
        in_data = {}
        pub = weekdays(public_holidays(country, None, first, last)) if country else {}
        gam, spread = day_gammas(days, X, cover, [pd.Timestamp(d) for d in pub], train_days, set())
        if pub and not math.isfinite(spread):
            notes.append(
                f"{len(pub)} public holiday(s) of {country} fall on weekdays in the data ("
                + ", ".join(f"{d} {n}" for d, n in list(pub.items())[:3])
                + (f" and {len(pub) - 3} more" if len(pub) > 3 else "")
                + "); too few training workdays and Sundays to tell whether the building closes on them: the models "
                f'treat them as workdays. If it closes on them, add [holidays] country = "{country}" to the building file'
            )
        elif pub and spread > MAX_WORKDAY_SPREAD:
            notes.append(
                f"{len(pub)} public holiday(s) of {country} fall on weekdays in the data, but its workdays and "
                f"Sundays do not run differently enough to tell whether the building closes on them (spread "
                f"{spread:.2f} > {MAX_WORKDAY_SPREAD}); no holiday applied. If it closes on them, add "
                f'[holidays] country = "{country}" to the building file'
            )
        elif pub:
            judged = {d.date(): g for d, g in gam.items()}
            closed = [d for d, g in judged.items() if g >= max(CLOSED_GAMMA, CLOSED_SPREADS * spread)]
            worked = [d for d, g in judged.items() if g < WORKED_GAMMA]
            single = (
                len(judged) == 1
                and len(closed) == 1
                and judged[closed[0]] >= max(SINGLE_GAMMA, SINGLE_SPREADS * spread)
            )
            if single or len(closed) >= max(MIN_CLOSED, math.ceil(2 * len(judged) / 3)):
                open_names = {pub[d] for d in worked}  # by name in every year ("... (observed)" stays apart)
                allp = weekdays(public_holidays(country, None, horizon_start, horizon_end))
                # a weekday observed in place of a weekend holiday is the building's convention, not the holiday's:
                # worked on every such day of the training weeks (none closed), it is worked on in every year
                shifted = observed_days(country, None, horizon_start, horizon_end)
                shifted_judged = [d for d in judged if d in shifted]
                open_shifted = bool(shifted_judged) and all(d in worked for d in shifted_judged)
                table = {d: n for d, n in allp.items() if n not in open_names and not (open_shifted and d in shifted)}
                named = sorted(open_names - ({pub[d] for d in shifted_judged} if open_shifted else set()))
                dates = set(table)
                in_data = {d: n for d, n in table.items() if first <= d <= last}
                source = "public"
                notes.append(
                    f"the building closed on {len(closed)} of the {len(judged)} public holiday(s) of {country} in the "
                    f"training weeks (their operation ran like a Sunday"
                    + (f": gamma {judged[closed[0]]:.2f}, the only one there" if single else "")
                    + f"); the models read Sunday's internal gains on {country}'s public holidays"
                    + (f" except {', '.join(named)} (worked on)" if named else "")
                    + (
                        f" {'and' if named else 'except'} every weekday observed in place of a weekend holiday (the "
                        "building worked on " + ", ".join(f"{d} {pub[d]}" for d in shifted_judged) + ")"
                        if open_shifted
                        else ""
                    )
                    + f'. Declare [holidays] in the building file to choose (e.g. country = "{country}", open = [...])'
                )
            elif len(judged) - len(closed) > len(judged) / 3:
                notes.append(
                    f"the building ran as on a workday on {len(judged) - len(closed)} of the {len(judged)} public "
                    f"holidays of {country} in the training weeks; no public holiday applied"
                )
            elif judged:
                notes.append(
                    f"the building closed on {len(closed)} public holiday of {country} in the training weeks ("
                    + ", ".join(f"{d} {pub[d]}" for d in closed)
                    + f"), too few to decide (at least {MIN_CLOSED}, or one at gamma {SINGLE_GAMMA}); no public holiday "
                    "applied. If it closes on "
                    f'them, add [holidays] country = "{country}" to the building file'
                )
            else:
                test_pub = [d for d in pub if pd.Timestamp(d) not in train_days]
                if test_pub:
                    notes.append(
                        f"public holiday(s) of {country} fall in held-out weeks only ("
                        + ", ".join(f"{d} {pub[d]}" for d in test_pub[:4])
                        + "); the training weeks cannot tell whether the building closes on them, and the models "
                        f'predict them as workdays. If it closes, add [holidays] country = "{country}" to the building file'
                    )
    gammas = {d.date().isoformat(): round(g, 3) for d, g in gam.items()}
    sunday = sunday_like_days(days, X, cover, {d.isoformat() for d in dates})
    if sunday:
        held = {d for d in sunday if pd.Timestamp(d) not in train_days}
        listed = ", ".join(
            f"{d} ({pd.Timestamp(d).day_name()[:3]}, gamma {g:.2f}{', held out' if d in held else ''})"
            for d, g in list(sunday.items())[:6]
        )
        more = f" and {len(sunday) - 6} more" if len(sunday) > 6 else ""
        notes.append(
            f"{len(sunday)} weekday(s) outside the holiday calendar ran like a Sunday ({listed}{more}; gamma: 0 = "
            "the neighbouring workdays, 1 = the neighbouring Sundays): the models predict them as working days. If "
            "the building was closed, list them in the building file's [holidays] dates (ranges such as "
            '"2025-12-24..2026-01-01" are allowed) and refit; if its plant ran off schedule, expect larger errors '
            "there"
        )
    return HolidayCalendar(
        dates=tuple(sorted(d.isoformat() for d in dates)),
        source=source,
        country=country,
        in_data={d.isoformat(): n for d, n in sorted(in_data.items())},
        gammas=gammas,
        notes=tuple(notes),
        sunday_like=sunday,
    )


def sunday_like_days(days, X, cover, listed) -> dict:
    """``{ISO date: gamma}`` of the weekdays not in ``listed`` (ISO dates) that ran like a Sunday beyond doubt.

    Every day of the data may serve as reference and be judged (held-out weeks too: the result only names
    days, the models never read it). A day counts at ``gamma`` >= :data:`SINGLE_GAMMA` and
    :data:`SINGLE_SPREADS` workday spreads, where the workdays and Sundays can be told apart at all
    (spread <= :data:`MAX_WORKDAY_SPREAD`); the listed days are left out of the workday reference.
    """
    days = pd.DatetimeIndex(days)
    if not len(days):
        return {}
    usable = set(days)
    exclude = {d for d in days if d.date().isoformat() in listed}
    cands = [d for d in days if d.day_of_week < 5 and d not in exclude]
    gam, spread = day_gammas(days, X, cover, cands, usable, exclude)
    if not math.isfinite(spread) or spread > MAX_WORKDAY_SPREAD:
        return {}
    floor = max(SINGLE_GAMMA, SINGLE_SPREADS * spread)
    return {d.date().isoformat(): round(g, 3) for d, g in sorted(gam.items()) if g >= floor}
