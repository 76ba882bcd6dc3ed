"""Does any pair statistic separate injected zone couplings from clean pairs? (session 16, issue 15)

Offline experiment, no diagnosis run and no rule change. For every pair of zones not adjacent in the base
structure, on injected coupling cases (recall set: the pair the emulator coupled) and on clean cases
(false-alarm set: every non-adjacent pair), on the detectability oracle's reference structure
(:class:`battery_oracle.Oracle`: base Model A plus the solar path of every window the emulator has), it
computes one-step statistics that need no cross-validation:

- ``k`` (t): each zone's free coefficient on the difference toward its partner (``T_p − T_z``), volume-scaled
  (``k_z V_z / V̄``), week-clustered t not used: the plain OLS t;
- ``sym``: ratio of the two zones' ``k`` (1 for an exchange through one conductance);
- ``lag split``: the difference cut at a lag ``L`` (1 h and 3 h) into the partner's old level
  ``T_p(k−L) − T_z(k)`` and its recent change ``T_p(k) − T_p(k−L)``, both free; an exchange acts on the
  present difference, so the two coefficients agree (ratio ``innov/level`` ≈ 1); a partner that only proxies a
  slow driver both zones share predicts as well from its old level (ratio < 1);
- ``rho``: correlation of the two zones' one-step residuals (season × time-of-week means removed): a shared
  driver moves both the same way (ρ > 0), an exchange moves them apart;
- ``rho|d``: the same after removing from each residual its projection on the difference (what is left of the
  co-movement once the exchange is allowed for).

Cross-validated gains of oracle (a), each zone alone with its partner measured, are read from the oracle records
of earlier sessions when they exist (``--oracle`` files), else computed (``--cv``).

Run: ``python3 benchmarks/coupling_s16.py [--sets q26,q27,d26] [--cv] [--out FILE.jsonl]``; prints one line per
pair; ``--table FILE.jsonl`` reprints a results file.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

ORACLE_FILES = {
    "d26": "battery_oracle_results.jsonl",
    "q26": "diagnosis_quad4_s15_oracle.jsonl",
    "q27": "diagnosis_quad4_s15_seed2027_oracle.jsonl",
}
LAGS_H = (1.0, 3.0)


def case_sets() -> dict:
    """The battery draws of the brief: quad4 seeds 2026/2027, the default battery seeds 2026/2027."""
    from bench_diagnosis_battery import make_cases

    return {
        "q26": make_cases(32, 2026, layouts=["quad4"], n_clean=4, n_pair=4, step=900),
        "q27": make_cases(16, 2027, layouts=["quad4"], n_clean=6, n_pair=4, step=900),
        "d26": make_cases(48, 2026),
        "d27": make_cases(48, 2027),
    }


def _is_coupling_case(c) -> bool:
    return any(e.startswith("zone_coupling") for e in c["effects"])


def _oracle_alone(set_name: str) -> dict:
    """{(case id, frozenset pair): {zone: gain record}} from an earlier oracle file."""
    f = ORACLE_FILES.get(set_name)
    out: dict = {}
    if not f or not os.path.exists(os.path.join(os.path.dirname(__file__), f)):
        return out
    for line in open(os.path.join(os.path.dirname(__file__), f)):
        r = json.loads(line)
        for e in r.get("effects", []) + r.get("clean", []):
            if e["name"] == "zone_coupling":
                out[(r["case"]["id"], frozenset(e["location"]["zones"]))] = e["alone"]
    return out


def _free_fit(sig, W, design, target_z, cols):
    """Free coefficients (and OLS t) of ``cols`` added to a zone's design (within-transformed)."""
    from hvacfmu.diagnosis.design import bounded_ls

    n = len(cols)
    X = W(np.column_stack([design.X, *cols]))
    y = W(target_z - design.offset)
    ls = bounded_ls(X, y, np.r_[design.lower, [-np.inf] * n], np.r_[design.upper, [np.inf] * n])
    sd = np.sqrt(np.maximum(np.diag(ls.cov)[-n:], 1e-300))
    return ls.theta[-n:], ls.theta[-n:] / sd


def _lagged(x, L):
    out = np.full_like(x, np.nan)
    out[L:] = x[:-L]
    return out


def pair_stats(sig, terms, resid, a, b) -> dict:
    """The one-step statistics of the module docstring for zones ``a``, ``b`` (indices)."""
    from hvacfmu.diagnosis.design import effective_inputs, term_features, zone_design
    from hvacfmu.models.causes.signals import Within, coupling_ratios

    target = np.vstack([sig.Y[1:], np.full((1, sig.nz), np.nan)])
    U = effective_inputs(sig, terms)
    feats = [term_features(sig, t, U) for t in terms]
    ra, rb = coupling_ratios(sig, a, b)
    Ls = [max(1, int(round(h * 3600.0 / sig.step))) for h in LAGS_H]
    rows = sig.rows("train")
    ok = np.ones(len(rows), bool)
    for L in Ls:
        ok &= rows >= L
        ok[ok] &= np.isfinite(sig.Y[rows[ok] - L][:, [a, b]]).all(axis=1)
    rows = rows[ok]
    W = Within(sig.group, rows)
    out: dict = {}
    for z, p, r in ((a, b, ra), (b, a, rb)):
        D = zone_design(sig, z, terms, U, feats)
        d = sig.Y[:, p] - sig.Y[:, z]
        (k,), (t,) = _free_fit(sig, W, D, target[:, z], [d])
        out.setdefault("k", []).append(float(k / r))
        out.setdefault("t", []).append(float(t))
        for L, h in zip(Ls, LAGS_H):
            old = _lagged(sig.Y[:, p], L)
            (kl, ki), (tl, ti) = _free_fit(sig, W, D, target[:, z], [old - sig.Y[:, z], sig.Y[:, p] - old])
            out.setdefault(f"lag{h:g}h", []).append([float(kl / r), float(ki / r), float(tl), float(ti)])
    ea, eb = W(resid[:, a]), W(resid[:, b])
    dw = W(sig.Y[:, b] - sig.Y[:, a])
    good = np.isfinite(ea) & np.isfinite(eb) & np.isfinite(dw)
    ea, eb, dw = ea[good], eb[good], dw[good]
    out["rho"] = float(np.corrcoef(ea, eb)[0, 1])
    pa = ea - dw * (dw @ ea) / (dw @ dw)
    pb = eb - dw * (dw @ eb) / (dw @ dw)
    out["rho_given_d"] = float(np.corrcoef(pa, pb)[0, 1])
    k = out["k"]
    out["sym"] = float(k[0] / k[1]) if k[1] != 0 else float("inf")
    out["dT_within_K"] = float(np.std(dw))
    return out


def _rho_adjacent(sig, resid, a, b) -> list:
    """Residual correlations of ``a`` and ``b`` with each zone adjacent to either (the building's wall-coupled
    pairs: how much residuals co-move where no undeclared exchange is injected)."""
    from hvacfmu.models.causes.signals import Within

    W = Within(sig.group, sig.rows("train"))
    E = [W(resid[:, z]) for z in range(sig.nz)]
    out = []
    for z in (a, b):
        for c in sorted(set(sig.neighbours[z])):
            ok = np.isfinite(E[z]) & np.isfinite(E[c])
            out.append(float(np.corrcoef(E[z][ok], E[c][ok])[0, 1]))
    return out


def run_case(case, set_name, oracle_alone, weeks=16, cv=False) -> list:
    from battery_oracle import Oracle

    from hvacfmu.data import prepare
    from hvacfmu.diagnosis.design import fit_structure
    from hvacfmu.diagnosis.selection import one_step_residuals
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.models.extended import ZoneCoupling

    paths = cached_dataset(weeks=weeks, seed=case["seed"], effects=case["effects"], layout=case["layout"])
    ds = prepare(paths.measurements, paths.building, step=case["step"])
    truth = json.loads(paths.truth.read_text())
    o = Oracle(ds, truth)
    sig, terms = o.sig, o.reference()
    resid = one_step_residuals(sig, fit_structure(sig, terms, sig.rows("train")).model)
    injected = {frozenset(e["zones"]): float(e["ua"]) for e in truth.get("effects", []) if e["name"] == "zone_coupling"}
    recs = []
    for a in range(sig.nz):
        for b in range(a + 1, sig.nz):
            if b in sig.neighbours[a] or a in sig.neighbours[b]:
                continue
            pair = frozenset((sig.zones[a], sig.zones[b]))
            if case["effects"] and pair not in injected:
                continue  # effect cases: only the injected pair (others are neither recall nor clean)
            rec = {
                "set": set_name,
                "case": case["id"],
                "layout": case["layout"],
                "step": case["step"],
                "pair": [sig.zones[a], sig.zones[b]],
                "injected": pair in injected,
                "ua": injected.get(pair),
                "effects": case["effects"],
            }
            rec.update(pair_stats(sig, terms, resid, a, b))
            rec["rho_adjacent"] = _rho_adjacent(sig, resid, a, b)
            alone = oracle_alone.get((case["id"], pair))
            if alone is None and cv and o.plan is not None:
                t = ZoneCoupling(zone_a=sig.zones[a], zone_b=sig.zones[b])
                alone = {sig.zones[a]: o.gain(t, (a,)), sig.zones[b]: o.gain(t, (b,))}
            if alone is not None:
                rec["alone"] = [
                    [alone[z]["gain_percent"], alone[z]["t"]] if alone.get(z) else None for z in rec["pair"]
                ]
            recs.append(rec)
    return recs


def line(r) -> str:
    al = r.get("alone")
    als = " ".join(f"{g:+5.1f}/{t:4.1f}" if g is not None else "  n/a" for g, t in al) if al else "     n/a     "
    lag = " ".join(
        f"{h}: " + " ".join(f"{v[1] / v[0] if v[0] else np.inf:+5.2f}" for v in r[h]) for h in r if h.startswith("lag")
    )
    return (
        f"{r['set']} {r['case']:3d} {r['layout']:5s} {int(r['step'] / 60):2d}m {'+'.join(r['pair']):6s} "
        f"{'INJ' if r['injected'] else 'cln'} alone {als}  k {r['k'][0]:+.3f}/{r['k'][1]:+.3f} "
        f"t {r['t'][0]:+5.1f}/{r['t'][1]:+5.1f} sym {r['sym']:+5.2f}  innov/level {lag}  "
        f"rho {r['rho']:+.2f} rho|d {r['rho_given_d']:+.2f} dT {r['dT_within_K']:.3f}"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sets", default="q26,q27,d26")
    ap.add_argument("--steps", default="900", help="model steps [s] to include (comma-separated)")
    ap.add_argument("--cv", action="store_true", help="compute oracle (a) gains where no record has them")
    ap.add_argument("--out", default=None)
    ap.add_argument("--table", default=None, help="reprint a results file")
    ap.add_argument("--controls", default=None, help="results file of the statistics: add the mass controls")
    ap.add_argument("--placebo", default=None, help="results file of the statistics: add the others-mean placebo")
    ap.add_argument(
        "--placebo2", default=None, help="set:case:A+B[:inj],...: gains beyond the common-neighbour placebo (s16 2nd)"
    )
    args = ap.parse_args()
    if args.placebo2:
        main_placebo2(args.placebo2, args.out)
        return
    if args.placebo:
        sets = {n: {c["id"]: c for c in cs} for n, cs in case_sets().items()}
        recs = [json.loads(ln) for ln in open(args.placebo)]
        keys = sorted({(r["set"], r["case"]) for r in recs if args.sets == "all" or r["set"] in args.sets.split(",")})
        for name, cid in keys:
            mine = [r for r in recs if (r["set"], r["case"]) == (name, cid)]
            if not any(r["injected"] or any(_passes_alone(g) for g in (r.get("alone") or [])) for r in mine):
                continue
            t0 = time.process_time()
            for r in placebo_case(sets[name][cid], name, mine):
                if r["placebo"]:
                    print(line(r))
                    for k, v in r["placebo"].items():
                        print(
                            f"      {k:4s} placebo {v['placebo'][0]:+5.1f} (t {v['placebo'][1]:4.1f})  coupling over "
                            f"placebo {v['coupling'][0]:+5.1f} (t {v['coupling'][1]:4.1f})  over placebo + slow "
                            f"{v['coupling_over_slow'][0]:+5.1f} (t {v['coupling_over_slow'][1]:4.1f})",
                            flush=True,
                        )
                    if args.out:
                        with open(args.out, "a") as f:
                            f.write(json.dumps(r) + "\n")
            print(f"  ({time.process_time() - t0:.0f} CPU-s)", flush=True)
        return
    if args.controls:
        sets = {n: {c["id"]: c for c in cs} for n, cs in case_sets().items()}
        recs = [json.loads(ln) for ln in open(args.controls)]
        keys = sorted({(r["set"], r["case"]) for r in recs if args.sets == "all" or r["set"] in args.sets.split(",")})
        for name, cid in keys:
            mine = [r for r in recs if (r["set"], r["case"]) == (name, cid)]
            if not any(r["injected"] or any(_passes_alone(g) for g in (r.get("alone") or [])) for r in mine):
                continue
            t0 = time.process_time()
            for r in control_case(sets[name][cid], name, mine):
                if r["controls"]:
                    print(line(r))
                    for k, v in r["controls"].items():
                        print(
                            f"      {k:10s} mass {v['mass'][0]:+5.1f} (t {v['mass'][1]:4.1f})  coupling over mass "
                            f"{v['coupling'][0]:+5.1f} (t {v['coupling'][1]:4.1f})",
                            flush=True,
                        )
                    if args.out:
                        with open(args.out, "a") as f:
                            f.write(json.dumps(r) + "\n")
            print(f"  ({time.process_time() - t0:.0f} CPU-s)", flush=True)
        return
    if args.table:
        for ln in open(args.table):
            print(line(json.loads(ln)))
        return
    sets = case_sets()
    steps = {float(s) for s in args.steps.split(",")}
    done = set()
    if args.out and os.path.exists(args.out):
        done = {(json.loads(ln)["set"], json.loads(ln)["case"]) for ln in open(args.out)}
    for name in args.sets.split(","):
        alone = _oracle_alone(name)
        for c in sets[name]:
            if (c["effects"] and not _is_coupling_case(c)) or c["step"] not in steps or (name, c["id"]) in done:
                continue
            t0 = time.process_time()
            for r in run_case(c, name, alone, cv=args.cv):
                print(line(r), flush=True)
                if args.out:
                    with open(args.out, "a") as f:
                        f.write(json.dumps(r) + "\n")
            print(f"  ({time.process_time() - t0:.0f} CPU-s)", flush=True)


# --- controls: does the zone-alone gain survive a term standing for the zone's own slow dynamics? ------------------
MASS_TAU_H = tuple(float(x) for x in os.environ.get("COUPLING_S16_MASS_TAU_H", "24,72").split(","))


def _passes_alone(g) -> bool:
    return g is not None and g[0] >= 3.0 and g[1] >= 2.0


def _gain_over(o, ref, term, key) -> dict:
    """Cross-validated gain of ``ref + [term]`` over ``ref`` on zones ``key`` (others measured), any ``ref``."""
    from battery_oracle import _test

    from hvacfmu.diagnosis.crossval import fold_fits, fold_scores

    before = fold_scores(o.sig, o.plan, fold_fits(o.sig, o.plan, ref, key), key)
    after = fold_scores(o.sig, o.plan, fold_fits(o.sig, o.plan, ref + [term], key), key)
    return _test(o.plan, before, after)


def _others_mean_term(zone: str, others: tuple):
    """Placebo for a partner that only proxies drivers every zone shares: ``p · (mean(T_others) − T_zone)`` into
    ``zone``, ``others`` every zone but the zone and its candidate partner, ``p`` free in [−1, 1]."""
    import dataclasses

    from hvacfmu.models.extended import ZoneCoupling

    @dataclasses.dataclass(frozen=True)
    class OthersMean(ZoneCoupling):
        def zones(self):
            return (self.zone_a,)

        def location(self):
            return {"zone": self.zone_a, "others": list(others)}

        def features(self, sig, U_eff):
            a = sig.zones.index(self.zone_a)
            idx = [sig.zones.index(o) for o in others]
            return [(a, "p", sig.Y[:, idx].mean(axis=1) - sig.Y[:, a], -1.0, 1.0)]

        def with_fit(self, sig, coefs, stds):
            return dataclasses.replace(self, coef_ab=float(coefs.get("p", 0.0)))

        def contribute(self, c) -> None:
            a = c.zi[self.zone_a]
            idx = [c.zi[o] for o in others]
            c.Tn[..., a] += self.coef_ab * (c.T[..., idx].mean(axis=-1) - c.T[..., a])

        def add_equations(self, e) -> None:
            a = e.zi[self.zone_a]
            for o in others:
                e.A[a, e.zi[o]] += self.coef_ab / len(others)
            e.A[a, a] -= self.coef_ab

    return OthersMean(zone_a=zone, zone_b=zone)  # zone_b: one block for the fit (design.coupled_blocks)


SLOW_TAU_H = {"lp2": 2.0, "lp8": 8.0}  # low-pass filters of the facade irradiance (delayed solar through mass)
TOUT_TAU_H = 12.0  # low-pass filter of the outdoor temperature (slow envelope)


def _slow_controls(sig, zone: str) -> list:
    """Terms for a zone's own slow drivers: its facades' irradiance and the outdoor temperature, low-pass filtered
    (added to ``sig.V`` as ``I_<o><lp>`` and ``I_Tout``; free sign), so that a partner proxying them has less to
    explain."""
    import dataclasses

    from hvacfmu.models.causes.signals import ema_series
    from hvacfmu.models.extended import SolarGain

    @dataclasses.dataclass(frozen=True)
    class FreeColumn(SolarGain):
        def features(self, sig, U_eff):
            return [(sig.zones.index(self.zone), "coef", sig.V[f"I_{self.facade}"], -np.inf, np.inf)]

    def lp(x, tau_h):
        return ema_series(np.nan_to_num(x), min(sig.step / (tau_h * 3600.0), 1.0))

    out = []
    if "I_Tout" not in sig.V:
        sig.V["I_Tout"] = lp(sig.V["T_out"], TOUT_TAU_H)
    out.append(FreeColumn(zone=zone, facade="Tout"))
    if sig.has_solar:
        for o in sig.facades[sig.zones.index(zone)]:
            for name, tau in SLOW_TAU_H.items():
                if f"I_{o}{name}" not in sig.V:
                    sig.V[f"I_{o}{name}"] = lp(sig.V[f"I_{o}"], tau)
                out.append(FreeColumn(zone=zone, facade=f"{o}{name}"))
    return out


def placebo_case(case, set_name, recs, weeks=16) -> list:
    """Per zone of ``recs`` passing alone (or injected): the placebo's own zone-alone gain and the coupling's
    zone-alone gain over reference + placebo (:func:`_others_mean_term`)."""
    from battery_oracle import Oracle

    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.models.extended import ZoneCoupling

    paths = cached_dataset(weeks=weeks, seed=case["seed"], effects=case["effects"], layout=case["layout"])
    ds = prepare(paths.measurements, paths.building, step=case["step"])
    o = Oracle(ds, json.loads(paths.truth.read_text()))
    sig, ref = o.sig, o.reference()
    out = []
    for r in recs:
        za, zb = r["pair"]
        res = {}
        for i, z in enumerate(r["pair"]):
            if not (r["injected"] or _passes_alone((r.get("alone") or [None, None])[i])):
                continue
            zi = sig.zones.index(z)
            others = tuple(x for x in sig.zones if x not in (za, zb))
            p = _others_mean_term(z, others)
            gp = _gain_over(o, ref, p, (zi,))
            gc = _gain_over(o, ref + [p], ZoneCoupling(zone_a=za, zone_b=zb), (zi,))
            res[z] = {"placebo": [gp["gain_percent"], gp["t"]], "coupling": [gc["gain_percent"], gc["t"]]}
            slow = _slow_controls(sig, z)
            gs = _gain_over(o, ref + [p], slow[0], (zi,)) if len(slow) == 1 else None
            gcs = _gain_over(o, ref + [p] + slow, ZoneCoupling(zone_a=za, zone_b=zb), (zi,))
            res[z]["coupling_over_slow"] = [gcs["gain_percent"], gcs["t"]]
            del gs
        out.append({**r, "placebo": res})
    return out


def control_case(case, set_name, recs, weeks=16) -> list:
    """For each zone of ``recs`` (pairs of this case) that passes alone, or of an injected pair: the zone-alone
    gain of the coupling over the reference plus a slow mass in that zone (τ of :data:`MASS_TAU_H`), and the
    mass's own gain."""
    from battery_oracle import Oracle

    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.models.extended import ThermalMass, ZoneCoupling

    paths = cached_dataset(weeks=weeks, seed=case["seed"], effects=case["effects"], layout=case["layout"])
    ds = prepare(paths.measurements, paths.building, step=case["step"])
    o = Oracle(ds, json.loads(paths.truth.read_text()))
    sig, ref = o.sig, o.reference()
    out = []
    for r in recs:
        za, zb = r["pair"]
        res = {}
        for i, z in enumerate(r["pair"]):
            if not (r["injected"] or _passes_alone((r.get("alone") or [None, None])[i])):
                continue
            zi = sig.zones.index(z)
            t = ZoneCoupling(zone_a=za, zone_b=zb)
            for tau in MASS_TAU_H:
                m = ThermalMass(zone=z, alpha=min(sig.step / (tau * 3600.0), 1.0))
                gm = o.gain(m, (zi,))
                gc = _gain_over(o, ref + [m], t, (zi,))
                res[f"{z}@{tau:g}h"] = {
                    "mass": [gm["gain_percent"], gm["t"]],
                    "coupling": [gc["gain_percent"], gc["t"]],
                }
        out.append({**r, "controls": res})
    return out


# --- second pass: the common-neighbour placebo ------------------------------------------------------------------
NB_TAU_H = (3.0, 12.0)  # low-pass filters of a common neighbour's temperature (heat arriving through wall mass)


def _common_neighbour_terms(sig, z: str, pair, lowpass: bool) -> list:
    """Placebo terms for zone ``z`` of ``pair``: per zone adjacent to both zones of the pair, ``p_c · (T_c − T_z)``
    free in [−1, 1] (:class:`OthersPlacebo` with one zone) and, with ``lowpass``, that zone's measured temperature
    low-pass filtered at :data:`NB_TAU_H` as free columns. Empty when the pair has no common neighbour."""
    import dataclasses

    from hvacfmu.models.causes.signals import ema_series
    from hvacfmu.models.causes.zone_coupling import OthersPlacebo
    from hvacfmu.models.extended import SolarGain

    @dataclasses.dataclass(frozen=True)
    class FreeColumn(SolarGain):
        def features(self, sig, U_eff):
            return [(sig.zones.index(self.zone), "coef", sig.V[f"I_{self.facade}"], -np.inf, np.inf)]

    a, b = (sig.zones.index(x) for x in pair)
    common = sorted(set(sig.neighbours[a]) & set(sig.neighbours[b]))
    out: list = [OthersPlacebo(zone_a=z, zone_b=z, others=(sig.zones[c],)) for c in common]
    if lowpass:
        for c in common:
            for tau in NB_TAU_H:
                key = f"nb{sig.zones[c]}lp{tau:g}"
                if f"I_{key}" not in sig.V:
                    x = np.asarray(sig.Y[:, c], float)
                    fill = np.where(np.isfinite(x), x, np.nanmean(x))
                    sig.V[f"I_{key}"] = ema_series(fill, min(sig.step / (tau * 3600.0), 1.0))
                out.append(FreeColumn(zone=z, facade=key))
    return out


def placebo2_case(case, set_name, pairs, weeks=16) -> list:
    """Per zone of each pair in ``pairs`` ([(pair, injected)]): the coupling's zone-alone gain over the reference,
    over reference + others-mean placebo (old), + each common neighbour (new), + their low-pass temperatures."""
    from battery_oracle import Oracle

    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.models.causes.zone_coupling import OthersPlacebo
    from hvacfmu.models.extended import ZoneCoupling

    paths = cached_dataset(weeks=weeks, seed=case["seed"], effects=case["effects"], layout=case["layout"])
    ds = prepare(paths.measurements, paths.building, step=case["step"])
    o = Oracle(ds, json.loads(paths.truth.read_text()))
    sig, ref = o.sig, o.reference()
    out = []
    for pair, injected in pairs:
        za, zb = pair
        a, b = sig.zones.index(za), sig.zones.index(zb)
        common = [sig.zones[c] for c in sorted(set(sig.neighbours[a]) & set(sig.neighbours[b]))]
        others = tuple(x for x in sig.zones if x not in pair)
        shared = sorted(set(sig.facades[a]) & set(sig.facades[b]))
        t = ZoneCoupling(zone_a=za, zone_b=zb)
        res = {}
        for z in pair:
            zi = sig.zones.index(z)
            old = [OthersPlacebo(zone_a=z, zone_b=z, others=others)]
            new = old + _common_neighbour_terms(sig, z, pair, False)
            lp = old + _common_neighbour_terms(sig, z, pair, True)
            row = {}
            for name, ctl in (("alone", []), ("old", old), ("new", new), ("new_lp", lp)):
                g = _gain_over(o, ref + ctl, t, (zi,))
                row[name] = [g["gain_percent"], g["t"]]
            res[z] = row
        out.append(
            {
                "set": set_name,
                "case": case["id"],
                "layout": case["layout"],
                "step": case["step"],
                "pair": list(pair),
                "injected": injected,
                "common": common,
                "shared_facades": shared,
                "gains": res,
            }
        )
    return out


def placebo2_line(r) -> str:
    def cell(k):
        return " ".join(f"{r['gains'][z][k][0]:+6.1f}/{r['gains'][z][k][1]:4.1f}" for z in r["pair"])

    return (
        f"{r['set']} {r['case']:3d} {r['layout']:5s} {'+'.join(r['pair']):6s} {'INJ' if r['injected'] else 'cln'} "
        f"common {','.join(r['common']) or '-':7s} | alone {cell('alone')} | old {cell('old')} | new {cell('new')} "
        f"| new+lp {cell('new_lp')}"
    )


def main_placebo2(targets: str, out: str | None) -> None:
    """``targets``: ``set:case:A+B[:inj]`` comma-separated."""
    sets = {n: {c["id"]: c for c in cs} for n, cs in case_sets().items()}
    by_case: dict = {}
    for tgt in targets.split(","):
        parts = tgt.split(":")
        by_case.setdefault((parts[0], int(parts[1])), []).append((tuple(parts[2].split("+")), parts[-1] == "inj"))
    for (name, cid), pairs in by_case.items():
        t0 = time.process_time()
        for r in placebo2_case(sets[name][cid], name, pairs):
            print(placebo2_line(r), flush=True)
            if out:
                with open(out, "a") as f:
                    f.write(json.dumps(r) + "\n")
        print(f"  ({time.process_time() - t0:.0f} CPU-s)", flush=True)


if __name__ == "__main__":
    main()
