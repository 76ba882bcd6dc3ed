"""Couplings of zones sharing a facade: the instrument with weather controls (session 18, issue 15).

For each case the diagnosis is run with the default options, then for every pair of zones not declared adjacent
the instrumented conductance (:func:`hvacfmu.diagnosis.selection.coupling_instrument`, 6-h window) is computed on
the final terms (couplings left out), with control columns added to both zones' equations:

- ``none``: as the diagnosis does it;
- ``sun``: the shared facades' irradiance ``I_o`` (the within transform makes each column its anomaly against
  the season's time-of-week mean);
- ``sun_lp``: as ``sun`` plus ``I_o`` low-passed at 3, 12, 48 h and the outdoor temperature low-passed at 3, 12,
  48 h (the day-to-day weather anomaly reaching a zone through its walls' mass);
- ``all_lp``: as ``sun_lp`` with every facade of either zone (not only the shared ones) (the option's controls);
- ``others_du``: the other zones' mean airflow change at the instruments' lags (moves the whole floor makes at
  once: arrival times, a day's occupancy level); ``others_du_all_lp``: both.

One JSON line per pair and control set. Write-up: ``benchmarks/facade_coupling_s18.md``.

Run: ``python3 benchmarks/facade_coupling_s18.py --cases d26:0,d26:15,e32:3 --out FILE.jsonl`` (sets: ``q26``
quad4 2026, ``d26``/``d27`` the README battery, ``e32`` the ell5 hold-out draw, ``m33`` the 5-min row4/core9/sdh
hold-out draw).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

TAUS_H = (3.0, 12.0, 48.0)


def _sets():
    from bench_diagnosis_battery import make_cases

    return {
        "q26": lambda: make_cases(32, 2026, layouts=["quad4"], n_clean=4, n_pair=4, step=900),
        "d26": lambda: make_cases(48, 2026),
        "d27": lambda: make_cases(48, 2027),
        "e32": lambda: make_cases(12, 2032, layouts=["ell5"], n_clean=3, n_pair=3, step=900),
        "m33": lambda: make_cases(8, 2033, layouts=["row4", "core9", "sdh"], n_clean=2, n_pair=2, step=300),
    }


def controls(sig, facades, lowpass: bool) -> np.ndarray | None:
    """Control columns: ``I_o`` of ``facades`` and, with ``lowpass``, their and ``T_out``'s low-passed series."""
    from hvacfmu.models.causes.signals import ema_series

    cols = []
    for o in facades:
        if f"I_{o}" in sig.V:
            irr = np.nan_to_num(np.asarray(sig.V[f"I_{o}"], float))
            cols.append(irr)
            if lowpass:
                cols += [ema_series(irr, min(sig.step / (tau * 3600.0), 1.0)) for tau in TAUS_H]
    if lowpass:
        tout = np.asarray(sig.V["T_out"], float)
        cols += [np.nan_to_num(ema_series(tout, min(sig.step / (tau * 3600.0), 1.0))) for tau in TAUS_H]
    return np.column_stack(cols) if cols else None


def run(spec: str, lags_h: float, options: dict) -> list:
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.diagnosis import selection as S
    from hvacfmu.diagnosis.design import make_signals
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.models.causes.signals import Within
    from hvacfmu.models.causes.zone_coupling import shared_drivers
    from hvacfmu.models.extended import ExtendedModel, ZoneCoupling

    name, cid = spec.split(":")
    case = _sets()[name]()[int(cid)]
    paths = cached_dataset(weeks=16, seed=case["seed"], effects=case["effects"], layout=case["layout"])
    ds = prepare(paths.measurements, paths.building, step=case["step"])
    c0 = time.process_time()
    rep = diagnose(ds, progress=False, **options)
    cpu = time.process_time() - c0
    found = {tuple(sorted(f["location"]["zones"])) for f in rep.to_dict()["findings"] if f["cause"] == "zone_coupling"}
    inj = {
        tuple(sorted(e.split("zones=")[1].split(",")[0].split("+")))
        for e in case["effects"]
        if e.startswith("zone_coupling")
    }
    sig = make_signals(ds, rep.base_model)
    model = rep.model
    terms = [t for t in (model.terms if isinstance(model, ExtendedModel) else []) if not isinstance(t, ZoneCoupling)]
    W = Within(sig.group, sig.rows("train"))
    lags = max(1, round(lags_h * 3600.0 / sig.step))
    out = []
    for a in range(sig.nz):
        for b in range(a + 1, sig.nz):
            if b in sig.neighbours[a] or a in sig.neighbours[b]:
                continue
            za, zb = sig.zones[a], sig.zones[b]
            pair = tuple(sorted((za, zb)))
            shared_f = sorted(set(sig.facades[a]) & set(sig.facades[b]))
            either = sorted(set(sig.facades[a]) | set(sig.facades[b]))
            sets = {
                "none": None,
                "sun": controls(sig, shared_f, False),
                "sun_lp": controls(sig, shared_f, True),
                "all_lp": controls(sig, either, True),
            }
            # the other zones' mean airflow change at the instruments' lags: box moves the whole floor makes
            # together (arrival times, a day's occupancy level) are no instrument of this pair's exchange
            from hvacfmu.models.causes.signals import effective_inputs, shifted

            U = effective_inputs(sig, terms)
            du = np.diff(U, axis=0, prepend=U[:1])
            rest = [j for j in range(sig.nz) if j not in (a, b)]
            if rest:
                m = du[:, rest].mean(axis=1)
                odu = np.column_stack([np.nan_to_num(shifted(m, lag)) for lag in range(1, lags + 1)])
                sets["others_du"] = odu
                sets["others_du_all_lp"] = odu if sets["all_lp"] is None else np.column_stack([odu, sets["all_lp"]])
            for cname, ctl in sets.items():
                ev = S.coupling_instrument(sig, W, terms, ZoneCoupling(zone_a=za, zone_b=zb), lags, controls=ctl)
                out.append(
                    {
                        "case": spec,
                        "layout": case["layout"],
                        "step_min": case["step"] / 60,
                        "pair": "+".join(pair),
                        "injected": pair in inj,
                        "found": pair in found,
                        "shared": shared_drivers(sig, a, b),
                        "controls": cname,
                        "coef": [ev[f"iv_coef_{z}"] for z in (za, zb)],
                        "t": [ev[f"iv_t_{z}"] for z in (za, zb)],
                        "first_F": [ev[f"iv_first_F_{z}"] for z in (za, zb)],
                        "pooled_coef": ev["iv_coef"],
                        "pooled_t": ev["iv_t"],
                        "diagnose_cpu_s": cpu,
                    }
                )
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", required=True, help="comma-separated set:id, e.g. d26:0,e32:3")
    ap.add_argument("--hours", type=float, default=6.0, help="instrument window [h]")
    ap.add_argument("--option", action="append", default=[], help="diagnose option KEY=VALUE (JSON value)")
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    options = {k: json.loads(v) for k, v in (o.split("=", 1) for o in args.option)}
    with open(args.out, "a") as fh:
        for spec in args.cases.split(","):
            rows = run(spec, args.hours, options)
            for r in rows:
                fh.write(json.dumps(r) + "\n")
            fh.flush()
            for pair in dict.fromkeys(r["pair"] for r in rows):
                rr = {r["controls"]: r for r in rows if r["pair"] == pair}
                r0 = rr["none"]
                if not r0["shared"] and not r0["injected"]:
                    continue
                print(
                    f"{spec:7s} {pair:7s} {'injected' if r0['injected'] else 'clean':8s} "
                    f"{'found' if r0['found'] else '':5s} {','.join(r0['shared']):18s} "
                    + " ".join(f"{k} {v['pooled_coef']:+.3f}/{v['pooled_t']:+.1f}" for k, v in rr.items()),
                    flush=True,
                )


if __name__ == "__main__":
    main()
