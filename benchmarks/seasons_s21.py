"""Per-season coefficient sets shipped (session 21): the fit's ``memory_select="season"`` through the real code path.

Issue 13 p.8 on the EnergyPlus mid-rise apartments (``regimes_s20.py``'s bed: the 8 flats of the middle floor with
wind, Sterling VA 2017). ``regimes_s20.md`` section 2 assembled the ``season_switch`` table from the memory check's
candidates; here the model is what ``fit(..., memory_select="season")`` returns (a
:class:`~hvacfmu.models.linear.SeasonalZoneModel` when the seasons pick different candidates), written to a model
file, read back, and scored by :func:`hvacfmu.evaluation.evaluate` (each window by its season's set), beside the
``"mean"`` rule's model (the candidate that rule keeps, from the same fit).

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/seasons_s21.py --out DIR apartments [--split-seed 1]
    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/seasons_s21.py --out DIR emulator --seeds 0 1
    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/seasons_s21.py --out DIR energyplus --dirs EXPORT_DIR ...

``emulator`` / ``energyplus``: the default fit under ``memory_select="mean"`` and ``"season"``: are the saved model
files the same (the check does not run where the fit has memory)?
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _scored(ds, kind, out: Path, tag: str, opts: dict) -> dict:
    from energyplus_unseen5_run import _per_zone_season
    from regimes_s20 import _fit_capturing, _summary

    from hvacfmu.evaluation import evaluate
    from hvacfmu.models import load_model
    from hvacfmu.models.memory import select_candidate

    m, cands, cpu = _fit_capturing(ds, kind, memory_select="season", **opts)
    mem = m.meta.get("memory") or {}
    path = m.save(out / f"{tag}_{kind}_season.json")
    loaded = load_model(path)
    rec: dict = {
        "kind": kind,
        "fit_cpu_s": cpu,
        "seasonal": bool(getattr(loaded, "seasonal", False)),
        "kept": mem.get("kept"),
        "season_best": mem.get("season_best"),
        "sets": (mem.get("selection") or {}).get("season_sets"),
    }
    print(f"{tag} {kind}: fit CPU {cpu:.1f} s, seasonal {rec['seasonal']}, kept {rec['kept']}")
    models = {"season": loaded}
    if mem.get("checked"):
        models = {"mean": cands[select_candidate(mem["week_cv"], "mean")[0]], "season": loaded}
    res = evaluate(list(models.values()), ds, names=list(models))
    per = _per_zone_season(res)
    rec["summaries"] = {k: _summary(v) for k, v in per.items()}
    rec["per_zone_season"] = per
    for r, sm in rec["summaries"].items():
        line = " ".join(f"{s[:2]} {v['model']:.3f}" for s, v in sm["means"].items())
        print(
            f"  {r:>8}: behind pers. {sm['behind_persistence']}/{sm['cells']}, "
            f"ToW {sm['behind_time_of_week']}/{sm['cells']}; {line}"
        )
    return rec


def apartments(out: Path, split_seed: int = 0) -> None:
    from held_zones_s14 import _paths

    from hvacfmu.data import prepare

    tag = "apartments" if split_seed == 0 else f"apartments_split{split_seed}"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        paths = _paths("wind")
        ds = prepare(paths.measurements, paths.building, seed=split_seed)
        recs = {k: _scored(ds, k, out, tag, {"memory": "auto"}) for k in ("zones", "lumped")}
    (out / f"{tag}.json").write_text(json.dumps(recs, indent=1, default=str))


def _same_file(ds, tag, out: Path) -> dict:
    """The default fit under ``memory_select`` "mean" and "season": identical model files (meta aside)?"""
    from hvacfmu.fitting import fit

    recs = {}
    for k in ("zones", "lumped"):
        d = {}
        for rule in ("mean", "season"):
            m = fit(ds, k, progress=False, memory_select=rule)
            body = {a: b for a, b in m.to_dict().items() if a != "meta"}
            d[rule] = json.dumps(body, sort_keys=True)
            d[rule + "_memory"] = (m.meta.get("memory") or {}).get("checked")
        recs[k] = {"identical": d["mean"] == d["season"], "checked": d["season_memory"]}
        print(f"{tag} {k}: check run {recs[k]['checked']}; coefficients identical {recs[k]['identical']}")
    (out / f"{tag}.json").write_text(json.dumps(recs, indent=1))
    return recs


def emulator(out: Path, seeds) -> None:
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset

    for seed in seeds:
        p = cached_dataset(weeks=8, seed=seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _same_file(prepare(p.measurements, p.building), f"default_seed{seed}", out)


def energyplus(out: Path, dirs) -> None:
    from hvacfmu.data import prepare

    for d in dirs:
        d = Path(d)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _same_file(prepare(d / "measurements.parquet", d / "building.toml"), d.name, out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["apartments", "emulator", "energyplus"])
    ap.add_argument("--split-seed", type=int, default=0)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--dirs", nargs="*", default=[])
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.what == "apartments":
        apartments(out, args.split_seed)
    elif args.what == "emulator":
        emulator(out, args.seeds)
    else:
        energyplus(out, args.dirs)


if __name__ == "__main__":
    main()
