"""Instrumented coupling conductance on every non-adjacent pair of battery cases (session 17, issue 15).

For each case: the diagnosis is run (options as given, e.g. ``coupling_alone_unshared=true``), then for every
pair of zones not declared adjacent the conductance is instrumented by each partner's own airflow changes
(:func:`hvacfmu.diagnosis.selection.coupling_instrument`) on the final model's terms (couplings left out), for
each instrument window of ``--lags``. One JSON line per pair and window: case, pair, injected?, found by the
diagnosis?, shared drivers, per-zone and pooled coefficient and t, first-stage F. Write-up:
``benchmarks/coupling_s17.md``.

Run: ``python3 benchmarks/coupling_s17.py --cases q26:13,d26:1,d26:6 --lags 3,6,12,24 --out FILE.jsonl``
(sets as in ``coupling_s16.py``: ``q26``/``q27`` the quad4 batteries of seeds 2026/2027, ``d26``/``d27`` the
README battery of seeds 2026/2027).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))


def _sets():
    from bench_diagnosis_battery import make_cases

    return {
        "q26": lambda: make_cases(32, 2026, layouts=["quad4"], n_clean=4, n_pair=4, step=900),
        "q27": lambda: make_cases(16, 2027, layouts=["quad4"], n_clean=6, n_pair=4, step=900),
        "d26": lambda: make_cases(48, 2026),
        "d27": lambda: make_cases(48, 2027),
    }


def run(spec: str, lags: list, options: dict) -> list:
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
    out = []
    for a in range(sig.nz):
        for b in range(a + 1, sig.nz):
            if b in sig.neighbours[a] or a in sig.neighbours[b]:
                continue
            za, zb = sig.zones[a], sig.zones[b]
            pair = tuple(sorted((za, zb)))
            for n in lags:
                ev = S.coupling_instrument(sig, W, terms, ZoneCoupling(zone_a=za, zone_b=zb), n)
                out.append(
                    {
                        "case": spec,
                        "layout": case["layout"],
                        "step_min": case["step"] / 60,
                        "pair": "+".join(pair),
                        "injected": pair in inj,
                        "found": pair in found,
                        "shared": shared_drivers(sig, a, b),
                        "lags": n,
                        "coef": [ev[f"iv_coef_{z}"] for z in (za, zb)],
                        "t": [ev[f"iv_t_{z}"] for z in (za, zb)],
                        "first_F": [ev[f"iv_first_F_{z}"] for z in (za, zb)],
                        "ols": [ev[f"iv_ols_{z}"] for z in (za, zb)],
                        "pooled_coef": ev["iv_coef"],
                        "pooled_t": ev["iv_t"],
                        "diagnose_cpu_s": cpu,
                    }
                )
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", required=True, help="comma-separated set:id, e.g. q26:13,d26:1")
    ap.add_argument("--lags", default="24", help="instrument windows [steps], comma-separated")
    ap.add_argument("--option", action="append", default=[], help="diagnose option KEY=VALUE (JSON value)")
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    options = {k: json.loads(v) for k, v in (o.split("=", 1) for o in args.option)}
    lags = [int(x) for x in args.lags.split(",")]
    with open(args.out, "a") as fh:
        for spec in args.cases.split(","):
            for r in run(spec, lags, options):
                fh.write(json.dumps(r) + "\n")
                if r["injected"] or r["found"] or r["lags"] == lags[-1] and r["pooled_t"] >= 2:
                    print(
                        f"{spec:7s} {r['pair']:7s} lags {r['lags']:3d} {'injected' if r['injected'] else 'clean':8s} "
                        f"{'found' if r['found'] else '':5s} pooled {r['pooled_coef']:+.3f} (t {r['pooled_t']:+.1f}) "
                        f"per zone t {r['t'][0]:+.1f} / {r['t'][1]:+.1f}",
                        flush=True,
                    )


if __name__ == "__main__":
    main()
