"""Held setpoints of cycling units: when a unit runs, and in which mode (session 16).

``held_setpoint``'s conditional edges hold a zone at a running unit's setpoint. Before this session a unit ran above
``max(1.05 u_min, 0.05 q99)`` and its mode was read from the airflow-weighted ``T_supply`` of every unit. Now a unit
without a minimum airflow (a split unit or furnace with a cycling fan) runs above ``0.001 q99``
(:func:`hvacfmu.models.causes.held_setpoint.running_threshold`) and the mode is read from the zone's own unit's supply
air (:func:`hvacfmu.diagnosis.held.own_supply`). One ``diagnose`` per case, as ``held_zones_s15.py``: its held stage is
run twice on the same selected model, first with both old rules (``old_rule``, main's code) and then with the new ones
(``extended``, what ``diagnose`` now saves). The three models are scored on the same held-out windows, per zone and
season; CPU seconds of each held stage are printed.

``--evidence CASE ...`` only learns each zone's edges on the training rows under both rules (no fit): a case whose
zones have no conditional edge under either gets the same diagnosis by construction.

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/apartments_s16.py --out DIR wind r3e
    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/apartments_s16.py --evidence r2c r1b emulator battery13 battery22
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


def old_threshold(q99: float, u_min: float) -> float:
    """The running threshold before session 16 (every unit: ``max(1.05 u_min, 0.05 q99)``)."""
    return float(max(1.05 * u_min, 0.05 * q99) + 1e-6)


class old_rules:
    """Within it, the held stage runs main's rules: the old threshold, the weighted ``T_supply`` for every zone and
    ``hold`` at every airflow."""

    def __enter__(self):
        from hvacfmu.diagnosis import held
        from hvacfmu.models.causes import held_setpoint as hs

        self.saved = hs.running_threshold, held.own_supply, hs.FULL_SHARE
        hs.running_threshold = old_threshold
        held.own_supply = lambda sig, zi: "T_supply"
        hs.FULL_SHARE = float("inf")  # u_full inf (or None): hold at every airflow

    def __exit__(self, *exc):
        from hvacfmu.diagnosis import held
        from hvacfmu.models.causes import held_setpoint as hs

        hs.running_threshold, held.own_supply, hs.FULL_SHARE = self.saved


#: ``--evidence`` keys of the emulator's datasets (``held_cost_s15.py``): the tests' 51-week default, battery cases
EMULATOR = {"emulator": "default51", "battery13": "battery_13", "battery22": "battery_22"}


def evidence(key: str) -> list:
    """Per zone: the conditional edges learned on the training rows under the old and the new threshold."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import held
    from hvacfmu.diagnosis.design import make_signals
    from hvacfmu.fitting import fit

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if key in EMULATOR:  # the emulator's datasets of held_cost_s15.py
            import bench_diagnosis_battery as battery
            from held_cost_s15 import _dataset

            ds = _dataset(EMULATOR[key], battery)
        else:
            paths = _paths(key)
            ds = prepare(paths.measurements, paths.building)
        base = fit(ds, "zones", progress=False, use_solar=False, heat="airflow", open_loop=False)  # as diagnose
        sig = make_signals(ds, base)
    rows, out = sig.rows("train"), []
    for zi, z in enumerate(sig.zones):
        row = {"zone": z, "u_min": float(sig.u_min[zi])}
        with old_rules():
            term, _ = held._learn(sig, zi, rows)
        row["old_rule"] = None if term is None else term.to_dict()
        term, _ = held._learn(sig, zi, rows)
        row["new_rule"] = None if term is None else term.to_dict()
        out.append(row)
        print(f"  {key} {row}")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cases", nargs="+", choices=sorted(CASES) + ["wind"] + sorted(EMULATOR))
    ap.add_argument("--out", help="folder for <case>.json and the three models")
    ap.add_argument("--evidence", action="store_true", help="only the edges under both thresholds (no diagnosis)")
    args = ap.parse_args(argv)
    if args.evidence:
        for key in args.cases:
            evidence(key)
        return
    if not args.out:
        ap.error("--out is required without --evidence")

    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose, pipeline
    from hvacfmu.evaluation import evaluate

    held_setpoints = pipeline.held_setpoints
    runs: dict = {}

    def both(sig, model, opts):
        """Main's rules, then the new ones, on the same selected model."""
        t0 = time.process_time()
        with old_rules():
            runs["old_rule"] = held_setpoints(sig, model, opts)
        t1 = time.process_time()
        out = held_setpoints(sig, model, opts)
        runs["cpu_s"] = {"old_rule": t1 - t0, "new_rule": time.process_time() - t1}
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
            old, old_cands = runs["old_rule"]
            models = {"selected": rep.selected_model, "old_rule": old, "extended": rep.model}
            res = evaluate(list(models.values()), ds, names=list(models))
        print(f"\n=== {key}: {len(ds.building.zones)} zones, {len(ds.weeks)} weeks; diagnose {t_diag:.0f} s")
        print(f"  held stage CPU: {runs['cpu_s']}")
        print(rep.summary())
        after = {c["location"]["zone"]: c for c in rep.candidates if c["cause"] == "held_setpoint"}
        after.update(
            {f["location"]["zone"]: {**f, "status": "found"} for f in rep.findings if f["cause"] == "held_setpoint"}
        )
        held = []
        before = {c.location["zone"]: c for c in old_cands}
        for z in [*before, *(z for z in after if z not in before)]:
            c = before.get(z)
            a = after.get(z, {})
            row = {
                "zone": z,
                "old_rule": c.status if c else None,
                "old_variant": c.evidence.get("variant") if c else None,
                "old_cv": c.cv if c else None,
                "new_rule": a.get("status"),
                "new_variant": (a.get("evidence") or {}).get("variant"),
                "new_cv": a.get("cv"),
                "new_reason": a.get("reason"),
            }
            held.append(row)
            print(f"  {row}")
        scores = print_scores(_per_zone_season(res))
        print(res.verdict.format())
        rec = {
            "case": key,
            "zones": list(ds.building.zones),
            "t_diagnose_s": t_diag,
            "held_cpu_s": runs["cpu_s"],
            "held": held,
            "summary": rep.summary(),
            "scores": scores,
            "verdict": res.verdict.format(),
        }
        (out / f"{key}.json").write_text(json.dumps(rec, indent=1, default=str))
        for name, m in models.items():
            m.save(out / f"{key}_{name}_model.json")


if __name__ == "__main__":
    main()
