"""CPU of the held-setpoint stage (:func:`hvacfmu.diagnosis.held.held_setpoints`) inside ``diagnose`` (session 15).

Runs ``diagnose`` on the emulator's 4-week winter dataset (the tests' ``winter_dataset``), 4 weeks from its default
start, its default 51-week
dataset and battery cases (``bench_diagnosis_battery.py``), and prints, per dataset, the held stage's CPU seconds,
the zones it found an edge in, how many fold fits and fold scorings it ran, and the held candidates (zone, status,
cross-validated gain). Compare two commits by running it on each.

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/held_cost_s15.py [--battery 13 ...] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _dataset(name, battery):
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset

    if name == "winter4":  # tests/conftest.py WINTER_WEEKS
        paths, step = cached_dataset(weeks=4, seed=0, start="2026-01-12T00:00:00"), None
    elif name == "weeks4":
        paths, step = cached_dataset(weeks=4, seed=0), None
    elif name == "default51":
        paths, step = cached_dataset(weeks=51, seed=0), None
    else:
        case = battery.make_cases(48, 2026)[int(name.split("_")[1])]
        paths, step = (
            cached_dataset(weeks=16, seed=case["seed"], effects=case["effects"], layout=case["layout"]),
            (case["step"]),
        )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return (
            prepare(paths.measurements, paths.building)
            if step is None
            else prepare(paths.measurements, paths.building, step=step)
        )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--battery", type=int, nargs="*", default=[13], help="battery case ids (48 cases, seed 2026)")
    ap.add_argument("--no-default", action="store_true", help="skip the 51-week dataset")
    ap.add_argument("--json", help="write the records here")
    args = ap.parse_args(argv)

    import bench_diagnosis_battery as battery

    from hvacfmu.diagnosis import diagnose, held, pipeline

    count: dict = {}

    def counted(name, fn):
        def wrapper(*a, **k):
            count[name] = count.get(name, 0) + 1
            return fn(*a, **k)

        return wrapper

    for name in ("make_plan", "fold_fits", "fold_scores", "fit_structure"):
        setattr(held, name, counted(name, getattr(held, name)))
    stage = pipeline.held_setpoints
    cpu: dict = {}

    def timed(sig, model, opts):
        c0 = time.process_time()
        out = stage(sig, model, opts)
        cpu["held"] = time.process_time() - c0
        return out

    pipeline.held_setpoints = timed
    names = ["winter4", "weeks4"] + ([] if args.no_default else ["default51"]) + [f"battery_{i}" for i in args.battery]
    recs = []
    for name in names:
        ds = _dataset(name, battery)
        count.clear()
        c0 = time.process_time()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                rep = diagnose(ds, progress=False)
        except Exception as e:  # noqa: BLE001 - reported, the other datasets still run
            print(json.dumps({"dataset": name, "error": f"{type(e).__name__}: {e}"}), flush=True)
            continue
        total = time.process_time() - c0
        held_c = [
            {
                "zone": c["location"]["zone"],
                "status": c["status"],
                "gain_percent": (c.get("cv") or {}).get("gain_percent"),
            }
            for c in rep.candidates
            if c["cause"] == "held_setpoint"
        ]
        rec = {
            "dataset": name,
            "diagnose_cpu_s": round(total, 2),
            "held_cpu_s": round(cpu["held"], 3),
            "calls": dict(count),
            "held": held_c,
            "findings": [(f["cause"], f["location"]) for f in rep.findings],
        }
        recs.append(rec)
        print(json.dumps(rec, default=str), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(recs, indent=1, default=str))


if __name__ == "__main__":
    main()
