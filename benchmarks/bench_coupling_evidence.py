"""Evidence for and against zone couplings on battery cases (issue 15, couplings).

For each pair of zones not coupled in the base structure, on the final structure the
diagnosis found (its accepted terms), it prints:

- ``dT``: standard deviation [K] of the measured difference ``T_b − T_a`` on the training
  rows, and what is left of it after the season × time-of-week means (the part the zones'
  seasonal gain profiles cannot absorb);
- ``k (t)``: untied one-step coefficients of the difference in each zone's equation
  [1/step] and their t-statistics, without and with a common-mode control (the other
  zones' mean one-step residual at the same step);
- cross-validated 24-h gains [%] (10 blocks of whole training weeks, week-clustered t):
  the pair simulated together with the one-step fit (the rule), each zone alone with its
  partner measured, the conductance fixed at ``k`` with the rest of the structure refitted
  around it, and the conductance chosen per fold by 24-h output error on the other folds
  (nested, grid ``0 … 0.04``/step at 15 min).

Run: ``python3 benchmarks/bench_coupling_evidence.py [--only 25,37,15,7,0]`` (row4 15-min
cases of ``bench_diagnosis_battery.py``; about 30 s of CPU per case; data cached).

``--pairs`` instead prints, without a diagnosis, what differs between the battery's injected pairs
(every coupling case by default) and, for comparison, every non-adjacent pair of the clean cases
of the same layouts: the pair's distance (zone centres) [m], volumes [m³] and fast capacitances
(air + furniture) [MJ/K], the conductance per step ``ua·step/C`` [1/step], ``sd(T_b − T_a)`` raw and
after the season × time-of-week means [K], each zone's own temperature sd after those means
(how tightly its boxes hold it) [K], the coupling heat this carries ``ua · sd_within`` [W] and
the temperature change per step it makes ``ua · step · sd_within / C`` [mK/step].
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

K_FIXED = (0.01, 0.04, 0.08)  # [1/step at 15 min] conductances forced on the pair
K_GRID = (0.0, 0.005, 0.01, 0.02, 0.04)  # output-error grid [1/step at 15 min]


def _fixed_coupling_class():
    from hvacfmu.models.extended import ZoneCoupling

    class FixedCoupling(ZoneCoupling):
        """A coupling whose conductance the refit may not change (bounds ``[k, k]``)."""

        k_fixed = 0.0

        def features(self, sig, U_eff):
            k = self.k_fixed
            return [(z, n, col, k, k + 1e-9) for z, n, col, _, _ in super().features(sig, U_eff)]

    return FixedCoupling


def _gain(plan, before, after) -> str:
    from hvacfmu.diagnosis.crossval import paired_test

    r = paired_test(plan, before, after)
    return f"{r['gain_percent']:+5.1f} % (t {r['t']:+5.1f})"


def _untied(sig, W, terms, a, b, extra) -> str:
    """Each zone's own coefficient on the difference toward the other, with ``extra`` control columns."""
    from hvacfmu.diagnosis.design import bounded_ls, effective_inputs, term_features, zone_design

    target = np.vstack([sig.Y[1:], np.full((1, sig.nz), np.nan)])
    U = effective_inputs(sig, terms)
    feats = [term_features(sig, t, U) for t in terms]
    d = sig.Y[:, b] - sig.Y[:, a]
    out = []
    for z, col in ((a, d), (b, -d)):
        D = zone_design(sig, z, terms, U, feats)
        X = np.column_stack([D.X, *extra, col])
        ne = len(extra)
        lo, hi = np.r_[D.lower, [-np.inf] * ne, -1.0], np.r_[D.upper, [np.inf] * ne, 1.0]
        ls = bounded_ls(W(X), W(target[:, z] - D.offset), lo, hi, dof_extra=W.n_groups)
        sd = np.sqrt(max(ls.cov[-1, -1], 0.0))
        out.append(f"{ls.theta[-1]:.3f} ({ls.theta[-1] / sd:.1f})")
    return " / ".join(out)


def _nested_output_error(sig, plan, terms, za, zb, key) -> str:
    """Per fold the fixed conductance of the grid with the lowest 24-h RMS on the other folds' windows."""
    from hvacfmu.diagnosis.crossval import fold_fits, fold_scores

    Fixed = _fixed_coupling_class()
    nf = len(plan.starts)
    R = {}
    for k in K_GRID:
        Fixed.k_fixed = k
        extra = [Fixed(zone_a=za, zone_b=zb)] if k > 0 else []
        models = fold_fits(sig, plan, list(terms) + extra, key)
        # every fold model on every fold's windows: R[k][f][g]
        R[k] = [fold_scores(sig, plan, [m] * nf, key) for m in models]
    before, after, chosen = [], [], []
    for f in range(nf):
        cost = {k: np.mean([np.nanmean(R[k][f][g]) for g in range(nf) if g != f]) for k in K_GRID}
        kb = min(K_GRID, key=lambda k: cost[k])
        chosen.append(kb)
        before.append(R[0.0][f][f])
        after.append(R[kb][f][f])
    return f"{_gain(plan, before, after)}, k per fold {chosen}"


def pair_evidence(sig, terms, a, b) -> dict:
    """The measures of the module docstring for zones ``a``, ``b`` (indices) on structure ``terms``."""
    from hvacfmu.diagnosis.crossval import fold_fits, fold_scores, make_plan
    from hvacfmu.diagnosis.design import Within, fit_structure
    from hvacfmu.diagnosis.selection import one_step_residuals
    from hvacfmu.models.extended import ZoneCoupling

    za, zb = sig.zones[a], sig.zones[b]
    rows = sig.rows("train")
    W = Within(sig.group, rows)
    d = sig.Y[:, b] - sig.Y[:, a]
    out = {"dT_std_K": f"{np.nanstd(d[rows]):.2f}, after time-of-week means {np.nanstd(W(d)):.2f}"}
    resid = one_step_residuals(sig, fit_structure(sig, terms, rows).model)
    others = [j for j in range(sig.nz) if j not in (a, b)]
    r = resid[:, others]
    n_ok = np.isfinite(r).sum(axis=1)
    cm = np.where(n_ok > 0, np.nansum(r, axis=1) / np.maximum(n_ok, 1), 0.0)  # common mode, 0 where unknown
    out["k_untied"] = _untied(sig, W, terms, a, b, [])
    out["k_untied_common_mode"] = _untied(sig, W, terms, a, b, [cm])
    plan = make_plan(sig, 10, 96)
    key = (a, b)
    t = ZoneCoupling(zone_a=za, zone_b=zb)
    base = fold_fits(sig, plan, terms, key)
    with_ls = fold_fits(sig, plan, list(terms) + [t], key)
    out["pair_together"] = _gain(plan, fold_scores(sig, plan, base, key), fold_scores(sig, plan, with_ls, key))
    for z in key:
        b0, b1 = fold_scores(sig, plan, base, (z,)), fold_scores(sig, plan, with_ls, (z,))
        out[f"alone_{sig.zones[z]}"] = _gain(plan, b0, b1)
    Fixed = _fixed_coupling_class()
    ref = fold_scores(sig, plan, base, key)
    for k in K_FIXED:
        Fixed.k_fixed = k
        ms = fold_fits(sig, plan, list(terms) + [Fixed(zone_a=za, zone_b=zb)], key)
        out[f"fixed_k_{k}"] = _gain(plan, ref, fold_scores(sig, plan, ms, key))
    out["output_error_nested"] = _nested_output_error(sig, plan, terms, za, zb, key)
    return out


def run_case(case, weeks):
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.diagnosis.design import make_signals
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(weeks=weeks, seed=case["seed"], effects=case["effects"], layout=case["layout"])
    ds = prepare(paths.measurements, paths.building, step=case["step"])
    truth = json.loads(paths.truth.read_text())
    injected = {frozenset(e["zones"]): e["ua"] for e in truth.get("effects", []) if e["name"] == "zone_coupling"}
    rep = diagnose(ds, progress=False)
    sig = make_signals(ds, rep.base_model)
    terms = list(rep.model.terms)
    have = {frozenset(t.zones()) for t in terms if t.cause == "zone_coupling"}
    print(f"case {case['id']} {case['layout']} {case['step'] / 60:.0f} min {case['effects'] or 'clean'}")
    for a in range(sig.nz):
        for b in range(a + 1, sig.nz):
            if b in sig.neighbours[a] or a in sig.neighbours[b] or frozenset((sig.zones[a], sig.zones[b])) in have:
                continue
            ua = injected.get(frozenset((sig.zones[a], sig.zones[b])))
            print(f"  {sig.zones[a]}+{sig.zones[b]} ({f'{ua:.0f} W/K' if ua else 'not coupled'})")
            for name, val in pair_evidence(sig, terms, a, b).items():
                print(f"    {name:24s} {val}")


def pair_properties(case, weeks, ua_clean=1200.0) -> list:
    """Rows of ``--pairs`` for one case: its injected pairs, or every non-adjacent pair of a clean case."""
    from battery_oracle import fast_capacitance

    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.emulator.layouts import get_layout
    from hvacfmu.models.causes.signals import Within

    paths = cached_dataset(weeks=weeks, seed=case["seed"], effects=case["effects"], layout=case["layout"])
    ds = prepare(paths.measurements, paths.building, step=case["step"])
    truth = json.loads(paths.truth.read_text())
    lay = get_layout(case["layout"])
    injected = [(e["zones"], float(e["ua"])) for e in truth.get("effects", []) if e["name"] == "zone_coupling"]
    if not case["effects"]:
        b = ds.building
        adj = {frozenset((z.name, n)) for z in b.zones for n in z.adjacent}
        names = [z.name for z in b.zones]
        injected = [
            ([a, c], ua_clean) for i, a in enumerate(names) for c in names[i + 1 :] if frozenset((a, c)) not in adj
        ]
    fr = ds.frame
    train = np.isin(np.asarray(ds.week_of_row), [w.number for w in ds.weeks if w.train])
    idx = fr.index
    tow = ((np.asarray(idx.dayofweek) * 24 + np.asarray(idx.hour)) * 3600 + np.asarray(idx.minute) * 60) // int(ds.step)
    season = np.unique(ds.season_of_row, return_inverse=True)[1]
    group = season * 10000 + tow
    temps = fr[[f"T_{z.name}" for z in ds.building.zones]].to_numpy(float)
    rows = np.flatnonzero(train & np.isfinite(temps).all(axis=1))
    W = Within(group, rows)
    vol = {z.name: z.volume for z in ds.building.zones}
    out = []
    for (za, zb), ua in injected:
        ta, tb = fr[f"T_{za}"].to_numpy(float), fr[f"T_{zb}"].to_numpy(float)
        d = tb - ta
        ca, cb = fast_capacitance(truth, za), fast_capacitance(truth, zb)
        (ax0, ax1, ay0, ay1), (bx0, bx1, by0, by1) = lay.rects[za], lay.rects[zb]
        dist = float(np.hypot((ax0 + ax1 - bx0 - bx1) / 2, (ay0 + ay1 - by0 - by1) / 2))
        sw = float(np.std(W(d)))
        out.append(
            {
                "case": case["id"],
                "layout": case["layout"],
                "pair": f"{za}+{zb}",
                "ua": ua,
                "injected": bool(case["effects"]),
                "distance_m": dist,
                "volume_m3": (vol[za], vol[zb]),
                "C_MJ_per_K": (ca / 1e6, cb / 1e6),
                "k_per_step": (ua * ds.step / ca, ua * ds.step / cb),
                "sd_dT_K": float(np.nanstd(d[rows])),
                "sd_dT_within_K": sw,
                "sd_zone_within_K": (float(np.std(W(ta))), float(np.std(W(tb)))),
                "heat_W": ua * sw,
                "dT_per_step_mK": (1e3 * ua * ds.step * sw / ca, 1e3 * ua * ds.step * sw / cb),
            }
        )
    return out


def _pair_line(r) -> str:
    def two(v, f):
        return "/".join(format(x, f) for x in v)

    return (
        f"case {r['case']:3d} {r['layout']:5s} {r['pair']:7s} {'injected' if r['injected'] else 'clean   '} "
        f"ua {r['ua']:5.0f} W/K  dist {r['distance_m']:5.1f} m  V {two(r['volume_m3'], '.0f')} m3  "
        f"C {two(r['C_MJ_per_K'], '.1f')} MJ/K  k {two(r['k_per_step'], '.3f')}/step  "
        f"sd dT {r['sd_dT_K']:.2f}, within {r['sd_dT_within_K']:.3f} K  "
        f"zones within {two(r['sd_zone_within_K'], '.3f')} K  heat {r['heat_W']:4.0f} W  "
        f"dT/step {two(r['dT_per_step_mK'], '.1f')} mK"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "--only",
        default=None,
        help="battery case ids (default 25,37,15,7,0; with --pairs every "
        "coupling case and every 15-min clean row4/core9 case)",
    )
    ap.add_argument("--weeks", type=int, default=16)
    ap.add_argument("--pairs", action="store_true", help="pair properties only (no diagnosis)")
    args = ap.parse_args()
    from bench_diagnosis_battery import make_cases

    cases = {c["id"]: c for c in make_cases(48, 2026)}
    if args.pairs:
        ids = [int(x) for x in args.only.split(",")] if args.only else [15, 25, 37, 31, 43, 0, 1, 3, 6, 7, 10]
        for cid in ids:
            for r in pair_properties(cases[cid], args.weeks):
                print(_pair_line(r), flush=True)
        return
    keep = [int(x) for x in (args.only or "25,37,15,7,0").split(",")]
    for cid in keep:
        c0 = time.process_time()
        run_case(cases[cid], args.weeks)
        print(f"  ({time.process_time() - c0:.0f} s CPU)", flush=True)


if __name__ == "__main__":
    main()
