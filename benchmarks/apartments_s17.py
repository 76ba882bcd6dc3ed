"""Held setpoints of a mode that runs in one season only (session 17).

Before this session ``held_setpoint`` learned a running unit's edge (``cooling_floor``/``heating_ceiling``) only from
at least ``max(MIN_MODE_ROWS, 2 % of the training rows)`` rows in that mode. The EnergyPlus mid-rise apartments'
corner flats (SW, SE) heat in the coldest weeks only: 482-499 of 27,725 training rows (1.7-1.8 %), their heating edge at
21.1 °C was never learned, and the winter model let them drift (and their neighbours S1, S2 with them). Now the
share is 0 (``hvacfmu.models.causes.held_setpoint.MIN_MODE_SHARE``): 200 rows, the pile-up rule and the
cross-validation decide.

As ``apartments_s16.py``: one ``diagnose`` per case, its held stage run twice on the same selected model, with the
old share (``old_rule``) and with the new one (``extended``, what ``diagnose`` saves); the three models scored on the
same held-out windows per zone and season.

``--evidence CASE ...`` only learns each zone's edges on the training rows and on each cross-validation fold's fit
rows under both rules (no fit of a held model): a case whose edges are the same everywhere under both gets the same
diagnosis by construction.

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/apartments_s17.py --out DIR wind
    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/apartments_s17.py --evidence wind r3e r2c r1b emulator battery13
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import apartments_s16 as s16  # noqa: E402
from energyplus_unseen5_run import CASES  # noqa: E402

#: the share of the training rows a mode needed before session 17
OLD_SHARE = 0.02


class old_rules:
    """Within it, the held stage asks a mode for ``OLD_SHARE`` of the training rows (main's rule)."""

    def __enter__(self):
        from hvacfmu.models.causes import held_setpoint as hs

        self.saved = hs.MIN_MODE_SHARE
        hs.MIN_MODE_SHARE = OLD_SHARE

    def __exit__(self, *exc):
        from hvacfmu.models.causes import held_setpoint as hs

        hs.MIN_MODE_SHARE = self.saved


def evidence(key: str) -> list:
    """Per zone: the edges learned on the training rows and on each fold's fit rows under the old and the new rule,
    and whether they differ anywhere (where they do not, the held stage is the same under both)."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import held
    from hvacfmu.diagnosis.crossval import make_plan
    from hvacfmu.diagnosis.design import make_signals
    from hvacfmu.diagnosis.selection import horizon_steps
    from hvacfmu.fitting import fit

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if key in s16.EMULATOR:
            import bench_diagnosis_battery as battery
            from held_cost_s15 import _dataset

            ds = _dataset(s16.EMULATOR[key], battery)
        else:
            paths = s16._paths(key)
            ds = prepare(paths.measurements, paths.building)
        base = fit(ds, "zones", progress=False, use_solar=False, heat="airflow", open_loop=False)  # as diagnose
        sig = make_signals(ds, base)
    rows, out = sig.rows("train"), []
    for zi, z in enumerate(sig.zones):
        with old_rules():
            t_old, _ = held._learn(sig, zi, rows)
        t_new, ev = held._learn(sig, zi, rows)
        row = {
            "zone": z,
            "old_rule": None if t_old is None else t_old.coefficients(),
            "new_rule": None if t_new is None else t_new.coefficients(),
            "mode_rows": {k: ev[k].get("n") for k in ("cooling_floor", "heating_ceiling") if k in ev},
            "train_rows": len(rows),
        }
        # the held stage also learns the edges on each cross-validation fold's fit rows (fewer, fewer of a season)
        plan = make_plan(sig, 10, horizon_steps(ds.step))
        folds = [] if plan is None else plan.fit_rows
        n_fold_diff = 0
        for fr in folds:
            with old_rules():
                f_old, _ = held._learn(sig, zi, fr)
            f_new, _ = held._learn(sig, zi, fr)
            n_fold_diff += (None if f_old is None else f_old.coefficients()) != (
                None if f_new is None else f_new.coefficients()
            )
        row["folds_changed"] = f"{n_fold_diff} of {len(folds)}"
        row["changed"] = row["old_rule"] != row["new_rule"] or n_fold_diff > 0
        out.append(row)
        print(f"  {key} {row}")
    print(f"  {key}: {sum(r['changed'] for r in out)} of {len(out)} zones change their edges")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("cases", nargs="+", choices=sorted(CASES) + ["wind"] + sorted(s16.EMULATOR))
    ap.add_argument("--out", help="folder for <case>.json and the three models")
    ap.add_argument("--evidence", action="store_true", help="only the edges under both rules (no diagnosis)")
    args = ap.parse_args(argv)
    if args.evidence:
        for key in args.cases:
            evidence(key)
        return
    if not args.out:
        ap.error("--out is required without --evidence")
    s16.old_rules = old_rules  # s16's driver runs its main arm within ``old_rules``
    s16.main(["--out", args.out, *args.cases])


if __name__ == "__main__":
    main()
