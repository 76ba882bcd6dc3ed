"""Load -> check -> fit -> evaluate, the notebook path through ``import hvacfmu as hf``.

    python3 examples/fit_and_evaluate.py [--data FOLDER] [--out FOLDER] [--weeks 8]

Without ``--data`` it first writes an emulated dataset (``hf.generate``) of ``--weeks``
weeks into ``--out``; a folder with ``measurements.parquet`` and ``building.toml`` (what
``hvacfmu generate`` writes) can be given instead.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import hvacfmu as hf


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", help="folder with measurements.parquet and building.toml (default: generate one)")
    ap.add_argument("--out", default="hvacfmu-example", help="output folder (default ./hvacfmu-example)")
    ap.add_argument("--weeks", type=int, default=8, help="weeks to generate without --data (default 8)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    folder = Path(args.data) if args.data else hf.generate(out / "data", weeks=args.weeks).measurements.parent

    building = hf.load_building(folder / "building.toml")
    print(hf.check(folder / "measurements.parquet", building))  # span, coverage, gaps, split
    data = hf.prepare(folder / "measurements.parquet", building)  # the model step, weeks, seasons

    print("model kinds:", ", ".join(hf.model_kinds()))
    model = hf.fit(data, "zones", progress=False)  # Model A, one state per zone
    model.save(out / "zones.json")

    result = hf.evaluate([model, out / "zones.json"], data, names=["fitted", "reloaded"])
    print(result.format())  # the verdict first, then Table I
    print(result.to_pandas().groupby("output")[["rms", "persistence"]].mean().round(3))
    for path in result.plot(out / "figures", dataset=data):
        print("figure:", path)
    return 0 if not result.verdict.losing() else 1


if __name__ == "__main__":
    raise SystemExit(main())
