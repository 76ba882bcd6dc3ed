"""Probe (session 19, ``holgrow_s19.md``): every holiday screen of a battery case's diagnosis, round by round.

For each call of the holiday screen (``holiday_candidate``): the dates a holiday term of the model already holds
(``known``), the weeks the screen's rules picked, the three largest week means γ with their z, and the week by
likelihood that followed (``_holiday_week_by_likelihood``: its best week, ΔBIC and the weeks it scored). The
diagnosis itself is unchanged (the recorders only read).

Run::

    python3 benchmarks/holgrow_s19_screen.py --layouts quad4 --seed 2042 --cases 20 --only 15
"""

from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from bench_diagnosis_battery import make_cases, run_case  # noqa: E402

import hvacfmu.models.causes.internal_gain_schedule as igs  # noqa: E402
from hvacfmu.diagnosis import selection  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--cases", type=int, default=32)
    ap.add_argument("--layouts", default="quad4")
    ap.add_argument("--clean", type=int, default=4)
    ap.add_argument("--pairs", type=int, default=4)
    ap.add_argument("--step-min", type=float, default=15.0)
    ap.add_argument("--only", required=True)
    a = ap.parse_args()
    cases = make_cases(a.cases, a.seed, a.layouts.split(","), a.clean, a.pairs, a.step_min * 60.0)
    screen, by_lik = igs.holiday_candidate, selection._holiday_week_by_likelihood

    def rec_screen(sig, W, options, shift=0, known=frozenset()):
        c = screen(sig, W, options, shift=shift, known=known)
        ev = c.evidence or {}
        means = sorted(((g, w) for w, g in (ev.get("week_means") or {}).items()), reverse=True)[:3]
        med, sd = ev.get("week_mean_median"), ev.get("week_mean_robust_std")
        top = ", ".join(
            f"wk {w} γ {g:.3f} z {(g - med) / sd:.1f}" if med is not None and sd else f"wk {w} γ {g:.3f}"
            for g, w in means
        )
        picked = [w["week"] for w in ev.get("weeks", [])] + [w["week"] for w in ev.get("zone_weeks", [])]
        print(f"  screen known {len(known)} d: {c.status}, weeks picked {picked}, top week means: {top}")
        return c

    def rec_lik(sig, W, terms, cur_rss, factors, c, opts, cache, resid_all):
        by_lik(sig, W, terms, cur_rss, factors, c, opts, cache, resid_all)
        print(f"    week by likelihood: {c.evidence.get('week_likelihood')} -> {c.status}")

    igs.holiday_candidate = rec_screen
    selection._holiday_week_by_likelihood = rec_lik
    for i in [int(x) for x in a.only.split(",")]:
        print(f"== {a.layouts} {a.seed} case {i} {cases[i]['effects']}")
        r = run_case(cases[i], 16)
        print(f"   found {r['found']} false {r['unsupported']}")


if __name__ == "__main__":
    main()
