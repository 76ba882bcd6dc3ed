"""Bad inputs the session-17 red team found crashing, poorly reported or silent (benchmarks/redteam_s17.py).

Each test is one corrupted export and what the user now sees (README "What gets refused"); each failed on main
before its change (checked: main reads UTF-16 and cp1252 files as 'utf-8' codec errors, a report preamble as a
pandas tokenizing error, says nothing of a unit appended to a header or of rows newest first, and lets a zone
sensor that repeats its last reading every night through silently).
"""

from __future__ import annotations

import copy

import numpy as np
import pandas as pd
import pytest
from test_properties import BUILDING, base_frame, write

from hvacfmu.building import building_from_dict
from hvacfmu.data import load_measurements
from hvacfmu.errors import DataError


def _building(**extra):
    d = copy.deepcopy(BUILDING)
    d.update(extra)
    return building_from_dict(d)


def _problems(path, building=None):
    with pytest.raises(DataError) as exc:
        load_measurements(path, building or _building())
    return str(exc.value)


def _text(frame, tmp_path):
    return write(frame, tmp_path / "plain.csv", "offset").read_text()


def test_utf16_and_cp1252_files_are_read(tmp_path):
    """Excel's 'Unicode text' (UTF-16 with BOM, tab-separated) and a Windows-1252 file with '°' in a header were
    refused as "'utf-8' codec can't decode byte ..."; they are now decoded and read like the UTF-8 file."""
    frame = base_frame()
    text = _text(frame, tmp_path)
    utf16 = tmp_path / "u16.csv"
    utf16.write_bytes(text.replace(",", "\t").encode("utf-16"))
    got, _ = load_measurements(utf16, _building())
    ref, _ = load_measurements(tmp_path / "plain.csv", _building())
    assert np.allclose(got["T_A"], ref["T_A"])
    cp = tmp_path / "cp.csv"
    cp.write_bytes(text.replace("T_A,", "Room A (°C),", 1).encode("cp1252"))
    got, _ = load_measurements(cp, _building(columns={"T_A": "Room A (°C)"}))
    assert np.allclose(got["T_A"], ref["T_A"])


def test_report_lines_above_the_header_are_named(tmp_path):
    """Three title lines above the header were a pandas 'Error tokenizing data. C error: Expected 1 fields in
    line 4, saw 13'; the message now names the lines and the header line."""
    path = tmp_path / "m.csv"
    path.write_text("Trend Report\nSite: B12\nPeriod: March\n" + _text(base_frame(), tmp_path))
    msg = _problems(path)
    assert "lines 1-3 above the header hold 1, 1, 1 field(s) where the rest of the file has 12" in msg
    assert "'Trend Report'" in msg and "the header looks like line 4 ('time,T_A," in msg
    assert "delete the lines above it" in msg


def test_a_unit_appended_to_a_header_is_named(tmp_path):
    """'T_A (°C)' in the header for T_A: the message named only the missing column."""
    path = tmp_path / "m.csv"
    path.write_text(_text(base_frame(), tmp_path).replace("T_A,", "T_A (°C),", 1).replace("T_B,", "T_B [degC],", 1))
    msg = _problems(path)
    assert "missing required column 'T_A': the file has 'T_A (°C)', the name with a unit appended" in msg
    assert '(T_A = "T_A (°C)")' in msg and "'T_B [degC]'" in msg


def test_rows_newest_first_and_repeated_records_are_named(tmp_path):
    """A file newest first was 'times go backwards at 767 place(s): ...' (and, in naive local time across the
    autumn change, a message about the repeated hour first); exact repeats of a row were only duplicates."""
    frame = base_frame()
    path = tmp_path / "m.csv"
    write(frame.iloc[::-1], path, "offset")
    msg = _problems(path)
    assert "the rows run newest first (times go backwards at 767 of 767 steps" in msg
    assert "sort the file oldest first" in msg
    rows = np.sort(np.concatenate([np.arange(len(frame)), [10, 20, 30]]))
    write(frame.iloc[rows], path, "offset")
    msg = _problems(path)
    assert "3 duplicate timestamps at row 12" in msg
    assert "3 of them repeat the row before them exactly (every column): a logger re-sending records?" in msg


def test_naive_local_times_shuffled_across_the_autumn_change_name_the_order_not_the_hour(tmp_path):
    """Shuffled rows in naive local time across the end of daylight saving time: main led with 'naive local
    times are ambiguous ...'; the order is the problem to fix, and the only one named."""
    frame = base_frame(start="2025-10-30 00:00", tz="America/Los_Angeles")
    path = tmp_path / "m.csv"
    write(frame.iloc[np.random.default_rng(0).permutation(len(frame))], path, "naive")
    msg = _problems(path)
    assert "ambiguous" not in msg
    assert "the rows are in no time order" in msg and "the first occurrence of the repeated autumn hour" in msg


def test_a_zone_sensor_repeating_its_last_reading_every_night_is_flagged(tmp_path):
    """Zone A's controller offline 20:00-06:00 repeats its last reading, which jumps at 06:00: silent on main
    (red team: 0.253 K on the clean data against 0.199 K). Flagged; the samples are kept (masked, the red team's
    model got worse: 1.44 K)."""
    frame = base_frame()
    clean, rep = load_measurements(write(frame, tmp_path / "c.csv", "offset"), _building())
    assert not [w for w in rep.warnings if "held sensor" in w]
    h = frame.index.hour
    night = (h >= 20) | (h < 6)
    held = frame["T_A"].copy()
    held[night] = np.nan
    held = held.ffill()
    held[~night] = frame["T_A"][~night] + 1.0  # the air warmed overnight: the first reading jumps
    frame["T_A"] = held
    got, rep = load_measurements(write(frame, tmp_path / "m.csv", "offset"), _building())
    msg = next(w for w in rep.warnings if "a held sensor?" in w)
    assert "column 'T_A': a held sensor? the value repeats exactly for 6 h or more and then jumps" in msg
    assert "7 times on 7 days" in msg and "held sample(s), kept as read" in msg
    assert got["T_A"].notna().sum() == frame["T_A"].notna().sum()


def test_outdoor_air_in_celsius_declared_fahrenheit_in_march_is_flagged(tmp_path):
    """Every temperature in °F but T_out from a weather feed in °C (8, read as °F, is -13.3 °C). Silent on main, whose cold-half envelope must admit midwinter (red team: 2.27 K on the clean data
    against 0.199 K); a March mean below -10 °C at 38° is colder than any station, and 8 °C fits."""
    frame = base_frame()
    for c in ("T_A", "T_B", "T_supply_AHU1", "T_supply_AHU2", "Td_V1"):
        frame[c] = frame[c] * 1.8 + 32
    frame["T_out"] = frame["T_out"] - 6.0  # 8 °C, left in °C
    b = _building(units={"T_*": "degF", "Td_*": "degF"})
    _, rep = load_measurements(write(frame, tmp_path / "m.csv", "offset"), b)
    msg = next(w for w in rep.warnings if "colder than any weather station" in w)
    assert msg.startswith("m.csv: column 'T_out': monthly mean outdoor temperature (Mar -13.3 °C; declared degF)")
    assert "read as degC it would be Mar 8.0 °C" in msg and '(T_out = "degC")' in msg
    frame["T_out"] = frame["T_out"] * 1.8 + 32  # the same air in °F: nothing to say
    _, rep = load_measurements(write(frame, tmp_path / "ok.csv", "offset"), b)
    assert not [w for w in rep.warnings if "colder than any weather station" in w]


def test_date_and_time_in_two_columns_and_local_times_marked_utc_are_named(tmp_path):
    """Excel's split 'Date','Time' columns were told to map time = "Date"; local wall-clock times written with a
    'Z' across the autumn change were only 'times go backwards at 1 place(s)'."""
    frame = base_frame()
    text = _text(frame, tmp_path).splitlines()
    rows = ["Date,Time," + text[0].split(",", 1)[1]]
    rows += [line[:10] + "," + line[11:19] + "," + line.split(",", 1)[1] for line in text[1:]]
    path = tmp_path / "m.csv"
    path.write_text("\n".join(rows) + "\n")
    msg = _problems(path)
    assert "the file splits each time over columns 'Date' (dates, e.g. '2025-03-03') and 'Time'" in msg
    assert "join them into one column of times" in msg
    fall = base_frame(start="2025-10-31 00:00", days=4)
    write(fall, path, "naive")
    path.write_text(
        "\n".join(x if i == 0 else x.replace(",", "Z,", 1) for i, x in enumerate(path.read_text().splitlines()))
    )
    msg = _problems(path)
    assert "times go backwards at 1 place(s)" in msg
    assert "step back in the hour that America/Los_Angeles's clocks repeat when daylight saving time ends" in msg
    assert "local wall-clock times written with a 'Z'? drop the 'Z'" in msg


def test_a_totals_row_at_the_end_is_named(tmp_path):
    """An 'Average' row appended by the report: main said only that 'Average' is not an ISO 8601 time."""
    path = tmp_path / "m.csv"
    path.write_text(_text(base_frame(), tmp_path) + "Average,21.6,22.0,0.2,0.1,13.0,14.0,14.0,200,25.0,0.5,0\n")
    msg = _problems(path)
    assert "'Average' at row 769; the last rows of the file hold words, not times ('Average')" in msg
    assert "a summary row (total, average, min/max) that the report appends? delete it" in msg


def test_irradiance_per_square_foot_is_named_and_can_be_declared(tmp_path):
    """ghi in W/ft² read as W/m² (a tenth): main's warning offered energy per interval or a shaded sensor (red
    team: 5.1 K on the clean data). The warning now names W/ft², and declaring it reads the column right."""
    frame = base_frame()
    frame["ghi"] = frame["ghi"] / 10.7639
    _, rep = load_measurements(write(frame, tmp_path / "m.csv", "offset"), _building())
    msg = next(w for w in rep.warnings if "is not W/m²" in w)
    assert "read as W/ft2 (x 10.76 W/m²) its highest peak would be 700 W/m²" in msg
    assert 'declare ghi = "W/ft2" in the building\'s [units] table' in msg
    got, rep = load_measurements(tmp_path / "m.csv", _building(units={"ghi": "W/ft2"}))
    assert not [w for w in rep.warnings if "is not W/m²" in w]
    assert np.allclose(got["ghi"], base_frame()["ghi"].to_numpy(), atol=1e-6)


def test_the_most_specific_unit_glob_wins(tmp_path):
    """[units] "T_*" = "degF" then "T_supply_*" = "degC": main took the first matching glob (°F) for the supply
    air, whatever the more specific line said (red team: a wrong "T_supply_*" line was silently ignored, a right
    one refused); the most specific glob now wins."""
    frame = base_frame()
    for c in ("T_A", "T_B", "T_out"):
        frame[c] = frame[c] * 1.8 + 32
    b = _building(units={"T_*": "degF", "T_supply_*": "degC"})
    assert b.unit_for("T_supply_AHU1") == "degC" and b.unit_for("T_A") == "degF"
    got, _ = load_measurements(write(frame, tmp_path / "m.csv", "offset"), b)
    assert np.allclose(got["T_supply_AHU1"], base_frame()["T_supply_AHU1"].to_numpy())


def test_a_clock_that_never_springs_forward_is_named(tmp_path):
    """A logger on standard time all year writes the hour that local clocks skip in spring: main said only 'write
    times with their UTC offset'; the message now names the fix for a clock that never changes, as it does for the
    autumn hour written once."""
    frame = base_frame(start="2025-03-06 00:00", days=6)
    std = frame.index.tz_convert("UTC") - pd.Timedelta(hours=8)  # Pacific standard time all year
    path = tmp_path / "m.csv"
    out = frame.reset_index(drop=True)
    out.insert(0, "time", [t.tz_localize(None).isoformat() for t in std])
    out.to_csv(path, index=False)
    msg = _problems(path)
    assert "4 naive local times do not exist (skipped when daylight saving time starts" in msg
    assert "if the export inserted rows for the skipped hour, delete them" in msg
    assert "writes the hour that local clocks skip), declare its zone" in msg
    assert 'data_timezone = "Etc/GMT+8" (UTC-08:00)' in msg
    got, _ = load_measurements(path, _building(data_timezone="Etc/GMT+8"))
    assert len(got) == len(frame)


def test_file_level_slips_are_named(tmp_path):
    """A workbook saved under .csv was 'no data rows', an empty file pandas' 'No columns to parse from file', a row
    with two extra fields only pandas' tokenizer error; a separator at the end of every line (Excel) was an
    'unknown column ignored' that needs action; a last line cut off mid-row was read, its cut value included."""
    path = tmp_path / "m.csv"
    path.write_bytes(b"PK\x03\x04" + bytes(100))
    assert "the file is an Excel workbook (.xlsx) or another zip archive, not text" in _problems(path)
    path.write_bytes(b"")
    assert "m.csv: the file is empty (0 bytes)" in _problems(path)
    lines = _text(base_frame(), tmp_path).splitlines()
    path.write_text("\n".join(lines[:50] + [lines[50] + ",1,2"] + lines[51:]) + "\n")
    assert "(line 51 holds 14 fields where the header has 12: a value holding the separator unquoted" in _problems(path)
    path.write_text("\n".join(x + "," for x in lines) + "\n")
    _, rep = load_measurements(path, _building())
    assert not rep.unknown_columns and not [w for w in rep.warnings if "unknown column" in w]
    path.write_text("\n".join(lines)[:-25])
    got, rep = load_measurements(path, _building())
    msg = next(w for w in rep.warnings if "(the last) ends the file" in w)
    assert msg.startswith("m.csv: row 768 (the last) ends the file after") and "the row is dropped" in msg
    assert len(got) == 767
    path.write_text("\n".join(lines))  # only the final line break missing: nothing to say
    got, rep = load_measurements(path, _building())
    assert len(got) == 768 and not [w for w in rep.warnings if "(the last)" in w]
