"""``diagnose`` on cases of ``energyplus_unseen5_run.py``: findings and held-out RMS per zone and season (session 13).

The export of each case is the cached one of ``energyplus_unseen5_run.py`` (same options); ``diagnose`` runs with its
defaults, and its extended model, the zones model and both baselines are scored on the held-out windows. Used for
``apartments_mass_s13.md`` (run once on the code before and once after a change, in two checkouts).

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/diagnose_unseen_s13.py --out DIR CASE ...
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from energyplus_unseen5_run import CASES, _per_zone_season  # noqa: E402


def case_export(key: str):
    """The cached export of case ``key`` of :data:`CASES` (prototype[:floor|:zones][@weather], its options)."""
    from hvacfmu.energyplus import cached_export

    spec, extra = CASES[key]
    prototype, _, weather = spec.partition("@")
    name, _, floor = prototype.partition(":")
    zones = floor.split(",") if "," in floor else None
    opts = dict(extra)
    if weather:
        opts["weather"] = weather
    if zones:
        opts["zones"] = zones
    return cached_export(name, floor=None if zones else (floor or None), weeks=opts.pop("weeks", None), **opts)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cases", nargs="+", choices=sorted(CASES))
    ap.add_argument("--out", required=True, help="folder for <case>.json, <case>_report.json and <case>_model.json")
    ap.add_argument(
        "--option", action="append", default=[], metavar="NAME=VALUE", help="a diagnose option (JSON value), repeatable"
    )
    args = ap.parse_args(argv)
    options = {k: json.loads(v) for k, v in (o.split("=", 1) for o in args.option)}

    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.evaluation import evaluate
    from hvacfmu.fitting import fit

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for key in args.cases:
        spec = CASES[key][0]
        paths = case_export(key)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds = prepare(paths.measurements, paths.building)
            t0, c0 = time.perf_counter(), time.process_time()
            rep = diagnose(ds, progress=False, **options)
            t_diag, cpu_diag = time.perf_counter() - t0, time.process_time() - c0
            models = {"zones": fit(ds, "zones", progress=False), "extended": rep.model}
            res = evaluate(list(models.values()), ds, names=list(models))
        print(
            f"\n=== {key}: {spec}: {len(ds.building.zones)} zones, {len(ds.weeks)} weeks; "
            f"diagnose {t_diag:.0f} s ({cpu_diag:.0f} CPU-s)"
        )
        print(rep.summary())
        masses = [c for c in rep.candidates if c["cause"] == "thermal_mass"]
        for c in masses:
            ev = c["evidence"]
            print(
                f"  thermal_mass {c['location']['zone']}: {c['status']}; tau {ev.get('time_constant_h', float('nan')):g} h"
                + (f"; left out (joint refit fails the load checks): {sorted(ev['unstable_time_constants_h'])} h"
                   if ev.get("unstable_time_constants_h") else "")
            )  # fmt: skip
        scores = _per_zone_season(res)
        for name, per in scores.items():
            for s, row in per["seasons"].items():
                print(
                    f"  {name:>9} {s:>7}: model {np.nanmean(row['model']):.3f} K, persistence "
                    f"{np.nanmean(row['persistence']):.3f} K, time-of-week {np.nanmean(row['time_of_week']):.3f} K"
                    f"  per zone {np.round(row['model'], 3).tolist()}"
                )
        rec = {
            "case": key,
            "spec": spec,
            "options": options,
            "t_diagnose_s": t_diag,
            "cpu_diagnose_s": cpu_diag,
            "summary": rep.summary(),
            "scores": scores,
        }
        rep.save_json(out / f"{key}_report.json")
        (out / f"{key}.json").write_text(json.dumps(rec, indent=1, default=str))
        rep.model.save(out / f"{key}_model.json")


if __name__ == "__main__":
    main()
