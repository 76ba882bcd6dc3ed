"""The data's clock against the sun (issue 13 p.2): emulator data with their timestamps shifted by hand."""

from __future__ import annotations

import warnings

import pandas as pd
import pytest

from hvacfmu.building import building_from_dict, load_building
from hvacfmu.data import check
from hvacfmu.data.clock import clock_check
from hvacfmu.errors import HvacfmuWarning


@pytest.fixture(scope="module")
def emulated(short_paths):
    """Ten days of the emulator's data every 5 minutes (September, PDT = UTC-7) and its building (the first days
    of the 8-week dataset other fast tests generate: a 12-week one cost 4 CPU-s more on an empty cache)."""
    paths = short_paths
    raw = pd.read_parquet(paths.measurements)
    if "time" not in raw.columns:
        raw = raw.reset_index()
    raw["time"] = pd.to_datetime(raw["time"], utc=True, format="ISO8601")
    times = pd.DatetimeIndex(raw["time"])
    keep = (times < times[0] + pd.Timedelta(days=10)) & (times.minute % 5 == 0)  # 5-minute samples keep it quick
    return raw[keep].reset_index(drop=True), load_building(paths.building)


def _write(raw, path, clock, drop=()):
    """The data with naive timestamps on ``clock`` ('UTC' or the building's zone), as CSV."""
    out = raw.drop(columns=list(drop))
    times = pd.DatetimeIndex(out["time"]).tz_convert(clock).tz_localize(None)
    out["time"] = [t.isoformat() for t in times]
    out.to_csv(path, index=False)
    return path


def _clock_warnings(report):
    return [w for w in report.warnings if "clock:" in w]


def _check(path, building, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return check(path, building, **kw)


def test_naive_utc_read_as_local_looks_7_hours_late(tmp_path, emulated):
    raw, building = emulated
    path = _write(raw, tmp_path / "utc.csv", "UTC")
    report = _check(path, building)
    (msg,) = _clock_warnings(report)
    assert report.clock.method == "ghi" and abs(report.clock.offset - 7.0) < 0.3
    assert "the data look 7 h late: measured solar noon (ghi-weighted mean time) 20:1" in msg  # 20:10 here
    assert "naive timestamps in UTC? use --timezone UTC" in msg
    fixed = _check(path, building, timezone="UTC")
    assert not _clock_warnings(fixed) and abs(fixed.clock.offset) < 0.3


def test_naive_local_declared_utc_looks_7_hours_early(tmp_path, emulated):
    raw, building = emulated
    path = _write(raw, tmp_path / "local.csv", building.timezone)
    d = building.to_dict()
    d["data_timezone"] = "UTC"
    declared_utc = building_from_dict(d)
    (msg,) = _clock_warnings(_check(path, declared_utc))
    assert "the data look 7 h early" in msg and f"use --timezone {building.timezone}" in msg
    assert not _clock_warnings(_check(path, building))


def test_without_ghi_the_outdoor_temperature_cycle_shows_the_offset(tmp_path, emulated):
    raw, building = emulated
    path = _write(raw, tmp_path / "utc.csv", "UTC", drop=["ghi"])
    report = _check(path, building)
    assert report.clock.method == "T_out" and abs(report.clock.offset - 7.0) < 2.0
    (msg,) = _clock_warnings(report)
    assert "outdoor temperature lowest at" in msg and "use --timezone UTC" in msg
    fixed = _check(path, building, timezone="UTC")
    assert fixed.clock.method == "T_out" and not _clock_warnings(fixed)


def test_clock_offset_follows_a_hand_shift(emulated):
    """Shifting the index by k hours moves the measured solar noon by k hours (both signs)."""
    raw, building = emulated
    frame = raw.set_index(pd.DatetimeIndex(raw["time"]).tz_convert(building.timezone))[["ghi", "T_out"]]
    frame = frame.resample("15min").mean()
    base = clock_check(frame, building, 900).offset
    for k in (-3, 2, 5):
        shifted = frame.set_axis(frame.index + pd.Timedelta(hours=k))
        assert clock_check(shifted, building, 900).offset == pytest.approx(base + k, abs=0.05)
    assert abs(base) < 0.3


def test_check_cli_timezone_option(tmp_path, emulated, cli):
    """In-process (``cli``): the real ``check`` subprocess is tested in test_data and test_check_summary."""
    raw, building = emulated
    path = _write(raw, tmp_path / "utc.csv", "UTC")
    b = building.save(tmp_path / "b.toml")
    fixed = cli(
        "check", path, "-b", b, "--timezone", "UTC"
    )  # without the option: the 7 h warning (test_naive_utc_read_as_local...)
    assert "clock:" not in fixed.stdout and "Clock: measured solar noon" in fixed.stdout, fixed.stdout[-3000:]
    assert "Traceback" not in fixed.stderr
