"""Holiday calendars: the weekdays a building runs its Sunday schedule on.

A model's internal gains follow a seasonal time-of-week profile (the paper's
eq. qig_estimation). On a holiday the building is closed and its gains follow
Sunday's profile instead; a model that does not know the date predicts an
ordinary weekday and misses by the whole working-day load (measured on the DOE
90.1 prototypes simulated by EnergyPlus, whose ten US holidays run the Sunday
schedule, and on a school's Thanksgiving).

The building file may declare the calendar (``[holidays]``, see
:func:`holidays_from_toml`); without it the data decide
(:mod:`hvacfmu.data.holidays`): the public holidays of the country of the
building's time zone apply when the training weeks show that the building
closes on them.

Country calendars come from `python-holidays <https://github.com/vacanza/holidays>`_.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import functools
from pathlib import Path

#: Weekday (0 = Monday ... 6 = Sunday) whose profile a holiday follows.
HOLIDAY_WEEKDAY = 6


@dataclasses.dataclass(frozen=True)
class HolidaySpec:
    """The building file's ``[holidays]``.

    Attributes
    ----------
    country : str or None
        ISO 3166 code of a country whose public holidays the building observes (``"US"``).
    subdivision : str or None
        State or province of ``country`` (``"CA"``), for regional holidays.
    dates : tuple of str
        Further closed days, ISO ``YYYY-MM-DD`` (a plant shutdown, a school break).
    open : tuple of str
        Public holidays of ``country`` on which the building works as usual.
    declared : bool
        True when the building file has the key (then the data do not choose; ``holidays = []``
        declares that the building observes no holiday).
    """

    country: str | None = None
    subdivision: str | None = None
    dates: tuple = ()
    open: tuple = ()
    declared: bool = False

    def between(self, first: _dt.date, last: _dt.date) -> dict:
        """Closed days ``{date: name}`` from ``first`` to ``last`` (inclusive), weekdays and weekends."""
        out: dict = {}
        if self.country:
            out.update(public_holidays(self.country, self.subdivision, first, last))
        for d in self.open:
            out.pop(_dt.date.fromisoformat(d), None)
        for d in self.dates:
            day = _dt.date.fromisoformat(d)
            if first <= day <= last:
                out[day] = "closed (building file)"
        return dict(sorted(out.items()))

    def to_toml(self):
        """The building file's value (a list of dates when only dates are given)."""
        if not self.country and not self.open:
            return list(self.dates)
        d: dict = {"country": self.country}
        if self.subdivision:
            d["subdivision"] = self.subdivision
        if self.dates:
            d["dates"] = list(self.dates)
        if self.open:
            d["open"] = list(self.open)
        return d


def _dates(value, what: str, problems: list) -> tuple:
    """ISO dates from a list of ``"YYYY-MM-DD"`` and ``"YYYY-MM-DD..YYYY-MM-DD"`` ranges (inclusive)."""
    if not isinstance(value, (list, tuple)):
        problems.append(
            f"{what} must be a list of dates 'YYYY-MM-DD' (or ranges 'YYYY-MM-DD..YYYY-MM-DD'), got {value!r}"
        )
        return ()
    out: list = []
    for item in value:
        if isinstance(item, _dt.date) and not isinstance(item, _dt.datetime):  # a TOML date literal
            out.append(item.isoformat())
            continue
        if not isinstance(item, str):
            problems.append(f"{what}: {item!r} is not a date 'YYYY-MM-DD'")
            continue
        first, _, last = item.partition("..")
        try:
            a = _dt.date.fromisoformat(first.strip())
            b = _dt.date.fromisoformat(last.strip()) if last else a
        except ValueError:
            problems.append(f"{what}: {item!r} is not a date 'YYYY-MM-DD' or a range 'YYYY-MM-DD..YYYY-MM-DD'")
            continue
        if b < a or (b - a).days > 366:
            problems.append(f"{what}: range {item!r} must run forward and span at most a year")
            continue
        out.extend((a + _dt.timedelta(days=i)).isoformat() for i in range((b - a).days + 1))
    return tuple(dict.fromkeys(out))


def holidays_from_toml(value, problems: list) -> HolidaySpec:
    """Parse the building file's ``holidays`` (problems appended to ``problems``).

    Either a list of dates (``holidays = ["2026-12-24..2027-01-01"]``) or a table::

        [holidays]
        country = "US"           # public holidays of a country (ISO 3166 code)
        subdivision = "CA"       # optional: its state or province
        dates = ["2026-12-24"]   # optional: further closed days or ranges
        open = ["2026-10-12"]    # optional: public holidays the building works on
    """
    if isinstance(value, (list, tuple)):
        return HolidaySpec(dates=_dates(value, "holidays", problems), declared=True)
    if not isinstance(value, dict):
        problems.append(
            f"holidays must be a list of dates or a table (country, subdivision, dates, open), got {value!r}"
        )
        return HolidaySpec(declared=True)
    unknown = sorted(set(value) - {"country", "subdivision", "dates", "open"})
    if unknown:
        problems.append(f"holidays: unknown key(s) {unknown} (known: country, subdivision, dates, open)")
    country, subdiv = value.get("country"), value.get("subdivision")
    for key, v in (("country", country), ("subdivision", subdiv)):
        if v is not None and not (isinstance(v, str) and v.strip()):
            problems.append(f"holidays.{key} must be a text code (e.g. 'US', 'CA'), got {v!r}")
    spec = HolidaySpec(
        country=country.strip().upper() if isinstance(country, str) and country.strip() else None,
        subdivision=subdiv.strip().upper() if isinstance(subdiv, str) and subdiv.strip() else None,
        dates=_dates(value.get("dates", []), "holidays.dates", problems),
        open=_dates(value.get("open", []), "holidays.open", problems),
        declared=True,
    )
    if spec.subdivision and not spec.country:
        problems.append("holidays.subdivision needs holidays.country")
    if spec.country:
        problems.extend(country_problems(spec.country, spec.subdivision))
    return spec


def country_problems(country: str, subdivision: str | None = None) -> list:
    """Why ``country``/``subdivision`` is not a calendar python-holidays knows (empty if it is)."""
    import holidays

    supported = holidays.list_supported_countries()
    if country not in supported:
        return [
            f"holidays.country {country!r} is not a country code python-holidays knows (ISO 3166 alpha-2, "
            f"e.g. {', '.join(c for c in ('US', 'CA', 'GB', 'DE', 'FR', 'AU') if c in supported)})"
        ]
    subs = supported[country]
    if subdivision and subdivision not in subs:
        return [f"holidays.subdivision {subdivision!r} is not a subdivision of {country} (known: {', '.join(subs)})"]
    return []


def public_holidays(country: str, subdivision: str | None, first: _dt.date, last: _dt.date) -> dict:
    """Public holidays ``{date: name}`` of ``country`` from ``first`` to ``last`` (inclusive)."""
    table = _country_table(country, subdivision, first.year, last.year)
    return {d: n for d, n in table.items() if first <= d <= last}


def observed_days(country: str, subdivision: str | None, first: _dt.date, last: _dt.date) -> set:
    """Dates from ``first`` to ``last`` that are public holidays of ``country`` only as the weekday observed in place
    of a holiday falling on a weekend (US ``Veterans Day (observed)``, a Friday): the days python-holidays lists
    with its observance rules and not without them."""
    shifted = set(_country_table(country, subdivision, first.year, last.year))
    shifted -= set(_country_table(country, subdivision, first.year, last.year, observed=False))
    return {d for d in shifted if first <= d <= last}


@functools.lru_cache(maxsize=32)
def _country_table(country: str, subdivision: str | None, y0: int, y1: int, observed: bool = True) -> dict:
    import holidays

    return dict(holidays.country_holidays(country, subdiv=subdivision, years=range(y0, y1 + 1), observed=observed))


@functools.lru_cache(maxsize=1)
def _zone_countries() -> dict:
    """Time zone name -> ISO 3166 country code, from the tz database's ``zone.tab`` (may be empty)."""
    out: dict = {}
    for parts in zone_table_rows(("zone.tab",)):
        out.setdefault(parts[2], parts[0])
    return out


def zone_table_rows(names=("zone1970.tab", "zone.tab")):
    """Rows (tab-separated fields, at least three: codes, coordinates, zone name) of the tz database's zone tables
    ``names``, from the system's ``/usr/share/zoneinfo`` and the ``tzdata`` package (none if neither is there)."""
    paths = [Path("/usr/share/zoneinfo") / n for n in names]
    try:
        import tzdata

        paths += [Path(tzdata.__file__).parent / "zoneinfo" / n for n in names]
    except ImportError:  # pragma: no cover - the system tables suffice
        pass
    for path in paths:
        try:
            lines = path.read_text(encoding="utf-8").splitlines()
        except OSError:
            continue
        for line in lines:
            parts = line.split("\t")
            if len(parts) > 2 and not line.startswith("#"):
                yield parts


def country_of_timezone(timezone: str) -> str | None:
    """The country of an IANA time zone (``America/Denver`` -> ``US``), None for ``UTC`` and unknown zones."""
    return _zone_countries().get(timezone)


def holiday_slots(index, step: float, holidays) -> tuple:
    """Rows of ``index`` on a holiday weekday, and the time-of-week slot each row's internal gains are read at.

    Parameters
    ----------
    index : pandas.DatetimeIndex
        Local (building) time.
    step : float
        Model step [s].
    holidays : iterable of str
        ISO dates.

    Returns
    -------
    on : array of bool (n,)
        Rows whose local date is a listed holiday falling on Monday to Friday (a weekend keeps its own profile).
    slots : array of int (n,)
        :func:`hvacfmu.timeutil.time_of_week`, with the rows ``on`` moved to the same time of day on Sunday.
    """
    import numpy as np
    import pandas as pd

    from .timeutil import local_seconds, n_time_of_week, week_seconds

    index = pd.DatetimeIndex(index)
    secs = local_seconds(index)  # the wall clock once, for the slot and the date (not a conversion per field)
    sow = week_seconds(secs)
    slots = (sow // int(step)).astype(np.int64)  # as timeutil.time_of_week
    if not len(index) or not holidays:
        return np.zeros(len(index), bool), slots
    on = np.isin(secs // 86400, _listed_days(tuple(holidays))) & (sow < 5 * 86400)
    n_tow = n_time_of_week(step)
    if n_tow % 7:
        raise ValueError(f"model step {step} s does not divide a day: a holiday cannot read Sunday's profile")
    per_day = n_tow // 7
    return on, np.where(on, HOLIDAY_WEEKDAY * per_day + slots % per_day, slots)


@functools.lru_cache(maxsize=8)
def _listed(holidays: tuple):
    """The ISO dates as a DatetimeIndex, parsed once per calendar (models read it at every step)."""
    import pandas as pd

    return pd.DatetimeIndex(pd.to_datetime(list(holidays)))


@functools.lru_cache(maxsize=8)
def _listed_days(holidays: tuple):
    """The listed dates as local day numbers since 1970-01-01 (a listed time other than midnight matches no day,
    as in ``normalize().isin``)."""
    import numpy as np

    secs = np.asarray(_listed(holidays).values).astype("datetime64[s]").astype(np.int64)
    return secs[secs % 86400 == 0] // 86400


def gain_slots(index, step: float, holidays=()):
    """Time-of-week slot each row's internal gains are read at: its own, or on a holiday weekday Sunday's
    (the second result of :func:`holiday_slots`)."""
    return holiday_slots(index, step, holidays)[1]
