"""How the time constant of a thermal-mass candidate is chosen, and what each choice scores (issue 15).

The diagnosis picks a thermal-mass candidate's time constant τ from the grid
(:data:`hvacfmu.models.causes.thermal_mass.TIME_CONSTANTS_H`) by the one-step likelihood on the
training rows and then cross-validates that one τ (10 blocks of whole weeks, 24-h open loop,
week-clustered paired t). This benchmark runs the diagnosis on battery cases and, the first time a
thermal-mass candidate of a zone reaches the cross-validation, scores on the same folds against
the same baseline:

- every τ of the grid (cross-validated gain ± SE [%], t);
- ``one-step``: the diagnosis's own choice;
- ``in-sample 24 h``: the τ whose structure, fitted on all training rows, predicts the training
  days best 24 h open loop (chosen before the cross-validation, like the one-step choice);
- ``nested``: for each fold, the τ with the best cross-validated gain on the *other* folds (the
  fold's own held-out error never enters its choice);
- ``best t of grid``: the τ with the highest paired t — a selection on the test folds, not an honest score.

Run: ``python3 benchmarks/bench_mass_time_constant.py [--only 16,12,18] [--zones S]`` (cases of
``bench_diagnosis_battery.py``; data cached; about 7× the CPU time of the cases' diagnosis).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _fmt(r) -> str:
    return f"{r['gain_percent']:+6.2f} ± {r['se_percent']:.2f} % (t {r['t']:+5.2f})"


def _in_sample_choice(sig, plan, terms, variants, key) -> int:
    """Index of the τ whose structure fitted on every training row predicts the training days best (24 h)."""
    from hvacfmu.diagnosis.crossval import CVPlan, fold_scores
    from hvacfmu.diagnosis.design import Within, fit_structure

    rows = sig.rows("train")
    st = np.concatenate(plan.starts)
    one = CVPlan([np.unique(sig.week[rows])], [rows], [Within(sig.group, rows)], [st], [sig.week[st]], plan.horizon)
    rms = []
    for t in variants:
        m = fit_structure(sig, list(terms) + [t], rows, within=one.within[0], only_zones=key).model
        rms.append(float(np.nanmean(fold_scores(sig, one, [m], key)[0])))
    return int(np.argmin(rms))


def _nested(plan, before, afters) -> tuple:
    """Per fold the τ with the best summed gain on the other folds; its scores on the fold itself."""
    nf = len(before)
    gain = np.array([[np.nansum(before[f] - a[f]) for f in range(nf)] for a in afters])  # (n_tau, n_folds)
    picks = [int(np.argmax(gain.sum(axis=1) - gain[:, f])) for f in range(nf)]
    return [afters[j][f] for f, j in enumerate(picks)], picks


def probe(sig, plan, terms, c, base_scores, out: list) -> None:
    """Score every τ of candidate ``c`` on the diagnosis's folds and print the choices (appended to ``out``)."""
    from hvacfmu.diagnosis import selection as S
    from hvacfmu.diagnosis.crossval import fold_fits, fold_scores, paired_test

    key = tuple(sorted(set(S._affected(sig, c.term))))
    before = base_scores[key]
    afters = [fold_scores(sig, plan, fold_fits(sig, plan, list(terms) + [t], key), key) for t in c.variants]
    taus = [sig.step / t.alpha / 3600.0 for t in c.variants]
    res = [paired_test(plan, before, a) for a in afters]
    one = next(i for i, t in enumerate(c.variants) if t.alpha == c.term.alpha)
    ins = _in_sample_choice(sig, plan, terms, c.variants, key)
    nested, picks = _nested(plan, before, afters)
    rn = paired_test(plan, before, nested)
    best = int(np.argmax([r["t"] for r in res]))
    print(f"  zone {c.location['zone']} (round with {len(terms)} terms, ΔBIC {c.test['delta_bic']:.1f})")
    for tau, r in zip(taus, res):
        print(f"    τ {tau:6.1f} h: {_fmt(r)}")
    print(f"    one-step       τ {taus[one]:6.1f} h: {_fmt(res[one])}")
    print(f"    in-sample 24 h τ {taus[ins]:6.1f} h: {_fmt(res[ins])}")
    print(f"    nested         τ per fold {[taus[j] for j in picks]}: {_fmt(rn)}")
    print(f"    best t of grid τ {taus[best]:6.1f} h: {_fmt(res[best])} (selected on the test folds)")
    out.append(
        {
            "zone": c.location["zone"],
            "one_step": res[one],
            "in_sample": res[ins],
            "nested": rn,
            "best": res[best],
            "by_tau": dict(zip(taus, res)),
        }
    )


def run(case, zones) -> None:
    from bench_diagnosis_battery import run_case

    from hvacfmu.diagnosis import selection as S

    seen: set = set()
    rec: list = []
    orig = S.cross_validate

    def hooked(sig, plan, terms, c, base_scores):
        orig(sig, plan, terms, c, base_scores)
        z = c.location.get("zone")
        if c.cause == "thermal_mass" and z not in seen and (not zones or z in zones):
            seen.add(z)
            probe(sig, plan, terms, c, base_scores, rec)

    S.cross_validate = hooked
    try:
        t0 = time.process_time()
        print(f"case {case['id']} {case['layout']} {case['step'] / 60:.0f} min seed {case['seed']} {case['effects']}")
        r = run_case(case, 16)
        print(f"  found {r['found']} missed {[m['name'] for m in r['missed']]} ({time.process_time() - t0:.0f} s CPU)")
    finally:
        S.cross_validate = orig


def main() -> None:
    from bench_diagnosis_battery import make_cases

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", default="16", help="comma-separated battery case ids")
    ap.add_argument("--zones", default="", help="comma-separated zones to probe (default: every zone)")
    args = ap.parse_args()
    cases = {c["id"]: c for c in make_cases(48, 2026)}
    zones = {z for z in args.zones.split(",") if z}
    for i in (int(x) for x in args.only.split(",")):
        run(cases[i], zones)


if __name__ == "__main__":
    main()
