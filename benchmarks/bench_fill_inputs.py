"""How much does filling an input gap of L hours change a model's 24-h open-loop RMS?

The measurement behind ``hvacfmu.evaluation.windows.FILL_INPUTS_H`` (2 h): on a gap-free
emulated dataset, every input column (everything except the zone temperatures) is removed for
L hours at a random time inside every scored test window, the evaluation fills it by linear
interpolation (``fill_inputs_h=L``), and the mean RMS is compared with the gap-free windows.

Usage::

    python3 benchmarks/bench_fill_inputs.py [--weeks 16] [--kinds lumped,zones,physics]
    python3 benchmarks/bench_fill_inputs.py --hvac reheat-dual --climate cold --start 2025-11-03 --weeks 10
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hvacfmu.data import prepare
from hvacfmu.emulator import cached_dataset
from hvacfmu.evaluation import evaluate
from hvacfmu.fitting import fit


def with_input_gaps(ds, starts, hours, rng):
    """``ds`` with every input missing for ``hours`` at a random time inside each window."""
    f = ds.frame.copy()
    zones = {f"T_{z}" for z in ds.building.zone_names}
    cols = [f.columns.get_loc(c) for c in f.columns if c not in zones]
    n = int(round(hours * 3600 / ds.step))
    for t in starts:
        k0 = f.index.get_loc(t)
        s = k0 + 1 + int(rng.integers(0, 96 - n - 1))
        f.iloc[s : s + n, cols] = np.nan
    return dataclasses.replace(ds, frame=f)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--weeks", type=int, default=16)
    ap.add_argument("--hvac", default="vav")
    ap.add_argument("--climate", default="mild")
    ap.add_argument("--start", default="2025-09-01")
    ap.add_argument("--kinds", default="lumped,zones,physics")
    ap.add_argument("--hours", default="0.5,1,2,3,4,6,8")
    args = ap.parse_args(argv)
    kinds = args.kinds.split(",")
    opts = {} if args.hvac == "vav" else {"hvac": args.hvac, "export_step": 900}
    if args.climate != "mild":
        opts["climate"] = args.climate
    if args.start != "2025-09-01":
        opts["start"] = args.start
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        paths = cached_dataset(weeks=args.weeks, seed=0, **opts)
        ds = prepare(paths.measurements, paths.building)
        models = [fit(ds, k, progress=False) for k in kinds]
        base = evaluate(models, ds, names=kinds, fill_inputs_h=0)
        rng = np.random.default_rng(0)
        print(f"{len(base.scores[0].starts)} gap-free test windows; mean 24-h RMS [K]:")
        for sc in base.scores:
            print(f"  {sc.name}: {np.nanmean(sc.rms):.4f} (persistence {np.nanmean(sc.baselines['persistence']):.4f})")
        print("gap L [h] | " + " | ".join(f"{k}: RMS change, margin vs persistence" for k in kinds))
        for hours in (float(h) for h in args.hours.split(",")):
            res = evaluate(
                models, with_input_gaps(ds, base.scores[0].starts, hours, rng), names=kinds, fill_inputs_h=hours
            )
            cells = []
            for sc, sb in zip(res.scores, base.scores):
                common = [i for i, t in enumerate(sb.starts) if t in sc.starts]
                a = np.nanmean(sb.rms[common])
                b = np.nanmean(sc.rms[[sc.starts.index(sb.starts[i]) for i in common]])
                p = np.nanmean(sb.baselines["persistence"][common])
                cells.append(f"{100 * (b / a - 1):+.1f} %, {100 * (1 - a / p):.0f} -> {100 * (1 - b / p):.0f} %")
            print(f"{hours:9g} | " + " | ".join(cells), flush=True)


if __name__ == "__main__":
    main()
