"""Diagnosis test bed on EnergyPlus data: effects injected through the IDF, scored against a clean run.

Issue 15 is judged on buildings built independently of our emulator. EnergyPlus is such a
simulator: this script exports the ASHRAE 90.1 medium office's middle floor (five zones, VAV with
reheat; ``hvacfmu.energyplus.cached_export``) for 26 weeks from 1 January 2017, each case with ONE
effect added to the run's IDF (``extra_idf`` / ``files`` of :func:`hvacfmu.energyplus.generate`;
the building file is still read from the unedited IDF, so the effect is hidden from it, as from a
BMS), and runs ``hvacfmu.diagnose`` with its default options.

Effects (truth recorded per case):

- ``zone_coupling``: a ``ZoneCrossMixing`` of constant flow between two zones that share no surface
  (a duct), conductance ``flow · ρ_site · 1005`` [W/K];
- ``solar_gain``: an ``ElectricEquipment`` whose ``Schedule:File`` is the irradiance on one vertical
  facade (pvlib, isotropic sky, from the EPW's direct normal and diffuse) × an effective area
  (area × SHGC) [m²];
- ``reheat`` (a perimeter heater the BMS does not see): an ``ElectricEquipment`` of ``power`` [W] on
  when the EPW's outdoor temperature is below ``below`` [°C] outside the HVAC's operating hours
  (weekdays 6–22 h, Saturday 6–18 h, local clock);
- ``internal_gain_schedule`` (holiday): two weeks' Monday–Friday made ``Holiday`` special days
  (``RunPeriodControl:SpecialDays``; the prototype's schedules then run their Sunday values, HVAC off);
- ``thermal_mass``: an ``InternalMass`` of ``area`` [m²] of 20 cm concrete in one zone.

Scoring: the EnergyPlus baseline has physics the base model may miss (window solar, furniture
mass), so a finding counts against the **clean run of the same weather**: an injected effect is
*found* when a finding of its cause at its location is in the effect run and not in the clean run;
*masked* when such a finding is in both; a *false* finding is one in the effect run that is neither
the injected effect nor in the clean run. Before diagnosing, each effect's size is measured
(``detectability``): the injected heat [W] on average and over its active hours; a coupling's
exchange ``ua · |T_a − T_b|`` from the effect run's data; a mass's exchange estimated with a
one-node model of the slab driven by the effect run's zone temperature.

Run: ``python3 benchmarks/bench_diagnosis_energyplus.py [--list] [--only 0,3] [--results FILE]
[--summary]`` (one case at a time: about 25 s of EnergyPlus and 15–30 s of diagnosis each on the
shared 2-core machine; exports are cached in ``$HVACFMU_CACHE``). Results: JSON lines, one per case;
a rerun skips cases already in the file. ``benchmarks/diagnosis_energyplus_s8.md`` holds the measured
table and the analysis.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_diagnosis_battery import _brief as _battery_brief  # noqa: E402
from bench_diagnosis_battery import git_commit  # noqa: E402

from hvacfmu.models.heat import CP_AIR  # noqa: E402

PROTOTYPE = "ASHRAE901_OfficeMedium_STD2019_Denver"
FLOOR = "mid"
WEEKS = 26
YEAR = 2017
WEATHERS = {"denver": "usa_co_denver", "chicago": "usa_il_chicago"}
TIMEZONES = {"denver": "America/Denver", "chicago": "America/Chicago"}
#: HVAC operating hours of the prototype (HVACOperationSchd): weekdays 6-22 h, Saturday 6-18 h, local clock.
OCCUPIED = {0: (6, 22), 1: (6, 22), 2: (6, 22), 3: (6, 22), 4: (6, 22), 5: (6, 18)}
Z = "Perimeter_mid_ZN_{}".format

#: The cases, chosen before any effect run (zone 1 faces S, 2 E, 3 N, 4 W; pairs 1+3 and 2+4 share no surface).
CASES = [
    {"id": 0, "weather": "denver", "effect": None},
    {"id": 1, "weather": "chicago", "effect": None},
    {"id": 2, "weather": "denver", "effect": {"cause": "zone_coupling", "zones": [Z(1), Z(3)], "ua": 2000.0}},
    {"id": 3, "weather": "chicago", "effect": {"cause": "zone_coupling", "zones": [Z(2), Z(4)], "ua": 2500.0}},
    # north facade of the north zone (its own facade; the clean Denver run has no solar finding there)
    {"id": 4, "weather": "denver", "effect": {"cause": "solar_gain", "zone": Z(3), "facade": "N", "area": 15.0}},
    # east sun into the south zone: a facade the zone does not have in the building file
    {"id": 5, "weather": "chicago", "effect": {"cause": "solar_gain", "zone": Z(1), "facade": "E", "area": 8.0}},
    {"id": 6, "weather": "denver", "effect": {"cause": "reheat", "zone": Z(3), "power": 3000.0, "below": 0.0}},
    {"id": 7, "weather": "chicago", "effect": {"cause": "reheat", "zone": Z(2), "power": 2500.0, "below": 5.0}},
    {"id": 8, "weather": "denver", "effect": {"cause": "internal_gain_schedule", "weeks": [5, 11]}},
    {"id": 9, "weather": "chicago", "effect": {"cause": "internal_gain_schedule", "weeks": [3, 14]}},
    {"id": 10, "weather": "denver", "effect": {"cause": "thermal_mass", "zone": Z(1), "area": 150.0}},
    {"id": 11, "weather": "chicago", "effect": {"cause": "thermal_mass", "zone": Z(4), "area": 100.0}},
]
CONCRETE = {"thickness": 0.2, "conductivity": 1.95, "density": 2240.0, "specific_heat": 900.0}
#: Interior convection coefficient [W/(m² K)] of the detectability estimate of an InternalMass.
H_MASS = 3.0
FACADE_AZIMUTH = {"N": 0.0, "E": 90.0, "S": 180.0, "W": 270.0}


def epw_path(weather: str) -> Path:
    import pyenergyplus.dataset as ds

    return Path(ds.weather_files[WEATHERS[weather]])


def read_weather(weather: str):
    """The EPW's hourly data of YEAR (pvlib), index = hour end in standard time."""
    import pvlib

    data, _meta = pvlib.iotools.read_epw(epw_path(weather), coerce_year=YEAR)
    return data, _meta


def hour_start(data):
    """Start of each EPW row's hour, local standard time (the EPW's ``hour`` field 1-24 is the hour ending then).

    Read from the EPW's own fields, not from pvlib's index: pvlib 0.16 labels a row with its hour's **start**
    (hour 1 -> 00:00), while this script, written against an older convention, took the index for the hour's end
    and subtracted an hour, which put the heater schedule (and the solar schedule's sun position) one hour late:
    the EnergyPlus heaters of cases 6 and 7 ran 6-7 h with the boxes already on and were off 22-23 h with the boxes
    off (session 17, ``diagnosis_energyplus_s17.md``).
    """
    import pandas as pd

    day = pd.to_datetime({"year": YEAR, "month": data["month"], "day": data["day"]})
    start = day + pd.to_timedelta(data["hour"].astype(int) - 1, unit="h")
    return pd.DatetimeIndex(start).tz_localize(data.index.tz)


def facade_irradiance(weather: str, facade: str) -> np.ndarray:
    """Hourly irradiance [W/m²] on a vertical ``facade`` over the EPW's year (8760 values, hour i = row i)."""
    import pvlib

    data, meta = read_weather(weather)
    mid = hour_start(data) + np.timedelta64(30, "m")
    sp = pvlib.solarposition.get_solarposition(mid, meta["latitude"], meta["longitude"], altitude=meta["altitude"])
    poa = pvlib.irradiance.get_total_irradiance(
        90.0,
        FACADE_AZIMUTH[facade],
        sp["apparent_zenith"].to_numpy(),
        sp["azimuth"].to_numpy(),
        data["dni"].to_numpy(),
        data["ghi"].to_numpy(),
        data["dhi"].to_numpy(),
        albedo=0.2,
        model="isotropic",
    )
    return np.clip(np.nan_to_num(np.asarray(poa["poa_global"], dtype=float)), 0.0, None)


def heater_on(weather: str, below: float) -> np.ndarray:
    """Hourly 0/1: outdoor temperature below ``below`` [°C] outside the HVAC's operating hours (local clock)."""

    data, _ = read_weather(weather)
    start = hour_start(data).tz_convert(TIMEZONES[weather])
    hour = start.hour.to_numpy()
    dow = start.dayofweek.to_numpy()
    occ = np.zeros(len(start), bool)
    for d, (h0, h1) in OCCUPIED.items():
        occ |= (dow == d) & (hour >= h0) & (hour < h1)
    return ((data["temp_air"].to_numpy() < below) & ~occ).astype(float)


def _schedule_file(name: str, values: np.ndarray) -> tuple[str, str]:
    """A Schedule:File object (hourly, standard time, not shifted for daylight saving) and its CSV text."""
    fname = f"{name}.csv"
    obj = f"Schedule:File,{name},,{{run_dir}}/{fname},1,0,8760,Comma,No,60,No;\n"
    return obj, "\n".join(f"{v:.6f}" for v in values) + "\n"


def site_density(weather: str) -> float:
    from hvacfmu.energyplus.hvac import std_air_density

    _data, meta = read_weather(weather)
    return float(std_air_density(meta["altitude"]))


def effect_edit(case: dict) -> tuple[str, dict, dict]:
    """``(extra_idf, files, truth)`` of ``case``'s effect (empty for a clean case)."""
    e = case["effect"]
    if e is None:
        return "", {}, {}
    cause = e["cause"]
    if cause == "zone_coupling":
        a, b = e["zones"]
        rho = site_density(case["weather"])
        flow = e["ua"] / (rho * CP_AIR)
        text = (
            "Schedule:Constant,hvacfmu_always_on,,1;\n"
            f"ZoneCrossMixing,hvacfmu_duct,{a},hvacfmu_always_on,Flow/Zone,{flow:.4f},,,,{b},0;\n"
        )
        return text, {}, {**e, "flow_m3s": flow, "rho": rho}
    if cause in ("solar_gain", "reheat"):
        if cause == "solar_gain":
            values = facade_irradiance(case["weather"], e["facade"]) * e["area"]
            radiant = 0.3
        else:
            values = heater_on(case["weather"], e["below"]) * e["power"]
            radiant = 0.0
        level = float(values.max())
        sched, csv = _schedule_file("hvacfmu_effect", values / level)
        text = sched + (
            f"ElectricEquipment,hvacfmu_effect,{e['zone']},hvacfmu_effect,EquipmentLevel,{level:.1f},,,0,{radiant},0,"
            "hvacfmu;\n"
        )
        return text, {"hvacfmu_effect.csv": csv}, {**e, "design_level_W": level, "hourly_W": values}
    if cause == "internal_gain_schedule":
        import datetime as _dt

        first = _dt.date(YEAR, 1, 1)
        text, dates = "", []
        for w in e["weeks"]:
            monday = first + _dt.timedelta(days=7 * w + (7 - first.weekday()) % 7)
            text += f"RunPeriodControl:SpecialDays,hvacfmu_holiday_{w},{monday.month}/{monday.day},5,Holiday;\n"
            dates += [(monday + _dt.timedelta(days=d)).isoformat() for d in range(5)]
        return text, {}, {**e, "dates": dates}
    if cause == "thermal_mass":
        c = CONCRETE
        text = (
            f"Material,hvacfmu_concrete,MediumRough,{c['thickness']},{c['conductivity']},{c['density']},"
            f"{c['specific_heat']},0.9,0.7,0.7;\n"
            "Construction,hvacfmu_heavy_mass,hvacfmu_concrete;\n"
            f"InternalMass,hvacfmu_mass,hvacfmu_heavy_mass,{e['zone']},,{e['area']};\n"
        )
        cap = e["area"] * c["thickness"] * c["density"] * c["specific_heat"]
        ua = e["area"] / (1.0 / H_MASS + c["thickness"] / 2.0 / c["conductivity"])
        return text, {}, {**e, "capacitance_J_per_K": cap, "ua_W_per_K": ua, "tau_h": cap / ua / 3600.0}
    raise ValueError(f"unknown cause {cause!r}")


def export(case: dict):
    from hvacfmu.energyplus import cached_export

    text, files, _truth = effect_edit(case)
    opts = {"floor": FLOOR, "weeks": WEEKS, "year": YEAR, "weather": WEATHERS[case["weather"]]}
    if text:
        opts.update(extra_idf=text, files=files)
    return cached_export(PROTOTYPE, **opts)


def detectability(case: dict, truth: dict, frame) -> dict:
    """Size of the injected effect over the exported period (see module docstring)."""
    e = case["effect"]
    cause = e["cause"]
    if cause in ("solar_gain", "reheat"):
        data, _ = read_weather(case["weather"])
        hours = hour_start(data).tz_convert(frame.index.tz)
        keep = (hours >= frame.index[0]) & (hours <= frame.index[-1])
        w = truth["hourly_W"][keep]
        on = w > 1.0
        return {
            "mean_W": float(w.mean()),
            "mean_active_W": float(w[on].mean()) if on.any() else 0.0,
            "active_hours": int(on.sum()),
            "peak_W": float(w.max()),
        }
    if cause == "zone_coupling":
        a, b = (frame[f"T_{z}"].to_numpy() for z in e["zones"])
        d = np.abs(a - b)
        return {"mean_abs_dT_K": float(np.nanmean(d)), "mean_exchange_W": float(e["ua"] * np.nanmean(d))}
    if cause == "thermal_mass":
        T = frame[f"T_{e['zone']}"].interpolate().to_numpy()
        dt = 900.0
        Tm = np.empty_like(T)
        Tm[0] = T[:672].mean()
        k = dt * truth["ua_W_per_K"] / truth["capacitance_J_per_K"]
        for i in range(1, len(T)):
            Tm[i] = Tm[i - 1] + k * (T[i - 1] - Tm[i - 1])
        q = truth["ua_W_per_K"] * (T - Tm)
        return {"mean_abs_exchange_W_estimate": float(np.mean(np.abs(q))), "tau_h": truth["tau_h"]}
    if cause == "internal_gain_schedule":
        return {"holiday_days": len(truth["dates"])}
    return {}


def _key(f: dict) -> tuple:
    """A finding's cause and place, without its fitted details (holiday: its dates)."""
    loc = f["location"]
    if f["cause"] == "internal_gain_schedule":
        return (f["cause"], loc.get("variant"), tuple(sorted(loc.get("dates", []))))
    place = tuple((k, tuple(sorted(v)) if isinstance(v, list) else v) for k, v in sorted(loc.items()))
    return (f["cause"], place)


def matches(finding: dict, e: dict, truth: dict) -> bool:
    """``finding`` names the injected effect's cause at its location."""
    loc = finding["location"]
    if finding["cause"] != e["cause"]:
        return False
    if e["cause"] == "zone_coupling":
        return set(loc.get("zones", [])) == set(e["zones"])
    if e["cause"] == "solar_gain":
        return loc.get("zone") == e["zone"] and loc.get("facade") == e["facade"]
    if e["cause"] in ("reheat", "thermal_mass"):
        return loc.get("zone") == e["zone"]
    if e["cause"] == "internal_gain_schedule":
        days = set(loc.get("dates", []))
        return loc.get("variant") == "holiday" and bool(days) and len(days & set(truth["dates"])) >= 0.5 * len(days)
    return False


def same_cause_place(f: dict, g: dict) -> bool:
    """``f`` and ``g`` are the same finding (holidays: sharing at least half of ``f``'s dates)."""
    if f["cause"] == "internal_gain_schedule" and g["cause"] == f["cause"]:
        a, b = f["location"], g["location"]
        if a.get("variant") != b.get("variant"):
            return False
        if a.get("variant") != "holiday":
            return True
        da, db = set(a.get("dates", [])), set(b.get("dates", []))
        return bool(da) and len(da & db) >= 0.5 * len(da)
    return _key(f) == _key(g)


def _brief(c: dict) -> dict:
    """The battery's record of a finding / candidate, with the rival it was compared with and its parameters."""
    ev = c.get("evidence") or {}
    out = _battery_brief(c)
    if isinstance(ev, dict) and ev.get("rival"):
        out["rival"] = ev["rival"]
    params = c.get("parameters")
    if params:
        out["parameters"] = {k: v.get("value") if isinstance(v, dict) else v for k, v in params.items()}
    return out


def run_case(case: dict) -> dict:
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose

    t0 = time.perf_counter()
    paths = export(case)
    t_export = time.perf_counter() - t0
    ds = prepare(paths.measurements, paths.building)
    _text, _files, truth = effect_edit(case)
    det = detectability(case, truth, ds.frame) if case["effect"] else {}
    t0, c0 = time.perf_counter(), time.process_time()
    rep = diagnose(ds, progress=False)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    d = rep.to_dict()
    commit = git_commit()
    return {
        "case": case,
        "truth": {k: v for k, v in truth.items() if k != "hourly_W"},
        "detectability": det,
        "commit": commit,
        "export": str(paths.outdir),
        "weeks": [(str(w.start.date()), w.season, w.train) for w in ds.weeks],
        "findings": [_brief(f) for f in d["findings"]],
        "candidates": [_brief(c) for c in d["candidates"] if (c.get("test") or {}).get("delta_bic") is not None],
        "verdict": d.get("verdict"),
        "heldout": {k: d["heldout"].get(k) for k in ("before", "after", "gain_percent") if k in d["heldout"]},
        "diagnose_wall_s": wall,
        "diagnose_cpu_s": cpu,
        "export_wall_s": t_export,
    }


#: A reheat coil "runs" when its discharge air is this much above its unit's supply air [K] ...
COIL_RUNS_K = 1.0
#: ... on at least this share of the rows (1 per mille: about 4 h of the 26 weeks; the Denver Core's coil heats its
#: air by up to 20 K on 0.4-0.9 % of the rows, Chicago's on 2.6-3.4 %: both run)
COIL_RUNS_SHARE = 0.001
_PHYSICS: dict = {}


def _export_facts(export: str) -> dict:
    """What the exported EnergyPlus model contains, from its files (cached per export directory):
    ``reheat_zones`` (every box of the zone a ``...:Reheat`` terminal whose coil runs in the data) and
    ``windows`` (``(zone, facade)`` with window area in the building file)."""
    if export in _PHYSICS:
        return _PHYSICS[export]
    import pandas as pd

    from hvacfmu.building import load_building

    d = Path(export)
    info = json.loads((d / "energyplus.json").read_text())
    b = load_building(d / "building.toml")
    frame = pd.read_parquet(d / "measurements.parquet")
    coil: dict = {}
    for box in info.get("boxes", []):
        td, ts = f"Td_{box['name']}", f"T_supply_{box['ahu']}"
        runs = False
        if box.get("terminal_type", "").endswith(":Reheat") and td in frame and ts in frame:
            runs = bool(((frame[td] - frame[ts]) > COIL_RUNS_K).mean() >= COIL_RUNS_SHARE)
        coil.setdefault(box["zone"], []).append(runs)
    facts = {
        "reheat_zones": {z for z, r in coil.items() if r and all(r)},
        "windows": {(z.name, f.orientation) for z in b.zones for f in z.facades if f.window_area > 0},
    }
    _PHYSICS[export] = facts
    return facts


def energyplus_physics(f: dict, r: dict) -> str | None:
    """Why the EnergyPlus model contains finding ``f``'s cause at its place, or None (a false finding).

    The clean run is the bed's reference (a finding in it is the baseline the diagnosis sees); a finding of an
    effect run outside it was counted false whatever it named. Here it is checked against the model's physics
    as the emulator's truth does (:func:`hvacfmu.diagnosis.truth.finding_supported`: reheat coils, window solar,
    bilinear supply air, wall/slab mass): ``reheat`` (either form) in a zone whose boxes are reheat terminals
    whose coils run in the data; ``solar_gain`` through a facade of the zone with windows;
    ``supply_air_bilinear`` (every box's supply air delivers ``m cp (T_supply − T_zone)``); ``thermal_mass``
    (every zone's walls and slabs). A column (``unused_input``) names no mechanism: not physics, even when the
    column carries the discharge heat.
    """
    loc = f["location"]
    facts = _export_facts(r["export"])
    if f["cause"] == "reheat" and loc.get("zone") in facts["reheat_zones"]:
        return "reheat coil of the zone's box runs"
    if f["cause"] == "solar_gain" and (loc.get("zone"), loc.get("facade")) in facts["windows"]:
        return "windows on that facade"
    if f["cause"] == "supply_air_bilinear":
        return "supply air heat m cp (T_supply - T_zone)"
    if f["cause"] == "thermal_mass":
        return "the zone's walls and slabs"
    return None


def score(results: dict) -> list:
    """Per effect case: found / masked / missed and false findings against the clean run of its weather.

    ``false``: in the effect run, not the effect, not in the clean run (the bed's count since session 8);
    ``false_physics``: those of them the EnergyPlus model does not contain (:func:`energyplus_physics`).
    """
    clean = {r["case"]["weather"]: r for r in results.values() if r["case"]["effect"] is None}
    rows = []
    for cid in sorted(results):
        r = results[cid]
        e = r["case"]["effect"]
        base = clean.get(r["case"]["weather"])
        if e is None:
            rows.append({"id": cid, "cause": "clean", "outcome": "clean", "false": [], "masked": []})
            continue
        if base is None:
            rows.append({"id": cid, "cause": e["cause"], "outcome": "no clean run", "false": [], "masked": []})
            continue
        in_clean = [f for f in r["findings"] if any(same_cause_place(f, g) for g in base["findings"])]
        new = [f for f in r["findings"] if f not in in_clean]
        hit = [f for f in new if matches(f, e, r["truth"])]
        masked = [f for f in in_clean if matches(f, e, r["truth"])]
        false = [f for f in new if not matches(f, e, r["truth"])]
        gone = [g for g in base["findings"] if not any(same_cause_place(g, f) for f in r["findings"])]
        outcome = "found" if hit else ("masked" if masked else "missed")
        absent = [f for f in false if energyplus_physics(f, r) is None]
        rows.append(
            {
                "id": cid,
                "cause": e["cause"],
                "outcome": outcome,
                "false": false,
                "false_physics": absent,
                "masked": masked,
                "gone": gone,
            }
        )
    return rows


def _place(f: dict) -> str:
    loc = f["location"]
    if f["cause"] == "internal_gain_schedule" and loc.get("dates"):
        return f"{loc.get('variant')} {loc['dates'][0]}..{loc['dates'][-1]} ({len(loc['dates'])} d)"
    return ", ".join(
        f"{k}={'+'.join(map(str, v)) if isinstance(v, list) else v}" for k, v in loc.items() if k != "cause"
    )


def print_summary(results: dict) -> None:
    rows = score(results)
    for row in rows:
        r = results[row["id"]]
        c = r["case"]
        e = c["effect"]
        what = "clean" if e is None else f"{e['cause']} " + _place({"cause": e["cause"], "location": e})
        print(f"case {row['id']:2d} {c['weather']:8s} {what}")
        if r["detectability"]:
            print("    size: " + ", ".join(f"{k} {v:.4g}" for k, v in r["detectability"].items()))
        for f in r["findings"]:
            tag = ""
            if e is not None:
                tag = "INJECTED" if matches(f, e, r["truth"]) else ("FALSE" if f in row["false"] else "in clean run")
            print(
                f"    {f['cause']:24s} {_place(f):55s} cv {f['cv_gain_percent'] or 0:+6.1f} % t {f['cv_t'] or 0:5.1f}  {tag}"
            )
        base = next(
            (b for b in results.values() if b["case"]["effect"] is None and b["case"]["weather"] == c["weather"]), None
        )
        for f in row["false"]:
            same = [g for g in (base or {}).get("candidates", []) if same_cause_place(f, g)]
            was = "; ".join(
                f"{g['status']} (dBIC {g['delta_bic'] or 0:.0f}, cv {g['cv_gain_percent'] or 0:+.1f} % t {g['cv_t'] or 0:.1f})"
                for g in same
            )
            why = energyplus_physics(f, r)
            print(
                f"      FALSE {f['cause']} {_place(f)}: in the clean run {was or 'not a screened candidate'}"
                + (f" [EnergyPlus physics: {why}]" if why else " [not EnergyPlus physics]")
            )
        if row.get("gone"):
            print("    clean-run findings absent here: " + "; ".join(f"{g['cause']} {_place(g)}" for g in row["gone"]))
        print(
            f"    -> {row['outcome']}, false {len(row['false'])} ({len(row.get('false_physics', []))} not EnergyPlus "
            f"physics)  (diagnose {r['diagnose_wall_s']:.0f} s wall, "
            f"{r['diagnose_cpu_s']:.0f} s CPU; export {r['export_wall_s']:.0f} s)"
        )
    table: dict = {}
    by_cause: dict = {}
    for row in rows:
        t = table.setdefault(row["cause"], {"found": 0, "masked": 0, "missed": 0, "false": 0, "absent": 0, "cases": 0})
        t["cases"] += 1
        if row["outcome"] in t:
            t[row["outcome"]] += 1
        t["false"] += len(row["false"])
        t["absent"] += len(row.get("false_physics", []))
        for f in row["false"]:
            k = by_cause.setdefault(f["cause"], [0, 0])
            k[0] += 1
            k[1] += f in row.get("false_physics", [])
    head = f"\n{'cause':26s} {'found':>6s} {'masked':>6s} {'missed':>6s} {'false':>6s} {'absent':>6s} {'cases':>6s}"
    print(head)
    for cause, t in table.items():
        print(
            f"{cause:26s} {t['found']:6d} {t['masked']:6d} {t['missed']:6d} {t['false']:6d} {t['absent']:6d} "
            f"{t['cases']:6d}"
        )
    print("(false: not the effect and not in the clean run; absent: of those, not EnergyPlus physics)")
    print(
        "false findings by cause (all / not EnergyPlus physics): "
        + ", ".join(f"{c} {a}/{b}" for c, (a, b) in sorted(by_cause.items(), key=lambda kv: -kv[1][0]))
    )


def _load(path: Path) -> dict:
    out = {}
    if path.exists():
        for line in path.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                out[r["case"]["id"]] = r
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--list", action="store_true", help="print the cases and exit")
    ap.add_argument("--only", default="", help="comma-separated case ids")
    ap.add_argument("--results", default="energyplus-diagnosis-results.jsonl")
    ap.add_argument("--summary", action="store_true", help="print the results file's table and exit")
    args = ap.parse_args()
    if args.list:
        for c in CASES:
            print(json.dumps(c))
        return
    path = Path(args.results)
    results = _load(path)
    if not args.summary:
        only = {int(x) for x in args.only.split(",") if x.strip()}
        for case in CASES:
            if (only and case["id"] not in only) or case["id"] in results:
                continue
            r = run_case(case)
            results[case["id"]] = r
            with path.open("a") as fh:
                fh.write(json.dumps(r, default=str) + "\n")
            print(f"case {case['id']} done: {len(r['findings'])} findings, diagnose {r['diagnose_wall_s']:.0f} s")
    print_summary(results)


if __name__ == "__main__":
    main()
