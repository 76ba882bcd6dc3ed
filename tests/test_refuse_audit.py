"""Audit of the bad inputs of issue 17 against README "What gets refused": the rows that had no test of their own.

Each case is one bad input and the message the user sees (the README row names the same message).
Rows tested elsewhere: building-file types and values (test_building.py), data columns, units,
spikes, stuck sensors, steps, coverage, clock (test_data.py, test_clock.py, test_refuse_units.py),
model files (test_properties_models.py), FMU inputs (test_properties_fmu.py), implausible fits
(test_datadriven.py, test_delivered_heat.py), controller limits (test_mpc.py).
"""

from __future__ import annotations

import copy

import numpy as np
import pandas as pd
import pytest
from test_properties import BUILDING, base_frame, write

from hvacfmu.building import building_from_dict
from hvacfmu.data import check
from hvacfmu.errors import BuildingError


def test_unknown_box_key_is_refused_naming_the_known_keys():
    d = copy.deepcopy(BUILDING)
    d["vavs"][0]["m_design"] = 0.5  # a misspelt or invented key would otherwise be ignored silently
    with pytest.raises(BuildingError, match=r"vavs\[0\] \(V1\): unknown key\(s\) \['m_design'\] \(known: ahu, m_max"):
        building_from_dict(d)


def test_column_answering_rarely_at_irregular_times_is_flagged_and_refused(tmp_path):
    f = base_frame(days=8)
    rng = np.random.default_rng(1)
    keep = np.zeros(len(f), bool)
    keep[rng.choice(len(f), len(f) // 12, replace=False)] = True  # a box controller missing most trend polls
    f.loc[~keep, "m_V2"] = np.nan
    report = check(write(f, tmp_path / "m.csv", "offset"), building_from_dict(copy.deepcopy(BUILDING)))
    (flag,) = [w for w in report.warnings if "'m_V2'" in w]
    assert "values in only 8.3 % of the rows, at irregular times" in flag and "not interpolated" in flag
    assert not report.ok
    (problem,) = [p for p in report.problems if "'m_V2'" in p]
    assert "a value in only 8.3 % of the model steps, below the 50 %" in problem


def test_cli_refuses_a_model_file_for_other_zones_without_a_traceback(tmp_path, short_paths, cli):
    """The evaluate command meets a model fitted elsewhere: exit 2, both zone lists, no KeyError (in-process:
    an exception escaping ``main`` fails the test; the real ``evaluate`` subprocess: test_evaluation_gaps)."""
    import json

    model = _linear_model(boxes=("B1", "B2"), zones=("X1", "X2"))
    path = tmp_path / "other.json"
    path.write_text(json.dumps(model.to_dict()))
    r = cli("evaluate", short_paths.measurements, "-b", short_paths.building, "-m", path)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr[-2000:]
    assert "Model zones: ['X1', 'X2']" in r.stderr and "data zones: ['NW'" in r.stderr, r.stderr[-2000:]


def test_data_after_the_last_whole_week_are_said_with_the_clock_change_that_cost_them(tmp_path):
    """4 x 168 h from a Monday across the autumn clock change end an hour short of the 4th week, which no stage uses:
    `check` says how much is left out and why (it said "Weeks: 3" and nothing else; fleet_sweep_s10.md, b004)."""
    f = base_frame(start="2025-10-20 00:00", days=28)  # 2688 steps of 15 min: the clock change on 2 Nov
    report = check(write(f, tmp_path / "m.csv", "offset"), building_from_dict(copy.deepcopy(BUILDING)))
    (line,) = [x for x in str(report).splitlines() if x.startswith("Weeks:")]
    assert line == (
        "Weeks: 3 from 2025-10-20; the last 6 d 23 h of data, from 2025-11-10T00:00:00-08:00, are not a whole week and "
        "are not used (1 h 00 min short of one: the week of 2025-10-27 holds the autumn clock change's extra hour)"
    ), line
    # whole weeks leave nothing to say; across the spring change the data run an hour past the last week's end
    for start, tail in (("2025-04-07", ""), ("2025-03-03", "; the last 1 h 00 min of data, from 2025-03-17")):
        f = base_frame(start=f"{start} 00:00", days=14)
        report = check(write(f, tmp_path / "w.csv", "offset"), building_from_dict(copy.deepcopy(BUILDING)))
        (line,) = [x for x in str(report).splitlines() if x.startswith("Weeks:")]
        assert line.startswith(f"Weeks: 2 from {start}{tail}") and ("not used" in line) == bool(tail), line


# --------------------------------------------------------------------------- audit of session 10: BMS-export mistakes
def _check(frame, tmp_path, mutate_building=None, name="m.csv"):
    d = copy.deepcopy(BUILDING)
    if mutate_building is not None:
        mutate_building(d)
    return check(write(frame, tmp_path / name, "offset"), building_from_dict(d))


def _one(lines, fragment):
    found = [x for x in lines if fragment in x]
    assert len(found) == 1, (fragment, lines)
    return found[0]


def test_a_column_name_repeated_in_the_header_is_refused(tmp_path):
    f = base_frame(days=8)
    path = write(f, tmp_path / "m.csv", "offset")
    lines = path.read_text().splitlines()
    lines[0] = lines[0].replace("T_B", "T_A")  # the export wrote two columns 'T_A'; pandas would rename one 'T_A.1'
    path.write_text("\n".join(lines) + "\n")
    report = check(path, building_from_dict(copy.deepcopy(BUILDING)))
    assert not report.ok
    assert "column 'T_A' appears 2 times in the header (columns 2, 3)" in _one(report.problems, "appears 2 times")


def test_decimal_commas_are_named_with_their_fix(tmp_path):
    f = base_frame(days=8)
    path = tmp_path / "m.csv"
    out = f.copy()
    out.index = [t.isoformat() for t in out.index]
    out.index.name = "time"
    out.to_csv(path, sep=";", decimal=",")
    report = check(path, building_from_dict(copy.deepcopy(BUILDING)))
    msg = _one(report.problems, "'T_A'")
    assert "written with a comma, e.g. '21," in msg and ": a decimal comma; numbers must be written plainly" in msg
    assert "with '.' as the decimal separator" in msg
    assert not any("every row is empty" in p for p in report.problems)


def test_zone_temperature_dropouts_to_zero_are_masked_and_many_refused(tmp_path):
    f = base_frame(days=8)
    f.iloc[[50, 300, 301, 500], f.columns.get_loc("T_A")] = 0.0  # a BMS writing 0 while the controller is offline
    report = _check(f, tmp_path)
    assert report.ok
    msg = _one(report.warnings, "'T_A'")
    assert "4 value(s)" in msg and "more than 12 K away from the median of the surrounding 12 h" in msg
    assert "masked as missing: 0 at row 51 (2025-03-03T12:30:00-08:00)" in msg
    f.iloc[::50, f.columns.get_loc("T_A")] = 0.0  # 2 % of the rows: the column or its mapping is wrong
    report = _check(f, tmp_path)
    assert not report.ok and "more than the 1 % that are masked" in _one(report.problems, "'T_A'")


def test_a_dead_ghi_sensor_is_refused(tmp_path):
    f = base_frame(days=8)
    f["ghi"] = 0.0
    report = _check(f, tmp_path)
    msg = _one(report.problems, "'ghi'")
    assert "the largest value over 7 day(s) is 0 W/m²" in msg and "a dead or disconnected sensor" in msg


def test_ghi_as_energy_per_interval_is_flagged(tmp_path):
    f = base_frame(days=8)
    f["ghi"] = f["ghi"] / 4  # Wh/m² per 15 min declared as W/m²
    report = _check(f, tmp_path)
    msg = _one(report.warnings, "'ghi'")
    assert "only 2" in msg and "% of the clear-sky peak" in msg and "Wh/m² per 15 min" in msg
    assert report.exit_code == 3
    assert _check(base_frame(days=8), tmp_path).exit_code == 0


def test_a_zone_sensor_exported_twice_is_refused(tmp_path):
    f = base_frame(days=8)
    f["T_B"] = f["T_A"]
    report = _check(f, tmp_path)
    msg = _one(report.problems, "hold the same value")
    assert "columns 'T_A' (T_A) and 'T_B' (T_B) hold the same value in 100.0 % of the 768 rows" in msg


def _one_unit(d):
    d["ahus"] = [{"name": "AHU1"}]
    for v in d["vavs"]:
        v["ahu"] = "AHU1"


def test_the_supply_air_mean_beside_the_only_units_own_column_is_not_a_copy(tmp_path):
    """An EnergyPlus export of a floor with one air handler writes T_supply (the units' airflow-weighted mean) and
    T_supply_<ahu>, equal on every row: that was refused as one point exported twice (medium office, primary school,
    large office exports). With two units, the mean equal to one of them still is."""
    f = base_frame(days=8).drop(columns=["T_supply_AHU2"])
    f["T_supply"] = f["T_supply_AHU1"]
    report = _check(f, tmp_path, _one_unit)
    assert report.ok and not [p for p in report.problems if "hold the same value" in p], report.problems
    f = base_frame(days=8)
    f["T_supply"] = f["T_supply_AHU1"]
    msg = _one(_check(f, tmp_path).problems, "hold the same value")
    assert "'T_supply_AHU1'" in msg and "'T_supply'" in msg


def test_outdoor_air_that_behaves_like_indoor_air_is_flagged(tmp_path):
    f = base_frame(days=8)
    f["T_out"] = f["T_B"] + np.random.default_rng(2).normal(0, 0.1, len(f))
    report = _check(f, tmp_path)
    assert "it behaves like indoor air" in _one(report.warnings, "'T_out'") and report.exit_code == 3


def test_supply_air_that_is_room_air_is_flagged(tmp_path):
    f = base_frame(days=8)
    f["T_supply_AHU1"] = f["T_A"] + 0.5  # the return air sensor mapped as supply air
    report = _check(f, tmp_path)
    msg = _one(report.warnings, "'T_supply_AHU1'")
    assert "within 1.5 K of the zones' mean temperature in 100 %" in msg and report.exit_code == 3


def test_an_inverted_excitation_flag_is_flagged(tmp_path):
    f = base_frame(days=8)
    f["excitation"] = 1.0
    f.iloc[:32, f.columns.get_loc("excitation")] = 0.0
    report = _check(f, tmp_path)
    assert "the flag looks inverted" in _one(report.warnings, "'excitation'") and report.exit_code == 3


def test_discharge_air_that_does_not_follow_its_reheat_is_flagged(tmp_path):
    f = base_frame(days=8)
    rh = np.where(np.arange(len(f)) % 2 == 0, 0.0, 0.8)
    f["rh_V2"] = rh
    f["Td_V2"] = f["T_supply_AHU2"] + np.where(rh > 0, 0.0, 12.0)  # warm when its reheat is off: another box's
    report = _check(f, tmp_path)
    notes = [w for w in report.warnings if "'Td_V2'" in w]
    assert len(notes) == 2 and all("does not follow its own reheat" in n for n in notes)
    assert report.exit_code == 3


def test_boxes_discharging_another_units_air_are_flagged(tmp_path):
    f = base_frame(days=8)
    hours = np.arange(len(f)) / 4
    f["T_supply_AHU2"] += 1.5 * np.sin(2 * np.pi * hours / 24)  # a supply reset moving with the day
    f["Td_V1"] = f["T_supply_AHU2"] + 0.8 + np.random.default_rng(3).normal(0, 0.05, len(f))  # V1 names AHU1
    report = _check(f, tmp_path)
    msg = _one(report.warnings, "another air handler")
    assert "(spread of Td_<vav> minus each supply column: V1: T_supply_AHU1 1.5 K, T_supply_AHU2 0.049 K)" in msg, msg
    assert report.exit_code == 3
    f["Td_V1"] = f["T_supply_AHU1"] + 1.0 + np.random.default_rng(3).normal(0, 0.05, len(f))  # duct gain: fine
    assert not [w for w in _check(f, tmp_path).warnings if "another air handler" in w]


def test_reheat_as_a_fraction_declared_percent_is_flagged(tmp_path):
    def percent(d):
        d["units"] = {"rh_*": "%"}

    report = _check(base_frame(days=8), tmp_path, percent)
    assert "the data look like a fraction 0..1" in _one(report.warnings, "'rh_V2'") and report.exit_code == 3


def test_airflow_in_cubic_metres_per_hour_is_read():
    from hvacfmu.data.units import from_si, normalize_unit, to_si

    assert normalize_unit("m³/h", "airflow") == "m3/h"
    assert float(to_si(3600.0, "m3/h")) == pytest.approx(1.2) and float(from_si(1.2, "m3/h")) == pytest.approx(3600)


def test_stuck_sensor_runs_ignore_rows_with_unusable_times(tmp_path):
    f = base_frame(days=8)
    f.iloc[100, f.columns.get_loc("T_A")] = f["T_A"].iloc[99]  # a value repeated on a row without a usable time
    path = write(f, tmp_path / "m.csv", "offset")
    lines = path.read_text().splitlines()
    lines[101] = "not a time" + lines[101][lines[101].index(",") :]
    path.write_text("\n".join(lines) + "\n")
    report = check(path, building_from_dict(copy.deepcopy(BUILDING)))
    assert not report.ok and not any("stuck" in w for w in report.warnings)


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda d: d.update(longitude=122.259), r"longitude 122\.259° is 7\.8 h of sun away from the time zone "),
        (lambda d: d.update(longitude=122.259), r"is the sign wrong \(-122\.259: west of Greenwich is negative\)"),
        (lambda d: d.update(latitude=-122.259 / 3.3, longitude=37.875), r"longitude 37\.875° is 9\.5 h of sun"),
        (lambda d: d.update(latitude=-37.875), r"latitude -37\.875° is in the southern hemisphere, but the time zone"),
        (
            lambda d: d["zones"][0].update(area=1076.4),  # ft2 beside a volume in m3
            r"zone A: volume / area = 300 m3 / 1076\.4 m2 = 0\.28 m of ceiling height, below 1\.5 m: is the area in ft2",
        ),
    ],
)
def test_building_file_slips_are_refused(mutate, message):
    d = copy.deepcopy(BUILDING)
    mutate(d)
    with pytest.raises(BuildingError, match=message):
        building_from_dict(d)


def test_building_file_places_that_are_legitimate_pass():
    for lat, lon, tz in [
        (39.47, 75.99, "Asia/Shanghai"),  # Kashgar on Beijing time: 44 degrees from the zone's meridian
        (42.88, -8.54, "Europe/Madrid"),  # Galicia on Central European time
        (-33.87, 151.21, "Australia/Sydney"),
        (-32.89, -68.83, "America/Argentina/Mendoza"),
        (64.18, -51.72, "America/Nuuk"),
        (1.35, 103.82, "Asia/Singapore"),
        (-1.29, 36.82, "Africa/Nairobi"),
        (51.5, 100.0, "UTC"),
    ]:
        d = copy.deepcopy(BUILDING)
        d.update(latitude=lat, longitude=lon, timezone=tz)
        building_from_dict(d)


def test_areas_in_ft2_with_volumes_in_ft3_are_flagged(tmp_path):
    def feet(d):
        for z in d["zones"]:
            z.update(area=z["area"] * 10.7639, volume=z["volume"] * 35.3147)

    report = _check(base_frame(days=8), tmp_path, feet)
    msg = _one(report.warnings, "ceiling height")
    assert "(A 9.84 m, B 9.84 m)" in msg and "if the areas are ft2 and the volumes ft3" in msg


def _linear_model(boxes=("V1", "V2"), meta=None, zones=("A", "B")):
    from hvacfmu.models.linear import LinearZoneModel

    return LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=zones,
        measured_zones=zones,
        output_weights=np.eye(2),
        vavs=boxes,
        input_map=np.eye(2),
        disturbances=("T_out",),
        A=0.9 * np.eye(2),
        B=-0.1 * np.eye(2),
        C=[[0.02], [0.02]],
        gains={"fall": np.full((672, 2), 0.4)},
        meta=meta or {},
    )


def test_a_model_meets_a_building_file_it_was_not_fitted_with():
    from hvacfmu.models.base import building_mismatch

    b = building_from_dict(copy.deepcopy(BUILDING))
    sha = b.sha256 or __import__("hashlib").sha256(b.to_toml().encode()).hexdigest()
    assert building_mismatch(_linear_model(meta={"building": b.name, "building_sha256": sha}), b) == ([], [])
    problems, notes = building_mismatch(_linear_model(meta={"building": "other floor", "building_sha256": sha}), b)
    assert not problems and "was fitted on building 'other floor', not on 'two rooms'" in notes[0]
    _, notes = building_mismatch(_linear_model(meta={"building": b.name, "building_sha256": "0" * 64}), b)
    assert "fitted with another version of the building file of 'two rooms'" in notes[0]
    problems, _ = building_mismatch(_linear_model(boxes=("X1", "X2")), b)
    assert "box(es) ['X1', 'X2'] are not declared in building 'two rooms'" in problems[0]


def test_export_refuses_a_building_file_without_the_models_boxes(tmp_path):
    import json

    from hvacfmu.errors import FMUError
    from hvacfmu.fmu import export_file

    path = tmp_path / "other.json"
    path.write_text(json.dumps(_linear_model(boxes=("X1", "X2")).to_dict()))
    with pytest.raises(FMUError, match=r"cannot export .*other\.json with building 'two rooms': .*\['X1', 'X2'\]"):
        export_file(path, tmp_path / "x.fmu", building=building_from_dict(copy.deepcopy(BUILDING)))


def test_a_setpoint_exported_as_the_zone_temperature_is_flagged(tmp_path):
    f = base_frame(days=8)
    hour = pd.DatetimeIndex(f.index).hour
    f["T_A"] = np.where((hour >= 7) & (hour < 19), 22.0, 18.0)
    report = _check(f, tmp_path)
    msg = _one(report.warnings, "'T_A'")
    assert "changes only 2 time(s) on a median day" in msg and "is it a setpoint exported as the zone" in msg
    assert report.exit_code == 3


def test_an_airflow_column_that_never_moves_is_flagged(tmp_path):
    f = base_frame(days=8)
    f["m_V2"] = 0.0
    report = _check(f, tmp_path)
    msg = _one(report.warnings, "'m_V2'")
    assert "reads 0 kg/s in every one of its 768 samples over 8.0 days" in msg and report.exit_code == 3

    # a constant-volume box (m_min = m_max: the 90.1 hospital's lab) delivering its one flow is what it should be
    def constant_volume(d):
        d["vavs"][1]["m_min"] = d["vavs"][1]["m_max"] = 0.4

    f["m_V2"] = 0.4
    report = _check(f, tmp_path, constant_volume)
    assert not [w for w in report.warnings if "'m_V2'" in w], report.warnings
    # a box held at its maximum all along (the large office's data centre): said, but nothing to fix
    f["m_V2"] = 0.4
    report = _check(f, tmp_path)
    msg = _one(report.warnings, "'m_V2'")
    assert "box V2 delivers its m_max = 0.4 kg/s in every one of its 768 samples" in msg, msg
    assert "cannot learn its effect" in msg and report.exit_code == 0


def test_a_vav_box_at_its_minimum_all_record_is_a_note_not_a_fault(tmp_path):
    # fourth EnergyPlus round: the 90.1 outpatient clinic's exam-room boxes sat at m_min from January to March (they
    # only reheat); `check` called that a dead sensor to fix before fitting and returned 3
    f = base_frame(days=8)
    f["m_V2"] = 0.03  # box V2: m_min 0.03, m_max 0.4
    report = _check(f, tmp_path)
    msg = _one(report.warnings, "'m_V2'")
    assert "reads its minimum m_min = 0.03 kg/s in every one of its 768 samples" in msg and "Td_V2" in msg
    assert "dead flow sensor" not in msg and report.exit_code == 0


@pytest.mark.parametrize(
    "times, hint",
    [
        (
            lambda t: [f"{(x.tz_localize(None) - pd.Timestamp('1899-12-30')) / pd.Timedelta(days=1):.6f}" for x in t],
            "numbers like Excel serial dates",
        ),
        (lambda t: [str(int(x.timestamp())) for x in t], "numbers like Unix times"),
        (lambda t: [x.strftime("%d/%m/%Y %H:%M") for x in t], "dates like 03/04/2025 are ambiguous"),
    ],
)
def test_times_that_are_not_iso_name_what_they_look_like(tmp_path, times, hint):
    f = base_frame(days=8)
    path = write(f, tmp_path / "m.csv", "offset")
    out = pd.read_csv(path, dtype={"time": str})
    out["time"] = times(pd.DatetimeIndex(f.index))
    out.to_csv(path, index=False)
    report = check(path, building_from_dict(copy.deepcopy(BUILDING)))
    assert hint in _one(report.problems, "not ISO 8601 times")


def test_thousands_separators_are_named(tmp_path):
    f = base_frame(days=8)
    path = write(f, tmp_path / "m.csv", "offset")
    out = pd.read_csv(path, dtype={"time": str})
    out["m_V1"] = [f"{1000 + x:,.0f}" if i % 10 == 0 else f"{x:.0f}" for i, x in enumerate(500 * out["m_V1"])]
    out.to_csv(path, index=False)
    report = check(path, building_from_dict(copy.deepcopy(BUILDING)))
    assert ": a thousands separator (or a decimal comma); numbers must be" in _one(report.problems, "with a comma")


def test_stray_rows_from_a_logger_clock_reset_are_refused(tmp_path):
    f = base_frame(days=8)
    path = write(f, tmp_path / "m.csv", "offset")
    out = pd.read_csv(path, dtype={"time": str})
    out.loc[:2, "time"] = ["1970-01-01T00:00:00Z", "1970-01-01T00:15:00Z", "1970-01-01T00:30:00Z"]
    out.to_csv(path, index=False)
    report = check(path, building_from_dict(copy.deepcopy(BUILDING)))
    msg = _one(report.problems, "lie ")
    assert "3 row(s) 1-3 (1969-12-31T16:00:00-08:00 .. 1969-12-31T16:30:00-08:00) lie 20150 days before" in msg
    assert "a logger clock reset or a wrong year?" in msg
    f2 = pd.concat([base_frame(days=8), base_frame(start="2025-07-07 00:00", days=8)])  # two campaigns: fine
    assert not [
        p
        for p in check(write(f2, tmp_path / "two.csv", "offset"), building_from_dict(copy.deepcopy(BUILDING))).problems
        if "lie " in p
    ]


def test_dot_thousands_separators_among_whole_numbers_are_refused(tmp_path):
    f = base_frame(days=8)
    f["m_V1"] = (2 * f["m_V1"] / 1.2 / 0.000471947).round(0)  # cfm, whole numbers; 1,000 and more written '1.006'
    out = f.copy()
    out["m_V1"] = [f"{x:,.0f}".replace(",", ".") for x in out["m_V1"]]
    out.index = [t.isoformat() for t in out.index]
    out.index.name = "time"
    path = tmp_path / "m.csv"
    out.to_csv(path, sep=";")
    d = copy.deepcopy(BUILDING)
    d["units"] = {"m_*": "cfm"}
    d["vavs"][0]["m_max"] = 0.8
    report = check(path, building_from_dict(d))
    msg = _one(report.problems, "'m_V1'")
    assert "among whole numbers: a '.' thousands separator ('1.006' = 1006)" in msg, msg


def test_a_stretch_logged_at_a_coarser_interval_is_named(tmp_path):
    f = base_frame(days=8)
    f.index = pd.date_range(f.index[0], periods=len(f), freq="5min", name="time")  # a 5-minute export ...
    hours = (f.index - f.index[0]) / pd.Timedelta(hours=1)
    coarse = (hours >= 10) & (hours < 30) & (f.index.minute % 15 != 0)  # ... logging every 15 min for 20 h
    report = _check(f[~coarse], tmp_path)
    msg = _one(report.warnings, "apart")
    assert "are 900 s apart, not the file's 300 s, 0.8 days in all" in msg and "stay missing" in msg
    assert not [w for w in _check(f, tmp_path).warnings if "apart" in w]


def test_error_codes_are_named_as_such(tmp_path):
    f = base_frame(days=8)
    f.iloc[10:13, f.columns.get_loc("T_out")] = -999.0
    f.iloc[20, f.columns.get_loc("m_V2")] = -9999.0
    report = _check(f, tmp_path)
    assert "; -999 looks like an error code of the export, not a reading" in _one(report.problems, "'T_out'")
    assert "; -9999 looks like an error code" in _one(report.problems, "'m_V2'")


def test_a_time_column_under_another_name_is_pointed_to(tmp_path):
    path = write(base_frame(days=8), tmp_path / "m.csv", "offset")
    path.write_text(path.read_text().replace("time,", "Timestamp,", 1))
    report = check(path, building_from_dict(copy.deepcopy(BUILDING)))
    msg = _one(report.problems, "missing time column")
    assert "the file's first column is 'Timestamp'" in msg and 'time = "Timestamp"' in msg


def test_ghi_of_the_polar_night_is_not_a_dead_sensor(tmp_path):
    f = base_frame(start="2025-12-08 00:00", days=8, tz="Europe/Oslo")
    f["ghi"] = 0.0
    f["T_out"] -= 14.0

    def tromso(d):
        d.update(latitude=69.65, longitude=18.96, timezone="Europe/Oslo")

    report = _check(f, tmp_path, tromso)
    assert not [p for p in report.problems if "'ghi'" in p], report.problems


def test_cosim_warns_about_an_fmu_of_another_building(tmp_path):
    import argparse
    import json

    from harness.cosim import _warn_building_mismatch
    from hvacfmu.errors import HvacfmuWarning
    from hvacfmu.fmu import export_file

    path = tmp_path / "other.json"
    path.write_text(json.dumps(_linear_model(meta={"building": "other floor", "building_sha256": "0" * 64}).to_dict()))
    fmu = export_file(path, tmp_path / "other.fmu")
    b = building_from_dict(copy.deepcopy(BUILDING))
    with pytest.warns(HvacfmuWarning, match=r"other\.fmu: the zones model was fitted on building 'other floor'"):
        _warn_building_mismatch(argparse.Namespace(model=None, fmu=str(fmu)), None, b)


def test_a_physics_model_meets_another_or_an_edited_building_file():
    from types import SimpleNamespace

    from hvacfmu.models.base import building_mismatch

    b = building_from_dict(copy.deepcopy(BUILDING))
    d = copy.deepcopy(BUILDING)
    d["vavs"][0]["m_max"] = 0.5
    model = SimpleNamespace(kind="physics", building=building_from_dict(d), meta={})
    assert "differs from this building file in its zones (area, volume) or boxes" in building_mismatch(model, b)[1][0]
    d["name"] = "other floor"
    model.building = building_from_dict(d)
    assert "was fitted on building 'other floor', not on 'two rooms'" in building_mismatch(model, b)[1][0]
    model.building = b
    assert building_mismatch(model, b) == ([], [])


def test_status_texts_are_refused_with_the_fix_and_dashes_are_missing(tmp_path):
    f = base_frame(days=8)
    path = write(f, tmp_path / "m.csv", "offset")
    out = pd.read_csv(path, dtype={"time": str})
    out["T_B"] = out["T_B"].astype(object)
    out.loc[[5, 6], "T_B"] = "--"
    out["T_A"] = out["T_A"].astype(object)
    out.loc[9, "T_A"] = "Offline"
    out.to_csv(path, index=False)
    report = check(path, building_from_dict(copy.deepcopy(BUILDING)))
    assert "status texts such as 'Offline' or 'Fault' are not readings: blank them" in _one(report.problems, "'T_A'")
    assert not [p for p in report.problems if "'T_B'" in p]


def test_outdoor_air_on_another_clock_than_the_sun_is_flagged(tmp_path):
    f = base_frame(days=8)
    assert not [w for w in _check(f, tmp_path).warnings if "T_out: its daily cycle" in w]
    f["T_out"] = np.roll(f["T_out"].to_numpy(), 7 * 4)  # a weather feed in UTC joined to local times
    report = _check(f, tmp_path)
    msg = _one(report.warnings, "T_out: its daily cycle")
    assert "h late against the sun that ghi puts on time" in msg and report.exit_code == 3


def test_a_repeated_header_name_in_a_semicolon_file_is_named(tmp_path):
    f = base_frame(days=8)
    out = f.copy()
    out.index = [t.isoformat() for t in out.index]
    out.index.name = "time"
    out.to_csv(tmp_path / "m.csv", sep=";")
    path = tmp_path / "m.csv"
    lines = path.read_text().splitlines()
    lines[0] = lines[0].replace("T_B", "T_A")
    path.write_text("\n".join(lines) + "\n")
    report = check(path, building_from_dict(copy.deepcopy(BUILDING)))
    assert report.problems == [
        "m.csv: column 'T_A' appears 2 times in the header (columns 2, 3); a reader cannot tell which one is the "
        "point: rename or drop the copies in the export"
    ]


def test_ghi_with_an_offset_at_night_is_flagged(tmp_path):
    f = base_frame(days=8)
    f["ghi"] += 80.0
    report = _check(f, tmp_path)
    msg = _one(report.warnings, "never falls below")
    assert "never falls below 80 W/m² at night" in msg and report.exit_code == 3


def test_a_box_mapped_to_another_zone_is_flagged(short_paths):
    """Two boxes' zones swapped in the building file fitted a plausible but wrong model in silence: each box's
    delivered heat moves the temperature of the zone it serves, so `check` names both boxes and both zones."""
    import tomllib

    d = tomllib.loads(short_paths.building.read_text())
    report = check(short_paths.measurements, building_from_dict(copy.deepcopy(d)))
    assert not [w for w in report.warnings if "mapped to the wrong zone" in w]
    zones = {v["name"]: v["zone"] for v in d["vavs"]}
    assert zones["VAV_NW_1"] == "NW" and zones["VAV_E_1"] == "E"
    for v in d["vavs"]:
        v["zone"] = {"VAV_NW_1": "E", "VAV_E_1": "NW"}.get(v["name"], v["zone"])
    report = check(short_paths.measurements, building_from_dict(d))
    nw, e = _one(report.warnings, "box VAV_NW_1:"), _one(report.warnings, "box VAV_E_1:")
    assert "explains the temperature changes of zone NW far better than those of zone E" in nw
    assert 'set zone = "NW" in its [[vavs]] entry (name = "VAV_NW_1")' in nw
    assert "explains the temperature changes of zone E far better than those of zone NW" in e
    assert nw in report.attention and report.exit_code == 3
    assert "box in another zone" in report.verdict_line()
