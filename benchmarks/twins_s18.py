"""Mirror-twin flats of the EnergyPlus apartments: a_ij <= a_ii in the one-step fits (session 18, issue 13).

``refit``: the structure of a saved diagnosed model (``--model``, e.g. main's) refitted jointly by this checkout's
``fit_structure`` (the diagnosis' one-step refit; on this branch under ``a_zj <= a_zz``), its held terms kept;
the rows of A and its eigenvalues printed, both models scored per zone and season on the held-out windows against
persistence, and ``memory_warnings`` of both.

``pairs``: the cross-validation's fold models of that structure for the twin pairs S1/S2 and N1/N2: 24-h RMS
with the pair simulated together (the rest measured) and each flat alone (its twin measured), all and winter
windows, and each fold's smallest eigenvalue of the pair's block of A.

The benchmarks' helper modules put this checkout first on ``sys.path``: run a copy of the script inside the
checkout to be measured (``git show BRANCH:benchmarks/twins_s18.py > CHECKOUT/benchmarks/twins_s18.py``). ``refit``
needs no second run: ``saved`` is the model main's ``diagnose`` saved, ``refit`` its structure refitted here.

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/twins_s18.py refit --model DIAGNOSED.json
    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/twins_s18.py pairs --model DIAGNOSED.json
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _signals():
    """The apartments with wind as ``diagnose`` sees them: idle supply held, its own airflow-form base, signals."""
    from held_zones_s14 import _paths

    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import pipeline
    from hvacfmu.diagnosis.design import make_signals
    from hvacfmu.fitting import fit

    paths = _paths("wind")
    ds0 = prepare(paths.measurements, paths.building)
    ds, _ = pipeline._hold_idle_supply(ds0, True, [])
    base = fit(ds, "zones", progress=False, use_solar=False, heat="airflow", open_loop=False)
    return ds0, ds, make_signals(ds, base)


def refit(path: str) -> None:
    from energyplus_unseen5_run import _per_zone_season

    from hvacfmu.diagnosis.selection import fit_consistent
    from hvacfmu.evaluation import evaluate
    from hvacfmu.models import load_model
    from hvacfmu.models.causes.held_setpoint import HeldSetpoint

    try:
        from hvacfmu.models.plausibility import memory_warnings
    except ImportError:  # main before this branch
        memory_warnings = None
    ds0, _, sig = _signals()
    m = load_model(path)
    sel = [t for t in m.terms if not isinstance(t, HeldSetpoint)]
    held = [t for t in m.terms if isinstance(t, HeldSetpoint)]
    f = fit_consistent(sig, sel, sig.rows("train")).model
    models = {"saved": m, "refit": f.with_terms(list(f.terms) + held, meta=m.meta)}
    np.set_printoptions(precision=3, suppress=True)
    for name, mm in models.items():
        A = np.asarray(mm.base.A, float)
        print(f"{name}: eigenvalues of A {np.sort(np.linalg.eigvals(A).real)}")
        for z, row in zip(sig.zones, A):
            print(f"    {z:16} {row}")
        if memory_warnings is not None:
            for w in memory_warnings(A, mm.base.outputs):
                print(f"    warning: {w}")
    per = _per_zone_season(evaluate(list(models.values()), ds0, names=list(models)))
    print("zones", [z.replace("M_", "").replace("_Apartment", "") for z in sig.zones])
    for s in ("winter", "spring", "summer", "fall", "all"):
        row = per["saved"]["seasons"][s]
        for label, vals in (("persistence", row["persistence"]), ("time-of-week", row["time_of_week"])):
            print(f"{s:7} {label:13} " + " ".join(f"{x:.3f}" for x in vals) + f"  mean {np.mean(vals):.3f}")
        for name in models:
            r = per[name]["seasons"][s]
            cells = [f"{x:.3f}{'*' if x > p else ' '}" for x, p in zip(r["model"], r["persistence"])]
            print(f"{s:7} {name:13} " + " ".join(cells) + f" mean {np.mean(r['model']):.3f}")


def pairs(path: str) -> None:
    from hvacfmu.diagnosis.crossval import fold_fits, fold_scores, make_plan
    from hvacfmu.models import load_model
    from hvacfmu.models.causes.held_setpoint import HeldSetpoint

    _, _, sig = _signals()
    m = load_model(path)
    sel = [t for t in m.terms if not isinstance(t, HeldSetpoint)]
    plan = make_plan(sig, 10, 96)
    Z = sig.zones
    wint = [sig.season[st] == "winter" for st in plan.starts]
    for pair in (("M_S1_Apartment", "M_S2_Apartment"), ("M_N1_Apartment", "M_N2_Apartment")):
        zis = [Z.index(z) for z in pair]
        fits = fold_fits(sig, plan, sel, zis)
        together = fold_scores(sig, plan, fits, zis)
        alone = [fold_scores(sig, plan, fits, [zi]) for zi in zis]

        def mean(scores, only=None):
            xs = scores if only is None else [x[k] for x, k in zip(scores, only)]
            return [round(float(v), 3) for v in np.nanmean(np.concatenate(xs), axis=0)]

        print(pair, "per fold, pair simulated:", np.round([float(np.nanmean(x)) for x in together], 3))
        print("    all windows: together", mean(together), "alone", [mean(a)[0] for a in alone])
        print("    winter:      together", mean(together, only=wint), "alone", [mean(a, only=wint)[0] for a in alone])
        lam = [float(np.min(np.linalg.eigvals(np.asarray(f.base.A)[np.ix_(zis, zis)]).real)) for f in fits]
        print("    smallest eigenvalue of the pair's block, per fold", np.round(lam, 2))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["refit", "pairs"])
    ap.add_argument("--model", required=True, help="a saved diagnosed model of the apartments (wind case)")
    args = ap.parse_args(argv)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        (refit if args.what == "refit" else pairs)(args.model)


if __name__ == "__main__":
    main()
