"""Probe (session 21, issue 15): what a false ``dst_shift`` on a clean emulator building follows.

The emulator's occupancy and HVAC schedule follow the local clock; its outdoor temperature's diurnal cycle follows
local standard time and the sun follows solar time. While daylight saving is on, both of the latter sit one hour
late on the local clock -- the signature of the injected ``internal_gain_schedule:kind=dst`` effect. This probe
regenerates a clean building with the weather moved onto the local clock (``sun``: the sun's position, hence every
irradiance, computed one hour later while daylight saving is on; ``tout``: the diurnal cycle of the outdoor
temperature likewise; ``both``), the same random draws, and diagnoses it with main's defaults, recording every
``dst_shift`` screen. ``regen`` regenerates the dataset untouched through the same path (a control).
``--fake-dst DATE`` moves the change the diagnosis sees to a placebo date; ``--hold-sunrise`` and ``--hold-timing``
add the day's sunrise hour, or its morning irradiance share and morning ``T_out``, to the weather the step test
holds. The first screen of each run also records a within-side placebo (:func:`placebo`). Nothing in the library
changes (the functions are wrapped for the run only). Findings: ``dstfalse_s21.md``.

    python3 benchmarks/dstfalse_s21.py --only quad4-6:asis,quad4-6:sun [--results FILE]
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

DST = "internal_gain_schedule:kind=dst"
#: name -> (layout, seed, step [s] or None, effects)
BUILDINGS = {
    "quad4-6": ("quad4", 6, 900.0, ()),
    "row4-30-5min": ("row4", 30, 300.0, ()),
    "fresh-a18": ("quad4", 6, 900.0, ("solar_gain:zone=NE,facade=N,shgc=0.42",)),
    "quad4-6-cold": ("quad4", 6, 900.0, (), {"climate": "cold"}),
    # injected shifts of benchmarks/dst_s18.py
    "sdh-0-dst": ("sdh", 0, None, (DST,)),
    "sdh-1-dst": ("sdh", 1, None, (DST,)),
    "sdh-2-dst": ("sdh", 2, None, (DST,)),
    "sdh-4-dst": ("sdh", 4, None, (DST,)),
    "sdh-5-dst": ("sdh", 5, None, (DST,)),
    "sdh-1-dst+reheat": ("sdh", 1, None, (DST, "reheat:power=4000")),
    "row4-901-dst": ("row4", 31, 900.0, (DST,)),
    "core9-902-dst": ("core9", 32, 900.0, (DST,)),
    "quad4-28-dst": ("quad4", 28, 900.0, (DST,)),
}
#: asis: the cached dataset; regen: generated again through this probe's path, weather untouched (a control);
#: sun / tout / both: the sun, the outdoor temperature's diurnal cycle, or both on the local clock
VARIANTS = ("asis", "regen", "sun", "tout", "both")
DATA = Path("/tmp/s21/dstfalse-data")


def _local_clock_index(index: pd.DatetimeIndex) -> pd.DatetimeIndex:
    """``index`` moved one hour later while daylight saving is on: solar and standard-time quantities computed on
    it follow the local clock (no jump at the change)."""
    off = (index.tz_localize(None) - index.tz_convert("UTC").tz_localize(None)).total_seconds().to_numpy()
    dst = off - off.min()
    return pd.DatetimeIndex(index.tz_convert("UTC") + pd.to_timedelta(dst, unit="s")).tz_convert(index.tz)


def _patched_weather(variant):
    import hvacfmu.emulator.weather as wmod

    orig = wmod.synthetic_weather

    def weather(index, rng, *a, **k):
        rng2 = copy.deepcopy(rng)
        w0 = orig(index, rng, *a, **k)
        if variant in ("asis", "regen"):
            return w0
        w1 = orig(_local_clock_index(index), rng2, *a, **k)
        out = dict(w0)
        if variant in ("sun", "both"):
            for key in ("ghi", "ghi_clear", "I_N", "I_E", "I_S", "I_W"):
                out[key] = w1[key]
        if variant in ("tout", "both"):
            out["T_out"] = w1["T_out"]
        return out

    return weather


def dataset(building: str, variant: str):
    from hvacfmu.emulator import cached_dataset, generate
    from hvacfmu.emulator.generate import GeneratedPaths

    layout, seed, _, effects, *more = BUILDINGS[building]
    opts = more[0] if more else {}
    if variant == "asis":
        return cached_dataset(weeks=16, seed=seed, effects=list(effects), layout=layout, **opts)
    out = DATA / f"{building}-{variant}"
    paths = GeneratedPaths(out / "measurements.parquet", out / "building.toml", out / "truth.json")
    if all(p.exists() for p in (paths.measurements, paths.building, paths.truth)):
        return paths
    import importlib

    sim = importlib.import_module("hvacfmu.emulator.simulate")

    orig = sim.synthetic_weather
    sim.synthetic_weather = _patched_weather(variant)
    try:
        return generate(out, weeks=16, seed=seed, effects=list(effects), fmt="parquet", layout=layout, **opts)
    finally:
        sim.synthetic_weather = orig


def _with_sunrise(day_weather):
    """``_day_weather`` plus ``sunrise``: each row carries its local day's first hour with facade irradiance
    above 10 W/m² (the sun's timing on the local clock, which jumps an hour at the change and drifts with the
    day length within each side)."""

    def wrapped(sig):
        out = day_weather(sig)
        irr = out.get("irradiance")
        if irr is None:
            return out
        idx = sig.index
        hour = np.asarray(idx.hour + idx.minute / 60.0, dtype=float)
        day = np.unique(np.array(idx.date), return_inverse=True)[1]
        first = np.full(day.max() + 1, np.nan)
        lit = np.flatnonzero(irr > 10.0)
        # the first lit row of each day (rows are in time order)
        for d, h in zip(day[lit][::-1], hour[lit][::-1]):
            first[d] = h
        out["sunrise"] = first[day]
        return out

    return wrapped


def _with_timing(day_weather, window=(6.0, 12.0)):
    """``_day_weather`` plus the weather's timing on the local clock: ``morning_share`` (the share of the day's
    facade irradiance that falls in the local hours ``window``) and ``morning_T_out`` (the window's mean outdoor
    temperature minus the day's). Both jump at the change when the weather keeps solar/standard time."""

    def wrapped(sig):
        out = day_weather(sig)
        idx = sig.index
        hour = np.asarray(idx.hour + idx.minute / 60.0, dtype=float)
        win = (hour >= window[0]) & (hour < window[1])
        day = np.unique(np.array(idx.date), return_inverse=True)[1]
        nd = day.max() + 1

        def per_day(v, sel):
            ok = sel & np.isfinite(v)
            return np.bincount(day[ok], weights=v[ok], minlength=nd), np.bincount(day[ok], minlength=nd)

        irr = out.get("irradiance")
        if irr is not None:
            s_win, _ = per_day(irr, win)
            s_all, _ = per_day(irr, np.ones_like(win))
            with np.errstate(invalid="ignore", divide="ignore"):
                out["morning_share"] = (s_win / s_all)[day]
        if "T_out" in out:
            t = out["T_out"]
            s_win, n_win = per_day(t, win)
            s_all, n_all = per_day(t, np.ones_like(win))
            with np.errstate(invalid="ignore", divide="ignore"):
                out["morning_T_out"] = (s_win / n_win - s_all / n_all)[day]
        return out

    return wrapped


def _fake_dst(date: str):
    """A ``dst_active`` whose change falls at local midnight of ``date`` (a placebo date: True before it)."""
    cut = pd.Timestamp(date)

    def dst_active(index):
        index = pd.DatetimeIndex(index)
        if index.tz is None or len(index) == 0:
            return np.zeros(len(index), dtype=bool)
        return np.asarray(index.tz_localize(None) < cut)

    return dst_active


def placebo(sig, W, options, exclude_dates=()) -> dict:
    """The screen's statistics at a placebo change inside each side of the real change.

    The training rows of one side (daylight saving on, or off) are split at the median date of their
    weekdays and compared as if the clock changed there (the earlier half playing the daylight-saving side):
    no clock changes inside a side, so a gain schedule on another clock shows no shift there, while a
    seasonal drift of the weekday profile does. Reports the morning lag, its R² and scale, the evening's R²
    at the legal lag and at the opposite one, and the step t with the day's weather held.
    """
    import dataclasses

    import hvacfmu.models.causes.internal_gain_schedule as igs

    gains = igs.apparent_gains(sig, options["_resid_all"])
    rows = W.rows
    if exclude_dates:
        iso = np.array([d.isoformat() for d in sig.index.date])
        rows = rows[~np.isin(iso[rows], sorted(exclude_dates))]
    dates = np.array(sig.index.date)
    wd = sig.index.day_of_week.to_numpy()
    steps = int(round(3600 / sig.step))
    out = {}
    for side, name in ((True, "dst_side"), (False, "standard_side")):
        r = rows[sig.dst[rows] == side]
        wk = np.unique(dates[r][wd[r] < 5])
        if len(wk) < 2 * igs.DST_MIN_DAYS:
            out[name] = {"skipped": f"{len(wk)} weekdays"}
            continue
        cut = wk[len(wk) // 2]
        fake = dates < cut
        s2 = dataclasses.replace(sig, dst=fake) if dataclasses.is_dataclass(sig) else sig
        ev = igs.dst_profile_lag(s2, gains, r)
        if not ev.get("seasons"):
            out[name] = {"skipped": "no season with both halves", "cut": str(cut)}
            continue
        legal = steps  # the real shifts found are all gains late on the daylight-saving side (lag > 0)
        eve = igs.dst_profile_lag(s2, gains, r, window=igs.DST_EVENING_H)
        st = igs.dst_step_given_weather(s2, gains, r, legal)
        out[name] = {
            "cut": str(cut),
            "morning_lag_h": ev["lag_h"],
            "morning_r2": ev["r2_at_lag"],
            "morning_scale": ev["scale_at_lag"],
            "morning_r2_at_legal": ev["r2_by_lag"].get(str(legal)),
            "evening_r2_legal": eve.get("r2_by_lag", {}).get(str(legal)),
            "evening_r2_opposite": eve.get("r2_by_lag", {}).get(str(-legal)),
            "step_jump": st.get("jump"),
            "step_jump_given_weather": st.get("jump_given_weather"),
            "step_t": st.get("t"),
        }
    return out


def run(building: str, variant: str, hold_sunrise: bool = False, hold_timing: bool = False, fake_dst=None) -> dict:
    import importlib

    signals = importlib.import_module("hvacfmu.models.causes.signals")
    extended = importlib.import_module("hvacfmu.models.extended")
    import hvacfmu.models.causes.internal_gain_schedule as igs
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose

    step = BUILDINGS[building][2]
    t0 = time.time()
    paths = dataset(building, variant)
    t_gen = time.time() - t0
    calls = []
    screen = igs.dst_candidate

    def recorded(sig, W, options, exclude_dates=()):
        c = screen(sig, W, options, exclude_dates=exclude_dates)
        if not options.get("_dst_retest") and not any("placebo" in x for x in calls) and c.evidence.get("seasons"):
            c_ev = dict(c.evidence)
            try:
                c_ev["placebo"] = placebo(sig, W, options, exclude_dates)
            except Exception as exc:  # a probe: record, do not stop the run
                c_ev["placebo"] = {"error": repr(exc)}
            calls.append({"status": c.status, "reason": c.reason, "retest": False, "evidence": c_ev, "placebo": True})
            return c
        calls.append(
            {"status": c.status, "reason": c.reason, "retest": bool(options.get("_dst_retest")), "evidence": c.evidence}
        )
        return c

    igs.dst_candidate = recorded
    day_weather = igs._day_weather
    if hold_sunrise:
        igs._day_weather = _with_sunrise(day_weather)
    if hold_timing:
        igs._day_weather = _with_timing(igs._day_weather)
    real_dst = signals.dst_active
    if fake_dst:
        igs.dst_active = signals.dst_active = extended.dst_active = _fake_dst(fake_dst)
    try:
        ds = prepare(paths.measurements, paths.building, **({"step": step} if step else {}))
        c0 = time.process_time()
        rep = diagnose(ds, progress=False)
        cpu = time.process_time() - c0
    finally:
        igs.dst_candidate = screen
        igs._day_weather = day_weather
        igs.dst_active = signals.dst_active = extended.dst_active = real_dst
    dst = [f for f in rep.findings if f["location"].get("variant") == "dst_shift"]
    return {
        "building": building,
        "variant": variant,
        "hold_sunrise": hold_sunrise,
        "hold_timing": hold_timing,
        "fake_dst": fake_dst,
        "dst_found": bool(dst),
        "dst_finding": dst[0] if dst else None,
        "findings": [(f["cause"], f["location"]) for f in rep.findings],
        "screens": [
            {
                "status": c["status"],
                "reason": c["reason"],
                "retest": c["retest"],
                "morning_lag_h": c["evidence"].get("lag_h"),
                "morning_r2": c["evidence"].get("r2_at_lag"),
                "morning_scale": c["evidence"].get("scale_at_lag"),
                "morning_r2_by_lag": c["evidence"].get("r2_by_lag"),
                "evening": c["evidence"].get("evening"),
                "step": c["evidence"].get("step_given_weather"),
                "placebo": c["evidence"].get("placebo"),
            }
            for c in calls
        ],
        "generate_s": t_gen,
        "diagnose_cpu_s": cpu,
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", required=True, help="comma-separated building:variant")
    ap.add_argument("--results", default="dstfalse_s21.jsonl")
    ap.add_argument("--hold-timing", action="store_true", help="hold the day's morning irradiance share and T_out")
    ap.add_argument("--fake-dst", help="a placebo change date (YYYY-MM-DD): daylight saving 'on' before it")
    ap.add_argument("--hold-sunrise", action="store_true", help="hold the day's sunrise hour too in the step test")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    for item in args.only.split(","):
        b, v = item.split(":")
        r = run(b, v, args.hold_sunrise, args.hold_timing, args.fake_dst)
        with open(args.results, "a") as f:
            f.write(json.dumps(r, default=str) + "\n")
        first = next((s for s in r["screens"] if not s["retest"]), {})
        print(
            f"{b:16s} {v:5s}{' +sunrise' if args.hold_sunrise else ''}{' +timing' if args.hold_timing else ''}{' fake ' + args.fake_dst if args.fake_dst else ''} dst found {r['dst_found']!s:5s} "
            f"{(r['dst_finding'] or {}).get('evidence', {}).get('cv', '') if r['dst_finding'] else ''} "
            f"first screen {first.get('status')} lag {first.get('morning_lag_h')} r2 {first.get('morning_r2')} "
            f"| {first.get('reason')} | gen {r['generate_s']:.0f} s cpu {r['diagnose_cpu_s']:.0f} s",
            flush=True,
        )


if __name__ == "__main__":
    main()
