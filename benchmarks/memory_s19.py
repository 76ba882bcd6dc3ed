"""The base kinds' memory (session 19): main's fit (``memory=False``) against the default (``memory="auto"``).

``apartments``: the EnergyPlus mid-rise apartments with wind (``apartments_s18.py``'s bed): lumped and zones fitted
both ways (CPU of each fit), scored on the held-out windows per zone and season against persistence and the
time-of-week mean; the zone-seasons behind each baseline counted; ``meta["memory"]`` printed.

``emulator``: the same on emulator datasets (``--case default`` = the tests' default 8-week dataset; ``reheat-dual``
and ``reheat`` = the 10 cold weeks of issue 13 p.4, README "The dual-maximum winter"; seeds from ``--seeds``;
``--forced`` also fits with ``memory=True``, the week cross-validation run whatever the time constants).

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/memory_s19.py --out DIR apartments
    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/memory_s19.py --out DIR emulator --case default reheat-dual reheat --seeds 0 1 --forced
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _counts(scores: dict) -> dict:
    """Per model: zone-seasons (seasons other than ``all``) behind persistence and behind the time-of-week mean."""
    import numpy as np

    out = {}
    for name, per in scores.items():
        n = bp = bt = 0
        for s, row in per["seasons"].items():
            if s == "all":
                continue
            if len(per["outputs"]) == 1:
                p, t = np.nanmean(row["persistence"]), np.nanmean(row["time_of_week"])
                ms, ps, ts = row["model"], [p], [t]
            else:
                ms, ps, ts = row["model"], row["persistence"], row["time_of_week"]
            for m, p, t in zip(ms, ps, ts):
                n += 1
                bp += int(m > p)
                bt += int(m > t)
        out[name] = {"cells": n, "behind_persistence": bp, "behind_time_of_week": bt}
    return out


def _fit_both(ds, kinds=("zones", "lumped"), forced=False):
    from hvacfmu.fitting import fit

    models, cpu = {}, {}
    for k in kinds:
        for mem in (False, "auto", True) if forced else (False, "auto"):
            name = f"{k}_{ {False: 'main', 'auto': 'memory', True: 'forced'}[mem] }"
            t1 = time.process_time()
            models[name] = fit(ds, k, progress=False, memory=mem)
            cpu[name] = time.process_time() - t1
            info = models[name].meta.get("memory", {})
            print(f"{name}: fit CPU {cpu[name]:.1f} s; memory: {json.dumps(info, default=str)}", flush=True)
    return models, cpu


def _score(models, ds, out: Path, tag: str, extra=None) -> dict:
    from apartments_s18 import _table
    from energyplus_unseen5_run import _per_zone_season

    from hvacfmu.evaluation import evaluate

    res = evaluate(list(models.values()), ds, names=list(models))
    scores = _per_zone_season(res)
    _table(scores)
    counts = _counts(scores)
    for name, c in counts.items():
        print(
            f"{tag} {name}: behind persistence {c['behind_persistence']}/{c['cells']}, "
            f"behind time-of-week {c['behind_time_of_week']}/{c['cells']}"
        )
    rec = {"scores": scores, "counts": counts, **(extra or {})}
    (out / f"{tag}.json").write_text(json.dumps(rec, indent=1, default=str))
    return rec


def apartments(out: Path, split_seed: int = 0) -> None:
    from held_zones_s14 import _paths

    from hvacfmu.data import prepare

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        paths = _paths("wind")
        ds = prepare(paths.measurements, paths.building, seed=split_seed)
        models, cpu = _fit_both(ds)
        _score(
            models,
            ds,
            out,
            "apartments" if split_seed == 0 else f"apartments_split{split_seed}",
            {"fit_cpu_s": cpu, "memory": {k: m.meta.get("memory") for k, m in models.items()}},
        )


def emulator(out: Path, cases, seeds, forced=False) -> None:
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset

    for case in cases:
        for seed in seeds:
            if case == "default":
                p = cached_dataset(weeks=8, seed=seed)
            else:  # issue 13 p.4: README "The dual-maximum winter ..." (reheat-dual) and constant minimum airflow
                p = cached_dataset(weeks=10, seed=seed, hvac=case, climate="cold", start="2025-11-03")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ds = prepare(p.measurements, p.building)
                models, cpu = _fit_both(ds, forced=forced)
                _score(
                    models,
                    ds,
                    out,
                    f"{case}_seed{seed}",
                    {"fit_cpu_s": cpu, "memory": {k: m.meta.get("memory") for k, m in models.items()}},
                )


def energyplus(out: Path, dirs, forced=False) -> None:
    """Export folders (``measurements.parquet``, ``building.toml``): the default fits; where ``meta["memory"]`` was
    checked, main's fit too and both scored (elsewhere the model is main's: the selection did not run). ``forced``:
    also ``memory=True``, scored beside main's."""
    from hvacfmu.data import prepare
    from hvacfmu.fitting import fit

    for d in dirs:
        d = Path(d)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds = prepare(d / "measurements.parquet", d / "building.toml")
            models, cpu = {}, {}
            for k in ("zones", "lumped"):
                t1 = time.process_time()
                m = fit(ds, k, progress=False)
                cpu[k] = time.process_time() - t1
                info = m.meta.get("memory", {})
                print(
                    f"{d.name} {k}: fit CPU {cpu[k]:.1f} s; memory: {json.dumps(info, default=str)[:400]}", flush=True
                )
                if info.get("checked") or forced:
                    models[f"{k}_memory"] = m
                    models[f"{k}_main"] = fit(ds, k, progress=False, memory=False)
                if forced:
                    t1 = time.process_time()
                    models[f"{k}_forced"] = fit(ds, k, progress=False, memory=True)
                    cpu[f"{k}_forced"] = time.process_time() - t1
                    mem = models[f"{k}_forced"].meta["memory"]
                    print(f"  forced: CPU {cpu[k + '_forced']:.1f} s, kept {mem['kept']}", flush=True)
            if models:
                _score(
                    models,
                    ds,
                    out,
                    d.name,
                    {"fit_cpu_s": cpu, "memory": {k: m.meta.get("memory") for k, m in models.items()}},
                )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["apartments", "emulator", "energyplus"])
    ap.add_argument("--dirs", nargs="*", default=[], help="energyplus: export folders")
    ap.add_argument("--split-seed", type=int, default=0, help="apartments: seed of the train/test week split")
    ap.add_argument("--out", required=True)
    ap.add_argument("--case", nargs="+", default=["default"])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--forced", action="store_true", help="also fit with memory=True (the selection always run)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.what == "apartments":
        apartments(out, args.split_seed)
    elif args.what == "energyplus":
        energyplus(out, args.dirs, args.forced)
    else:
        emulator(out, args.case, args.seeds, args.forced)


if __name__ == "__main__":
    main()
