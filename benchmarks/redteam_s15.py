"""Red team of the data path (session 15): corrupted BMS exports through check, fit and evaluate.

Starts from one real-world-like emulator export (°F, CFM, %, naive local times across the autumn clock
change, logger outages, two air handlers, discharge temperatures; CSV at 15 min) and derives corrupted
variants of it, each a mistake real trend-log exports make. Every variant goes through what a user runs:
``check`` (in-process, :func:`hvacfmu.data.check`), then, when ``check`` lets it through (exit 0 or 3),
``hvacfmu fit --model zones`` and ``hvacfmu evaluate`` as subprocesses. The outcome of a variant is

- ``refused``: ``check`` exits 1 (or ``fit`` exits 2), with the first problem;
- ``warned``: a warning that the clean export does not raise (the first new one is quoted);
- ``silent``: neither.

For a variant that was fitted, the model is also evaluated on the *clean* export (what the building
really does): ``wrong`` when that 24-h RMS is more than 25 % (and 0.02 K) above the clean model's, or the
variant's own evaluation reports a mean RMS that is off by as much from the clean one (a model that
looks better or worse than it is). A silent wrong result is the finding this script hunts.

Run: ``python3 benchmarks/redteam_s15.py [--out DIR] [--only NAME ...]`` (about 10 min on the 2-core
machine); it prints a markdown table and writes ``DIR/results.jsonl``. ``HVACFMU_CODE=/path/to/checkout``
runs another checkout's code (e.g. main, for the "before" column).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(os.environ.get("HVACFMU_CODE", Path(__file__).resolve().parents[1]))  # the checkout under test
sys.path.insert(0, str(ROOT))

GENERATE = [
    "--hvac", "reheat", "--climate", "cold", "--units", "us", "--clock", "naive-local", "--fault", "outages",
    "--start", "2025-10-20", "--weeks", "5", "--export-step", "900", "--seed", "0", "--format", "csv",
]  # fmt: skip
WRONG_FACTOR, WRONG_ABS = 1.25, 0.02  # [1], [K]


def _cli(*args, timeout=900):
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1")
    return subprocess.run(
        [sys.executable, "-m", "hvacfmu", *map(str, args)],
        capture_output=True,
        text=True,
        env=env,
        timeout=timeout,
        cwd=ROOT,  # python -m puts the working directory first on sys.path
    )


# --------------------------------------------------------------------------- variants
# Each variant takes (frame, building_text, rng) with the clean export as read by pandas (time as text,
# every other column a float) and returns (frame or CSV text, building_text).

TEMPS_F = None  # filled by main: column lists of the clean export


def _zone_cols(f):
    return [c for c in f.columns if c.startswith("T_") and not c.startswith("T_supply") and c != "T_out"]


def _box_cols(f):
    return [c for c in f.columns if c.startswith("m_")]


def _times(f):
    return pd.to_datetime(f["time"])


def _wall_clock(f, shift_s):
    """Naive local wall-clock text of the clean export's instants shifted by ``shift_s`` [s] (DST-aware)."""
    t = pd.DatetimeIndex(_times(f)).tz_localize("America/Chicago", ambiguous="infer")
    return _iso((t + pd.to_timedelta(shift_s, unit="s")).tz_localize(None))


def _iso(t):
    return [x.isoformat() for x in t]


def units_row(f, b, rng):
    units = ["" if c == "time" else "°F" if c.startswith(("T", "Td")) else "CFM" if c.startswith("m_") else "%"
             for c in f.columns]  # fmt: skip
    row = pd.DataFrame([units], columns=f.columns)
    return pd.concat([row, f.astype(object)], ignore_index=True), b


def semicolon_decimal_comma(f, b, rng):
    return f.to_csv(index=False, sep=";", decimal=","), b


def missing_spellings(f, b, rng):
    f = f.astype({"T_NW": object, "m_VAV_S_1": object, "T_out": object})
    for col, word in (("T_NW", "NULL"), ("m_VAV_S_1", "#N/A"), ("T_out", "--")):
        rows = rng.choice(len(f), 30, replace=False)
        f.loc[rows, col] = word
    return f, b


def status_text_bad(f, b, rng):
    f = f.astype({"T_E": object})
    f.loc[rng.choice(len(f), 5, replace=False), "T_E"] = "Bad"
    return f, b


def header_trailing_spaces(f, b, rng):
    return f.rename(columns={c: c + "  " for c in f.columns if c != "time"}), b


def header_lower_case(f, b, rng):
    return f.rename(columns={c: c.lower() for c in f.columns if c != "time"}), b


def unsorted_day(f, b, rng):
    idx = np.arange(len(f))
    day = idx[500:596].copy()
    rng.shuffle(day)
    idx[500:596] = day
    return f.iloc[idx].reset_index(drop=True), b


def duplicate_times_other_values(f, b, rng):
    extra = f.iloc[1000:1020].copy()
    extra[_zone_cols(f)] += 3.0
    return pd.concat([f.iloc[:1020], extra, f.iloc[1020:]], ignore_index=True), b


def file_exported_twice(f, b, rng):
    return pd.concat([f, f], ignore_index=True), b


def overlapping_exports(f, b, rng):
    return pd.concat([f.iloc[:1500], f.iloc[1400:]], ignore_index=True), b


def dst_hour_once(f, b, rng):
    """The repeated autumn hour logged once (the logger overwrote the first occurrence)."""
    t = f["time"]
    rep = np.flatnonzero(t.str.startswith("2025-11-02T01:"))
    return f.drop(index=rep[: len(rep) // 2]).reset_index(drop=True), b


def dst_sorted_by_wall_clock(f, b, rng):
    """The export sorted by its naive text: the two occurrences of the repeated hour interleaved."""
    return f.sort_values("time", kind="stable").reset_index(drop=True), b


def standard_time_all_year(f, b, rng):
    """A BMS server clock on standard time all year (never moves to DST): naive times 1 h early under DST."""
    t = pd.DatetimeIndex(_times(f)).tz_localize("America/Chicago", ambiguous="infer")
    std = (t.tz_convert("UTC") - pd.Timedelta(hours=6)).tz_localize(None)
    return f.assign(time=_iso(std)), b


def fixed_offset_text_wall_clock(f, b, rng):
    """Wall-clock times written with the summer offset all year (a server that appends a constant -05:00)."""
    return f.assign(time=[s + "-05:00" for s in f["time"]]), b


def utc_and_offset_mixed(f, b, rng):
    """Correct instants, some rows written in UTC ('Z') and others with the local offset."""
    t = pd.DatetimeIndex(_times(f)).tz_localize("America/Chicago", ambiguous="infer")
    text = [x.isoformat() for x in t]
    utc = [x.tz_convert("UTC").strftime("%Y-%m-%dT%H:%M:%SZ") for x in t]
    pick = rng.random(len(t)) < 0.3
    return f.assign(time=np.where(pick, utc, text)), b


def tz_abbreviation_suffix(f, b, rng):
    """Niagara-style times with a zone abbreviation ('2025-10-20 00:00:00 CDT')."""
    t = pd.DatetimeIndex(_times(f)).tz_localize("America/Chicago", ambiguous="infer")
    return f.assign(time=[x.strftime("%Y-%m-%d %H:%M:%S %Z") for x in t]), b


def us_12h_clock(f, b, rng):
    return f.assign(time=[x.strftime("%m/%d/%Y %I:%M %p") for x in _times(f)]), b


def excel_serial_dates(f, b, rng):
    t = _times(f)
    return f.assign(time=[f"{(x - pd.Timestamp('1899-12-30')) / pd.Timedelta(days=1):.6f}" for x in t]), b


def seconds_jitter(f, b, rng):
    """Poll times drift by up to ±40 s around the 15-minute marks."""
    return f.assign(time=_wall_clock(f, rng.integers(-40, 41, len(f)))), b


def times_a_second_early(f, b, rng):
    """Every poll stamped one second before the mark (00:14:59): every sample falls into the step before."""
    return f.assign(time=_wall_clock(f, np.full(len(f), -1))), b


def mixed_5_and_15_min(f, b, rng):
    """Two days re-polled at 5 min (interpolated rows inserted)."""
    t = _times(f)
    sel = (t >= "2025-10-28") & (t < "2025-10-30")
    part = f[sel].copy()
    part.index = pd.DatetimeIndex(t[sel])
    dense = part.drop(columns="time").resample("5min").interpolate()
    dense.insert(0, "time", _iso(dense.index))
    return pd.concat([f[t < "2025-10-28"], dense.reset_index(drop=True), f[t >= "2025-10-30"]], ignore_index=True), b


def one_zone_in_celsius(f, b, rng):
    return f.assign(T_C=(f["T_C"] - 32) / 1.8), b


def airflow_percent_of_max(f, b, rng):
    """Box NW_1's flow exported as % of its maximum (the controller's flow %), declared CFM like the rest."""
    m_max_cfm = 0.61 / 1.2 / 0.000471947
    return f.assign(m_VAV_NW_1=(100 * f["m_VAV_NW_1"] / m_max_cfm).round(0)), b


def airflow_all_percent(f, b, rng):
    """Every box's flow exported as % of its maximum, declared CFM."""
    out = f.copy()
    for c in _box_cols(f):
        out[c] = (100 * f[c] / f[c].quantile(0.999)).round(0)
    return out, b


def airflow_litres_declared_cfm(f, b, rng):
    out = f.copy()
    for c in _box_cols(f):
        out[c] = (f[c] * 0.471947).round(0)
    return out, b


def airflow_m3h_declared_cfm(f, b, rng):
    out = f.copy()
    for c in _box_cols(f):
        out[c] = (f[c] * 1.69901).round(0)
    return out, b


def supply_is_zone(f, b, rng):
    return f.assign(T_supply_AHU2=f["T_C"]), b


def supply_units_swapped(f, b, rng):
    return f.assign(T_supply_AHU1=f["T_supply_AHU2"], T_supply_AHU2=f["T_supply_AHU1"]), b


def zones_swapped_far(f, b, rng):
    return f.assign(T_NW=f["T_E"], T_E=f["T_NW"]), b


def zones_swapped_adjacent(f, b, rng):
    return f.assign(T_NW=f["T_W"], T_W=f["T_NW"]), b


def boxes_swapped_between_zones(f, b, rng):
    return f.assign(m_VAV_NW_1=f["m_VAV_E_1"], m_VAV_E_1=f["m_VAV_NW_1"]), b


def dead_discharge_sensor(f, b, rng):
    """Td of box NW_1 reads its unit's supply air (the sensor sits upstream of the coil)."""
    return f.assign(Td_VAV_NW_1=f["T_supply_AHU1"]), b


def discharge_swapped_no_rh(f, b, rng):
    out = f.assign(Td_VAV_NW_1=f["Td_VAV_S_1"], Td_VAV_S_1=f["Td_VAV_NW_1"])
    return out.drop(columns=[c for c in f.columns if c.startswith("rh_")]), b


def ghi_kw(f, b, rng):
    return f.assign(ghi=f["ghi"] / 1000), b


def ghi_one_hour_late(f, b, rng):
    return f.assign(ghi=f["ghi"].shift(4)), b


def ghi_two_hours_late(f, b, rng):
    return f.assign(ghi=f["ghi"].shift(8)), b


def weather_feed_in_utc(f, b, rng):
    """T_out and ghi joined from a weather feed on UTC (6 h late against the local rows)."""
    return f.assign(ghi=f["ghi"].shift(-24), T_out=f["T_out"].shift(-24)), b


def t_out_stuck_month(f, b, rng):
    out = f.copy()
    out.loc[200 : 200 + 96 * 30, "T_out"] = out.loc[200, "T_out"]
    return out, b


def t_out_stuck_noisy(f, b, rng):
    """T_out frozen for 3 weeks at its last value, with the export's quantisation noise (±0.1 °F)."""
    out = f.copy()
    sl = slice(200, 200 + 96 * 21)
    n = len(out.loc[sl, "T_out"])
    out.loc[sl, "T_out"] = out.loc[200, "T_out"] + rng.choice([-0.1, 0.0, 0.1], n)
    return out, b


def t_out_default_minus_40(f, b, rng):
    """The outdoor sensor disconnected for 4 days reads its default -40."""
    out = f.copy()
    out.loc[1200 : 1200 + 96 * 4, "T_out"] = -40.0
    return out, b


def zone_reads_32f_half_day(f, b, rng):
    """A zone sensor at 0 °C (32 °F, a default) for 12 h."""
    out = f.copy()
    out.loc[1500:1548, "T_NE"] = 32.0
    return out, b


def box_zero_all(f, b, rng):
    return f.assign(m_VAV_S_2=0.0), b


def box_zero_week(f, b, rng):
    """Box S_2's flow sensor reads 0 for 8 days (failed), the box still blowing."""
    out = f.copy()
    out.loc[700 : 700 + 96 * 8, "m_VAV_S_2"] = 0.0
    return out, b


def all_boxes_of_zone_zero_week(f, b, rng):
    out = f.copy()
    for c in ("m_VAV_W_1", "m_VAV_W_2", "m_VAV_W_3"):
        out.loc[700 : 700 + 96 * 8, c] = 0.0
    return out, b


def airflow_offset_negative(f, b, rng):
    out = f.copy()
    for c in ("m_VAV_W_1", "m_VAV_W_2"):
        out[c] = f[c] - 30
    return out, b


def airflow_offset_small(f, b, rng):
    out = f.copy()
    out["m_VAV_W_1"] = f["m_VAV_W_1"] - 4
    return out, b


def one_row(f, b, rng):
    return f.iloc[:1], b


def every_row_one_nan(f, b, rng):
    out = f.copy()
    cols = [c for c in f.columns if c != "time"]
    pick = rng.integers(0, len(cols), len(f))
    for i, j in enumerate(pick):
        out.iat[i, out.columns.get_loc(cols[j])] = np.nan
    return out, b


def t_out_is_return_air(f, b, rng):
    return f.assign(T_out=f[_zone_cols(f)].mean(axis=1).round(1)), b


def hold_last_value_in_outages(f, b, rng):
    """The BMS fills logger outages with the last value (no empty cells)."""
    return f.ffill(), b


def rh_fraction_declared_percent(f, b, rng):
    out = f.copy()
    for c in [c for c in f.columns if c.startswith("rh_")]:
        out[c] = (f[c] / 100).round(2)
    return out, b


def discharge_in_celsius(f, b, rng):
    out = f.copy()
    for c in [c for c in f.columns if c.startswith("Td_")]:
        out[c] = ((f[c] - 32) / 1.8).round(1)
    return out, b


def naive_utc_read_local(f, b, rng):
    t = pd.DatetimeIndex(_times(f)).tz_localize("America/Chicago", ambiguous="infer").tz_convert("UTC")
    return f.assign(time=_iso(t.tz_localize(None))), b


def zone_tenths_of_degree(f, b, rng):
    return f.assign(T_S=(f["T_S"] * 10).round(0)), b


def times_at_interval_end(f, b, rng):
    """Samples labelled at the end of their interval (+15 min): undetectable and harmless (control)."""
    t = pd.DatetimeIndex(_times(f)).tz_localize("America/Chicago", ambiguous="infer") + pd.Timedelta(minutes=15)
    return f.assign(time=[x.isoformat() for x in t]), b


VARIANTS = [
    units_row, semicolon_decimal_comma, missing_spellings, status_text_bad, header_trailing_spaces,
    header_lower_case, unsorted_day, duplicate_times_other_values, file_exported_twice, overlapping_exports,
    dst_hour_once, dst_sorted_by_wall_clock, standard_time_all_year, fixed_offset_text_wall_clock,
    utc_and_offset_mixed, tz_abbreviation_suffix, us_12h_clock, excel_serial_dates, seconds_jitter,
    times_a_second_early, mixed_5_and_15_min, one_zone_in_celsius, airflow_percent_of_max, airflow_all_percent,
    airflow_litres_declared_cfm, airflow_m3h_declared_cfm, supply_is_zone, supply_units_swapped, zones_swapped_far,
    zones_swapped_adjacent, boxes_swapped_between_zones, dead_discharge_sensor, discharge_swapped_no_rh, ghi_kw,
    ghi_one_hour_late, ghi_two_hours_late, weather_feed_in_utc, t_out_stuck_month, t_out_stuck_noisy,
    t_out_default_minus_40, zone_reads_32f_half_day, box_zero_all, box_zero_week, all_boxes_of_zone_zero_week,
    airflow_offset_negative, airflow_offset_small, one_row, every_row_one_nan, t_out_is_return_air,
    hold_last_value_in_outages, rh_fraction_declared_percent, discharge_in_celsius, naive_utc_read_local,
    zone_tenths_of_degree, times_at_interval_end,
]  # fmt: skip


# --------------------------------------------------------------------------- running
def _mean_rms(eval_json: Path) -> float | None:
    try:
        d = json.loads(eval_json.read_text())
        return float(d["models"][0]["table"]["all"]["mean"])
    except (OSError, ValueError, KeyError, IndexError, TypeError):
        return None


def run_one(name, data: Path, building: Path, clean: dict, work: Path) -> dict:
    from hvacfmu.data import check

    rep = check(data, building)
    new_warnings = [w for w in rep.warnings if _key(w) not in clean["warning_keys"]]
    out = {"variant": name, "check_exit": rep.exit_code, "problems": rep.problems[:3], "warnings": new_warnings[:3]}
    if rep.exit_code == 1:
        out["outcome"] = "refused"
        return out
    model = work / "zones.json"
    fit = _cli("fit", data, "-b", building, "-m", "zones", "-o", model)
    if fit.returncode != 0:
        out["outcome"] = "refused"
        out["problems"] = [fit.stderr.strip().splitlines()[-1] if fit.stderr.strip() else f"fit exit {fit.returncode}"]
        return out
    own = _cli("evaluate", data, "-b", building, "--model", model, "--json", work / "own.json")
    true = _cli("evaluate", clean["data"], "-b", clean["building"], "--model", model, "--json", work / "true.json")
    out["rms_own"] = _mean_rms(work / "own.json") if own.returncode == 0 else None
    out["rms_true"] = _mean_rms(work / "true.json") if true.returncode == 0 else None
    if own.returncode != 0:
        out["evaluate_error"] = (own.stderr.strip().splitlines() or [""])[-1]
    base = clean["rms"]
    wrong = []
    for key in ("rms_true", "rms_own"):
        v = out.get(key)
        if v is None:
            wrong.append(f"{key} missing")
        elif abs(v - base) > max(WRONG_FACTOR * base - base, WRONG_ABS):
            wrong.append(f"{key} {v:.3f} K vs clean {base:.3f} K")
    out["wrong"] = wrong
    out["outcome"] = "warned" if new_warnings else "silent"
    return out


def _key(warning: str) -> str:
    """A warning without its numbers (so the clean export's notes match the variant's)."""
    import re

    return re.sub(r"[-+]?\d[\d.:T-]*", "#", warning)[:80]


#: Fragments of the messages the session-15 fixes added (a false alarm is one of them on a clean export).
NEW_MESSAGES = ("from the zone air before and after that run",)


def false_alarms(dirs, out: Path) -> None:
    """The loader (where the new checks run) on clean exports (folders with building.toml and measurements.*).

    Any message of :data:`NEW_MESSAGES` there is a false alarm. :func:`hvacfmu.data.load_measurements` is the
    stage of ``check`` that runs the column checks; the rest of ``check`` (resampling, clock, box map) is unchanged.
    """
    from hvacfmu.data import load_measurements
    from hvacfmu.errors import DataError

    with open(out, "w") as fh:
        for d in map(Path, dirs):
            data = next(iter(sorted(d.glob("measurements.*"))), None)
            if data is None or not (d / "building.toml").exists():
                continue
            try:
                _, rep = load_measurements(data, d / "building.toml")
                messages, status = list(rep.warnings), "loaded"
            except DataError as exc:
                messages, status = str(exc).splitlines(), "refused"
            hits = [m for m in messages if any(f in m for f in NEW_MESSAGES)]
            r = {"export": d.name, "status": status, "new_messages": hits}
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            print(f"{d.name}: {status}, new messages {len(hits)}", *hits[:1], flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="/tmp/redteam_s15", help="work directory")
    ap.add_argument("--table", nargs=2, metavar=("BEFORE", "AFTER"), help="print the markdown table of two results")
    ap.add_argument("--false-alarms", nargs="*", metavar="DIR", help="only run check on these clean exports")
    ap.add_argument("--only", nargs="*", help="variant names to run (default all)")
    ap.add_argument("--results", default=None, help="JSON-lines file (default OUT/results.jsonl)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.table:
        print(table(Path(args.table[0]), Path(args.table[1])))
        return
    if args.false_alarms is not None:
        false_alarms(args.false_alarms, Path(args.results) if args.results else out / "false_alarms.jsonl")
        return
    clean_dir = out / "clean"
    if not (clean_dir / "measurements.csv").exists():
        r = _cli("generate", clean_dir, *GENERATE)
        if r.returncode:
            sys.exit(r.stderr)
    data, building = clean_dir / "measurements.csv", clean_dir / "building.toml"
    from hvacfmu.data import check

    clean_rep = check(data, building)
    if not (clean_dir / "eval.json").exists():
        _cli("fit", data, "-b", building, "-m", "zones", "-o", clean_dir / "zones.json")
        _cli("evaluate", data, "-b", building, "--model", clean_dir / "zones.json", "--json", clean_dir / "eval.json")
    clean = {
        "data": data,
        "building": building,
        "warning_keys": {_key(w) for w in clean_rep.warnings},
        "rms": _mean_rms(clean_dir / "eval.json"),
    }
    print(f"clean export: check exit {clean_rep.exit_code}, zones mean 24-h RMS {clean['rms']:.3f} K", flush=True)
    frame = pd.read_csv(data, dtype={"time": str})
    btext = building.read_text()
    results = Path(args.results) if args.results else out / "results.jsonl"
    wanted = set(args.only or [v.__name__ for v in VARIANTS])
    with open(results, "w") as fh:
        for i, variant in enumerate(VARIANTS):
            name = variant.__name__
            if name not in wanted:
                continue
            work = out / name
            work.mkdir(parents=True, exist_ok=True)
            got, btext2 = variant(frame.copy(), btext, np.random.default_rng(i))
            vdata = work / "measurements.csv"
            if isinstance(got, str):
                vdata.write_text(got)
            else:
                got.to_csv(vdata, index=False)
            (work / "building.toml").write_text(btext2)
            r = run_one(name, vdata, work / "building.toml", clean, work)
            fh.write(json.dumps(r, default=str) + "\n")
            fh.flush()
            print(_row(r), flush=True)


def _cell(r) -> str:
    """'refused', 'warned' or 'silent', with the RMS on its own and the clean data when fitted, '**wrong**' if so."""
    if r is None:
        return "–"
    text = r["outcome"] + f" ({r['check_exit']})"
    if "rms_own" in r:
        own, true = (f"{r[k]:.3f}" if r.get(k) is not None else "–" for k in ("rms_own", "rms_true"))
        text += f"; {own} / {true} K"
    if r.get("wrong"):
        text += " **wrong**" if r["outcome"] == "silent" else " wrong"
    return text


def table(before: Path, after: Path) -> str:
    """Markdown table of two results files (before and after the fixes), one row per variant."""
    b = {r["variant"]: r for r in map(json.loads, before.read_text().splitlines())}
    a = {r["variant"]: r for r in map(json.loads, after.read_text().splitlines())}
    lines = ["| variant | before | after | what the user sees (after) |", "| --- | --- | --- | --- |"]
    for v in VARIANTS:
        n = v.__name__
        r = a.get(n) or b.get(n)
        if r is None:
            continue
        msg = (r.get("problems") or r.get("warnings") or [""])[0].replace("|", "/").replace("measurements.csv: ", "")
        msg = (msg[:150] + " ...") if len(msg) > 150 else msg
        lines.append(f"| `{n}` | {_cell(b.get(n))} | {_cell(a.get(n))} | {msg} |")
    return "\n".join(lines)


def _row(r) -> str:
    msg = (r.get("problems") or r.get("warnings") or [""])[0]
    wrong = "; ".join(r.get("wrong", [])) or ("-" if r["outcome"] == "refused" else "right")
    return f"| {r['variant']} | {r['outcome']} (exit {r['check_exit']}) | {wrong} | {msg[:160]} |"


if __name__ == "__main__":
    main()
