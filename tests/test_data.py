"""Tests of hvacfmu.data: loading, validation, units, resampling, solar, weeks, check CLI."""

from __future__ import annotations

import copy
import hashlib
import warnings

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from hvacfmu.building import building_from_dict
from hvacfmu.data import (
    AIR_DENSITY,
    Dataset,
    Week,
    check,
    facade_irradiance,
    from_si,
    interpolate_gaps,
    load_measurements,
    make_weeks,
    prepare,
    resample,
    to_si,
)
from hvacfmu.errors import DataError, HvacfmuWarning

TZ = "America/Los_Angeles"


# --------------------------------------------------------------------------- helpers
def make_measurements(building, start="2024-09-02 00:00", periods=1440, freq="1min", seed=0, ghi=True):
    """Plausible SI measurements for ``building`` with a tz-aware index named ``time``."""
    rng = np.random.default_rng(seed)
    index = pd.date_range(pd.Timestamp(start, tz=building.timezone), periods=periods, freq=freq, name="time")
    hours = (index.hour + index.minute / 60).to_numpy()
    cols = {}
    for i, z in enumerate(building.zone_names):
        cols[f"T_{z}"] = 21.0 + i + 0.5 * np.sin(2 * np.pi * hours / 24) + rng.normal(0, 0.05, periods)
    for j, v in enumerate(building.vav_names):
        cols[f"m_{v}"] = 0.1 + 0.05 * j + 0.02 * rng.random(periods)
    cols["T_supply"] = 14.0 + rng.normal(0, 0.1, periods)
    cols["T_out"] = 15.0 + 5 * np.sin(2 * np.pi * (hours - 9) / 24)
    if ghi:
        cols["ghi"] = np.clip(800 * np.sin(np.pi * (hours - 6) / 12), 0, None)
    cols["excitation"] = np.zeros(periods)
    return pd.DataFrame(cols, index=index)


def write(frame, path, time_style="offset"):
    """Write a frame with its index as the ``time`` column.

    time_style: 'offset' (ISO 8601 with offset), 'naive' (local wall clock),
    'timestamp' (Parquet tz-aware timestamps).
    """
    out = frame.copy()
    if time_style == "offset":
        times = [t.isoformat() for t in out.index]
    elif time_style == "naive":
        times = [t.tz_localize(None).isoformat() for t in out.index]
    elif time_style == "timestamp":
        times = out.index
    else:
        raise ValueError(time_style)
    out.index = pd.RangeIndex(len(out))
    out.insert(0, "time", times)
    if str(path).endswith(".parquet"):
        out.to_parquet(path, index=False)
    else:
        out.to_csv(path, index=False)
    return path


@pytest.fixture
def good_frame(small_building):
    return make_measurements(small_building, periods=2 * 1440)


# --------------------------------------------------------------------------- loading good data
@pytest.mark.parametrize(
    "suffix, time_style",
    [(".csv", "offset"), (".csv", "naive"), (".parquet", "offset"), (".parquet", "timestamp"), (".parquet", "naive")],
)
def test_load_good_data(tmp_path, small_building, good_frame, suffix, time_style):
    path = write(good_frame, tmp_path / f"m{suffix}", time_style)
    frame, report = load_measurements(path, small_building)
    assert frame.index.name == "time"
    assert str(frame.index.tz) == TZ
    assert frame.index.equals(good_frame.index)
    assert list(frame.columns) == list(good_frame.columns)
    assert_allclose(frame.to_numpy(), good_frame.to_numpy(), rtol=0, atol=1e-9)
    assert report.rows == len(good_frame)
    assert report.native_step == 60.0
    assert report.has_offsets == (time_style != "naive")
    assert report.unknown_columns == ()


def test_load_accepts_building_path_and_warns_unknown_column(tmp_path, small_building, good_frame):
    good_frame = good_frame.assign(comment_col=1.0)
    path = write(good_frame, tmp_path / "m.csv")
    frame, report = load_measurements(path, small_building.save(tmp_path / "b.toml"))
    assert "comment_col" not in frame.columns
    assert report.unknown_columns == ("comment_col",)
    assert any("unknown column" in w and "comment_col" in w for w in report.warnings)


def test_offsets_across_dst_end_are_accepted(tmp_path, small_building):
    # 2024-11-03: clocks go back 02:00 PDT -> 01:00 PST; the day has 25 hours
    frame = make_measurements(small_building, start="2024-11-02 00:00", periods=3 * 1440 + 60)
    assert frame.index.is_monotonic_increasing
    path = write(frame, tmp_path / "m.csv", "offset")
    loaded, report = load_measurements(path, small_building)
    assert loaded.index.is_unique and loaded.index.is_monotonic_increasing
    assert report.has_offsets
    ds = _quiet_prepare(path, small_building)
    day = ds.frame.loc["2024-11-03"]
    assert len(day) == 100  # 25 h of 15-minute steps
    assert (day.index.minute % 15 == 0).all()  # still on the local quarter hours


def test_offsets_across_dst_start_are_accepted(tmp_path, small_building):
    frame = make_measurements(small_building, start="2024-03-09 00:00", periods=3 * 1440)
    ds = _quiet_prepare(write(frame, tmp_path / "m.csv", "offset"), small_building)
    day = ds.frame.loc["2024-03-10"]
    assert len(day) == 92  # 23 h
    assert day.index[8] == pd.Timestamp("2024-03-10 03:00", tz=TZ)  # 02:00..02:59 do not exist
    assert np.isfinite(day.to_numpy()).all()


def test_naive_times_across_both_dst_changes_are_inferred(tmp_path, small_building):
    # one naive 1-minute export with two days around each change of 2024: the spring day skips
    # 02:00..02:59, the autumn day lists 01:00..01:59 twice (PDT, then PST)
    spring = make_measurements(small_building, start="2024-03-09 12:00", periods=2 * 1440 - 60, seed=1)
    fall = make_measurements(small_building, start="2024-11-02 12:00", periods=2 * 1440 + 60, seed=2)
    frame = pd.concat([spring, fall])
    path = write(frame, tmp_path / "year.csv", "naive")
    assert (pd.read_csv(path)["time"] == "2024-11-03T01:00:00").sum() == 2
    loaded, report = load_measurements(path, small_building)
    assert not report.has_offsets
    assert loaded.index.equals(frame.index)  # the same UTC instants, not just the same wall clock
    utc = loaded.index.tz_convert("UTC")
    first = np.flatnonzero(loaded.index.tz_localize(None) == pd.Timestamp("2024-11-03 01:00"))
    assert list(utc[first]) == [pd.Timestamp("2024-11-03 08:00", tz="UTC"), pd.Timestamp("2024-11-03 09:00", tz="UTC")]
    assert (np.diff(utc.asi8)[np.r_[: len(spring) - 1, len(spring) : len(frame) - 1]] == 60 * 10**9).all()
    assert_allclose(loaded.to_numpy(), frame.to_numpy(), rtol=0, atol=1e-9)
    # hourly data with gaps: the repeated hour is a repeated time, still inferred from the order
    hourly = make_measurements(small_building, start="2024-11-02 20:00", periods=12, freq="1h").iloc[
        [0, 1, 4, 5, 6, 7, 9]
    ]
    loaded, _ = load_measurements(write(hourly, tmp_path / "hourly.csv", "naive"), small_building)
    assert loaded.index.equals(hourly.index)


def test_naive_times_that_cannot_be_inferred_are_reported(tmp_path, small_building):
    # the repeated hour logged once only (a logger that dropped the second occurrence)
    once = make_measurements(small_building, start="2024-11-03 00:00", periods=4 * 60).reset_index(drop=True)
    once.insert(0, "time", [t.isoformat() for t in pd.date_range("2024-11-03 00:00", periods=4 * 60, freq="1min")])
    once.to_csv(tmp_path / "once.csv", index=False)
    with pytest.raises(
        DataError,
        match=r"60 naive local times are ambiguous.*2024-11-03 01:00:00\.\.2024-11-03 01:59:00 \(rows 61-120\): "
        r"the repeated hour appears once only.*2024-11-03T01:00:00-07:00 for the first occurrence, "
        r"2024-11-03T01:00:00-08:00 for the second",
    ):
        load_measurements(tmp_path / "once.csv", small_building)
    # the two occurrences interleaved (rows out of order): the order cannot tell them apart
    fall = make_measurements(small_building, start="2024-11-03 00:00", periods=4 * 60)
    path = write(fall, tmp_path / "fall.csv", "naive")
    rows = pd.read_csv(path)
    order = np.r_[0:60, np.ravel(np.column_stack([np.arange(60, 120), np.arange(120, 180)])), 180:240]
    rows.iloc[order].to_csv(path, index=False)
    with pytest.raises(
        DataError, match=r"120 naive local times are ambiguous.*\(rows 61-180\): times step back 60 times"
    ):
        load_measurements(path, small_building)
    # a naive logger writing every wall-clock minute from 00:00: 02:00..02:59 do not exist locally
    spring = make_measurements(small_building, start="2024-03-09 00:00", periods=4 * 60).reset_index(drop=True)
    spring.insert(0, "time", [t.isoformat() for t in pd.date_range("2024-03-10 00:00", periods=4 * 60, freq="1min")])
    spring.to_csv(tmp_path / "spring.csv", index=False)
    with pytest.raises(DataError, match=r"60 naive local times do not exist.*2024-03-10 02:00:00 at row 121"):
        load_measurements(tmp_path / "spring.csv", small_building)


# --------------------------------------------------------------------------- bad input
def _set(frame, column, row, value):
    frame = frame.astype({column: object}) if isinstance(value, str) else frame
    frame.iloc[row, frame.columns.get_loc(column)] = value
    return frame


def _dup_time(frame):
    idx = frame.index.to_list()
    idx[10] = idx[9]
    frame.index = pd.DatetimeIndex(idx, name="time")
    return frame


def _swap_times(frame):
    idx = frame.index.to_list()
    idx[20], idx[21] = idx[21], idx[20]
    frame.index = pd.DatetimeIndex(idx, name="time")
    return frame


def _bad_time_text(frame):
    out = frame.copy()
    out.index = pd.Index([t.isoformat() for t in frame.index], name="time")
    out.index = out.index.where(np.arange(len(out)) != 4, "yesterday noon")
    return out


def _mixed_offsets(frame):
    out = frame.copy()
    text = [t.isoformat() for t in frame.index]
    text[7] = frame.index[7].tz_localize(None).isoformat()
    out.index = pd.Index(text, name="time")
    return out


def _units(**units):
    def mutate(frame, bdict):
        bdict["units"] = units
        return frame, bdict

    return mutate


def _frame_only(f):
    return lambda frame, bdict: (f(frame), bdict)


BAD_INPUTS = [
    ("missing column", _frame_only(lambda f: f.drop(columns=["T_out"])), r"missing required column 'T_out'"),
    (
        "missing mapped column",
        lambda f, b: (f, {**b, "columns": {"T_A": "Room A"}}),
        r"missing required column 'Room A' \(mapped from T_A\)",
    ),
    (
        "non-numeric",
        _frame_only(lambda f: _set(f, "T_A", 5, "abc")),
        r"column 'T_A': 1 non-numeric value\(s\), e\.g\. 'abc' at row 6 \(2024-09-02T00:05:00-07:00\)",
    ),
    ("duplicate time", _frame_only(_dup_time), r"column 'time': 1 duplicate timestamps at row 11"),
    ("time backwards", _frame_only(_swap_times), r"times go backwards at 1 place\(s\): row 22 .* after row 21"),
    (
        "unparseable time",
        _frame_only(_bad_time_text),
        r"1 values are not ISO 8601 times, e\.g\. 'yesterday noon' at row 5",
    ),
    (
        "mixed offsets",
        _frame_only(_mixed_offsets),
        r"mixes times with and without UTC offset; 1 without offset at .*row 8",
    ),
    (
        "negative airflow",
        _frame_only(lambda f: _set(f, "m_V2", 30, -0.4)),
        r"column 'm_V2': 1 negative airflow .* -0\.4 at row 31",
    ),
    (
        "hot room",
        _frame_only(lambda f: _set(f, "T_B", 40, 95.0)),
        r"column 'T_B': 1 value\(s\) outside -50\.\.80 °C .* 95 at row 41",
    ),
    (
        "degF declared as degC",
        _frame_only(lambda f: f.assign(T_A=f["T_A"] * 1.8 + 32)),
        r"column 'T_A': declared degC but the median is \d\d\.\d+.*look like degF",
    ),
    (
        "kelvin declared as degC",
        _frame_only(lambda f: f.assign(T_out=f["T_out"] + 273.15)),
        r"column 'T_out': declared degC .* look like K",
    ),
    (
        "cfm declared as kg/s",
        _frame_only(lambda f: f.assign(m_V3=f["m_V3"] / 1.2 / 0.000471947)),
        (
            r"column 'm_V3': the 99th percentile of the airflow is \d+(\.\d+)? kg/s \(declared kg/s\), above "
            r"1\.5 x m_max = 0\.6 kg/s of box V3.*the data look like L/s or cfm"
        ),
    ),
    (
        "cfm declared as L/s",
        lambda f, b: (f.assign(m_V3=0.35 / 1.2 / 0.000471947), {**b, "units": {"m_*": "L/s"}}),
        r"column 'm_V3': the 99th percentile of the airflow is 0\.74\d* kg/s \(declared L/s\).*look like cfm",
    ),
    (
        "L/s declared as cfm",
        lambda f, b: (f.assign(m_V1=0.055 / 1.2e-3), {**b, "units": {"m_*": "cfm"}}),
        (
            r"column 'm_V1': while the box runs, its median airflow is 0\.0259\d* kg/s \(declared cfm\), below "
            r"0\.6 x m_min = 0\.03 kg/s of box V1.*look like L/s"
        ),
    ),
    (
        "airflow spikes in 5 % of rows",
        _frame_only(lambda f: f.assign(m_V2=np.where(np.arange(len(f)) % 20 == 3, 50.0, f["m_V2"]))),
        (
            r"column 'm_V2': 75 value\(s\) \(5 % of its samples, more than the 1 % that are masked as spikes\) "
            r"above 2 x m_max = 1\.2 kg/s of box V2, e\.g\. 50 at row 4"
        ),
    ),
    (
        "+inf airflow",
        _frame_only(lambda f: _set(f, "m_V1", 9, np.inf)),
        r"column 'm_V1': 1 infinite value\(s\), e\.g\. inf at row 10",
    ),
    (
        "-inf temperature",
        _frame_only(lambda f: _set(f, "T_A", 2, -np.inf)),
        r"column 'T_A': 1 infinite value\(s\), e\.g\. -inf at row 3",
    ),
    (
        "negative irradiance",
        _frame_only(lambda f: _set(f, "ghi", 3, -50.0)),
        r"column 'ghi': 1 negative irradiance .* -50 at row 4",
    ),
    (
        "excessive irradiance",
        _frame_only(lambda f: _set(f, "ghi", 700, 5000.0)),
        r"column 'ghi': 1 value\(s\) above 1500 W/m²",
    ),
    (
        "kW/m2 declared as W/m2",
        _frame_only(lambda f: f.assign(ghi=f["ghi"] / 1000)),
        r"column 'ghi': the largest value over 1 day\(s\) is 0\.8 W/m² \(declared W/m2\).*look like kW/m²",
    ),
    (
        "excitation not 0/1",
        _frame_only(lambda f: _set(f, "excitation", 2, 2.0)),
        r"column 'excitation': 1 value\(s\) other than 0 or 1",
    ),
    ("unknown unit", _units(**{"T_*": "furlongs"}), r"column 'T_A'.*unit 'furlongs' is not a temperature unit"),
    ("empty column", _frame_only(lambda f: f.assign(T_supply=np.nan)), r"column 'T_supply': no values at all"),
    (
        "partial facades without ghi",
        _frame_only(lambda f: f.drop(columns=["ghi"]).assign(I_S=100.0)),
        r"facade irradiance given for S but not for N, E, W, and no 'ghi' column",
    ),
]


@pytest.mark.parametrize("name, mutate, message", BAD_INPUTS, ids=[b[0] for b in BAD_INPUTS])
def test_bad_input_is_rejected_with_message(tmp_path, small_building_dict, name, mutate, message):
    building = building_from_dict(small_building_dict)
    frame = make_measurements(building, periods=1500)
    frame, bdict = mutate(frame.copy(), copy.deepcopy(small_building_dict))
    building = building_from_dict(bdict)
    if isinstance(frame.index, pd.DatetimeIndex):
        path = write(frame, tmp_path / "bad.csv")
    else:  # index already holds time text
        out = frame.reset_index()
        out.to_csv(tmp_path / "bad.csv", index=False)
        path = tmp_path / "bad.csv"
    with pytest.raises(DataError, match=message) as info:
        load_measurements(path, building)
    assert "bad.csv" in str(info.value)


@pytest.mark.parametrize(
    "filename, message",
    [("nothere.csv", r"nothere\.csv: file does not exist"), ("m.xlsx", r"unknown file type '\.xlsx'")],
)
def test_bad_files(tmp_path, small_building, filename, message):
    if filename.endswith(".xlsx"):
        (tmp_path / filename).write_bytes(b"PK")
    with pytest.raises(DataError, match=message):
        load_measurements(tmp_path / filename, small_building)


def test_all_problems_reported_at_once(tmp_path, small_building):
    frame = make_measurements(small_building, periods=720)
    frame = _set(frame, "T_A", 5, "abc")
    frame = _set(frame, "m_V1", 7, -3.0)
    frame = _set(frame, "T_B", 100, 200.0)
    frame = _dup_time(frame).drop(columns=["T_out"])
    path = write(frame, tmp_path / "bad.csv")
    with pytest.raises(DataError) as info:
        load_measurements(path, small_building)
    msg = str(info.value)
    assert "(5 problems)" in msg
    for part in (
        "missing required column 'T_out'",
        "duplicate timestamps",
        "'abc'",
        "negative airflow",
        "outside -50..80",
    ):
        assert part in msg


def test_small_negative_noise_is_clipped_with_warning(tmp_path, small_building):
    frame = make_measurements(small_building, periods=720)
    frame = _set(frame, "ghi", 0, -2.0)
    frame = _set(frame, "m_V1", 1, -0.001)
    loaded, report = load_measurements(write(frame, tmp_path / "m.csv"), small_building)
    assert loaded["ghi"].iloc[0] == 0.0 and loaded["m_V1"].iloc[1] == 0.0
    assert sum("sensor noise" in w for w in report.warnings) == 2


# --------------------------------------------------------------------------- units
@pytest.mark.parametrize(
    "unit, si, value",
    [
        ("degF", 0.0, 32.0),
        ("degF", 100.0, 212.0),
        ("degF", -40.0, -40.0),
        ("K", 0.0, 273.15),
        ("K", 21.0, 294.15),
        ("m3/s", 1.2, 1.0),
        ("L/s", 1.2, 1000.0),
        ("cfm", 0.3048**3 / 60 * AIR_DENSITY, 1.0),
        ("cfm", 1.2, 2118.880),
        ("kg/s", 0.3, 0.3),
        ("degC", 21.5, 21.5),
        ("W/m2", 500.0, 500.0),
        ("kW/m2", 500.0, 0.5),
    ],
)
def test_unit_conversion_known_points(unit, si, value):
    assert_allclose(to_si([value], unit), [si], rtol=1e-6, atol=1e-12)
    assert_allclose(from_si([si], unit), [value], rtol=1e-6, atol=1e-12)


@pytest.mark.parametrize("unit", ["degC", "degF", "K", "kg/s", "m3/s", "L/s", "cfm", "W/m2", "kW/m2"])
def test_unit_round_trip(unit, rng):
    x = rng.normal(10.0, 5.0, 100)
    assert_allclose(to_si(from_si(x, unit), unit), x, rtol=0, atol=1e-12)


def test_load_converts_declared_units_and_mapped_names(tmp_path, small_building_dict):
    building = building_from_dict(small_building_dict)
    si = make_measurements(building, periods=720)
    bdict = copy.deepcopy(small_building_dict)
    bdict["columns"] = {"T_A": "RM-A ZN-T", "m_V1": "VAV1 FLOW", "time": "Timestamp"}
    bdict["units"] = {"T_*": "degF", "T_out": "K", "m_*": "cfm", "m_V2": "L/s", "m_V3": "m3/s"}
    mapped = building_from_dict(bdict)
    raw = si.copy()
    for c in raw.columns:
        unit = mapped.unit_for(c)
        if unit:
            raw[c] = from_si(raw[c], unit)
    raw = raw.rename(columns={"T_A": "RM-A ZN-T", "m_V1": "VAV1 FLOW"})
    raw.index.name = "Timestamp"
    out = raw.reset_index()
    out["Timestamp"] = [t.isoformat() for t in raw.index]
    out.to_csv(tmp_path / "bms.csv", index=False)
    frame, report = load_measurements(tmp_path / "bms.csv", mapped)
    assert report.units["T_A"] == "degF" and report.units["T_out"] == "K" and report.units["m_V2"] == "L/s"
    assert report.columns["T_A"] == "RM-A ZN-T"
    assert list(frame.columns) == list(si.columns)
    assert_allclose(frame.to_numpy(), si.to_numpy(), rtol=0, atol=1e-9)


# --------------------------------------------------------------------------- resampling
def _series(values, start="2024-09-02 00:00", freq="1min", name="T_A"):
    index = pd.date_range(pd.Timestamp(start, tz=TZ), periods=len(values), freq=freq, name="time")
    return pd.DataFrame({name: np.asarray(values, dtype=float)}, index=index)


def test_resample_exact_averages_and_left_closed_labels():
    frame = _series(np.arange(30))
    out, cov = resample(frame, 900)
    assert list(out.index) == [pd.Timestamp("2024-09-02 00:00", tz=TZ), pd.Timestamp("2024-09-02 00:15", tz=TZ)]
    assert_allclose(out["T_A"], [7.0, 22.0], rtol=0, atol=1e-12)  # mean of 0..14, 15..29
    assert_allclose(cov["T_A"], [1.0, 1.0], rtol=0, atol=1e-12)
    assert str(out.index.tz) == TZ and out.index.name == "time"


def test_resample_aligns_bins_to_local_clock():
    frame = _series(np.arange(20), start="2024-09-02 00:07")
    out, cov = resample(frame, 900)
    assert out.index[0] == pd.Timestamp("2024-09-02 00:00", tz=TZ)
    # 00:07..00:14 are 8 samples of 15 (53 %) -> kept; 00:15..00:26 are 12 samples
    assert_allclose(out["T_A"], [3.5, 13.5], rtol=0, atol=1e-12)
    assert_allclose(cov["T_A"], [8 / 15, 12 / 15], rtol=0, atol=1e-12)


def test_resample_coverage_rule():
    v = np.arange(45, dtype=float)
    v[0:8] = np.nan  # bin 0: 7 of 15 samples -> NaN
    v[15:22] = np.nan  # bin 1: 8 of 15 samples -> mean of the 8
    out, _ = resample(_series(v), 900)
    assert np.isnan(out["T_A"].iloc[0])
    assert_allclose(out["T_A"].iloc[1], np.mean(np.arange(22, 30)), rtol=0, atol=1e-12)
    assert_allclose(out["T_A"].iloc[2], 37.0, rtol=0, atol=1e-12)
    out_strict, _ = resample(_series(v), 900, min_coverage=0.6)
    assert np.isnan(out_strict["T_A"].iloc[1])


def test_resample_excitation_any_sample():
    e = np.zeros(60)
    e[14] = 1.0  # last minute of bin 0
    e[30:45] = np.nan  # bin 2 missing entirely
    out, _ = resample(_series(e, name="excitation"), 900)
    assert out["excitation"].iloc[0] == 1.0
    assert out["excitation"].iloc[1] == 0.0
    assert np.isnan(out["excitation"].iloc[2])
    assert out["excitation"].iloc[3] == 0.0


def test_gaps_preserved_without_interpolation_and_filled_with_limit():
    v = np.linspace(20.0, 22.0, 240)
    gapped = v.copy()
    gapped[20:28] = np.nan  # 8-minute gap inside bin 1 (coverage 7/15 -> NaN)
    gapped[120:180] = np.nan  # 1-hour gap: bins 8..11
    frame = _series(gapped)
    out, _ = resample(frame, 900)
    assert np.isnan(out["T_A"].iloc[1])
    assert np.isnan(out["T_A"].iloc[8:12]).all()
    filled = interpolate_gaps(frame, limit=10)
    assert_allclose(filled["T_A"].iloc[20:28], v[20:28], rtol=0, atol=1e-9)  # linear data -> exact
    assert np.isnan(filled["T_A"].iloc[120:180]).all()  # 60 min > 10 min limit: kept
    out2, _ = resample(filled, 900)
    assert_allclose(out2["T_A"].iloc[1], v[15:30].mean(), rtol=0, atol=1e-9)
    assert np.isnan(out2["T_A"].iloc[8:12]).all()
    filled_long = interpolate_gaps(frame, limit=60)
    assert np.isfinite(filled_long["T_A"]).all()
    assert np.isnan(interpolate_gaps(frame, limit=59)["T_A"].iloc[150])


def test_interpolation_fills_missing_timestamps():
    frame = _series(np.arange(60, dtype=float))
    frame = frame.drop(frame.index[10:15])  # 5 rows missing from the file
    filled = interpolate_gaps(frame, limit=5)
    assert len(filled) == 60
    assert_allclose(filled["T_A"], np.arange(60), rtol=0, atol=1e-9)
    assert len(interpolate_gaps(frame, limit=4).dropna()) == 55


def test_resample_coarse_column_interpolated_to_midpoints():
    index = pd.date_range(pd.Timestamp("2024-09-02 00:00", tz=TZ), periods=181, freq="1min", name="time")
    ghi = np.full(181, np.nan)
    ghi[::60] = [0.0, 100.0, 200.0, 300.0]  # hourly readings at 00:00, 01:00, 02:00, 03:00
    frame = pd.DataFrame({"T_A": 20.0, "ghi": ghi}, index=index)
    out, _ = resample(frame, 900)
    # midpoint of the 00:15 bin is 00:22:30 -> 37.5 W/m2
    assert_allclose(out["ghi"].iloc[:4], [12.5, 37.5, 62.5, 87.5], rtol=0, atol=1e-9)
    assert_allclose(out["T_A"].iloc[:12], 20.0, rtol=0, atol=1e-12)
    assert np.isnan(out["T_A"].iloc[12])  # the 03:00 bin holds a single 1-minute sample


def test_resample_rejects_step_not_dividing_an_hour():
    with pytest.raises(ValueError, match="dividing one hour"):
        resample(_series(np.arange(10)), 7 * 60)


# --------------------------------------------------------------------------- weeks and seasons
def _weeks(start, days, seed=0, train_fraction=0.9, building=None, step=900):
    index = pd.date_range(pd.Timestamp(start, tz=TZ), periods=int(days * 86400 / step), freq=f"{step}s")
    return make_weeks(index, index[-1] + pd.Timedelta(seconds=step), building, seed=seed, train_fraction=train_fraction)


def test_week_blocks_start_at_first_local_midnight(small_building):
    weeks, _ = _weeks("2024-08-28 10:00", 22, building=small_building)
    # first midnight after 08-28 10:00 is 08-29; 21.6 days left -> 3 full weeks... only 2 fit before 09-19 10:00
    assert [w.start for w in weeks] == [
        pd.Timestamp("2024-08-29", tz=TZ),
        pd.Timestamp("2024-09-05", tz=TZ),
        pd.Timestamp("2024-09-12", tz=TZ),
    ]
    assert all(w.end - w.start == pd.Timedelta(days=7) for w in weeks)
    assert [w.number for w in weeks] == [0, 1, 2]
    # season of the midpoint: 08-29 + 3.5 d = 09-01 12:00 -> fall
    assert [w.season for w in weeks] == ["fall", "fall", "fall"]
    weeks2, _ = _weeks("2024-08-28 10:00", 21.5, building=small_building)
    assert len(weeks2) == 2  # trailing partial block dropped


def test_week_midpoint_season_and_dst_week(small_building):
    weeks, _ = _weeks("2024-08-24 00:00", 14, building=small_building)
    assert [w.season for w in weeks] == ["summer", "fall"]  # midpoints 08-27 12:00 and 09-03 12:00
    weeks, _ = _weeks("2024-10-28 00:00", 14, building=small_building)
    assert weeks[0].end - weeks[0].start == pd.Timedelta(days=7, hours=1)  # contains the end of DST
    assert weeks[0].end == pd.Timestamp("2024-11-04", tz=TZ)


def test_week_split_per_season(small_building):
    weeks, _notes = _weeks("2024-09-02 00:00", 51 * 7, building=small_building)
    assert len(weeks) == 51
    n_weeks = {s: sum(w.season == s for w in weeks) for s in small_building.season_names}
    n_test = {s: sum(w.season == s and not w.train for w in weeks) for s in small_building.season_names}
    assert n_weeks == {"fall": 15, "winter": 6, "spring": 16, "summer": 14}
    # 10 %, rounded half up, at least one: 1.5 -> 2, 0.6 -> 1, 1.6 -> 2, 1.4 -> 1
    assert n_test == {"fall": 2, "winter": 1, "spring": 2, "summer": 1}
    assert 0.05 <= sum(not w.train for w in weeks) / len(weeks) <= 0.15
    again, _ = _weeks("2024-09-02 00:00", 51 * 7, building=small_building)
    assert [w.train for w in again] == [w.train for w in weeks]  # deterministic
    splits = {
        tuple(w.train for w in _weeks("2024-09-02", 51 * 7, seed=s, building=small_building)[0]) for s in range(5)
    }
    assert len(splits) > 1  # the seed matters


def test_season_with_one_week_gets_no_test_week(small_building):
    # 2024-12-16 (Mon) .. : winter 12-16..01-25: the 2-week span gives 2 winter weeks, 1 test
    weeks, notes = _weeks("2024-12-16", 14, building=small_building)
    assert [w.season for w in weeks] == ["winter", "winter"]
    assert sum(not w.train for w in weeks) == 1
    weeks, notes = _weeks("2024-12-16", 7, building=small_building)
    assert len(weeks) == 1 and weeks[0].train
    assert any("only one week" in n for n in notes)


# --------------------------------------------------------------------------- facade irradiance
def test_facade_irradiance_sanity(small_building):
    import pvlib

    loc = pvlib.location.Location(small_building.latitude, small_building.longitude, tz=TZ)
    times = pd.DatetimeIndex(
        [
            pd.Timestamp("2024-12-21 12:00", tz=TZ),  # winter noon
            pd.Timestamp("2024-12-21 23:00", tz=TZ),  # night
            pd.Timestamp("2024-06-21 09:00", tz=TZ),  # summer morning
            pd.Timestamp("2024-06-21 16:00", tz=TZ),  # summer afternoon
        ]
    )
    ghi = loc.get_clearsky(times)["ghi"].to_numpy()
    irr = facade_irradiance(times, ghi, small_building.latitude, small_building.longitude)
    noon, night, morning, afternoon = (irr.iloc[i] for i in range(4))
    assert noon["I_S"] > 2 * noon["I_N"] and noon["I_S"] > 300.0
    assert_allclose(night.to_numpy(), 0.0, rtol=0, atol=1e-9)
    assert morning["I_E"] > 2 * morning["I_W"]
    assert afternoon["I_W"] > 2 * afternoon["I_E"]
    assert (irr.to_numpy() >= 0).all()
    nan = facade_irradiance(times[:1], [np.nan], small_building.latitude, small_building.longitude)
    assert nan.isna().all(axis=None)


# --------------------------------------------------------------------------- prepare
def _quiet_prepare(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(*args, **kwargs)


def test_prepare_dataset(tmp_path, small_building):
    frame = make_measurements(small_building, start="2024-12-09 00:00", periods=3 * 7 * 1440)
    frame.iloc[3000:3300, 0] = np.nan  # 5-hour gap in T_A
    frame.loc["2024-12-14 10:00":"2024-12-14 11:59", "excitation"] = 1.0
    path = write(frame, tmp_path / "m.parquet", "timestamp")
    with pytest.warns(HvacfmuWarning, match="no excitation|only one week|season"):
        ds = prepare(path, small_building.save(tmp_path / "b.toml"), seed=3)
    assert isinstance(ds, Dataset)
    assert ds.step == 900.0 and ds.has_solar
    assert ds.sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    assert ds.source == str(path)
    cols = ["T_A", "T_B", "m_V1", "m_V2", "m_V3", "T_supply", "T_out", "ghi", "I_N", "I_E", "I_S", "I_W", "excitation"]
    assert list(ds.frame.columns) == cols
    assert len(ds.frame) == 3 * 7 * 96
    assert ds.frame.index.name == "time" and str(ds.frame.index.tz) == TZ
    assert (np.diff(ds.frame.index.asi8) == 900 * 10**9).all()
    assert_allclose(
        ds.frame["T_B"].iloc[:4], frame["T_B"].iloc[:60].to_numpy().reshape(4, 15).mean(axis=1), rtol=0, atol=1e-12
    )
    assert np.isnan(ds.frame["T_A"].iloc[200:220]).all()  # rows 3000..3300 of 1-min data = steps 200..219
    assert ds.frame["excitation"].sum() == 8
    # weeks: 12-09 (fall, midpoint 12-12), 12-16 and 12-23 (winter)
    assert [w.season for w in ds.weeks] == ["fall", "winter", "winter"]
    assert len(ds.train_weeks()) + len(ds.test_weeks()) == 3
    assert len(ds.test_weeks("winter")) == 1 and ds.test_weeks("fall") == ()
    for w in ds.weeks:
        assert len(ds.week_frame(w)) == 672
        assert isinstance(w, Week)
    assert list(np.unique(ds.season_of_row)) == ["fall", "winter"]
    assert ds.season_of_row[0] == "fall" and ds.season_of_row[96 * 7] == "winter"


def test_prepare_without_solar(tmp_path, small_building):
    frame = make_measurements(small_building, periods=1440, ghi=False)
    ds = _quiet_prepare(write(frame, tmp_path / "m.csv"), small_building)
    assert not ds.has_solar
    assert not any(c.startswith("I_") or c == "ghi" for c in ds.frame.columns)
    assert any("no solar" in w for w in ds.warnings)


def test_prepare_interpolate_limit(tmp_path, small_building):
    frame = make_measurements(small_building, periods=1440)
    frame.iloc[20:28, frame.columns.get_loc("T_A")] = np.nan
    path = write(frame, tmp_path / "m.csv")
    kept = _quiet_prepare(path, small_building).frame
    ds = _quiet_prepare(path, small_building, interpolate_limit=10)
    assert np.isnan(kept["T_A"].iloc[1])
    assert np.isfinite(ds.frame["T_A"].iloc[1])
    assert "interpolated 8 missing value(s) linearly in gaps of at most 10 min" in ds.warnings


# --------------------------------------------------------------------------- check
def test_check_report_contents(tmp_path, small_building):
    frame = make_measurements(small_building, start="2024-09-02", periods=15 * 1440)
    frame.iloc[3000:3300, 1] = np.nan
    frame.iloc[7 * 1440 : 10 * 1440, 0] = np.nan  # 3 of 7 days of week #1 without T_A
    frame.loc["2024-09-07 10:00":"2024-09-07 13:59", "excitation"] = 1.0
    frame.loc["2024-09-14 10:00":"2024-09-14 10:29", "excitation"] = 1.0
    frame["ghi"] = np.roll(frame["ghi"].to_numpy(), 67)  # the sun at solar noon (13:07 PDT), not 12:00
    report = check(write(frame, tmp_path / "m.csv"), small_building)
    assert report.ok and report.problems == []
    text = str(report)
    assert "Span: 2024-09-02T00:00:00-07:00 .. 2024-09-16T23:59:00-07:00" in text
    assert "Native resolution: 60 s" in text
    assert "T_B" in text and "1 gap(s), longest 5 h 00 min from 2024-09-04T02:00:00-07:00" in text
    assert "fall       2 weeks: 1 train, 1 test" in text
    assert "week #1 (2024-09-09, fall, test): only 57 % of its steps have every zone temperature" in text
    assert "Excitation periods: 2 (4 h 30 min in total)" in text
    assert "2024-09-07 Sat 10:00 .. 14:00" in text
    assert "Plausibility: 3 airflow column(s) against their box's m_min..m_max" in text and "nothing masked" in text
    assert "Clock: measured solar noon (ghi-weighted mean time)" in text
    # a note (the week with few complete steps) is not a clean bill, but needs no action
    assert text.rstrip().splitlines()[-1].startswith("OK with ") and report.exit_code == 0


def test_check_counts_masked_samples(tmp_path, small_building):
    frame = make_measurements(small_building, start="2024-09-02", periods=8 * 1440)
    frame.iloc[[10, 5000], frame.columns.get_loc("m_V3")] = 50.0
    frame.iloc[1440 : 4 * 1440, frame.columns.get_loc("T_B")] = 22.25
    report = check(write(frame, tmp_path / "m.csv"), small_building)
    text = str(report)
    assert report.ok
    assert "  2 sample(s) of m_V3 masked (airflow spike)" in text
    assert "  4320 sample(s) of T_B masked (stuck sensor)" in text


def test_check_reports_problems_instead_of_raising(tmp_path, small_building):
    frame = make_measurements(small_building, periods=3 * 1440)  # 3 days: no full week
    report = check(write(frame, tmp_path / "short.csv"), small_building)
    assert not report.ok and any("no complete week" in p for p in report.problems)
    bad = _set(frame, "T_A", 3, "oops").drop(columns=["T_supply"])
    report = check(write(bad, tmp_path / "bad.csv"), small_building)
    assert not report.ok and len(report.problems) == 2
    assert "NOT USABLE: 2 problems" in str(report)


def test_check_cli(tmp_path, small_building, cli):
    building = small_building.save(tmp_path / "b.toml")
    frame = make_measurements(small_building, periods=8 * 1440)
    frame["ghi"] = np.roll(frame["ghi"].to_numpy(), 67)  # the sun at solar noon (13:07 PDT), not 12:00
    good = write(frame, tmp_path / "good.csv")
    res = cli("check", good, "--building", building)  # in-process; the real subprocess: test_check_summary
    assert res.returncode == 0, res.stdout + res.stderr
    assert "OK with 3 notes (see above): the data can be used for fitting" in res.stdout and "Weeks: 1" in res.stdout
    # the week starts on Labor Day: one week cannot tell whether the building closes on it
    assert "2024-09-02 Labor Day); too few training workdays and Sundays" in res.stdout
    bad = _set(_set(frame, "T_A", 5, "abc"), "m_V1", 9, -1.0).drop(columns=["T_out"])
    res = cli("check", write(bad, tmp_path / "bad.csv"), "--building", building)  # in-process: no start-up
    assert res.returncode == 1
    assert "NOT USABLE: 3 problems" in res.stdout
    for part in ("missing required column 'T_out'", "'abc' at row 6", "negative airflow"):
        assert part in res.stdout
    assert "Traceback" not in res.stderr
    res = cli("check", good, "--building", tmp_path / "missing.toml")
    assert res.returncode == 1 and "does not exist" in res.stdout


def test_season_of_row_follows_week_season(small_building):
    index = pd.date_range(pd.Timestamp("2024-12-11 12:00", tz=TZ), periods=12 * 96, freq="15min", name="time")
    frame = pd.DataFrame({"T_A": 21.0}, index=index)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        ds = Dataset.from_frame(frame, small_building)
    (week,) = ds.weeks  # 12-12 .. 12-19, midpoint 12-15 12:00 -> fall
    assert week.season == "fall" and week.start == pd.Timestamp("2024-12-12", tz=TZ)
    rows = ds.season_of_row
    assert rows[index.get_loc(pd.Timestamp("2024-12-18 10:00", tz=TZ))] == "fall"  # calendar: winter, week: fall
    assert rows[index.get_loc(pd.Timestamp("2024-12-20 10:00", tz=TZ))] == "winter"  # outside every week
    assert (ds.week_of_row[index < week.start] == -1).all()
    assert (ds.week_of_row[(index >= week.start) & (index < week.end)] == 0).all()


def test_from_frame_rejects_irregular_frame(small_building):
    index = pd.date_range(pd.Timestamp("2024-09-02", tz=TZ), periods=10, freq="15min", name="time")
    frame = pd.DataFrame({"T_A": 21.0}, index=index.delete(4))
    with pytest.raises(
        DataError, match=r"regular with the model step 900 s; 1 spacing\(s\) differ, first after 2024-09-02T00:45"
    ):
        Dataset.from_frame(frame, small_building)
    with pytest.raises(DataError, match="tz-aware"):
        Dataset.from_frame(frame.tz_localize(None), small_building)


def test_empty_optional_column_is_ignored_with_warning(tmp_path, small_building):
    frame = make_measurements(small_building, periods=720).assign(ghi=np.nan)
    loaded, report = load_measurements(write(frame, tmp_path / "m.csv"), small_building)
    assert "ghi" not in loaded.columns
    assert any("optional column 'ghi' has no values" in w for w in report.warnings)


def test_bms_style_csv_semicolons_bom_and_padded_header(tmp_path, small_building):
    frame = make_measurements(small_building, periods=120)
    out = frame.reset_index(drop=True)
    out.insert(0, "time", [t.isoformat() for t in frame.index])
    out.columns = [f" {c} " for c in out.columns]
    text = out.to_csv(index=False, sep=";")
    (tmp_path / "bms.csv").write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    loaded, _ = load_measurements(tmp_path / "bms.csv", small_building)
    assert_allclose(loaded.to_numpy(), frame.to_numpy(), rtol=0, atol=1e-9)


def test_parquet_with_unnamed_datetime_index(tmp_path, small_building):
    frame = make_measurements(small_building, periods=120)
    frame.index.name = None
    frame.to_parquet(tmp_path / "m.parquet")
    loaded, _ = load_measurements(tmp_path / "m.parquet", small_building)
    assert loaded.index.equals(frame.index.rename("time"))


def test_missing_columns_hint_lists_unmapped_columns(tmp_path, small_building):
    frame = make_measurements(small_building, periods=120).rename(columns={"T_A": "RM-A ZN-T"})
    with pytest.raises(
        DataError,
        match=r"missing required column 'T_A' \(the file has 1 column\(s\) that map to nothing: 'RM-A ZN-T'.*\[columns\]",
    ):
        load_measurements(write(frame, tmp_path / "m.csv"), small_building)


def test_hand_made_bms_export():
    """tests/data/bms_export.csv: mapped names, degF and cfm, naive times, an unknown column, a gap."""
    from pathlib import Path

    here = Path(__file__).parent / "data"
    frame, report = load_measurements(here / "bms_export.csv", here / "bms_building.toml")
    assert list(frame.columns) == ["T_A", "T_B", "m_V1", "m_V2", "T_supply", "T_out", "ghi"]
    assert frame.index[0] == pd.Timestamp("2024-01-15 08:00", tz=TZ) and len(frame) == 5
    assert_allclose(frame["T_A"].iloc[[0, 4]], [20.0, 20.4], rtol=0, atol=1e-9)  # 68.0, 68.72 degF
    assert_allclose(frame["T_B"].iloc[:2], [22.0, 22.0], rtol=0, atol=1e-9)
    assert np.isnan(frame["T_B"].iloc[2]) and np.isnan(frame["ghi"].iloc[3])
    assert_allclose(frame["m_V1"].iloc[0], 500 * 0.3048**3 / 60 * 1.2, rtol=1e-12, atol=0)  # 0.2832 kg/s
    assert_allclose(frame["T_supply"].iloc[0], 13.0, rtol=0, atol=1e-9)
    assert_allclose(frame["T_out"].iloc[0], 5.0, rtol=0, atol=1e-9)
    assert report.unknown_columns == ("Trend Flags",)
    assert report.native_step == 60.0 and not report.has_offsets


# --------------------------------------------------------------------------- air handlers, Td, rh (issue 13 p.1)
def _two_ahu_dict(d):
    d["ahus"] = [{"name": "AHU1"}, {"name": "AHU2", "columns": {"T_supply": "AHU-2 SAT"}}]
    for v, a in zip(d["vavs"], ("AHU1", "AHU1", "AHU2")):
        v["ahu"] = a
    d["columns"] = {"Td_V1": "V1 DAT"}
    d["units"] = {"T_supply_*": "degF", "Td_*": "degF", "rh_*": "%"}
    return d


def test_air_handlers_discharge_and_reheat_columns(tmp_path, small_building_dict):
    building = building_from_dict(_two_ahu_dict(small_building_dict))
    f = make_measurements(building, periods=1440).drop(columns=["T_supply"])
    rng = np.random.default_rng(3)
    s1, s2 = 13.0 + rng.normal(0, 0.1, len(f)), 15.0 + rng.normal(0, 0.1, len(f))
    f["T_supply_AHU1"], f["AHU-2 SAT"] = s1 * 1.8 + 32, s2 * 1.8 + 32
    td = {v: 20.0 + 3 * j + rng.normal(0, 0.2, len(f)) for j, v in enumerate(building.vav_names)}
    f["V1 DAT"], f["Td_V2"], f["Td_V3"] = (td[v] * 1.8 + 32 for v in building.vav_names)
    f["rh_V1"] = np.linspace(0, 100, len(f))
    ds = prepare(write(f, tmp_path / "m.csv"), building)
    fr = ds.frame
    for c in ("T_supply", "T_supply_AHU1", "T_supply_AHU2", "Td_V1", "Td_V2", "Td_V3", "rh_V1"):
        assert c in fr.columns
    assert "rh_V2" not in fr.columns
    assert_allclose(fr["T_supply_AHU1"].mean(), s1.mean(), atol=1e-6)
    assert_allclose(fr["Td_V3"].mean(), td["V3"].mean(), atol=1e-6)
    assert fr["rh_V1"].min() >= 0 and fr["rh_V1"].max() <= 1 and fr["rh_V1"].iloc[-1] > 0.98
    # T_supply: per-step mean of the units weighted by their boxes' airflow
    w1 = fr["m_V1"] + fr["m_V2"]
    w2 = fr["m_V3"]
    expect = (w1 * fr["T_supply_AHU1"] + w2 * fr["T_supply_AHU2"]) / (w1 + w2)
    assert_allclose(fr["T_supply"], expect, rtol=0, atol=1e-9)
    assert any("airflow-weighted mean of T_supply_AHU1, T_supply_AHU2" in w for w in ds.warnings)


def test_single_air_handler_keeps_plain_T_supply(tmp_path, small_building_dict):
    d = small_building_dict
    d["ahus"] = [{"name": "AHU"}]
    for v in d["vavs"]:
        v["ahu"] = "AHU"
    building = building_from_dict(d)
    f = make_measurements(building, periods=1440)
    ds = prepare(write(f, tmp_path / "m.csv"), building)
    assert_allclose(ds.frame["T_supply_AHU"], ds.frame["T_supply"], rtol=0, atol=0)


def test_missing_unit_supply_column_is_named(tmp_path, small_building_dict):
    building = building_from_dict(_two_ahu_dict(small_building_dict))
    f = make_measurements(building, periods=1440).drop(columns=["T_supply"]).assign(T_supply_AHU1=57.0)
    with pytest.raises(DataError, match=r"missing required column 'AHU-2 SAT' \(mapped from T_supply_AHU2\)"):
        load_measurements(write(f, tmp_path / "m.csv"), building)


@pytest.mark.parametrize(
    "column, values, units, message",
    [
        ("rh_V1", 55.0, {}, r"column 'rh_V1': values reach 55 \(declared as a fraction 0\.\.1\); .* percent"),
        ("rh_V1", 1.5, {"rh_*": "1"}, r"column 'rh_V1': \d+ value\(s\) outside 0\.\.1"),
        ("Td_V2", 85.0, {}, r"column 'Td_V2': declared degC but the median is 85.*degF"),
    ],
)
def test_bad_discharge_and_reheat_columns(tmp_path, small_building_dict, column, values, units, message):
    small_building_dict["units"] = units
    building = building_from_dict(small_building_dict)
    f = make_measurements(building, periods=1440)
    f[column] = values
    with pytest.raises(DataError, match=message):
        load_measurements(write(f, tmp_path / "m.csv"), building)


# --------------------------------------------------------------------------- plausibility (issue 17 p.1)
def _quarter_hourly(building, days=10, start="2024-09-02 00:00"):
    return make_measurements(building, start=start, periods=96 * days, freq="15min")


def test_rare_airflow_spikes_are_masked_with_counts(tmp_path, small_building):
    f = make_measurements(small_building, periods=3000)
    spikes = np.arange(3, 3000, 1000)  # 3 rows = 0.1 %
    f.loc[f.index[spikes], "m_V1"] = 50.0
    frame, report = load_measurements(write(f, tmp_path / "m.csv"), small_building)
    assert np.isnan(frame["m_V1"].to_numpy()[spikes]).all()
    assert np.isfinite(frame["m_V1"].to_numpy()).sum() == 3000 - 3
    msg = next(w for w in report.warnings if "m_V1" in w)
    assert "3 value(s) (0.1 % of its samples) above 2 x m_max = 1.2 kg/s" in msg and "masked" in msg
    assert "50 at row 4" in msg


def test_outdoor_celsius_declared_as_fahrenheit_is_refused(tmp_path, small_building_dict):
    small_building_dict["units"] = {"T_out": "degF"}
    building = building_from_dict(small_building_dict)
    f = _quarter_hourly(building)
    with pytest.raises(
        DataError,
        match=r"column 'T_out': monthly mean outdoor temperature \(Sep -9\.4 °C; declared degF\) "
        r"is outside 0\.\.40 °C.*latitude 37\.875.*read as degC it would be 15\.0 °C.*look like degC",
    ):
        load_measurements(write(f, tmp_path / "m.csv"), building)


def test_outdoor_fahrenheit_declared_as_celsius_is_refused(tmp_path, small_building):
    f = _quarter_hourly(small_building)
    f["T_out"] = f["T_out"] * 1.8 + 32
    with pytest.raises(DataError, match=r"column 'T_out': declared degC but the median is 59.*look like degF"):
        load_measurements(write(f, tmp_path / "m.csv"), small_building)


def test_outdoor_envelope_accepts_real_climates():
    from hvacfmu.data.plausibility import outdoor_envelope

    # (latitude, warm half, monthly mean) of real stations: Yakutsk Jan, Chicago Jan, Berkeley Jul, Phoenix Jul
    for lat, warm, mean in [(62.0, False, -38.6), (41.9, False, -4.6), (37.9, True, 17.0), (33.4, True, 35.0)]:
        lo, hi = outdoor_envelope(lat, warm)
        assert lo <= mean <= hi


def test_stuck_sensor_is_flagged_and_masked(tmp_path, small_building):
    f = _quarter_hourly(small_building)
    f.iloc[96 * 2 : 96 * 5, f.columns.get_loc("T_B")] = 21.5
    frame, report = load_measurements(write(f, tmp_path / "m.csv"), small_building)
    msg = next(w for w in report.warnings if "T_B" in w)
    assert "stuck sensor" in msg and "21.5 for 3.0 days from row 193 (2024-09-04T00:00:00-07:00)" in msg
    assert "288 sample(s) masked" in msg
    assert np.isnan(frame["T_B"].to_numpy()[96 * 2 : 96 * 5]).all()
    assert np.isfinite(frame["T_A"].to_numpy()).all()


def test_check_refuses_a_sparse_box_naming_it(tmp_path, small_building):
    f = _quarter_hourly(small_building, days=9)
    keep = np.zeros(len(f), bool)
    keep[: int(0.066 * len(f))] = True
    f["m_V2"] = np.where(keep, f["m_V2"], np.nan)
    path = write(f, tmp_path / "m.csv")
    report = check(path, small_building)
    assert not report.ok
    assert any("column 'm_V2': a value in only 6.6 % of the model steps, below the 50 %" in p for p in report.problems)
    assert not any("m_V2" in w for w in report.warnings)
    with pytest.warns(HvacfmuWarning, match=r"column 'm_V2': a value in only 6\.6 %"):
        prepare(path, small_building)


@pytest.mark.parametrize("step", [0, -900, 7, float("nan")])
def test_bad_step_is_a_clear_error(tmp_path, small_building, step):
    path = write(make_measurements(small_building, periods=60), tmp_path / "m.csv")
    with pytest.raises(DataError, match=r"step .* must be a positive whole number of seconds dividing one hour"):
        prepare(path, small_building, step=step)
    report = check(path, small_building, step=step)
    assert not report.ok and "dividing one hour" in report.problems[0]


def test_unit_column_named_T_supply_is_that_units_not_the_primary(tmp_path, small_building_dict):
    d = _two_ahu_dict(small_building_dict)
    d["units"] = {}
    d["columns"] = {"T_supply_AHU1": "T_supply"}
    building = building_from_dict(d)
    f = make_measurements(building, periods=1440).assign(**{"AHU-2 SAT": 16.0})
    ds = prepare(write(f, tmp_path / "m.csv"), building)
    assert_allclose(ds.frame["T_supply_AHU1"], f["T_supply"].resample("15min").mean().to_numpy(), atol=1e-9)
    assert (ds.frame["T_supply"] > ds.frame["T_supply_AHU1"]).all()  # the weighted mean with AHU2 at 16 °C


# --------------------------------------------------------------------------- the emulator's BMS-like export (issue 13)
@pytest.fixture(scope="module")
def bms_export():
    """Three winter weeks as a real BMS exports them: °F, CFM, %, naive UTC, 15-minute trend log, faults."""
    from hvacfmu.emulator import cached_dataset

    return cached_dataset(
        weeks=3,
        seed=1,
        start="2025-12-01",
        hvac="reheat",
        units="us",
        clock="naive-utc",
        export_step=900,
        faults=("outages", "sparse_box", "stuck_sensor"),
    )


def test_bms_like_export_sparse_box_refused_stuck_sensor_masked(bms_export):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        report = check(bms_export.measurements, bms_export.building)
    b = report.dataset.building
    assert b.ahu_names == ("AHU1", "AHU2") and b.data_timezone == "UTC"
    frame = report.dataset.frame
    for c in ("T_supply_AHU1", "T_supply_AHU2", "Td_VAV_NW_1", "rh_VAV_NW_1"):
        assert c in frame.columns
    assert 10 < np.nanmedian(frame["T_supply_AHU1"]) < 20 and 0 <= np.nanmax(frame["rh_VAV_NW_1"]) <= 1
    assert not report.ok
    sparse = [p for p in report.problems if "a value in only" in p]
    assert sparse and all("%" in p and "below the 50 %" in p for p in sparse)
    cov = [float(p.split("a value in only ")[1].split(" %")[0]) for p in sparse]
    assert max(cov) < 10  # the ~6 % box is not inflated by interpolation between its rare samples
    assert any("stuck sensor" in w and "masked" in w for w in report.warnings)
    assert abs(report.clock.offset) < 0.5 and not any("clock:" in w for w in report.warnings)


def test_bms_like_export_naive_utc_without_declaration_looks_8_hours_late(tmp_path, bms_export):
    from hvacfmu.building import load_building

    d = load_building(bms_export.building).to_dict()
    d.pop("data_timezone")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        report = check(bms_export.measurements, building_from_dict(d))
    (msg,) = [w for w in report.warnings if "clock:" in w]
    assert "the data look 8 h late" in msg and "naive timestamps in UTC? use --timezone UTC" in msg


def test_discharge_colder_than_supply_is_flagged(tmp_path, small_building_dict):
    d = _two_ahu_dict(small_building_dict)
    d["units"], d["columns"] = {}, {}
    d["ahus"][0]["T_supply_max"] = 30.0
    building = building_from_dict(d)
    f = make_measurements(building, periods=1440).drop(columns=["T_supply"])
    f["T_supply_AHU1"], f["AHU-2 SAT"] = 13.0, 14.0
    f["Td_V1"] = 8.0  # colder than the supply air: impossible
    f["Td_V2"] = 40.0  # 10 K above the heating limit
    f["Td_V3"] = 25.0  # fine
    with pytest.warns(HvacfmuWarning) as record:
        prepare(write(f, tmp_path / "m.csv"), building)
    text = "\n".join(str(r.message) for r in record)
    assert "column 'Td_V1': discharge air below its unit's supply air T_supply_AHU1 - 3 K in 100 %" in text
    assert "column 'Td_V2': discharge air above T_supply_max = 30 °C of AHU1 + 5 K in 100 %" in text
    assert "Td_V3" not in text


def test_check_says_why_a_stuck_column_is_empty(tmp_path, small_building):
    f = _quarter_hourly(small_building, days=8)
    f["T_B"] = 22.0
    report = check(write(f, tmp_path / "m.csv"), small_building)
    assert not report.ok
    (msg,) = [p for p in report.problems if "'T_B'" in p]
    assert "no model step of 900 s has enough samples" in msg and "(768 sample(s) masked as stuck sensor" in msg
