"""Diagnose -> export an FMU -> co-simulate it with a controller, through ``import hvacfmu as hf``.

    python3 examples/diagnose_export_cosim.py [--data FOLDER] [--out FOLDER] [--weeks 8]

The diagnosis fits the six-zone Model A, names what it gets wrong and returns the extended
model; that model is exported as an FMI 2.0 FMU and driven for one held-out week by the
rule-based controller in the FMPy co-simulation harness (``harness.cosim``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import harness
import hvacfmu as hf


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", help="folder with measurements.parquet and building.toml (default: generate one)")
    ap.add_argument("--out", default="hvacfmu-example", help="output folder (default ./hvacfmu-example)")
    ap.add_argument("--weeks", type=int, default=8, help="weeks to generate without --data (default 8)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    folder = Path(args.data) if args.data else hf.generate(out / "data", weeks=args.weeks).measurements.parent
    data = hf.prepare(folder / "measurements.parquet", folder / "building.toml")

    report = hf.diagnose(data, progress=False)  # causes, extended model, held-out gain
    print(report.format())
    model = report.model

    fmu = hf.export_fmu(model, out / "extended.fmu", timezone=data.building.timezone)
    print("FMU:", fmu)

    week = data.test_weeks()[0].number
    run = harness.cosim(fmu, data, "rule", model=model, week=week)
    print(run.format_summary())
    run.save(out / "cosim_rule.csv")
    return 0 if run.covered else 1


if __name__ == "__main__":
    raise SystemExit(main())
