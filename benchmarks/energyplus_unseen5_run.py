"""Rerun of the four earlier rounds of unseen EnergyPlus buildings (benchmarks/energyplus_unseen5.md).

One case at a time, as ``bench_energyplus.py`` does (same exports, fits and evaluation), plus what that bench does not
print: the holiday calendar the dataset applied, and per zone and season the model's and both baselines' RMS.
Each case's numbers go to ``OUT/<case>.json`` (and, with ``--keep``, the evaluation result and models pickled for
analysis: local files, never committed).

Usage::

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/energyplus_unseen5_run.py --out DIR [--keep] CASE ...
    python3 benchmarks/energyplus_unseen5_run.py --out DIR --reevaluate CASE ...   # the kept models, this code

CASE is a key of :data:`CASES` (``r2f``, ``r3a`` ...) or ``all``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import pickle
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_energyplus import DEFAULT_PROTOTYPES, UNSEEN2_PROTOTYPES, UNSEEN3_PROTOTYPES, UNSEEN_PROTOTYPES  # noqa: E402

#: case key -> (prototype[:floor|:zones][@weather], extra cached_export options). Rounds 1-3 are whole years (the
#: bench's lists); round 4's two buildings are the 10-week exports of energyplus_unseen4.md; r0a-r0c the README's.
CASES = {
    **{f"r0{c}": (p, {}) for c, p in zip("abc", DEFAULT_PROTOTYPES)},  # the README's three
    **{f"r1{c}": (p, {}) for c, p in zip("abcd", UNSEEN_PROTOTYPES)},
    **{k: (p, {}) for k, p in zip(("r2a", "r2b", "r2b'", "r2c", "r2d", "r2e", "r2f", "r2g"), UNSEEN2_PROTOTYPES)},
    **{f"r3{c}": (p, {}) for c, p in zip("abcde", UNSEEN3_PROTOTYPES)},
    "r4a": ("RefBldgFullServiceRestaurantNew2004_Chicago@usa_ca_fresno", {"start": "06-05", "weeks": 10}),
    "r4b": (
        "ASHRAE901_OutPatientHealthCare_STD2019_Denver:"
        + ",".join([f"Floor 2 Exam {i}" for i in range(1, 7)] + ["Floor 2 Conference", "Floor 2 Dictation"])
        + "@usa_co_colorado_springs",
        {"start": "01-02", "weeks": 10},
    ),
}
#: Order of the rerun: the cases that lost a season to a baseline in an earlier round first.
PRIORITY = (
    "r2f", "r2e", "r2b'", "r3b", "r3a", "r2d", "r2g", "r1a", "r1c", "r3e", "r3d", "r3c",
    "r2b", "r1b", "r1d", "r2a", "r2c", "r4a", "r4b",
)  # fmt: skip


def _per_zone_season(res) -> dict:
    """Per model: outputs and, per season (and ``all``), windows and the model's and baselines' RMS per output [K]."""
    per = {}
    for sc in res.scores:
        seasons = np.asarray(sc.seasons, dtype=object)
        rows = {}
        for s in [*dict.fromkeys(sc.seasons), "all"]:
            sel = np.ones(len(seasons), bool) if s == "all" else seasons == s
            rows[s] = {
                "windows": int(sel.sum()),
                "model": np.nanmean(sc.rms[sel], axis=0).tolist(),
                "persistence": np.nanmean(sc.baselines["persistence"][sel], axis=0).tolist(),
                "time_of_week": np.nanmean(sc.baselines["time-of-week mean"][sel], axis=0).tolist(),
            }
        per[sc.name] = {"outputs": list(sc.outputs), "seasons": rows}
    return per


def run_case(key: str, out: Path, keep: bool = False) -> dict:
    from hvacfmu.data import prepare
    from hvacfmu.energyplus import cached_export
    from hvacfmu.energyplus.checks import airflow_identifiability, margins_table
    from hvacfmu.errors import FitError
    from hvacfmu.evaluation import evaluate
    from hvacfmu.fitting import fit

    spec, extra = CASES[key]
    prototype, _, weather = spec.partition("@")
    name, _, floor = prototype.partition(":")
    zones = floor.split(",") if "," in floor else None
    floor = None if zones else floor
    opts = dict(extra)
    if weather:
        opts["weather"] = weather
    if zones:
        opts["zones"] = zones
    t0 = time.perf_counter()
    paths = cached_export(name, floor=floor or None, weeks=opts.pop("weeks", None), **opts)
    t_gen = time.perf_counter() - t0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(paths.measurements, paths.building)
        models, t_fit, refused = {}, {}, {}
        for k in ("lumped", "zones", "physics"):
            t1 = time.perf_counter()
            try:
                models[k] = fit(ds, k, progress=False)
            except FitError as exc:
                refused[k] = str(exc)
            t_fit[k] = time.perf_counter() - t1
        res = evaluate(list(models.values()), ds, names=list(models))
    cal = ds.holidays
    print(
        f"\n=== {key}: {spec}: {len(ds.building.zones)} zones, {len(ds.weeks)} weeks, export {t_gen:.1f} s incl. cache,"
        f" fit " + ", ".join(f"{k} {t:.1f} s" for k, t in t_fit.items())
    )
    print(f"holiday calendar: source {cal.source}, country {cal.country}; {cal.summary()}")
    for n in cal.notes:
        print(f"  calendar note: {n}")
    for k, why in refused.items():
        print(f"{k}: REFUSED by the fit: {why}")
    print(margins_table(res).to_string(float_format=lambda x: f"{x:.3f}"))
    if "zones" in models:
        for line in airflow_identifiability(models["zones"], ds.building):
            print("  " + line)
    if res.verdict is not None:
        print(res.verdict.format())
    per = _per_zone_season(res)
    record = {
        "case": key,
        "spec": spec,
        "options": extra,
        "export": paths.info.parent.name,
        "calendar": {
            "source": cal.source,
            "country": cal.country,
            "in_data": {str(d): n for d, n in cal.in_data.items()},
        },
        "refused": refused,
        "scores": per,
        "verdict": res.verdict.format() if res.verdict is not None else None,
        "t_export_s": t_gen,
        "t_fit_s": t_fit,
    }
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{key}.json").write_text(json.dumps(record, indent=1, default=str))
    if keep:  # the evaluation (residuals) and the models' saved form; a fitted model holds unpicklable factors
        saved = {k: m.to_dict() for k, m in models.items() if hasattr(m, "to_dict")}
        with open(out / f"{key}.pkl", "wb") as f:
            pickle.dump({"res": dataclasses.replace(res, models=[]), "models": saved, "paths": paths}, f)
    return record


def reevaluate(key: str, out: Path) -> dict:
    """The models ``run_case(..., keep=True)`` saved for ``key``, evaluated with this code's calendar and verdict (the
    calendar of the dataset replaces the models' own; their fitted parameters are kept): ``OUT/after/<case>.json``."""
    from hvacfmu.data import prepare
    from hvacfmu.energyplus.checks import margins_table
    from hvacfmu.evaluation import evaluate
    from hvacfmu.models import model_from_dict

    with open(out / f"{key}.pkl", "rb") as f:
        saved = pickle.load(f)  # noqa: S301 - a local file this script wrote
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(saved["paths"].measurements, saved["paths"].building)
        models = []
        for d in saved["models"].values():
            d = dict(d)
            if ds.holidays.source != "none":
                d["holidays"] = list(ds.holidays.dates)
            models.append(model_from_dict(d))
        res = evaluate(models, ds, names=list(saved["models"]))
    print(f"\n=== {key} re-evaluated: calendar {ds.holidays.source}")
    print(margins_table(res).to_string(float_format=lambda x: f"{x:.3f}"))
    record = {"case": key, "scores": _per_zone_season(res), "verdict": res.verdict.format() if res.verdict else None}
    (out / "after").mkdir(parents=True, exist_ok=True)
    (out / "after" / f"{key}.json").write_text(json.dumps(record, indent=1, default=str))
    return record


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cases", nargs="+")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--keep", action="store_true", help="also pickle the result and models (local analysis)")
    ap.add_argument("--reevaluate", action="store_true", help="evaluate the kept models with this code (OUT/after/)")
    args = ap.parse_args(argv)
    keys = list(PRIORITY) if args.cases == ["all"] else args.cases
    for k in keys:
        if k not in CASES:
            raise SystemExit(f"unknown case {k!r}; choose from {', '.join(CASES)}")
    for k in keys:
        try:
            reevaluate(k, args.out) if args.reevaluate else run_case(k, args.out, args.keep)
        except Exception as exc:  # one case failing must not stop the others: say it and go on
            print(f"\n=== {k}: FAILED: {type(exc).__name__}: {exc}", flush=True)
        sys.stdout.flush()


if __name__ == "__main__":
    main()
