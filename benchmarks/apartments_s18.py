"""Wind infiltration re-tested after the held setpoints, and the base kinds on the apartments (session 18).

``apartments``: the EnergyPlus mid-rise apartments with wind (``apartments_s16.py``'s ``wind`` case): one ``diagnose``
with ``wind_retest`` (default ``floating``, :mod:`hvacfmu.diagnosis.retest`), its wind candidates' re-test printed;
then the base kinds fitted as ``hvacfmu fit`` does (lumped, zones, physics, default options) and every model, with the
diagnosed one and any ``--model NAME=PATH``, scored on the held-out windows per zone and season against persistence
and the time-of-week mean; the evaluate verdict printed (what it names as the likely cause).

``clean``: the emulator's 8-week datasets with a ``wind`` column (``tests/test_wind_diagnosis.py``'s), no effect
and a wind effect, diagnosed with the option: the wind findings listed.

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/apartments_s18.py --out DIR apartments
    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/apartments_s18.py --out DIR clean --seeds 0 1
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _table(scores: dict) -> None:
    """Per season, one row per model and the two baselines, one column per zone [K]; ``*`` = behind persistence,
    ``+`` = behind the time-of-week mean."""
    import numpy as np

    first = next(iter(scores.values()))
    for s in first["seasons"]:
        zones = None
        for name, per in scores.items():
            row = per["seasons"][s]
            outs = per["outputs"]
            if name == next(iter(scores)):
                zones = outs
                print(f"\n{s} ({row['windows']} windows)  " + " ".join(f"{z.replace('M_', '')[:6]:>8}" for z in zones))
                for b in ("persistence", "time_of_week"):
                    print(f"  {b:>14} " + " ".join(f"{x:8.3f}" for x in row[b]))
            if outs != zones:  # lumped: one output
                p, t, m = np.nanmean(row["persistence"]), np.nanmean(row["time_of_week"]), row["model"][0]
                print(f"  {name:>14} {m:8.3f}{'*' if m > p else ''}{'+' if m > t else ''} (one output)")
                continue
            cells = [
                f"{m:7.3f}{'*' if m > p else ' '}{'+' if m > t else ''}"
                for m, p, t in zip(row["model"], row["persistence"], row["time_of_week"])
            ]
            print(f"  {name:>14} " + " ".join(f"{c:>8}" for c in cells))


def apartments(out: Path, mode, extra: dict) -> None:
    from energyplus_unseen5_run import _per_zone_season
    from held_zones_s14 import _paths

    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.evaluation import evaluate
    from hvacfmu.fitting import fit
    from hvacfmu.models import load_model

    paths = _paths("wind")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(paths.measurements, paths.building)
        t0 = time.perf_counter()
        rep = diagnose(ds, progress=False, wind_retest=mode)
        t_diag = time.perf_counter() - t0
        rep.model.save(out / "apartments_diagnosed_model.json")
        print(f"=== apartments with wind: diagnose (wind_retest={mode!r}) {t_diag:.0f} s")
        print(rep.summary())
        wind = [{"status": "found", **f} for f in rep.findings if f["cause"] == "wind_infiltration"] + [
            c for c in rep.candidates if c["cause"] == "wind_infiltration"
        ]
        for c in wind:
            print(f"  wind {c['location']['zone']}: {c['status']}: {c.get('reason')}")
        models, t_fit = {}, {}
        for k in ("lumped", "zones", "physics"):
            t1 = time.process_time()
            models[k] = fit(ds, k, progress=False)
            t_fit[k] = time.process_time() - t1
        models["diagnosed"] = rep.model
        for name, p in extra.items():
            models[name] = load_model(p)
        res = evaluate(list(models.values()), ds, names=list(models))
    scores = _per_zone_season(res)
    _table(scores)
    print(res.verdict.format())
    rec = {
        "t_diagnose_s": t_diag,
        "fit_cpu_s": t_fit,
        "summary": rep.summary(),
        "wind": wind,
        "scores": scores,
        "verdict": res.verdict.format(),
    }
    (out / "apartments.json").write_text(json.dumps(rec, indent=1, default=str))


def clean(out: Path, mode, seeds) -> None:
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.emulator import cached_dataset

    recs = []
    for seed in seeds:
        for effects in ([], ["wind_infiltration"]):
            p = cached_dataset(weeks=8, seed=seed, effects=effects, start="2025-11-03", wind="m/s")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ds = prepare(p.measurements, p.building)
                t0 = time.perf_counter()
                rep = diagnose(ds, progress=False, wind_retest=mode)
            truth = json.loads(p.truth.read_text())
            found = [f["location"] for f in rep.findings if f["cause"] == "wind_infiltration"]
            retested = [c["location"] for c in rep.candidates if "retest_after_held" in (c.get("evidence") or {})]
            held = [f["location"] for f in rep.findings if f["cause"] == "held_setpoint"]
            r = {
                "seed": seed,
                "effects": [e.get("zone") for e in truth.get("effects", [])],
                "wind_found": found,
                "held_found": held,
                "retested": retested,
                "n_findings": len(rep.findings),
                "t_s": time.perf_counter() - t0,
            }
            print(r, flush=True)
            recs.append(r)
    (out / "clean.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["apartments", "clean"])
    ap.add_argument("--out", required=True)
    ap.add_argument("--mode", default="floating", help="wind_retest: false, year or floating")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--model", action="append", default=[], help="NAME=PATH: another model file scored beside")
    args = ap.parse_args(argv)
    mode = False if args.mode.lower() in ("false", "off", "0") else args.mode
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.what == "apartments":
        apartments(out, mode, dict(m.split("=", 1) for m in args.model))
    else:
        clean(out, mode, args.seeds)


if __name__ == "__main__":
    main()
