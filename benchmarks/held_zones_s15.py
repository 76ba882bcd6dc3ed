"""``held_zones_s14.py`` with the held setpoints gated by the selection's acceptance rule (session 15).

The held-setpoint stage (:mod:`hvacfmu.diagnosis.held`) now passes the same rule as the forward selection
(:func:`hvacfmu.diagnosis.crossval.gate_failures`), absolute floor ``min_gain_abs`` (0.003 K) included. One
``diagnose`` per case; its held stage is also run a second time on the same selected model with ``min_gain_abs`` 0
(the session-14 rule: gain ≥ 1 % and t ≥ 2 only). Three models are scored on the same held-out windows, per zone and
season: ``selected`` (the forward selection alone), ``no_floor`` (held setpoints as in session 14) and ``extended``
(held setpoints through the shared rule, what ``diagnose`` saves). CPU seconds of each held stage are printed.

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/held_zones_s15.py --out DIR CASE ...
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from energyplus_unseen5_run import CASES, _per_zone_season  # noqa: E402
from held_zones_s14 import _paths, print_scores  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cases", nargs="+", choices=sorted(CASES) + ["wind"])
    ap.add_argument("--out", required=True, help="folder for <case>.json and the three models")
    args = ap.parse_args(argv)

    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose, pipeline
    from hvacfmu.evaluation import evaluate

    held_setpoints = pipeline.held_setpoints
    runs: dict = {}

    def both(sig, model, opts):
        """The session-14 rule (no absolute floor), then the shared rule, on the same selected model."""
        t0 = time.process_time()
        runs["no_floor"] = held_setpoints(sig, model, {**opts, "min_gain_abs": 0.0})
        t1 = time.process_time()
        out = held_setpoints(sig, model, opts)
        runs["cpu_s"] = {"no_floor": t1 - t0, "shared_rule": time.process_time() - t1}
        return out

    pipeline.held_setpoints = both
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for key in args.cases:
        paths = _paths(key)
        runs.clear()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds = prepare(paths.measurements, paths.building)
            t0 = time.perf_counter()
            rep = diagnose(ds, progress=False)
            t_diag = time.perf_counter() - t0
            no_floor, no_floor_cands = runs["no_floor"]
            models = {"selected": rep.selected_model, "no_floor": no_floor, "extended": rep.model}
            res = evaluate(list(models.values()), ds, names=list(models))
        print(f"\n=== {key}: {len(ds.building.zones)} zones, {len(ds.weeks)} weeks; diagnose {t_diag:.0f} s")
        print(f"  held stage CPU: {runs['cpu_s']}")
        print(rep.summary())
        held = []
        after = {c["location"]["zone"]: c for c in rep.candidates if c["cause"] == "held_setpoint"}
        after.update(
            {f["location"]["zone"]: {**f, "status": "found"} for f in rep.findings if f["cause"] == "held_setpoint"}
        )
        for c in no_floor_cands:
            z = c.location["zone"]
            a = after.get(z, {})
            cv = c.cv or {}
            row = {
                "zone": z,
                "no_floor": c.status,
                "shared_rule": a.get("status"),
                "variant": c.evidence.get("variant"),
                "gain_percent": cv.get("gain_percent"),
                "gain_abs_K": cv.get("gain_abs"),
                "t": cv.get("t"),
                "reason": a.get("reason"),
            }
            held.append(row)
            print(f"  {row}")
        scores = print_scores(_per_zone_season(res))
        rec = {
            "case": key,
            "zones": list(ds.building.zones),
            "t_diagnose_s": t_diag,
            "held_cpu_s": runs["cpu_s"],
            "held": held,
            "summary": rep.summary(),
            "scores": scores,
        }
        (out / f"{key}.json").write_text(json.dumps(rec, indent=1, default=str))
        for name, m in models.items():
            m.save(out / f"{key}_{name}_model.json")


if __name__ == "__main__":
    main()
