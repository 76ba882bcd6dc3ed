"""The wind speed column (issue 13): units, plausibility, coverage, the emulator's wind and its effect.

- ``wind`` is an optional column in m/s, km/h, mph or knots, mapped through ``[columns]``/``[units]``;
  negative or above 60 m/s refused naming the column and rows; ``check`` reports its coverage;
- the emulator's wind comes from its own random stream: adding the column changes no other series;
- the ``wind_infiltration`` effect heats/cools its zone by ``ua · wind · (T_out − T_zone)`` and the
  steppable :class:`Plant` reproduces the simulation with it.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from hvacfmu.building import building_from_dict
from hvacfmu.data import check, load_measurements, prepare
from hvacfmu.data.units import from_si, normalize_unit, to_si
from hvacfmu.emulator import Plant, generate, make_truth, parse_effect, simulate
from hvacfmu.errors import DataError, HvacfmuWarning

TZ = "America/Los_Angeles"

ONE_ZONE = {
    "name": "one room",
    "latitude": 37.875,
    "longitude": -122.259,
    "timezone": TZ,
    "zones": [{"name": "A", "area": 100.0, "volume": 300.0, "adjacent": [], "facades": []}],
    "vavs": [{"name": "V1", "zone": "A", "m_min": 0.05, "m_max": 0.6}],
}


def _csv(tmp_path, wind, name="anemometer", n=8 * 96):
    """Eight days of 15-min data with a wind column ``name`` holding ``wind`` (cycled)."""
    t = pd.date_range("2025-01-06", periods=n, freq="15min", tz=TZ)
    hour = t.hour.to_numpy() + t.minute.to_numpy() / 60
    rng = np.random.default_rng(0)
    f = pd.DataFrame(
        {
            "time": t.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "T_A": 21.0 + 0.5 * np.sin(hour / 24 * 2 * np.pi) + rng.normal(0, 0.1, n),
            "m_V1": rng.uniform(0.05, 0.5, n),
            "T_supply": 14.0 + rng.normal(0, 0.3, n),
            "T_out": 10.0 + 4 * np.sin((hour - 9) / 24 * 2 * np.pi),
            name: np.resize(np.asarray(wind, float), n),
        }
    )
    p = tmp_path / "data.csv"
    f.to_csv(p, index=False)
    return p


def _building(unit=None, name="anemometer"):
    d = dict(ONE_ZONE)
    d["columns"] = {"wind": name}
    if unit is not None:
        d["units"] = {"wind": unit}
    return building_from_dict(d)


@pytest.mark.parametrize(
    "unit, canonical, one_in_si",
    [
        ("m/s", "m/s", 1.0),
        ("km/h", "km/h", 1 / 3.6),
        ("kph", "km/h", 1 / 3.6),
        ("mph", "mph", 0.44704),
        ("kn", "kn", 1852 / 3600),
        ("kt", "kn", 1852 / 3600),
        ("knots", "kn", 1852 / 3600),
    ],
)
def test_wind_units_convert_to_metres_per_second(unit, canonical, one_in_si):
    assert normalize_unit(unit, "speed") == canonical
    assert_allclose(to_si([1.0], canonical), [one_in_si], rtol=1e-12, atol=0)
    assert_allclose(from_si(to_si([7.5], canonical), canonical), [7.5], rtol=1e-12, atol=0)


def test_wind_column_is_mapped_converted_and_resampled_as_a_mean(tmp_path):
    p = _csv(tmp_path, [10.0, 20.0])  # mph, alternating every 15 minutes
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        frame, report = load_measurements(p, _building("mph"))
        assert report.units["wind"] == "mph"
        assert_allclose(frame["wind"].to_numpy()[:2], [4.4704, 8.9408], rtol=0, atol=1e-9)  # [m/s]
        ds = prepare(p, _building("mph"), step=1800)
    assert "wind" in ds.frame.columns
    assert_allclose(ds.frame["wind"].to_numpy()[:5], 6.7056, rtol=0, atol=1e-9)  # mean of the two samples [m/s]


def test_a_temperature_unit_for_wind_is_refused_naming_the_column(tmp_path):
    p = _csv(tmp_path, [3.0])
    with pytest.raises(DataError, match=r"'anemometer' \(wind\).*not a speed unit"):
        load_measurements(p, _building("degC"))


@pytest.mark.parametrize(
    "values, unit, match",
    [
        ([3.0, -2.0, 4.0], "m/s", r"'anemometer' \(wind\): \d+ negative wind speed value\(s\).*row"),
        ([3.0, 250.0, 4.0], "km/h", r"'anemometer' \(wind\): \d+ value\(s\) above 60 m/s.*km/h.*row"),
        ([3.0, 270.0, 4.0], "m/s", r"above 60 m/s.*direction in degrees"),
    ],
)
def test_implausible_wind_is_refused_naming_column_and_rows(tmp_path, values, unit, match):
    p = _csv(tmp_path, values)
    with pytest.raises(DataError, match=match):
        load_measurements(p, _building(unit))
    report = check(p, _building(unit))
    assert not report.ok and any("anemometer" in q for q in report.problems)


def test_slightly_negative_wind_is_noise_set_to_zero(tmp_path):
    p = _csv(tmp_path, [3.0, -0.1, 4.0])
    frame, report = load_measurements(p, _building("m/s"))
    assert float(frame["wind"].min()) == 0.0
    assert any("anemometer" in w and "set to 0" in w for w in report.warnings)


def test_check_reports_wind_coverage_and_its_plausibility_rule(tmp_path):
    values = np.full(8 * 96, 3.0)
    values[: 8 * 96 // 3] = np.nan  # a third missing
    p = _csv(tmp_path, values)
    text = str(check(p, _building("kn")))
    assert "wind speed against 0..60 m/s (kn in the file)" in text
    cov = [line for line in text.splitlines() if "gap(s)" in line and line.endswith(": wind")]
    assert cov and cov[0].strip().startswith("66."), text


# ------------------------------------------------------------------ emulator
def test_emulator_wind_column_changes_no_other_series(tmp_path):
    plain = generate(tmp_path / "plain", weeks=1, seed=4, export_step=900)
    windy = generate(tmp_path / "windy", weeks=1, seed=4, export_step=900, wind="kn", units="us")
    us = generate(tmp_path / "us", weeks=1, seed=4, export_step=900, units="us")
    a, b, c = (pd.read_parquet(x.measurements) for x in (plain, windy, us))
    assert "wind" not in a.columns
    pd.testing.assert_frame_equal(b.drop(columns="wind"), c)
    assert 'wind = "kn"' in windy.building.read_text()
    ds = prepare(windy.measurements, windy.building)
    w = ds.frame["wind"].to_numpy()
    assert np.nanmin(w) >= 0 and 1.0 < np.nanmean(w) < 8.0  # [m/s] a plausible site mean
    # in SI the same speeds (knots written to 0.1 kn)
    si = generate(tmp_path / "si", weeks=1, seed=4, export_step=900, wind="m/s")
    w_si = prepare(si.measurements, si.building).frame["wind"].to_numpy()
    assert_allclose(w, w_si, rtol=0, atol=0.05 * 1852 / 3600 + 0.05)  # [m/s] both quantised to 0.1 of their unit


def test_wind_infiltration_effect_parses_and_needs_a_positive_ua():
    assert parse_effect("wind_infiltration:zone=NW,ua=60") == {"name": "wind_infiltration", "zone": "NW", "ua": 60.0}
    from hvacfmu.emulator.effects import EmulatorError

    with pytest.raises(EmulatorError, match="ua must be > 0"):
        make_truth(1, 0, ["wind_infiltration:ua=-1"])


def test_wind_infiltration_effect_follows_wind_and_outdoor_difference_and_plant_reproduces_it():
    truth = make_truth(1, 2, ["wind_infiltration:zone=W,ua=200"], start="2025-12-01")
    sim = simulate(truth)
    base = simulate(make_truth(1, 2, [], start="2025-12-01"))
    i = list(truth["zones"]).index("W")
    d = sim["T_zone"][:, i] - base["T_zone"][:, i]
    drive = sim["wind"] * (sim["T_out"] - base["T_zone"][:, i])
    assert np.corrcoef(d, drive)[0, 1] > 0.3
    assert d.mean() < -0.2  # [K] December: the leak cools the zone
    others = [k for k in range(len(truth["zones"])) if k != i]
    assert np.abs(d).mean() > 3 * np.abs(sim["T_zone"][:, others] - base["T_zone"][:, others]).mean()
    plant = Plant.from_truth(truth)
    x = sim["x0"]
    T = []
    for k in range(1500):
        T.append(plant.zone_temperatures(x))
        x, _ = plant.advance(
            x, 60.0 * k, 60.0, sim["m_vav"][k], sim["T_out"][k], sim["T_supply"][k], sim["I"][k],
            reheat=sim["reheat_command"][k],
        )  # fmt: skip
    assert_allclose(np.array(T), sim["T_zone"][:1500], rtol=0, atol=1e-9)  # [K]


@pytest.mark.slow
def test_cli_generate_writes_the_wind_column_and_check_reads_it(tmp_path):
    import subprocess
    import sys

    out = tmp_path / "g"
    cmd = [sys.executable, "-m", "hvacfmu", "generate", str(out), "--weeks", "1", "--export-step", "900"]
    r = subprocess.run([*cmd, "--wind", "kn"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "wind" in pd.read_parquet(out / "measurements.parquet").columns
    r = subprocess.run(
        [sys.executable, "-m", "hvacfmu", "check", str(out / "measurements.parquet"), "-b", str(out / "building.toml")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert "wind speed against 0..60 m/s (kn in the file)" in r.stdout, r.stdout + r.stderr
    bad = subprocess.run([*cmd, "--wind", "furlongs"], capture_output=True, text=True, timeout=300)
    assert bad.returncode != 0 and "--wind" in bad.stderr
