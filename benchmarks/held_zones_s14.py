"""``diagnose`` on cases of ``energyplus_unseen5_run.py``, scored with and without its held setpoints (session 14).

As ``diagnose_unseen_s13.py`` (cached export, ``diagnose`` with its defaults), and the model of the forward selection
before the held setpoints (``DiagnosisReport.selected_model``) is scored next to the final one on the same held-out
windows, per zone and season. ``wind`` is the apartments' export with the wind column (``bench_wind_energyplus.py``).

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/held_zones_s14.py --out DIR CASE ...
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

from diagnose_unseen_s13 import case_export  # noqa: E402
from energyplus_unseen5_run import CASES, _per_zone_season  # noqa: E402


def _paths(key):
    from hvacfmu.energyplus import cached_export

    if key == "wind":
        from bench_wind_energyplus import APARTMENTS

        proto, _, weather = APARTMENTS.partition("@")
        name, _, zones = proto.partition(":")
        return cached_export(name, floor=None, weeks=None, wind=True, weather=weather, zones=zones.split(","))
    return case_export(key)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cases", nargs="+", choices=sorted(CASES) + ["wind"])
    ap.add_argument("--out", required=True, help="folder for <case>.json and <case>_model.json")
    args = ap.parse_args(argv)

    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.evaluation import evaluate

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for key in args.cases:
        paths = _paths(key)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds = prepare(paths.measurements, paths.building)
            t0 = time.perf_counter()
            rep = diagnose(ds, progress=False)
            t_diag = time.perf_counter() - t0
            models = {"selected": rep.selected_model, "extended": rep.model}
            res = evaluate(list(models.values()), ds, names=list(models))
        print(f"\n=== {key}: {len(ds.building.zones)} zones, {len(ds.weeks)} weeks; diagnose {t_diag:.0f} s")
        print(rep.summary())
        for f in rep.findings:
            if f["cause"] == "held_setpoint":
                print(f"  {f['location']['zone']}: {f['reason']}")
        for c in rep.candidates:
            if c["cause"] == "held_setpoint":
                print(f"  {c['location']['zone']}: {c['status']}: {c['reason']} (cv {c['cv']})")
        scores = print_scores(_per_zone_season(res))
        print(res.verdict.format())
        rec = {"case": key, "t_diagnose_s": t_diag, "summary": rep.summary(), "scores": scores}
        (out / f"{key}.json").write_text(json.dumps(rec, indent=1, default=str))
        rep.model.save(out / f"{key}_model.json")
        rep.selected_model.save(out / f"{key}_selected_model.json")


def print_scores(scores: dict) -> dict:
    """Print each model's held-out 24-h RMS by season (mean and per zone) against persistence; returns ``scores``."""
    for name, per in scores.items():
        for s, row in per["seasons"].items():
            print(
                f"  {name:>9} {s:>7}: model {np.nanmean(row['model']):.3f} K, persistence "
                f"{np.nanmean(row['persistence']):.3f} K  per zone {np.round(row['model'], 3).tolist()}"
                f"  persistence {np.round(row['persistence'], 3).tolist()}"
            )
    return scores


if __name__ == "__main__":
    main()
