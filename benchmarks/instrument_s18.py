"""Instrument variants for the zone-by-zone coupling gate (session 18, issue 15).

For each case the diagnosis runs (default options), then on every non-adjacent pair the coupling conductance is
instrumented (6 h of the partner's airflow changes) in variants:

- ``base``: :func:`hvacfmu.diagnosis.selection.coupling_instrument` as on main;
- ``ctl_du``: the same with the *other* zones' airflow changes (same lags) added as controls in both stages: a
  partner's airflow that only tracks a driver another zone's boxes answer to (a common neighbour's reheat)
  loses its reach;
- ``ctl_u``: the other zones' airflow levels (same lags) as controls.

One JSON line per pair and variant. Write-up: ``benchmarks/instrument_s18.md``.
Run: ``python3 benchmarks/instrument_s18.py --cases q26:16,q26:4 --out FILE.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))


def _supply(sig, zone):
    cols = sorted({c for v, c in sig.supply_of.items() if v.split("_")[0] == zone or v.startswith(zone)})
    for c in cols:
        for src in (sig.V, sig.extra):
            if c in src:
                return np.asarray(src[c], float)
    return np.asarray(sig.V["T_supply"], float)


def instrument(sig, W, terms, t, lags, controls="none"):
    from hvacfmu.diagnosis.design import term_features, zone_design
    from hvacfmu.diagnosis.selection import _clustered_se
    from hvacfmu.models.causes.signals import coupling_ratios, effective_inputs, shifted

    target = np.vstack([sig.Y[1:], np.full((1, sig.nz), np.nan)])
    U_eff = effective_inputs(sig, terms)
    feats = [term_features(sig, tt, U_eff) for tt in terms]
    a, b = sig.zones.index(t.zone_a), sig.zones.index(t.zone_b)
    ra, rb = coupling_ratios(sig, a, b)
    d = sig.Y[:, b] - sig.Y[:, a]
    week = sig.week[W.rows]
    out, pooled = {}, []
    for z, p, col, r in ((a, b, d, ra), (b, a, -d, rb)):
        D = zone_design(sig, z, terms, U_eff, feats)
        du = np.diff(U_eff[:, p], prepend=U_eff[0, p])
        Z = np.column_stack([np.nan_to_num(shifted(du, lag)) for lag in range(1, lags + 1)])
        if controls in ("sup", "dusup"):  # the partner's delivered supply changes: Δ(u_p · T_supply of its unit)
            ts = _supply(sig, sig.zones[p])
            dq = np.diff(U_eff[:, p] * ts, prepend=U_eff[0, p] * ts[0])
            Zq = np.column_stack([np.nan_to_num(shifted(dq, lag)) for lag in range(1, lags + 1)])
            Z = Zq if controls == "sup" else np.column_stack([Z, Zq])
        X = D.X
        Ec = np.zeros((len(X), 0))
        if controls in (
            "endo",
            "endoTc",
        ):  # the neighbours' temperatures endogenous, instrumented by their own airflow moves
            nb = [j for j in sig.neighbours[z] if j != p]
            idx = [D.names.index(f"a[{sig.zones[j]}]") for j in nb]
            Ec = X[:, idx]
            X = np.delete(X, idx, axis=1)
            for j in nb:
                duj = np.diff(U_eff[:, j], prepend=U_eff[0, j])
                Z = np.column_stack([Z] + [np.nan_to_num(shifted(duj, lag)) for lag in range(1, lags + 1)])
        others = [o for o in range(sig.nz) if o not in (z, p)]
        if controls in ("Tc", "endoTc"):  # the neighbours' temperature history (a slow path via the walls)
            nb = [j for j in sig.neighbours[z] if j != p]
            hist = [np.nan_to_num(shifted(sig.Y[:, j], lag)) for j in nb for lag in (1, 2, 4, 8, 16, 24)]
            X = np.column_stack([X] + hist)
        if controls in ("du", "u"):
            extra = []
            for o in others:
                v = np.diff(U_eff[:, o], prepend=U_eff[0, o]) if controls == "du" else U_eff[:, o]
                extra += [np.nan_to_num(shifted(v, lag)) for lag in range(1, lags + 1)]
            X = np.column_stack([X] + extra)
        Xw = W(X)
        keep = (Xw * Xw).sum(axis=0) > 1e-300
        Xw = Xw[:, keep]
        Xw = Xw / np.sqrt((Xw * Xw).sum(axis=0))
        G = Xw.T @ Xw + 1e-10 * np.eye(Xw.shape[1])

        def resid(v, Xw=Xw, G=G):
            return v - Xw @ np.linalg.solve(G, Xw.T @ v)

        yt = resid(W(target[:, z] - D.offset))
        dt = resid(W(col))
        Zt = resid(W(Z))
        pi, *_ = np.linalg.lstsq(Zt, dt, rcond=None)
        dh = Zt @ pi
        e1 = dt - dh
        Ect = np.column_stack([resid(W(c)) for c in Ec.T]) if Ec.shape[1] else np.zeros((len(dt), 0))
        if Ec.shape[1]:
            Ech = Zt @ np.linalg.lstsq(Zt, Ect, rcond=None)[0]
            # 2SLS of y on [T_c, col]: the neighbours' coefficients, then FWL for the coupling's (the part of
            # the partner's instrumented move not reached through the instrumented T_c)
            yt = yt - Ect @ np.linalg.lstsq(np.column_stack([Ech, dh]), yt, rcond=None)[0][: Ec.shape[1]]
            dh = dh - Ech @ np.linalg.lstsq(Ech, dh, rcond=None)[0]
        m, n = Zt.shape[1], len(dt)
        F = (float(dh @ dh) / m) / (float(e1 @ e1) / max(n - m - Xw.shape[1], 1))
        den = float(dh @ dt)
        k_iv = float(dh @ yt) / den if den != 0 else 0.0
        e = yt - k_iv * dt
        se = _clustered_se(dh * e / den, week) if den != 0 else np.inf
        pooled.append((dh * r, dt * r, yt))
        zn = sig.zones[z]
        out[f"coef_{zn}"] = k_iv / r
        out[f"t_{zn}"] = float(k_iv / se) if se > 0 else 0.0
        out[f"F_{zn}"] = float(F)
        out[f"ols_{zn}"] = float(dt @ yt) / float(dt @ dt) / r
    den = sum(float(h @ x) for h, x, _ in pooled)
    k = sum(float(h @ y) for h, _, y in pooled) / den if den != 0 else 0.0
    u = sum(h * (y - k * x) for h, x, y in pooled) / den if den != 0 else np.zeros(len(week))
    se = _clustered_se(u, week)
    out["coef"] = float(k)
    out["t"] = float(k / se) if se > 0 else 0.0
    return out


def run(spec, variants, options):
    from coupling_s17 import _sets

    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.diagnosis.design import make_signals
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.models.causes.signals import Within
    from hvacfmu.models.causes.zone_coupling import shared_drivers
    from hvacfmu.models.extended import ExtendedModel, ZoneCoupling

    name, cid = spec.split(":", 1)
    if name == "raw":  # raw:LAYOUT/SEED/WEEKS/EFFECT&EFFECT (bench_control_gain's case strings, with the weeks)
        layout, seed, weeks, eff = cid.split("/", 3)
        case = {"layout": layout, "seed": int(seed), "weeks": int(weeks), "effects": eff.split("&"), "step": 900.0}
    else:
        case = {**_sets()[name]()[int(cid)], "weeks": 16}
    paths = cached_dataset(weeks=case["weeks"], seed=case["seed"], effects=case["effects"], layout=case["layout"])
    ds = prepare(paths.measurements, paths.building, step=case["step"])
    c0 = time.process_time()
    rep = diagnose(ds, progress=False, **options)
    cpu = time.process_time() - c0
    found = {tuple(sorted(f["location"]["zones"])) for f in rep.to_dict()["findings"] if f["cause"] == "zone_coupling"}
    inj = {
        tuple(sorted(e.split("zones=")[1].split(",")[0].split("+"))) for e in case["effects"] if "zone_coupling" in e
    }
    sig = make_signals(ds, rep.base_model)
    model = rep.model
    terms = [tt for tt in (model.terms if isinstance(model, ExtendedModel) else []) if not isinstance(tt, ZoneCoupling)]
    W = Within(sig.group, sig.rows("train"))
    lags = max(1, round(6 * 3600.0 / sig.step))
    out = []
    for a in range(sig.nz):
        for b in range(a + 1, sig.nz):
            if b in sig.neighbours[a] or a in sig.neighbours[b]:
                continue
            za, zb = sig.zones[a], sig.zones[b]
            pair = tuple(sorted((za, zb)))
            rec = {
                "case": spec,
                "effects": case["effects"],
                "pair": "+".join(pair),
                "injected": pair in inj,
                "found": pair in found,
                "shared": shared_drivers(sig, a, b),
                "diagnose_cpu_s": cpu,
            }
            for v in variants:
                rec[v] = instrument(sig, W, terms, ZoneCoupling(zone_a=za, zone_b=zb), lags, v)
            out.append(rec)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", default="")
    ap.add_argument("--variants", default="none,du,u")
    ap.add_argument("--raw", action="append", default=[], help="raw:LAYOUT/SEED/WEEKS/EFFECT&EFFECT (repeatable)")
    ap.add_argument("--option", action="append", default=[], help="diagnose option KEY=VALUE (JSON value)")
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    variants = args.variants.split(",")
    with open(args.out, "a") as fh:
        for spec in (args.cases.split(",") if args.cases else []) + args.raw:
            for r in run(spec, variants, {k: json.loads(v) for k, v in (o.split("=", 1) for o in args.option)}):
                fh.write(json.dumps(r) + "\n")
                if r["injected"] or r["found"] or r["none"]["t"] >= 2:
                    s = " | ".join(f"{v} {r[v]['coef']:+.3f} t {r[v]['t']:+.1f}" for v in variants)
                    print(f"{spec:7s} {r['pair']:7s} inj={r['injected']:d} found={r['found']:d} {s}", flush=True)


if __name__ == "__main__":
    main()
