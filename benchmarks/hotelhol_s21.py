"""Operation-signature γ of holiday weeks: the checked battery's injected holidays against an EnergyPlus hotel's
proposed weeks (issue 13 p.6 / 15, ``benchmarks/hotelhol_s21.md``).

For every checked-battery case with an injected holiday (``benchmarks/battery_checked_cases.jsonl``), the training
weekdays of its holiday weeks are read on the data check's day signature (:func:`hvacfmu.data.holidays.operation_groups`:
0 = workday, 1 = Sunday; those days and the calendar's holidays left out of the workday reference), one mean per week.
With ``--data DIR`` (a ``measurements.parquet`` + ``building.toml`` + ``diag.json`` from ``hvacfmu diagnose``), the
same for the weeks of the first finding's holiday dates. Run::

    python3 benchmarks/hotelhol_s21.py [--data DIR ...] [--no-battery]
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import pandas as pd


def week_table(ds, dates) -> tuple[float, dict]:
    from hvacfmu.data.holidays import operation_days, operation_groups

    op = operation_days(ds)
    groups: dict = {}
    for d in sorted(dates):
        t = pd.Timestamp(d)
        if t.normalize() in op.usable:
            groups.setdefault(str((t - pd.Timedelta(days=t.day_of_week)).date()), []).append(d)
    res = operation_groups(op, groups)
    return res["spread"], {k: (round(v["gamma"], 3), v["n"], v["ok"]) for k, v in res["groups"].items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", nargs="*", default=[])
    ap.add_argument("--no-battery", action="store_true")
    args = ap.parse_args()
    from hvacfmu.data import prepare

    if not args.no_battery:
        from hvacfmu.diagnosis.truth import _holiday_dates
        from hvacfmu.emulator import cached_dataset

        for line in open(Path(__file__).with_name("battery_checked_cases.jsonl")):
            c = json.loads(line)["case"]
            if not any("kind=holiday" in e for e in c["effects"]):
                continue
            paths = cached_dataset(weeks=16, seed=c["seed"], effects=c["effects"], layout=c["layout"])
            ds = prepare(paths.measurements, paths.building, step=c["step"])
            truth = json.loads(paths.truth.read_text())
            eff = next(e for e in truth["effects"] if e.get("kind") == "holiday")
            spread, tab = week_table(ds, [str(d) for d in _holiday_dates(truth, eff)])
            print(f"battery case {c['id']:2d}: workday spread {spread:.3f}; training holiday weeks {tab}", flush=True)
    for d in args.data:
        d = Path(d)
        dates = json.loads((d / "diag.json").read_text())["findings"][0]["location"].get("dates", [])
        ds = prepare(d / "measurements.parquet", d / "building.toml")
        spread, tab = week_table(ds, dates)
        s = "inf" if math.isinf(spread) else f"{spread:.3f}"
        print(f"{d}: {len(dates)} dates named; workday spread {s}; weeks {tab}", flush=True)


if __name__ == "__main__":
    main()
