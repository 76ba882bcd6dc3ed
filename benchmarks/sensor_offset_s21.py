"""Session 21: the ``sensor_offset`` cause on data it was not tuned on (false alarms, every rule's margin) and
on two changes (a sensor put back, two zones' sensors changed at different dates).

``--clean``: clean emulated cases on seeds >= 2040 (never used before): six layouts, 15 and 5-min steps, autumn,
winter and spring starts, a cold climate, the reheat and night-off modes, and building-wide set-point changes
(every zone's set points moved at one date: :func:`setpoint_change`, a patch of the emulator's controllers made
here only, the library's emulator has no such option). ``--eplus DIR``: an EnergyPlus export (``measurements.parquet``
and ``building.toml``). ``--two``: the two-change cases. Every case is diagnosed with the default options; every
``sensor_offset`` candidate is printed with its screen numbers and each rule's margin (value over threshold:
> 1 passes), then the findings it left. Run: ``python3 benchmarks/sensor_offset_s21.py --clean [--only 0,3]``
(see ``benchmarks/sensor_offset_s21.md``).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

#: (layout, seed, step [s], generate options, building-wide set-point change or None)
CLEAN = [
    ("quad4", 2040, 900.0, {}, None),
    ("ell5", 2041, 900.0, {}, None),
    ("stack4", 2042, 900.0, {}, None),
    ("row4", 2043, 900.0, {}, None),
    ("core9", 2044, 900.0, {}, None),
    ("sdh", 2045, 900.0, {}, None),
    ("quad4", 2046, 300.0, {}, None),
    ("row4", 2047, 300.0, {}, None),
    ("core9", 2048, 900.0, {"start": "2025-12-01"}, None),
    ("sdh", 2049, 900.0, {"start": "2025-12-01"}, None),
    ("ell5", 2050, 900.0, {"start": "2026-03-02"}, None),
    ("stack4", 2051, 900.0, {"start": "2026-03-02"}, None),
    ("quad4", 2052, 900.0, {"climate": "cold"}, None),
    ("core9", 2053, 900.0, {"climate": "cold", "start": "2025-10-06"}, None),
    ("row4", 2054, 900.0, {"hvac": "reheat"}, None),
    ("sdh", 2055, 900.0, {"schedule": "night-off"}, None),
    # building-wide set-point changes (every zone at one date): not one sensor
    ("core9", 2056, 900.0, {}, {"day": 50, "hour": 10.0, "heating": 0.0, "cooling": 1.0}),
    ("sdh", 2057, 900.0, {}, {"day": 60, "hour": 10.0, "heating": -1.0, "cooling": 0.0}),
    ("quad4", 2058, 900.0, {}, {"day": 45, "hour": 10.0, "heating": 1.5, "cooling": 1.5}),
    ("stack4", 2059, 900.0, {}, {"day": 40, "hour": 10.0, "heating": 0.0, "cooling": 1.0}),
    ("core9", 2060, 900.0, {"start": "2025-12-01"}, {"day": 55, "hour": 10.0, "heating": 1.0, "cooling": 1.0}),
    ("ell5", 2061, 300.0, {}, {"day": 50, "hour": 8.0, "heating": 0.0, "cooling": -1.0}),
]

#: two changes: a sensor put back (two steps of one zone) and two zones' sensors changed at different dates
TWO = [
    ("quad4", 2070, 900.0, ["sensor_offset:zone=NE,delta=2.0,day=35", "sensor_offset:zone=NE,delta=-2.0,day=56"]),
    ("row4", 2071, 900.0, ["sensor_offset:zone=R2,delta=-2.0,day=30", "sensor_offset:zone=R2,delta=2.0,day=60"]),
    ("core9", 2072, 900.0, ["sensor_offset:zone=W,delta=1.5,day=40", "sensor_offset:zone=W,delta=-1.5,day=75"]),
    ("sdh", 2073, 900.0, ["sensor_offset:zone=NE,delta=2.5,day=28", "sensor_offset:zone=W,delta=-2.0,day=70"]),
    ("quad4", 2074, 900.0, ["sensor_offset:zone=SW,delta=2.0,day=33", "sensor_offset:zone=NE,delta=1.5,day=74"]),
    ("ell5", 2075, 900.0, ["sensor_offset:delta=2.0,day=40", "sensor_offset:delta=-2.0,day=60"]),
    ("row4", 2076, 300.0, ["sensor_offset:zone=R3,delta=2.0,day=29", "sensor_offset:zone=R3,delta=-2.0,day=78"]),
    ("stack4", 2077, 900.0, ["sensor_offset:zone=S1,delta=-2.0,day=36", "sensor_offset:zone=N2,delta=2.0,day=72"]),
    # one zone re-calibrated twice (no return): the second change is searched after the first is accepted
    ("quad4", 2078, 900.0, ["sensor_offset:zone=SE,delta=2.0,day=30", "sensor_offset:zone=SE,delta=1.5,day=70"]),
    ("row4", 2079, 900.0, ["sensor_offset:zone=R1,delta=-2.0,day=33", "sensor_offset:zone=R1,delta=3.0,day=66"]),
]


@contextlib.contextmanager
def setpoint_change(change):
    """Patch the emulator's closed loop: from ``day`` days after the first midnight at ``hour`` (local, control
    intervals counted from the start) every box's heating and cooling set points (occupied and set-back) move by
    ``heating`` / ``cooling`` [K]. A building-wide change: the operator's schedule, not a sensor."""
    simulate = importlib.import_module("hvacfmu.emulator.simulate")  # the module (the package exports a function)

    if change is None:
        yield
        return
    orig = simulate._ClosedLoop._commands

    def commands(self, b, x):
        if not hasattr(self, "_sp0"):
            self._sp0 = dict(self.ctrl.sp)
            self._b_change = int((change["day"] * 1440 + change["hour"] * 60) // self.per)
        if b >= self._b_change:
            self.ctrl.sp = {k: (h + change["heating"], c + change["cooling"]) for k, (h, c) in self._sp0.items()}
        else:
            self.ctrl.sp = self._sp0
        return orig(self, b, x)

    simulate._ClosedLoop._commands = commands
    try:
        yield
    finally:
        simulate._ClosedLoop._commands = orig


def clean_paths(layout, seed, options, change, weeks=16):
    """The case's data: ``cached_dataset``, or with a set-point change generated once into the cache under its own
    name (the emulator's cache key does not know the patch)."""
    from hvacfmu.emulator import cached_dataset, generate
    from hvacfmu.emulator.generate import GeneratedPaths, cache_key

    if change is None:
        return cached_dataset(weeks=weeks, seed=seed, layout=layout, **options)
    root = Path(os.environ.get("HVACFMU_CACHE", Path.home() / ".cache" / "hvacfmu"))
    tag = "sp" + "-".join(f"{k}{v:g}" for k, v in change.items())
    final = root / (cache_key(weeks, seed, (), layout=layout, **options) + "-" + tag)
    paths = GeneratedPaths(final / "measurements.parquet", final / "building.toml", final / "truth.json")
    if not paths.truth.exists():
        with setpoint_change(change):
            generate(final, weeks=weeks, seed=seed, layout=layout, **options)
        t = json.loads(paths.truth.read_text())
        t["setpoint_change_s21"] = change
        paths.truth.write_text(json.dumps(t))
    return paths


def margins(ev: dict) -> dict:
    """Each evidence rule's value over its threshold (> 1: passes) from a candidate's evidence."""
    from hvacfmu.models.causes import sensor_offset as so

    t, shift, local = ev["split_t"], ev["offset_K"], ev["local_jump_K"]
    sign = 1.0 if shift >= 0 else -1.0
    al = abs(local) or 1e-9
    m = {
        "t": abs(t) / so.MIN_SPLIT_T,
        "size": abs(local) / so.MIN_OFFSET_K,
        "abrupt": sign * local / (so.MIN_LOCAL_SHARE * abs(shift) or 1e-9),
        "persist": min(sign * p for p in ev["persist_halves_K"]) / (so.MIN_PERSIST_SHARE * al),
        "hours": min(sign * q for q in ev["move_by_quarter_day_K"]) / (so.MIN_HOUR_SHARE * al),
    }
    others = [abs(v) for v in ev["others_local_jump_K"].values() if v is not None and np.isfinite(v)]
    m["one_zone"] = (so.MAX_OTHER_SHARE * al) / max(others) if others else np.inf
    if ev.get("after"):
        m["gap_t"] = abs(t) / so.MIN_GAP_T
        m["gap_size"] = abs(local) / so.MIN_GAP_OFFSET_K
        m["gap_share"] = sign * local / (so.MIN_GAP_LOCAL_SHARE * abs(shift) or 1e-9)
    else:
        spike, mad = ev.get("jump_residual_K"), ev.get("residual_mad_K") or 0.0
        if spike is None:
            m["jump_floor"] = 0.0
        else:
            m["jump_floor"] = abs(spike) / (so.SPIKE_Z * mad) if mad > 0 else np.inf
            m["jump_share"] = abs(spike) / (so.MIN_JUMP_SHARE * al)
            oth = [abs(v) for v in ev["others_residual_at_jump_K"].values() if v is not None]
            m["others_at_jump"] = (so.MAX_OTHER_SHARE * abs(spike)) / max(oth) if oth else np.inf
    return m


#: the change-and-return candidate's rules, as its reason words them
IV_RULES = (
    "have t ",
    "at the split, under",
    "gradual",
    "not persistent",
    "no return",
    "not the same at every hour",
    "move against the rest",
    "no jump",
    "the one-step residual at the jump",
    "jump at the same step",
    "the split falls",
)


def summarize(files) -> None:
    """Per rule, over every single-change candidate of the records: how many candidates it alone stopped, and the
    closest any of those came (largest margin < 1); candidates that passed every rule; the change-and-return
    candidates' reasons by count."""
    import collections

    only = collections.defaultdict(list)
    passed, n, iv_fails = [], 0, collections.Counter()
    nfail, few, iv_few = collections.Counter(), [], []
    for f in files:
        for line in open(f, encoding="utf-8"):
            r = json.loads(line)
            for c in r["offset_candidates"]:
                ev = c.get("evidence") or {}
                if "split_t" not in ev:
                    continue
                n += 1
                m = margins(ev)
                bad = [k for k, v in m.items() if v < 1]
                nfail[len(bad)] += 1
                if len(bad) <= 2:
                    few.append((len(bad), r["case"][:44], c["location"].get("zone"), {k: round(m[k], 2) for k in bad}))
                if len(bad) == 1:
                    only[bad[0]].append((m[bad[0]], r["case"][:40], c["location"].get("zone")))
                if not bad:
                    passed.append((r["case"][:40], c["location"], c["status"], (c.get("test") or {}).get("delta_bic")))
                cr = ev.get("change_and_return") or {}
                if cr.get("reason"):
                    k = sum(cr["reason"].count(rule) for rule in IV_RULES)
                    iv_fails[k] += 1
                    iv_few.append((k, r["case"][:44], c["location"].get("zone"), cr["reason"][:300]))
    print(f"{n} single-change candidates; by number of failed rules {dict(sorted(nfail.items()))}")
    for x in sorted(few, key=lambda x: x[0]):
        print("  ", x)
    for k, v in sorted(only.items()):
        best = max(v)
        print(f"  stopped by {k} alone: {len(v)}; closest {best[0]:.2f} ({best[1]}, zone {best[2]})")
    print(f"  passed every rule: {passed}")
    print(f"change-and-return candidates by number of failed rules: {dict(sorted(iv_fails.items()))}")
    for x in sorted(iv_few)[:4]:
        print("  ", x)


def candidate_line(c: dict) -> str:
    ev = c.get("evidence") or {}
    if "split_t" not in ev:
        return f"  {c['location'].get('zone')}: {c['status']} {c.get('reason', '')[:120]}"
    m = margins(ev)
    test = c.get("test") or {}
    cv = c.get("cv") or {}
    spike = ev.get("jump_residual_K")
    lo = min(m.values())
    return (
        f"  {c['location'].get('zone'):>4s} {c['status']:16s} {str(c['location'].get('start'))[:16]} "
        f"{'bracket ' if ev.get('after') else ''}t {ev['split_t']:+.1f} shift {ev['offset_K']:+.2f} "
        f"local {ev['local_jump_K']:+.2f} halves {np.round(ev['persist_halves_K'], 2).tolist()} "
        f"quarters {np.round(ev['move_by_quarter_day_K'], 2).tolist()} "
        f"jump {'-' if spike is None else f'{spike:+.2f}'} floor {6 * (ev.get('residual_mad_K') or 0):.2f} "
        f"dBIC {test.get('delta_bic', float('nan')):.1f} cv_t {cv.get('t', float('nan')):.1f} | min margin "
        f"{lo:.2f} ({min(m, key=m.get)}) fails {sum(v < 1 for v in m.values())} | "
        + " ".join(f"{k} {v:.2f}" for k, v in m.items())
    )


def diagnose_case(measurements, building, step):
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.errors import HvacfmuWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        ds = prepare(measurements, building, step=900.0 if step is None else step)  # the CLI's default step
    c0 = time.process_time()
    rep = diagnose(ds, progress=False)
    return rep, time.process_time() - c0


def report(tag, rep, cpu, truth=None, results=None):
    from hvacfmu.diagnosis.truth import compare_with_truth

    d = rep.to_dict()
    cands = [c for c in d["candidates"] if c["cause"] == "sensor_offset"]
    offs = [f for f in d["findings"] if f["cause"] == "sensor_offset"]
    line = f"{tag}: {len(d['findings'])} findings, sensor_offset findings {[f['location'] for f in offs]}"
    if truth is not None:
        cmp = compare_with_truth(rep, truth)
        line += (
            f"; found {[e['name'] + ':' + str(e.get('zone')) + '@' + str(e.get('day')) for e in cmp['found']]}"
            f" missed {[e['name'] + ':' + str(e.get('zone')) + '@' + str(e.get('day')) for e in cmp['missed']]}"
            f" false {[(f['cause'], f['location']) for f in cmp['unsupported']]}"
        )
    print(line + f" (diagnose {cpu:.0f} CPU-s)", flush=True)
    for f in offs:
        print(f"  FINDING {f['location']} cv {f.get('cv', {}).get('gain_percent')} t {f.get('cv', {}).get('t')}")
    for c in cands:
        print(candidate_line(c), flush=True)
    if results:
        with open(results, "a", encoding="utf-8") as fh:
            fh.write(json.dumps({"case": tag, "findings": d["findings"], "offset_candidates": cands}) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clean", action="store_true", help="the clean cases (CLEAN)")
    ap.add_argument("--two", action="store_true", help="the two-change cases (TWO)")
    ap.add_argument("--eplus", nargs="*", default=[], help="EnergyPlus export folders")
    ap.add_argument("--only", default=None, help="comma-separated case numbers")
    ap.add_argument("--results", default=None, help="JSON-lines file (appended)")
    ap.add_argument("--summary", nargs="*", default=[], help="summarise the margins of these results files")
    args = ap.parse_args()
    only = None if args.only is None else {int(x) for x in args.only.split(",")}
    if args.summary:
        summarize(args.summary)
    if args.clean:
        for i, (layout, seed, step, opts, change) in enumerate(CLEAN):
            if only is not None and i not in only:
                continue
            p = clean_paths(layout, seed, opts, change)
            rep, cpu = diagnose_case(p.measurements, p.building, step)
            tag = f"clean {i:2d} {layout} seed {seed} {int(step) // 60} min {opts} setpoints {change}"
            report(tag, rep, cpu, json.loads(p.truth.read_text()), args.results)
    if args.two:
        from hvacfmu.emulator import cached_dataset

        for i, (layout, seed, step, effects) in enumerate(TWO):
            if only is not None and i not in only:
                continue
            p = cached_dataset(weeks=16, seed=seed, layout=layout, effects=effects)
            rep, cpu = diagnose_case(p.measurements, p.building, step)
            report(
                f"two {i} {layout} seed {seed} {int(step) // 60} min {effects}",
                rep,
                cpu,
                json.loads(p.truth.read_text()),
                args.results,
            )
    for d in args.eplus:
        rep, cpu = diagnose_case(Path(d) / "measurements.parquet", Path(d) / "building.toml", None)
        report(f"eplus {Path(d).name}", rep, cpu, None, args.results)


if __name__ == "__main__":
    main()
