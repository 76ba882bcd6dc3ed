"""Holiday calendars: the building file's [holidays], the data's decision, and every model reading Sunday's gains."""

from __future__ import annotations

import dataclasses
import datetime as dt
import warnings

import numpy as np
import pandas as pd
import pytest

from hvacfmu.building import building_from_dict
from hvacfmu.calendars import HolidaySpec, country_of_timezone, gain_slots, holidays_from_toml
from hvacfmu.errors import BuildingError
from hvacfmu.timeutil import time_of_week


# --------------------------------------------------------------------------- the building file
def test_holidays_list_and_ranges_expand_to_dates():
    problems = []
    spec = holidays_from_toml(["2026-12-24..2026-12-28", "2027-01-01", dt.date(2026, 7, 3)], problems)
    assert problems == []
    assert spec.declared and spec.country is None
    assert spec.dates == (
        "2026-12-24",
        "2026-12-25",
        "2026-12-26",
        "2026-12-27",
        "2026-12-28",
        "2027-01-01",
        "2026-07-03",
    )


def test_holidays_table_with_country_open_and_dates():
    problems = []
    spec = holidays_from_toml({"country": "us", "dates": ["2026-12-24"], "open": ["2026-10-12"]}, problems)
    assert problems == []
    days = spec.between(dt.date(2026, 10, 1), dt.date(2026, 12, 31))
    assert dt.date(2026, 11, 26) in days and "Thanksgiving" in days[dt.date(2026, 11, 26)]
    assert dt.date(2026, 10, 12) not in days  # Columbus Day: open
    assert days[dt.date(2026, 12, 24)] == "closed (building file)"
    assert all(dt.date(2026, 10, 1) <= d <= dt.date(2026, 12, 31) for d in days)


@pytest.mark.parametrize(
    "value, fragment",
    [
        ({"country": "XX"}, "not a country code"),
        ({"country": "US", "subdivision": "ZZ"}, "not a subdivision of US"),
        ({"subdivision": "CA"}, "needs holidays.country"),
        (["2026-13-01"], "is not a date"),
        (["2026-12-31..2026-12-01"], "must run forward"),
        ({"country": "US", "closed": []}, "unknown key"),
        ("US", "must be a list of dates or a table"),
    ],
)
def test_bad_holidays_are_named(small_building_dict, value, fragment):
    small_building_dict["holidays"] = value
    with pytest.raises(BuildingError, match="holidays") as err:
        building_from_dict(small_building_dict, source="b.toml")
    assert fragment in str(err.value)


def test_building_round_trip_keeps_the_declaration(small_building_dict):
    small_building_dict["holidays"] = {"country": "US", "open": ["2026-10-12"]}
    b = building_from_dict(small_building_dict)
    again = building_from_dict(b.to_dict())
    assert again.holidays == b.holidays and again.holidays.country == "US"
    small_building_dict["holidays"] = []
    none = building_from_dict(small_building_dict)
    assert none.holidays == HolidaySpec(declared=True) and building_from_dict(none.to_dict()).holidays.declared
    del small_building_dict["holidays"]
    assert not building_from_dict(small_building_dict).holidays.declared


def test_country_of_timezone():
    assert country_of_timezone("America/Denver") == "US"
    assert country_of_timezone("Europe/Berlin") == "DE"
    assert country_of_timezone("UTC") is None


# --------------------------------------------------------------------------- the models read Sunday's gains
def test_gain_slots_move_a_holiday_weekday_to_sunday():
    idx = pd.date_range("2026-11-26", periods=96 * 3, freq="15min", tz="America/Los_Angeles")  # Thu, Fri, Sat
    plain = time_of_week(idx, 900.0)
    slots = gain_slots(idx, 900.0, ("2026-11-26", "2026-11-28"))
    thu = idx.day == 26
    assert np.array_equal(slots[thu], 6 * 96 + np.arange(96))  # Thanksgiving reads Sunday's day
    assert np.array_equal(slots[~thu], plain[~thu])  # Friday as usual; a listed Saturday keeps Saturday's


def _linear_model(holidays=()):
    from hvacfmu.models.linear import LinearZoneModel

    n_tow = 672
    prof = np.zeros((n_tow, 2))
    prof[6 * 96 :, :] = -0.01  # Sunday
    prof[: 5 * 96, :] = 0.02  # workdays
    return LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=("A", "B"),
        measured_zones=("A", "B"),
        output_weights=np.eye(2),
        vavs=("V1", "V2"),
        input_map=np.eye(2),
        disturbances=("T_out",),
        A=np.eye(2) * 0.9,
        B=-np.eye(2) * 0.1,
        C=np.full((2, 1), 0.05),
        gains={"fall": prof, "winter": prof},
        holidays=tuple(holidays),
    )


def test_a_model_with_holidays_reads_sunday_and_keeps_them_through_its_file(tmp_path):
    from hvacfmu.fmu_slave import calendar_dependent
    from hvacfmu.fmu_slave.zone_layout import without_holidays
    from hvacfmu.models import load_model

    m = _linear_model(["2026-11-26"])
    idx = pd.date_range("2026-11-25", periods=96 * 2, freq="15min", tz="America/Los_Angeles")
    q = m.gains_at(idx, "fall")
    assert np.allclose(q[:96], 0.02) and np.allclose(q[96:], -0.01)  # Wednesday, then Thanksgiving as a Sunday
    plain = _linear_model()
    assert np.allclose(plain.gains_at(idx, "fall"), 0.02)
    again = load_model(m.save(tmp_path / "m.json"))
    assert again.holidays == ("2026-11-26",) and np.array_equal(again.gains_at(idx, "fall"), q)
    assert calendar_dependent(m) and not calendar_dependent(plain)
    assert not calendar_dependent(without_holidays(m))


def test_a_model_file_with_a_bad_holiday_is_refused(tmp_path):
    from hvacfmu.errors import ModelError
    from hvacfmu.models import model_from_dict

    d = _linear_model(["2026-11-26"]).to_dict()
    d["holidays"] = ["26.11.2026"]
    with pytest.raises(ModelError, match="'26.11.2026', not a date"):
        model_from_dict(d)


# --------------------------------------------------------------------------- the data decide
def _operation_frame(days, closed=(), seed=0):
    """Synthetic 15-min operation: workdays run the boxes 6-20 h, Sundays (and ``closed`` days) idle."""
    from hvacfmu.building import building_from_dict

    rng = np.random.default_rng(seed)
    idx = pd.date_range("2026-08-31", periods=96 * days, freq="15min", tz="America/Chicago", name="time")
    hour = idx.hour.to_numpy()
    day = np.asarray(idx.strftime("%Y-%m-%d"))
    open_ = (idx.day_of_week.to_numpy() < 5) & ~np.isin(day, list(closed))
    run = open_ & (hour >= 6) & (hour < 20)
    n = len(idx)
    frame = pd.DataFrame(index=idx)
    frame["T_A"] = 22 + 1.5 * run + rng.normal(0, 0.2, n)
    frame["m_V1"] = 0.05 + 0.3 * run * rng.uniform(0.6, 1.0, n)
    frame["T_supply"] = 14.0
    frame["T_out"] = 20 + 5 * np.sin(2 * np.pi * (hour - 9) / 24)
    building = building_from_dict(
        {
            "name": "one room",
            "latitude": 41.9,
            "longitude": -87.6,
            "timezone": "America/Chicago",
            "zones": [{"name": "A", "area": 50.0, "volume": 150.0}],
            "vavs": [{"name": "V1", "zone": "A", "m_min": 0.05, "m_max": 0.5}],
        }
    )
    return frame, building


def _weeks(frame, building, test=()):
    from hvacfmu.data.dataset import Week

    start = frame.index[0]
    return tuple(
        Week(i, start + pd.Timedelta(weeks=i), start + pd.Timedelta(weeks=i + 1), "fall", i not in test)
        for i in range(len(frame) // (96 * 7))
    )


def test_public_holidays_apply_when_the_training_weeks_closed_on_them():
    from hvacfmu.data.holidays import decide_holidays

    # Labor Day 2026-09-07, Columbus Day 10-12, Veterans Day 11-11, Thanksgiving 11-26: 13 weeks
    closed = ("2026-09-07", "2026-10-12", "2026-11-11", "2026-11-26")
    frame, building = _operation_frame(13 * 7, closed)
    cal = decide_holidays(frame, building, _weeks(frame, building, test=(12,)))
    assert cal.source == "public" and cal.country == "US"
    assert set(closed) <= set(cal.in_data)
    assert "2027-11-25" in cal.dates  # next year's Thanksgiving, for forecasts
    assert all(cal.gammas[d] > 0.8 for d in closed[:3])
    assert "2026-11-26" not in cal.gammas  # held out: never judged
    assert any("closed on 3 of the 3 public holiday(s) of US" in n for n in cal.notes)


def test_public_holidays_do_not_apply_to_a_building_working_on_them():
    from hvacfmu.data.holidays import decide_holidays

    frame, building = _operation_frame(13 * 7, closed=())
    cal = decide_holidays(frame, building, _weeks(frame, building, test=(12,)))
    assert cal.source == "none" and cal.dates == ()
    assert all(g < 0.25 for g in cal.gammas.values()) and len(cal.gammas) == 3
    assert any("ran as on a workday on 3 of the 3" in n for n in cal.notes)


def test_a_building_working_on_some_holidays_keeps_them_by_name():
    from hvacfmu.data.holidays import decide_holidays

    # closed on Labor Day, Veterans Day and Thanksgiving, open on Columbus Day
    closed = ("2026-09-07", "2026-11-11", "2026-11-26")
    frame, building = _operation_frame(13 * 7, closed)
    cal = decide_holidays(frame, building, _weeks(frame, building))
    assert cal.source == "public" and "2026-10-12" not in cal.dates and "2027-10-11" not in cal.dates
    assert "2027-09-06" in cal.dates
    assert any("except Columbus Day (worked on)" in n for n in cal.notes)


def test_a_declared_holiday_run_as_a_workday_is_named():
    from hvacfmu.data.holidays import decide_holidays

    frame, building = _operation_frame(13 * 7, closed=("2026-09-07",))
    building = dataclasses.replace(building, holidays=HolidaySpec(dates=("2026-09-07", "2026-10-12"), declared=True))
    cal = decide_holidays(frame, building, _weeks(frame, building))
    assert cal.source == "declared" and cal.dates == ("2026-09-07", "2026-10-12")
    assert any("2026-10-12" in n and "ran like an ordinary workday" in n for n in cal.notes)
    assert not any("2026-09-07 (" in n for n in cal.notes)


def test_a_round_the_clock_building_cannot_tell_and_says_so():
    from hvacfmu.data.holidays import decide_holidays

    frame, building = _operation_frame(13 * 7)
    rng = np.random.default_rng(1)
    frame["m_V1"] = rng.uniform(0.1, 0.4, len(frame))  # every day alike
    frame["T_A"] = 22 + rng.normal(0, 0.3, len(frame))
    cal = decide_holidays(frame, building, _weeks(frame, building))
    assert cal.source == "none" and cal.dates == ()
    assert any("do not run differently enough" in n for n in cal.notes)


# --------------------------------------------------------------------------- end to end on the emulator
@pytest.mark.slow
def test_emulated_building_closing_on_holidays_is_found_and_predicted_better(tmp_path):
    """An emulated building that closes on US holidays (occupancy and BMS schedule of a Sunday): the data find
    the calendar, every model carries it, and 24-h predictions of the holidays improve over the same fit told
    that the building keeps no holiday (``holidays = []``)."""
    import hvacfmu
    from hvacfmu.building import load_building
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(weeks=9, seed=5, start="2025-11-03", holidays="US")
    import json

    truth = json.loads(paths.truth.read_text())
    closed = sorted(truth["holidays"]["dates"])
    assert closed == ["2025-11-11", "2025-11-27", "2025-12-25", "2026-01-01"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(paths.measurements, paths.building)
        b0 = load_building(paths.building)
        ds0 = prepare(paths.measurements, dataclasses.replace(b0, holidays=HolidaySpec(declared=True)))
    assert ds.holidays.source == "public" and set(closed) <= set(ds.holidays.in_data)
    assert ds0.holidays.dates == ()
    errors = {}
    for kind in ("lumped", "zones", "physics"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = hvacfmu.fit(ds, kind)
            m0 = hvacfmu.fit(ds0, kind)
        assert set(closed) <= set(m.holidays) and m0.holidays == ()
        again = hvacfmu.load_model(m.save(tmp_path / f"{kind}.json"))
        assert again.holidays == m.holidays
        errors[kind] = (_holiday_rms(m, ds, closed), _holiday_rms(m0, ds0, closed))
    for kind, (with_cal, without) in errors.items():
        assert with_cal < 0.9 * without, (kind, with_cal, without)


def _holiday_rms(model, ds, days):
    """RMS [K] of 24-h open-loop predictions from 00:00 of each of ``days`` (rows with every value)."""
    frame = ds.frame
    err = []
    for d in days:
        k0 = frame.index.searchsorted(pd.Timestamp(d, tz=frame.index.tz))
        sub = frame.iloc[k0 : k0 + 97]
        u, v = (np.asarray(a, float) for a in model.signals(sub))
        y = model.measured_outputs(sub)
        u, v = pd.DataFrame(u).ffill().bfill().to_numpy(), pd.DataFrame(v).ffill().bfill().to_numpy()
        season = ds.season_of_row[k0]
        q = np.asarray(model.gains_at(sub.index[:-1], season if season in model.gains else next(iter(model.gains))))
        x0 = model.initial_state(frame, k0)
        _, yp = model.simulate(x0, u[:-1], v[:-1], q)
        e = yp[1:] - y[1:]
        err.append(e[np.isfinite(e)])
    e = np.concatenate(err)
    return float(np.sqrt(np.mean(e**2)))


def test_the_verdict_names_a_held_out_public_holiday_the_model_predicts_as_a_workday():
    from types import SimpleNamespace

    from hvacfmu.data.holidays import HolidayCalendar
    from hvacfmu.evaluation.verdict import _holiday_cause

    _, building = _operation_frame(7)
    tz = building.timezone
    starts = [pd.Timestamp("2026-11-25 00:00", tz=tz) + pd.Timedelta(hours=12 * i) for i in range(4)]
    idx = pd.DatetimeIndex([t + pd.Timedelta(minutes=15 * k) for t in starts for k in range(96)])
    score = SimpleNamespace(starts=starts, seasons=["fall"] * 4, residuals=pd.DataFrame({"A": 0.0}, index=idx))
    sv = SimpleNamespace(output="A", season="fall")
    ds = SimpleNamespace(building=building, holidays=HolidayCalendar())
    plain = _linear_model()
    (line,) = _holiday_cause(score, sv, plain, ds)
    assert "2026-11-26 Thanksgiving Day" in line and 'country = "US"' in line
    assert _holiday_cause(score, sv, _linear_model(["2026-11-26"]), ds) == []
    other = SimpleNamespace(starts=starts, seasons=["winter"] * 4, residuals=score.residuals)
    assert _holiday_cause(other, sv, plain, ds) == []


def test_a_single_training_holiday_closed_beyond_doubt_is_enough():
    """A short export (five weeks from 31 August): Labor Day is the only public holiday in it. Closed beyond doubt,
    the calendar applies (Thanksgiving, later, reads Sunday's gains); run half-way to a Sunday, it does not."""
    from hvacfmu.data.holidays import SINGLE_GAMMA, decide_holidays

    frame, building = _operation_frame(5 * 7, closed=("2026-09-07",))
    cal = decide_holidays(frame, building, _weeks(frame, building))
    assert cal.gammas["2026-09-07"] >= SINGLE_GAMMA
    assert cal.source == "public" and "2026-11-26" in cal.dates
    assert any("the only one there" in n for n in cal.notes)
    half = frame.copy()
    day = np.asarray(half.index.strftime("%Y-%m-%d")) == "2026-09-07"
    hour = half.index.hour.to_numpy()
    run = day & (hour >= 6) & (hour < 20)
    half.loc[run, "m_V1"] = 0.05 + 0.15 * np.random.default_rng(3).uniform(0.6, 1.0, run.sum())  # half the load
    half.loc[run, "T_A"] = 22.75
    cal = decide_holidays(half, building, _weeks(half, building))
    assert cal.source == "none" and cal.dates == ()
    assert 0.25 <= cal.gammas["2026-09-07"] < SINGLE_GAMMA
    assert any("too few to decide" in n for n in cal.notes)


def test_unlisted_closures_are_named_in_training_and_held_out_weeks_never_applied():
    """A building closed on its public holidays and also 28-30 December (no public holiday) and on one held-out
    Wednesday: the calendar applies the public holidays only; the other closed weekdays are named, the held-out
    one marked, and an ordinary building names none."""
    from hvacfmu.data.holidays import decide_holidays

    closed = ("2026-09-07", "2026-10-12", "2026-11-11", "2026-11-26", "2026-12-25")
    unlisted = ("2026-12-28", "2026-12-29", "2026-12-30", "2026-10-21")
    frame, building = _operation_frame(18 * 7, closed + unlisted)
    weeks = _weeks(frame, building, test=(7,))  # the week of 2026-10-19
    cal = decide_holidays(frame, building, weeks)
    assert cal.source == "public" and not set(unlisted) & set(cal.dates)
    assert set(cal.sunday_like) == set(unlisted)
    (note,) = [n for n in cal.notes if "outside the holiday calendar ran like a Sunday" in n]
    assert "2026-10-21 (Wed, gamma" in note and "held out" in note.split("2026-10-21")[1].split(")")[0]
    assert "[holidays] dates" in note
    plain, _ = _operation_frame(18 * 7, closed)
    assert decide_holidays(plain, building, weeks).sunday_like == {}
    worked, _ = _operation_frame(18 * 7)
    assert decide_holidays(worked, building, weeks).sunday_like == {}


def test_the_verdict_names_a_held_out_weekday_that_ran_like_a_sunday():
    from types import SimpleNamespace

    from hvacfmu.data.holidays import HolidayCalendar
    from hvacfmu.evaluation.verdict import _holiday_cause

    _, building = _operation_frame(7)
    tz = building.timezone
    starts = [pd.Timestamp("2026-12-28 00:00", tz=tz) + pd.Timedelta(hours=12 * i) for i in range(4)]
    idx = pd.DatetimeIndex([t + pd.Timedelta(minutes=15 * k) for t in starts for k in range(96)])
    score = SimpleNamespace(starts=starts, seasons=["winter"] * 4, residuals=pd.DataFrame({"A": 0.0}, index=idx))
    sv = SimpleNamespace(output="A", season="winter")
    cal = HolidayCalendar(sunday_like={"2026-12-29": 0.97, "2027-02-10": 0.9})
    ds = SimpleNamespace(building=building, holidays=cal)
    (line,) = _holiday_cause(score, sv, _linear_model(), ds)
    assert "2026-12-29 (Tue, gamma 0.97)" in line and "ran like a Sunday" in line and "2027-02-10" not in line
    assert "[holidays] dates" in line
    assert _holiday_cause(score, sv, _linear_model(["2026-12-29"]), ds) == []
    assert (
        _holiday_cause(score, sv, _linear_model(), SimpleNamespace(building=building, holidays=HolidayCalendar())) == []
    )
