"""Feedback is not delay: the actuation-delay evidence on true delays, clean emulator zones and EnergyPlus.

For every zone of each dataset, on the diagnosis' base structure (Model A refitted by within least
squares, no extension term): the best delay ``d`` of the screen's plain one-step test
(``ΔBIC = LR·(1 − ρ)/(1 + ρ) − ln N``, as :func:`hvacfmu.diagnosis.selection.score_candidate`) and,
at that ``d``, the same test with the zone's own temperatures of the last hour in both equations
(:func:`hvacfmu.diagnosis.selection.delay_given_history`, the gate: ``> bic_margin`` = 10).

Datasets: the diagnosis battery's cases (``--battery 14,18,...``: the seven injected delays are 14, 18,
20, 26, 32, 38, 44; clean cases 0-11; ``bench_diagnosis_battery.py`` cases, cached emulator data) and
the EnergyPlus test bed's cases (``--energyplus 0,1,...``, ``bench_diagnosis_energyplus.py``, cached
exports in ``$HVACFMU_CACHE``). A zone with an injected delay is marked ``TRUE``.

Run: ``python3 benchmarks/bench_diagnosis_delay_evidence.py --battery 0,1,14 --energyplus 0,1 [--results F]``
(JSON lines, one per dataset; ``--summary`` prints a results file). About 10-30 s per dataset.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def _zone_table(ds, truth_zones: dict) -> list:
    from hvacfmu.diagnosis.design import Within, fit_structure, make_signals
    from hvacfmu.diagnosis.selection import _gate, ess_factor, lag1, score_candidate
    from hvacfmu.fitting import fit
    from hvacfmu.models.causes import Candidate
    from hvacfmu.models.causes.signals import max_delay
    from hvacfmu.models.extended import ActuationDelay

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        base = fit(ds, "zones", progress=False, use_solar=False, heat="airflow", open_loop=False)
    sig = make_signals(ds, base)
    rows = sig.rows("train")
    W = Within(sig.group, rows)
    cur = fit_structure(sig, [], rows)
    cur_rss = [ls.rss for ls in cur.zone_ls]
    factors = [ess_factor(lag1(cur.resid[:, z])) for z in range(sig.nz)]
    out = []
    for z in sig.zones:
        c = Candidate(
            "actuation_delay", {"zone": z}, [ActuationDelay(zone=z, delay=d) for d in range(1, max_delay(sig.step) + 1)]
        )
        score_candidate(sig, W, [], cur_rss, factors, c, None)
        h = c.evidence["history"]
        _gate(c, _defaults())
        out.append(
            {
                "zone": z,
                "true_delay_steps": truth_zones.get(z),
                "delay": int(c.term.delay),
                "delta_bic": c.test["delta_bic"],
                "history_delta_bic": h.get("delta_bic"),
                "history_lr": h.get("lr"),
                "history_b": h.get("b"),
                "status": c.status,
            }
        )
    return out


def _defaults() -> dict:
    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS

    return dict(DEFAULT_OPTIONS)


def battery_case(i: int) -> dict:
    from bench_diagnosis_battery import make_cases

    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset

    case = make_cases(48, 2026)[i]
    paths = cached_dataset(weeks=16, seed=case["seed"], effects=case["effects"], layout=case["layout"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(paths.measurements, paths.building, step=case["step"])
    truth = {}
    for e in json.loads(paths.truth.read_text())["effects"]:
        if e["name"] == "actuation_delay":
            truth[e["zone"]] = float(e["minutes"]) * 60.0 / case["step"]
    return {"source": f"battery {i}", "case": case, "zones": _zone_table(ds, truth)}


def energyplus_case(i: int) -> dict:
    from bench_diagnosis_energyplus import CASES, export

    from hvacfmu.data import prepare

    case = CASES[i]
    paths = export(case)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(paths.measurements, paths.building)
    return {"source": f"energyplus {i}", "case": case, "zones": _zone_table(ds, {})}


def print_summary(records: list) -> None:
    print(f"{'dataset':16s} {'zone':22s} {'true d':>6s} {'d':>3s} {'ΔBIC plain':>11s} {'ΔBIC | hist':>11s}  status")
    for r in records:
        for z in r["zones"]:
            t = "" if z["true_delay_steps"] is None else f"{z['true_delay_steps']:.0f}"
            hb = z["history_delta_bic"]
            print(
                f"{r['source']:16s} {z['zone']:22s} {t:>6s} {z['delay']:3d} {z['delta_bic']:11.1f} "
                f"{(hb if hb is not None else np.nan):11.1f}  {z['status']}"
            )
    groups = {"true delays": [], "emulator zones without delay": [], "EnergyPlus zones": []}
    for r in records:
        for z in r["zones"]:
            if z["true_delay_steps"] is not None:
                groups["true delays"].append(z)
            elif r["source"].startswith("battery"):
                groups["emulator zones without delay"].append(z)
            else:
                groups["EnergyPlus zones"].append(z)
    print()
    for g, zs in groups.items():
        if not zs:
            continue
        p = [z["delta_bic"] for z in zs]
        h = [z["history_delta_bic"] for z in zs if z["history_delta_bic"] is not None]
        passed_plain = sum(x > 10 for x in p)
        passed_both = sum(z["delta_bic"] > 10 and (z["history_delta_bic"] or -np.inf) > 10 for z in zs)
        print(
            f"{g:30s} n {len(zs):3d}: plain ΔBIC {min(p):8.1f} .. {max(p):8.1f} ({passed_plain} > 10); given the "
            f"history {min(h):8.1f} .. {max(h):8.1f} ({passed_both} pass both)"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--battery", default="", help="comma-separated battery case ids")
    ap.add_argument("--energyplus", default="", help="comma-separated EnergyPlus test-bed case ids")
    ap.add_argument("--results", default="delay-evidence-results.jsonl")
    ap.add_argument("--summary", action="store_true")
    args = ap.parse_args()
    path = Path(args.results)
    done = [json.loads(x) for x in path.read_text().splitlines() if x.strip()] if path.exists() else []
    have = {r["source"] for r in done}
    if not args.summary:
        todo = [("battery", int(x)) for x in args.battery.split(",") if x.strip()]
        todo += [("energyplus", int(x)) for x in args.energyplus.split(",") if x.strip()]
        for kind, i in todo:
            if f"{kind} {i}" in have:
                continue
            r = battery_case(i) if kind == "battery" else energyplus_case(i)
            done.append(r)
            with path.open("a") as fh:
                fh.write(json.dumps(r) + "\n")
            print(f"{r['source']} done", flush=True)
    print_summary(done)


if __name__ == "__main__":
    main()
