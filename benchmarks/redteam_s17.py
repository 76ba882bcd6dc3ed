"""Red team of the data path, session 17: 44 new corruptions of the real-world-like export.

Same protocol and scoring as ``benchmarks/redteam_s15.py`` / ``redteam_s16.py`` (clean export: °F, CFM, %,
naive Chicago wall clock across the autumn clock change, outages, two air handlers, ``Td_``/``rh_``; CSV at
15 min): each variant goes through ``check`` (in-process, as ``python3 -m hvacfmu check`` does), then, when
``check`` lets it through (exit 0 or 3), ``hvacfmu fit --model zones`` and ``hvacfmu evaluate`` as subprocesses,
and the fitted model is also scored on the clean export. Outcomes: ``refused`` (check exit 1 or fit exit 2),
``warned`` (a warning the clean export does not raise), ``silent``, and ``crash`` (a traceback instead of a
message, from ``check`` or a later command). ``wrong``: a 24-h RMS more than 25 % and 0.02 K off the clean one.

The variants cover what the previous rounds did not: Unix times, local times written with ``Z``, a logger that
never leaves summer time, rows newest first / shuffled / exactly duplicated / months concatenated out of order,
Kelvin, a °C outdoor or supply column among °F, one °F zone among °C, declared units that do not match,
setpoints with ramps, stale or interpolated sensors, negative airflow at night, a +2 K sensor offset, a box off
for three weeks, ``ghi`` in W/ft² or lux, a totals row, BOM, UTF-16 and cp1252 files, a report preamble, split
date and time columns, day-first dates, quoted thousands separators, descriptive headers with units, one box in
L/s, discharge sensors reading the supply air, an inverted reheat signal, a supply setpoint, doubled airflows, and
return air as a zone.

Run: ``python3 benchmarks/redteam_s17.py [--out DIR] [--only NAME ...]``; ``--table BEFORE AFTER`` prints the
markdown table of two results files and the totals; ``HVACFMU_CODE=/path/to/checkout`` runs another checkout's
code (e.g. main, for "before").
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import traceback
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
import redteam_s15 as s15  # noqa: E402

_zone_cols, _box_cols, _times, _iso = s15._zone_cols, s15._box_cols, s15._times, s15._iso
TZ = "America/Chicago"


def _instants(f):
    return pd.DatetimeIndex(_times(f)).tz_localize(TZ, ambiguous="infer")


def _f_to_c(x):
    return ((x - 32) / 1.8).round(2)


# --------------------------------------------------------------------------- time column
def epoch_seconds(f, b, rng):
    """Times as Unix seconds (a Python/InfluxDB-style export)."""
    return f.assign(time=((_instants(f) - pd.Timestamp(0, tz="UTC")) // pd.Timedelta(seconds=1)).astype(str)), b


def epoch_milliseconds(f, b, rng):
    """Times as Unix milliseconds (a JavaScript/SkySpark-style export)."""
    return f.assign(time=((_instants(f) - pd.Timestamp(0, tz="UTC")) // pd.Timedelta(milliseconds=1)).astype(str)), b


def local_times_with_z(f, b, rng):
    """Naive local wall clock written with a 'Z' suffix (a server that stamps 'Z' on local time)."""
    return f.assign(time=[s + "Z" for s in f["time"]]), b


def dst_never_falls_back(f, b, rng):
    """A logger that stays on summer time after the autumn change (naive times 1 h late from 2 Nov)."""
    t = _instants(f).tz_convert("UTC") - pd.Timedelta(hours=5)
    return f.assign(time=_iso(t.tz_localize(None))), b


def reverse_chronological(f, b, rng):
    """Rows newest first (many BMS trend viewers export that way)."""
    return f.iloc[::-1].reset_index(drop=True), b


def shuffled_rows(f, b, rng):
    """Rows in random order (an export merged from a database without ORDER BY)."""
    return f.iloc[rng.permutation(len(f))].reset_index(drop=True), b


def exact_duplicate_rows(f, b, rng):
    """2 % of the rows repeated right after themselves, identical (a logger that re-sends a record)."""
    idx = np.arange(len(f))
    dup = np.sort(rng.choice(len(f), len(f) // 50, replace=False))
    return f.iloc[np.sort(np.concatenate([idx, dup]))].reset_index(drop=True), b


def months_concatenated_wrong_order(f, b, rng):
    """Two monthly exports pasted with November above October."""
    t = _times(f)
    oct_ = t < "2025-11-01"
    return pd.concat([f[~oct_], f[oct_]], ignore_index=True), b


def dayfirst_dates(f, b, rng):
    """European day-first dates ('20/10/2025 00:00')."""
    return f.assign(time=[x.strftime("%d/%m/%Y %H:%M") for x in _times(f)]), b


def date_and_time_columns(f, b, rng):
    """Date and time in two columns ('Date', 'Time'), as Excel splits them."""
    t = _times(f)
    out = f.drop(columns="time")
    out.insert(0, "Time", [x.strftime("%H:%M:%S") for x in t])
    out.insert(0, "Date", [x.strftime("%Y-%m-%d") for x in t])
    return out, b


def times_offset_7_min(f, b, rng):
    """Polls at :07, :22, :37, :52 (a logger started at 00:07): control, nothing is wrong."""
    t = _instants(f) + pd.Timedelta(minutes=7)
    return f.assign(time=[x.isoformat() for x in t]), b


# --------------------------------------------------------------------------- file format
def bom_utf8(f, b, rng):
    """UTF-8 with a byte-order mark (Excel's 'CSV UTF-8')."""
    return ("\ufeff" + f.to_csv(index=False)).encode("utf-8"), b


def utf16_tab(f, b, rng):
    """Excel's 'Unicode text': UTF-16 LE with BOM, tab-separated, saved as .csv."""
    return f.to_csv(index=False, sep="\t").encode("utf-16"), b


def tab_separated(f, b, rng):
    """Tab-separated values in a .csv file."""
    return f.to_csv(index=False, sep="\t"), b


def report_preamble(f, b, rng):
    """Three report lines above the header (a trend-report export: title, site, period)."""
    pre = "Trend Report: Floor 4 VAV\nSite: Building 12\nPeriod: 2025-10-20 to 2025-11-24\n"
    return pre + f.to_csv(index=False), b


def trailing_totals_row(f, b, rng):
    """A summary row at the end ('Average' in the time column, the column means after it)."""
    row = {c: (f[c].mean().round(1) if c != "time" else "Average") for c in f.columns}
    return pd.concat([f.astype(object), pd.DataFrame([row])], ignore_index=True), b


def thousands_separator_quoted(f, b, rng):
    """Airflows of 1000 CFM and more written '1,006' (quoted in the comma-separated file: 345 cells)."""
    text = f.astype(object)
    for c in _box_cols(f):
        text[c] = [("" if np.isnan(v) else f"{int(v):,}") for v in f[c]]
    return text.to_csv(index=False), b


def cp1252_unit_headers(f, b, rng):
    """Descriptive headers with units ('Zone NW Temp (°F)'), mapped in [columns], file saved in cp1252."""
    names = {c: f"Zone {c[2:]} Temp (°F)" for c in _zone_cols(f)}
    cols = "\n[columns]\n" + "".join(f'{k} = "{v}"\n' for k, v in names.items())
    return f.rename(columns=names).to_csv(index=False).encode("cp1252"), b + cols


def unit_headers_unmapped(f, b, rng):
    """Every header with its unit appended ('T_NW (°F)', 'm_VAV_NW_1 (CFM)'), building file unchanged."""
    unit = {"T": "°F", "Td": "°F", "m": "CFM", "rh": "%", "ghi": "W/m²", "excitation": "-"}
    ren = {c: f"{c} ({unit.get(c.split('_')[0], '-')})" for c in f.columns if c != "time"}
    return f.rename(columns=ren), b


def descriptive_headers_mapped(f, b, rng):
    """Headers with spaces and units, all mapped in [columns] (control: nothing is wrong)."""
    names = {c: f"Zone {c[2:]} Temp (°F)" for c in _zone_cols(f)}
    names.update({c: f"{c[2:].replace('_', ' ')} Airflow (CFM)" for c in _box_cols(f)})
    cols = "\n[columns]\n" + "".join(f'{k} = "{v}"\n' for k, v in names.items())
    return f.rename(columns=names), b + cols


# --------------------------------------------------------------------------- units
def zone_in_kelvin(f, b, rng):
    """Zone C exported in kelvin, declared °F like the others."""
    return f.assign(T_C=(_f_to_c(f["T_C"]) + 273.15).round(2)), b


def t_out_in_celsius(f, b, rng):
    """The outdoor air from a weather service in °C, declared °F like the rest."""
    return f.assign(T_out=_f_to_c(f["T_out"])), b


def one_zone_in_f_rest_c(f, b, rng):
    """All temperatures converted to °C and declared °C, but zone E left in °F."""
    out = f.copy()
    for c in [c for c in f.columns if c.startswith(("T_", "Td_")) and c != "T_E"]:
        out[c] = _f_to_c(f[c])
    return out, b.replace('"T_*" = "degF"', '"T_*" = "degC"').replace('"Td_*" = "degF"', '"Td_*" = "degC"')


def supply_in_celsius(f, b, rng):
    """T_supply_AHU1 exported in °C (the AHU controller's own unit), declared °F like the rest."""
    return f.assign(T_supply_AHU1=_f_to_c(f["T_supply_AHU1"])), b


def supply_declared_celsius(f, b, rng):
    """The building file declares the supply air in °C (a wrong [units] line), the data are °F."""
    return f, b.replace('"Td_*" = "degF"', '"Td_*" = "degF"\n"T_supply_*" = "degC"')


def one_discharge_in_celsius(f, b, rng):
    """One box's discharge air Td_VAV_S_1 in °C among °F columns."""
    return f.assign(Td_VAV_S_1=_f_to_c(f["Td_VAV_S_1"])), b


def rh_percent_declared_fraction(f, b, rng):
    """The reheat valve in % (0-100), declared as a fraction 0..1."""
    return f, b.replace('"rh_*" = "%"', '"rh_*" = "1"')


def ghi_w_per_ft2(f, b, rng):
    """Irradiance in W/ft² (US weather station), declared W/m²."""
    return f.assign(ghi=(f["ghi"] / 10.764).round(1)), b


def ghi_in_lux(f, b, rng):
    """An illuminance sensor in lux (about 110 lm/W of daylight) exported as ghi."""
    return f.assign(ghi=(f["ghi"] * 110).round(0)), b


def damper_position_all_boxes(f, b, rng):
    """Every box's damper position 0-100 % exported as its flow (declared CFM), min position 30 %."""
    out = f.copy()
    for c in _box_cols(f):
        x = f[c] / f[c].quantile(0.999)
        out[c] = (30 + 70 * (x - x.min()) / (1 - x.min())).clip(0, 100).round(0)
    return out, b


# --------------------------------------------------------------------------- sensors
def setpoint_with_ramp(f, b, rng):
    """Zone S's column is its active setpoint with a 2-h morning warm-up ramp in 0.5 °F steps."""
    t = _times(f)
    h = t.dt.hour + t.dt.minute / 60
    occ = (t.dt.day_of_week < 5) & (h >= 8) & (h < 18)
    ramp = (t.dt.day_of_week < 5) & (h >= 6) & (h < 8)
    sp = np.where(occ, 71.0, np.where(ramp, 65.0 + np.floor((h - 6) * 6) * 0.5, 65.0))
    return f.assign(T_S=np.where(f["T_S"].isna(), np.nan, sp)), b


def zone_stale_nightly(f, b, rng):
    """Zone E's sensor reports on change of value only: the last value is repeated for 10 h every night."""
    out = f.copy()
    t = _times(f)
    night = (t.dt.hour >= 20) | (t.dt.hour < 6)
    grp = (~night).cumsum()
    out["T_E"] = f["T_E"].where(~night).groupby(grp).transform("first").where(night, f["T_E"])
    return out, b


def interpolated_outages(f, b, rng):
    """The BMS fills logger outages with straight lines (every column interpolated, no empty cells)."""
    out = f.copy()
    num = [c for c in f.columns if c != "time"]
    out[num] = f[num].interpolate(limit_area="inside")
    return out, b


def airflow_negative_at_night(f, b, rng):
    """Boxes of zone W read -15 to -25 CFM when the fans are off at night (a zero-offset drift)."""
    out = f.copy()
    t = _times(f)
    night = ((t.dt.hour >= 22) | (t.dt.hour < 5)).to_numpy()
    for c in ("m_VAV_W_1", "m_VAV_W_2", "m_VAV_W_3"):
        out.loc[night, c] = -rng.integers(15, 26, night.sum())
    return out, b


def zone_offset_plus_2k(f, b, rng):
    """Zone NE's sensor reads 2 K (3.6 °F) high all along (a calibration offset)."""
    return f.assign(T_NE=f["T_NE"] + 3.6), b


def zone_sensor_drift(f, b, rng):
    """Zone NW's sensor drifts up 3 °F over the five weeks."""
    return f.assign(T_NW=f["T_NW"] + 3.0 * np.arange(len(f)) / len(f)), b


def box_zero_three_weeks(f, b, rng):
    """Box S_2's flow reads 0 for three weeks (a failed flow sensor), the box still blowing."""
    out = f.copy()
    out.loc[700 : 700 + 96 * 21, "m_VAV_S_2"] = 0.0
    return out, b


def t_out_hourly_steps(f, b, rng):
    """T_out from an hourly weather feed held for the four 15-min rows of each hour (staircase)."""
    out = f.copy()
    t = _times(f)
    out["T_out"] = f["T_out"].where(t.dt.minute == 0).ffill(limit=3)
    return out, b


def one_box_litres_declared_cfm(f, b, rng):
    """Box E_2's flow in L/s (a replaced controller), declared CFM like the others."""
    return f.assign(m_VAV_E_2=(f["m_VAV_E_2"] * 0.471947).round(0)), b


def all_discharge_is_supply(f, b, rng):
    """Every Td_ column holds its air handler's supply air (discharge sensors upstream of the coils)."""
    out = f.copy()
    for c in [c for c in f.columns if c.startswith("Td_")]:
        ahu = "T_supply_AHU2" if "_C_" in c else "T_supply_AHU1"
        out[c] = f[ahu]
    return out, b


def reheat_inverted(f, b, rng):
    """The reheat valve exported inverted (100 - %), a normally-open actuator's signal."""
    out = f.copy()
    for c in [c for c in f.columns if c.startswith("rh_")]:
        out[c] = 100 - f[c]
    return out, b


def supply_is_setpoint(f, b, rng):
    """Both T_supply columns hold the discharge-air setpoint (55 °F all along), not the measured supply air."""
    return f.assign(T_supply_AHU1=55.0, T_supply_AHU2=55.0), b


def airflow_doubled(f, b, rng):
    """Every box's flow doubled (the point sums two boxes behind one controller), declared CFM."""
    out = f.copy()
    out[_box_cols(f)] = f[_box_cols(f)] * 2
    return out, b


def zone_is_return_air(f, b, rng):
    """Zone W's column is the return air of its unit (the airflow-weighted mean of AHU1's zones)."""
    z = ["T_NW", "T_W", "T_S", "T_E", "T_NE"]
    return f.assign(T_W=f[z].mean(axis=1).round(1)), b


VARIANTS = [
    epoch_seconds, epoch_milliseconds, local_times_with_z, dst_never_falls_back, reverse_chronological,
    shuffled_rows, exact_duplicate_rows, months_concatenated_wrong_order, dayfirst_dates, date_and_time_columns,
    times_offset_7_min, bom_utf8, utf16_tab, tab_separated, report_preamble, trailing_totals_row,
    thousands_separator_quoted, cp1252_unit_headers, unit_headers_unmapped, descriptive_headers_mapped,
    zone_in_kelvin, t_out_in_celsius, one_zone_in_f_rest_c, supply_in_celsius, supply_declared_celsius,
    one_discharge_in_celsius, rh_percent_declared_fraction, ghi_w_per_ft2, ghi_in_lux, damper_position_all_boxes,
    setpoint_with_ramp, zone_stale_nightly, interpolated_outages, airflow_negative_at_night, zone_offset_plus_2k,
    zone_sensor_drift, box_zero_three_weeks, t_out_hourly_steps, one_box_litres_declared_cfm,
    all_discharge_is_supply, reheat_inverted, supply_is_setpoint, airflow_doubled, zone_is_return_air,
]  # fmt: skip
#: Fragments of the messages of the session-17 rules that can fire on readable data (a false alarm on a clean export).
NEW_MESSAGES = (
    "a held sensor?", "colder than any weather station", "lines 1-", "the rows run newest first",
    "the name with a unit appended", "repeat the row before them exactly", "(the last) ends the file",
    "unknown column(s) ignored: ''",
)  # fmt: skip
#: Variants where nothing is wrong for the model (controls): a warning there is noise, silent is right.
CONTROLS = {"times_offset_7_min", "descriptive_headers_mapped"}


# --------------------------------------------------------------------------- running
# --------------------------------------------------------------------------- check-only probes
def _probe_files(clean_dir: Path) -> dict:
    """File-level slips of the clean CSV (name -> bytes), judged by ``check`` alone (no model is fitted)."""
    import gzip

    text = (clean_dir / "measurements.csv").read_text()
    lines = text.splitlines()
    return {
        "empty_file": b"",
        "header_only": (lines[0] + "\n").encode(),
        "crlf": ("\r\n".join(lines) + "\r\n").encode(),
        "trailing_comma": ("\n".join(x + "," for x in lines) + "\n").encode(),
        "blank_lines_between": ("\n\n".join(lines) + "\n").encode(),
        "truncated_last_line": text[: len(text) - 200].encode(),
        "ragged_row_extra_field": ("\n".join(lines[:100] + [lines[100] + ",99,98"] + lines[101:]) + "\n").encode(),
        "xlsx_renamed_csv": b"PK\x03\x04" + bytes(200),
        "gz_csv_with_bom": gzip.compress(("\ufeff" + text).encode()),
        "header_repeated_midfile": ("\n".join(lines[:1500] + [lines[0]] + lines[1500:]) + "\n").encode(),
        "quoted_everything": ("\n".join(",".join(f'"{x}"' for x in line.split(",")) for line in lines) + "\n").encode(),
    }


def _spring_variants(spring_dir: Path) -> dict:
    """Naive local times around the spring change (name -> CSV text), from a clean export spanning 8 March 2026."""
    f = pd.read_csv(spring_dir / "measurements.csv", dtype={"time": str})
    i = int(np.flatnonzero(f["time"] == "2026-03-08T01:45:00")[0])
    ins = f.iloc[[i] * 4].copy()
    ins["time"] = [f"2026-03-08T02:{m:02d}:00" for m in (0, 15, 30, 45)]
    inst = pd.DatetimeIndex(_times(f)).tz_localize(TZ, nonexistent="raise")
    std = (inst.tz_convert("UTC") - pd.Timedelta(hours=6)).tz_localize(None)
    return {
        "spring_gap_filled": pd.concat([f.iloc[: i + 1], ins, f.iloc[i + 1 :]]).to_csv(index=False),
        "dst_never_springs_forward": f.assign(time=_iso(std)).to_csv(index=False),
        "spring_hour_written_twice": pd.concat([f.iloc[: i + 1], f.iloc[i - 3 : i + 1], f.iloc[i + 1 :]]).to_csv(
            index=False
        ),
    }


def probe(out: Path) -> None:
    """``check`` on the file-level slips and the spring variants; prints exit code and first problem or warning."""
    from hvacfmu.data import check

    clean_dir, spring_dir = out / "clean", out / "spring"
    for d, start in ((clean_dir, "2025-10-20"), (spring_dir, "2026-02-23")):
        if not (d / "measurements.csv").exists():
            args = list(s15.GENERATE)
            args[args.index("--start") + 1] = start
            s15._cli("generate", d, *args)
    items = {**_probe_files(clean_dir), **_spring_variants(spring_dir)}
    for name, content in items.items():
        src = (
            spring_dir
            if name in ("spring_gap_filled", "dst_never_springs_forward", "spring_hour_written_twice")
            else clean_dir
        )
        work = out / "probe" / name
        work.mkdir(parents=True, exist_ok=True)
        data = work / ("measurements.csv.gz" if name.startswith("gz_") else "measurements.csv")
        data.write_bytes(content if isinstance(content, bytes) else content.encode())
        (work / "building.toml").write_text((src / "building.toml").read_text())
        try:
            rep = check(data, work / "building.toml")
            first = (rep.problems or rep.attention or [""])[0]
            print(f"| `{name}` | exit {rep.exit_code} | {first[:220]} |", flush=True)
        except Exception as exc:  # noqa: BLE001 - a crash is a finding
            print(f"| `{name}` | crash | {type(exc).__name__}: {exc} |", flush=True)


def run_one(name, data: Path, building: Path, clean: dict, work: Path) -> dict:
    """s15's run_one, with a crash (traceback) from ``check``, ``fit`` or ``evaluate`` as its own outcome."""
    try:
        out = s15.run_one(name, data, building, clean, work)
    except Exception as exc:  # noqa: BLE001 - a crash is a finding
        return {"variant": name, "check_exit": None, "outcome": "crash", "problems": [
            f"check raised {type(exc).__name__}: {exc}"[:400], traceback.format_exc().splitlines()[-3][:200]]}  # fmt: skip
    exc = re.compile(r"^[\w.]*(Error|Exception)\b")  # a last stderr line naming an exception, not a message
    if exc.match(out.get("evaluate_error", "")) or (
        out["outcome"] == "refused" and out.get("check_exit") != 1 and out["problems"] and exc.match(out["problems"][0])
    ):
        out["outcome"] = "crash"
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="/tmp/redteam_s17", help="work directory")
    ap.add_argument("--table", nargs=2, metavar=("BEFORE", "AFTER"), help="print the markdown table of two results")
    ap.add_argument("--only", nargs="*", help="variant names to run (default all)")
    ap.add_argument("--false-alarms", nargs="*", metavar="DIR", help="only load these clean exports")
    ap.add_argument("--probe", action="store_true", help="only run check on the file-level and spring probes")
    ap.add_argument("--results", default=None, help="JSON-lines file (default OUT/results.jsonl)")
    args = ap.parse_args(argv)
    if args.table:
        s15.VARIANTS = VARIANTS
        print(s15.table(Path(args.table[0]), Path(args.table[1])))
        for p in args.table:
            print(f"{p}: {totals(Path(p))}")
        return
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.probe:
        probe(out)
        return
    if args.false_alarms is not None:
        s15.NEW_MESSAGES = NEW_MESSAGES
        s15.false_alarms(args.false_alarms, Path(args.results) if args.results else out / "false_alarms.jsonl")
        return
    clean_dir = out / "clean"
    if not (clean_dir / "measurements.csv").exists():
        r = s15._cli("generate", clean_dir, *s15.GENERATE)
        if r.returncode:
            sys.exit(r.stderr)
    data, building = clean_dir / "measurements.csv", clean_dir / "building.toml"
    from hvacfmu.data import check

    clean_rep = check(data, building)
    if not (clean_dir / "eval.json").exists():
        s15._cli("fit", data, "-b", building, "-m", "zones", "-o", clean_dir / "zones.json")
        s15._cli(
            "evaluate", data, "-b", building, "--model", clean_dir / "zones.json", "--json", clean_dir / "eval.json"
        )
    clean = {
        "data": data,
        "building": building,
        "warning_keys": {s15._key(w) for w in clean_rep.warnings},
        "rms": s15._mean_rms(clean_dir / "eval.json"),
    }
    print(f"clean export: check exit {clean_rep.exit_code}, zones mean 24-h RMS {clean['rms']:.3f} K", flush=True)
    frame = pd.read_csv(data, dtype={"time": str})
    btext = building.read_text()
    results = Path(args.results) if args.results else out / "results.jsonl"
    wanted = set(args.only or [v.__name__ for v in VARIANTS])
    with open(results, "a" if args.only else "w") as fh:
        for i, variant in enumerate(VARIANTS):
            name = variant.__name__
            if name not in wanted:
                continue
            work = out / name
            work.mkdir(parents=True, exist_ok=True)
            got, btext2 = variant(frame.copy(), btext, np.random.default_rng(100 + i))
            vdata = work / "measurements.csv"
            if isinstance(got, bytes):
                vdata.write_bytes(got)
            elif isinstance(got, str):
                vdata.write_text(got)
            else:
                got.to_csv(vdata, index=False)
            (work / "building.toml").write_text(btext2)
            r = run_one(name, vdata, work / "building.toml", clean, work)
            fh.write(json.dumps(r, default=str) + "\n")
            fh.flush()
            print(s15._row(r), flush=True)


def totals(path: Path) -> str:
    """Counts of one results file (the last record of a variant wins)."""
    rs = {}
    for line in path.read_text().splitlines():
        r = json.loads(line)
        rs[r["variant"]] = r
    rs = list(rs.values())
    count = {k: sum(r["outcome"] == k for r in rs) for k in ("refused", "warned", "silent", "crash")}
    wrong = sum(r["outcome"] == "silent" and bool(r.get("wrong")) for r in rs)
    return (
        f"{len(rs)} variants: {count['refused']} refused, {count['warned']} warned, {count['silent']} silent "
        f"({wrong} silent and wrong), {count['crash']} crash"
    )


if __name__ == "__main__":
    main()
