"""Seven winter weeks of a real-BMS-like export (issue 13): every model kind against both baselines.

The cases below were chosen before any run (``benchmarks/short_winter_s8.md``); seeds 8101-8110 were
never used before. Each case is an emulated VAV office with reheat (``--hvac reheat`` or
``reheat-dual``), cold climate, exported like a real BMS trend log: US units, naive timestamps that are
UTC (the export's building file declares ``data_timezone = "UTC"``), 15-minute samples, logger outages,
seven weeks starting in December or January.

Per case: ``check`` (exit code and clock line), fit ``lumped``, ``zones`` and ``physics``, ``evaluate``
(per model, zone and season: 24-h open-loop RMS, persistence, time-of-week mean, margins, scored
windows, verdict lines). On the cases in :data:`NO_UTC` also ``check`` with the building file's
``data_timezone`` removed (must warn about the ~6 h offset), on :data:`NO_TD` the same fits and evaluation
with the ``Td_*`` columns removed from the measurements, on :data:`DIAGNOSE` ``diagnose`` with its
findings compared with the emulator's truth.

Usage::

    python3 benchmarks/bench_short_winter.py [--case c1 --case c2 ...] [--out DIR] [--no-diagnose] [--force]

Every case's results go to ``DIR/<case>/result.json`` (default ``/tmp/short-winter``; a case already there
is read back, not rerun, unless ``--force``); the table is printed at the end.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

#: The cases, chosen before any run: name -> generate options. Every one: cold climate, US units,
#: naive-utc clock, outages, 15-min export, 7 weeks.
CASES = {
    "c1": dict(seed=8101, layout="sdh", hvac="reheat", construction="medium", start="2025-12-01"),
    "c2": dict(seed=8102, layout="sdh", hvac="reheat-dual", construction="light", start="2026-01-05"),
    "c3": dict(seed=8103, layout="row4", hvac="reheat", construction="heavy", start="2026-01-05"),
    "c4": dict(seed=8104, layout="row4", hvac="reheat-dual", construction="medium", start="2025-12-01"),
    "c5": dict(seed=8105, layout="core9", hvac="reheat", construction="light", start="2025-12-01"),
    "c6": dict(seed=8106, layout="core9", hvac="reheat-dual", construction="heavy", start="2026-01-05"),
    "c7": dict(seed=8107, layout="sdh", hvac="reheat", construction="heavy", start="2025-12-15"),
    "c8": dict(seed=8108, layout="row4", hvac="reheat", construction="light", start="2025-12-15"),
    "c9": dict(seed=8109, layout="core9", hvac="reheat-dual", construction="medium", start="2026-01-12"),
    "c10": dict(seed=8110, layout="sdh", hvac="reheat-dual", construction="medium", start="2025-12-08"),
}
COMMON = dict(weeks=7, climate="cold", units="us", clock="naive-utc", export_step=900, faults=("outages",))
KINDS = ("lumped", "zones", "physics")
#: cases also checked with the building file's data_timezone removed
NO_UTC = ("c1",)
#: cases also fitted and evaluated without the Td_* columns
NO_TD = ("c1", "c4")
#: cases diagnosed
DIAGNOSE = ("c1", "c3", "c5")


def _verdict_lines(res) -> list[str]:
    """The verdict text before the per-zone table."""
    text = res.verdict.format()
    return text.split("\nVerdict per zone:")[0].strip().splitlines()


def _scores(res) -> dict:
    """Per model: zone verdicts, season verdicts, windows."""
    out = {}
    v = res.verdict
    for sc in res.scores:
        out[sc.name] = {
            "zones": [z.to_dict() for z in v.zones if z.model == sc.name],
            "seasons": [s.to_dict() for s in v.seasons if s.model == sc.name],
            "windows": sc.n_windows(),
            "skipped": {k: int(n) for k, n in sc.skipped.items() if n},
            "summary": v.summary(sc.name),
        }
    return out


def _fit_and_evaluate(ds, kinds, folder: Path) -> dict:
    import hvacfmu as hf

    models, fit_s, fit_warnings = {}, {}, {}
    for k in kinds:
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            models[k] = hf.fit(ds, k, progress=False)
        fit_s[k] = round(time.perf_counter() - t0, 1)
        fit_warnings[k] = sorted({str(w.message) for w in caught})
        models[k].save(folder / f"{k}.json")
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = hf.evaluate(list(models.values()), ds, names=list(models))
    eval_s = round(time.perf_counter() - t0, 1)
    res.save_json(folder / "evaluation.json")
    return {
        "fit_seconds": fit_s,
        "fit_warnings": fit_warnings,
        "evaluate_seconds": eval_s,
        "verdict_lines": _verdict_lines(res),
        "models": _scores(res),
    }


def _check(measurements, building) -> dict:
    import hvacfmu as hf

    rep = hf.check(measurements, building)
    text = str(rep)
    clock = [line for line in text.splitlines() if line.startswith("Clock:")]
    weeks = [line.strip() for line in text.splitlines() if line.startswith("Weeks:") or line.startswith("  ")][:4]
    return {
        "exit_code": rep.exit_code,
        "clock": clock[0] if clock else None,
        "clock_offset_h": rep.clock.offset if rep.clock is not None else None,
        "attention": list(rep.attention),
        "final": text.strip().splitlines()[-1],
        "weeks": weeks,
    }


def run_case(name: str, out: Path, diagnose: bool) -> dict:
    import pandas as pd

    import hvacfmu as hf

    folder = out / name
    folder.mkdir(parents=True, exist_ok=True)
    opts = {**COMMON, **CASES[name]}
    t0 = time.perf_counter()
    paths = hf.generate(folder / "data", **opts)
    result: dict = {"case": name, "options": {k: v for k, v in opts.items() if k != "faults"}}
    result["generate_seconds"] = round(time.perf_counter() - t0, 1)
    result["check"] = _check(paths.measurements, paths.building)

    if name in NO_UTC:  # the building file without its data_timezone: the clock check must see the offset
        text = Path(paths.building).read_text(encoding="utf-8")
        assert 'data_timezone = "UTC"' in text, "the export's building file no longer declares UTC"
        local = folder / "building-no-utc.toml"
        local.write_text(text.replace('data_timezone = "UTC"\n', ""), encoding="utf-8")
        result["check_no_utc"] = _check(paths.measurements, local)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = hf.prepare(paths.measurements, paths.building)
    result["prepare_warnings"] = sorted({str(w.message) for w in caught} | set(ds.warnings))
    result["weeks"] = [
        {"number": w.number, "start": str(w.start.date()), "season": w.season, "train": bool(w.train)} for w in ds.weeks
    ]
    result["with_td"] = _fit_and_evaluate(ds, KINDS, folder)

    if name in NO_TD:
        frame = pd.read_parquet(paths.measurements)
        no_td = folder / "measurements-no-td.parquet"
        frame.drop(columns=[c for c in frame.columns if str(c).startswith("Td_")]).to_parquet(no_td)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds_no = hf.prepare(no_td, paths.building)
        sub = folder / "no-td"
        sub.mkdir(exist_ok=True)
        result["without_td"] = _fit_and_evaluate(ds_no, KINDS, sub)

    if diagnose and name in DIAGNOSE:
        from hvacfmu.diagnosis.truth import compare_with_truth

        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rep = hf.diagnose(ds, progress=False)
        rep.save_json(folder / "diagnosis.json")
        truth = json.loads(Path(paths.truth).read_text(encoding="utf-8"))
        cmp = compare_with_truth(rep, truth)
        result["diagnose"] = {
            "seconds": round(time.perf_counter() - t0, 1),
            "verdict": rep.verdict,
            "summary": rep.summary(),
            "findings": [{"cause": f["cause"], "location": f["location"]} for f in rep.findings],
            "supported": cmp["supported"],
            "unsupported": cmp["unsupported"],
            "heldout_verdict": (rep.heldout or {}).get("verdict"),
        }
    (folder / "result.json").write_text(json.dumps(result, indent=1, default=str), encoding="utf-8")
    return result


def worst(seasons: list, key: str) -> tuple:
    """(margin [%], zone, season) of the worst zone-season cell by ``key`` (margin_persistence / _time_of_week)."""
    cells = [(s[key], s["output"], s["season"]) for s in seasons if s[key] is not None]
    if not cells:
        return (float("nan"), "-", "-")
    m, z, s = min(cells)
    return (100 * m, z, s)


def table(results: list[dict], which: str = "with_td") -> str:
    """Per case and model: worst zone margin (all windows) and worst zone-season margin, against each baseline."""
    head = (
        f"{'case':<4} {'layout':<6} {'hvac':<11} {'constr':<6} {'start':<10} {'model':<8} "
        f"{'zone vs persist':>17} {'zone vs tow':>15} {'season vs persist':>26} {'season vs tow':>26}  windows"
    )
    lines = [head]
    for r in results:
        if which not in r:
            continue
        o = r["options"]
        for k, m in r[which]["models"].items():
            zp = min(m["zones"], key=lambda z: z["margin_persistence"])
            zt = min(m["zones"], key=lambda z: z["margin_time_of_week"] if z["margin_time_of_week"] is not None else 9)
            sp = worst(m["seasons"], "margin_persistence")
            st = worst(m["seasons"], "margin_time_of_week")
            win = ", ".join(f"{s} {n}" for s, n in m["windows"].items())
            lines.append(
                f"{r['case']:<4} {o['layout']:<6} {o['hvac']:<11} {o['construction']:<6} {o['start']:<10} {k:<8} "
                f"{100 * zp['margin_persistence']:+6.1f} {zp['output']:<10}"
                f"{100 * (zt['margin_time_of_week'] or float('nan')):+6.1f} {zt['output']:<8}"
                f"{sp[0]:+6.1f} {sp[1]:<5} {sp[2]:<13}{st[0]:+6.1f} {st[1]:<5} {st[2]:<13}  {win}"
            )
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", action="append", choices=sorted(CASES), help="cases to run (default: all)")
    ap.add_argument("--out", default="/tmp/short-winter", help="result folder")
    ap.add_argument("--no-diagnose", action="store_true")
    ap.add_argument("--force", action="store_true", help="rerun cases whose result.json exists")
    args = ap.parse_args(argv)
    out = Path(args.out)
    results = []
    for name in args.case or list(CASES):
        path = out / name / "result.json"
        if path.exists() and not args.force:
            results.append(json.loads(path.read_text(encoding="utf-8")))
            continue
        t0 = time.perf_counter()
        with contextlib.redirect_stdout(sys.stderr):
            r = run_case(name, out, diagnose=not args.no_diagnose)
        print(f"{name}: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
        results.append(r)
    print(
        "24-h open-loop margins [%] (1 - RMS_model / RMS_baseline), worst zone over all windows and worst zone-season:"
    )
    print(table(results))
    if any("without_td" in r for r in results):
        print("\nWithout the Td_* columns:")
        print(table(results, "without_td"))
    for r in results:
        print(f"\n== {r['case']}: check exit {r['check']['exit_code']}; {r['check']['clock']}")
        if "check_no_utc" in r:
            c = r["check_no_utc"]
            print(f"   without data_timezone: exit {c['exit_code']}; {c['clock']}; {c['final']}")
        for line in r["with_td"]["verdict_lines"]:
            print("   " + line)
        if "without_td" in r:
            print("   -- without Td:")
            for line in r["without_td"]["verdict_lines"]:
                print("   " + line)
        if "diagnose" in r:
            d = r["diagnose"]
            print(f"   diagnose ({d['seconds']} s): {d['summary']}")
            print(f"   not in the truth: {d['unsupported']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
