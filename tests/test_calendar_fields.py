"""Calendar fields read from the wall clock once (timeutil.local_seconds) equal pandas' own fields.

The diagnosis reads the time of week, holiday weekdays and the dates of a holiday term for every row of
every fold model (benchmarks/diagnosis_speed_s15.md); these checks hold the integer arithmetic to the
pandas definitions it replaced, across daylight-saving changes, naive and tz-aware indexes and units.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from hvacfmu.calendars import holiday_slots
from hvacfmu.models.causes.internal_gain_schedule import InternalGainSchedule
from hvacfmu.timeutil import seconds_of_week

INDEXES = [
    ("America/Denver", "15min", "2025-02-20"),  # spring change inside
    ("Europe/Berlin", "7min", "2025-10-20"),  # fall change inside
    ("Australia/Sydney", "1h", "2025-03-25"),  # southern hemisphere
    (None, "5min", "1969-12-20"),  # naive, across the 1970 epoch (floored, not truncated)
    ("UTC", "13s", "2025-06-01 00:00:00.25"),  # sub-second timestamps
]


def _index(tz, freq, start, n=30000):
    return pd.date_range(start, periods=n, freq=freq, tz=tz)


@pytest.mark.parametrize("tz, freq, start", INDEXES)
def test_seconds_of_week_equal_the_pandas_fields(tz, freq, start):
    for index in (_index(tz, freq, start), _index(tz, freq, start).as_unit("ns")[::3]):
        expected = (
            index.day_of_week.to_numpy() * 86400
            + index.hour.to_numpy() * 3600
            + index.minute.to_numpy() * 60
            + index.second.to_numpy()
        )
        got = seconds_of_week(index)
        assert got.dtype == np.int64
        np.testing.assert_array_equal(got, expected)


#: weekdays, a Saturday and Sundays (which keep their own profile), and a Friday
HOLIDAYS = (
    "2025-01-01",
    "2025-03-10",
    "2025-05-26",
    "2025-10-25",
    "2025-10-26",
    "2025-12-25",
    "2026-04-03",
    "2026-04-05",
)


@pytest.mark.parametrize("tz, freq, start", INDEXES[:3])
def test_holiday_slots_equal_the_normalized_dates(tz, freq, start):
    index = _index(tz, freq, start, n=60000)
    step = pd.Timedelta(freq).total_seconds() if freq == "15min" else 900.0
    on, slots = holiday_slots(index, step, HOLIDAYS)
    days = index.normalize().tz_localize(None) if index.tz is not None else index.normalize()
    expected_on = np.asarray(days.isin(pd.to_datetime(list(HOLIDAYS)))) & (np.asarray(index.day_of_week) < 5)
    assert expected_on.any()
    np.testing.assert_array_equal(on, expected_on)
    per_day = round(86400 / step)
    sow = index.day_of_week.to_numpy() * 86400 + index.hour.to_numpy() * 3600 + index.minute.to_numpy() * 60
    tow = (sow + index.second.to_numpy()) // int(step)
    np.testing.assert_array_equal(slots, np.where(expected_on, 6 * per_day + tow % per_day, tow))


@pytest.mark.parametrize("tz", ["America/Denver", None])
def test_holiday_term_matches_its_iso_dates_only(tz):
    """A holiday term acts on the rows whose local date prints as one of its strings: other spellings of a
    date ('20250310', '2025-3-11') and non-dates match no row, as when each row's date was compared as text."""
    index = pd.date_range("2025-03-01", periods=4 * 672, freq="15min", tz=tz)
    prof = np.random.default_rng(3).normal(size=(672, 2))
    term = InternalGainSchedule(
        variant="holiday",
        zone_names=("a", "b"),
        coef=(1.0, 0.5),
        dates=("2025-03-12", "20250310", "2025-3-11", "holiday", "2025-03-20"),
    )
    adj = term.adjustment(index, prof, 900.0)
    texts = np.array([d.isoformat() for d in index.date])
    expected_days = np.isin(texts, ["2025-03-12", "2025-03-20"])
    assert not adj[~expected_days].any()
    assert (adj[expected_days] != 0).any(axis=1).mean() > 0.9
