"""Probe (session 19, ``holiday_s19.md``): the holiday scale gate's and the daylight-saving gate's inputs on
battery cases of any layout, and on extra cases named on the command line.

For each case the default diagnosis runs (``options`` as ``--option``; data from ``cached_dataset``, cached in
``$HVACFMU_CACHE``) with two recorders around it (the diagnosis itself is unchanged):

- every holiday candidate that meets the gate (``selection._gate``): dates, ΔBIC, status, scale by zone and its
  amplitude weights, the zones left out at the bound and each zone's mean departure over the days
  (``scale_zone_departure``), the week-by-likelihood record;
- every call of the daylight-saving screen (``dst_candidate``): status, lag and its weather test
  (``step_given_weather``: jump, jump with the weather held, t, kept share).

Run::

    python3 benchmarks/holiday_s19.py --layouts quad4 --seed 2040 --cases 20 --clean 4 --pairs 4 --only 0,6 \\
        --out probe.jsonl
    python3 benchmarks/holiday_s19.py --extra dst-q40:quad4:40:internal_gain_schedule:kind=dst --out probe.jsonl
"""

from __future__ import annotations

import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from bench_diagnosis_battery import make_cases, run_case  # noqa: E402

import hvacfmu.models.causes.internal_gain_schedule as igs  # noqa: E402
from hvacfmu.diagnosis import selection  # noqa: E402


def _holiday_record(c) -> dict:
    ev = c.evidence or {}
    return {
        "dates": list(c.location.get("dates", [])),
        "status": c.status,
        "delta_bic": c.test.get("delta_bic"),
        "scale_mean": ev.get("scale_mean"),
        "scale_mean_all_zones": ev.get("scale_mean_all_zones"),
        "scale_by_zone": ev.get("scale_by_zone"),
        "scale_weight_by_zone": ev.get("scale_weight_by_zone"),
        "scale_zones_at_bound": ev.get("scale_zones_at_bound"),
        "scale_zone_departure": ev.get("scale_zone_departure"),
        "scale_zones_uninformative": ev.get("scale_zones_uninformative"),
        "scale_rule": ev.get("scale_rule"),
        "groups": [{k: v for k, v in g.items() if k != "dates"} for g in ev.get("groups", [])],
        "week_likelihood": ev.get("week_likelihood"),
    }


def summary(path: str) -> None:
    """Print a probe file: each case's outcome, its holiday candidates by zone (fitted scale, amplitude weight, mean
    departure over the days ± its standard error, flags: B left out at the bound reading against, U left out as
    uninformative) and its daylight-saving screens that reached the weather test."""
    for line in open(path):
        r = json.loads(line)
        print(
            f"== {r['layout']} {r['seed']} case {r['id']} {r['effects']}: found {r['found']} "
            f"missed {[m['name'] for m in r['missed']]} false {r['unsupported']}"
        )
        for h in r["holiday_candidates"]:
            at = set(h.get("scale_zones_at_bound") or ())
            un = set(h.get("scale_zones_uninformative") or ())
            all_z = h.get("scale_mean_all_zones")
            print(
                f"   holiday {h['dates'][:1]} ({len(h['dates'])} d) {h['status']}, dBIC {h['delta_bic'] or 0:.1f}, "
                f"scale {h['scale_mean'] or 0:.3f}"
                + ("" if all_z is None else f" (all zones {all_z:.3f})")
                + f", groups {[g.get('rule') for g in h['groups']]}"
            )
            dep = h.get("scale_zone_departure") or {}
            for z, g in (h.get("scale_by_zone") or {}).items():
                d = dep.get(z)
                txt = ""
                if d:
                    se = abs(d["gamma"] / d["t"]) if d["t"] else float("nan")
                    txt = f" departure {d['gamma']:+.3f} ± {se:.3f} (t {d['t']:+.2f})"
                flag = ("B" if z in at and z not in un else "") + ("U" if z in un else "")
                print(f"      {z:3s} scale {g:.3f} w {h['scale_weight_by_zone'][z]:.4f}{txt} {flag}")
        for d in r["dst_screens"]:
            if "gate" in d:
                print(
                    f"   dst_shift candidate at the gate: {d['gate']}, dBIC {d['delta_bic'] or 0:.1f} {d['reason'][:120]}"
                )
                continue
            st = d.get("step_given_weather") or {}
            if st.get("t") is not None:
                print(
                    f"   dst screen {d['status']}: lag {d['lag_h']} h, jump {st['jump']:+.3f} -> "
                    f"{st['jump_given_weather']:+.3f} with the weather held (t {st['t']:.2f})"
                )
        for c in r.get("candidates") or []:
            loc = c.get("location") or {}
            if loc.get("variant") in ("holiday", "dst_shift") and c.get("status") != "found":
                print(f"   candidate {c['cause']} {loc.get('variant')} {c.get('status')}: {str(c.get('reason'))[:160]}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seed", type=int, default=2040)
    ap.add_argument("--cases", type=int, default=20)
    ap.add_argument("--layouts", default="quad4")
    ap.add_argument("--clean", type=int, default=4)
    ap.add_argument("--pairs", type=int, default=4)
    ap.add_argument("--step-min", type=float, default=15.0)
    ap.add_argument("--only", default="", help="comma-separated battery case ids (none: no battery case)")
    ap.add_argument(
        "--extra", action="append", default=[], help="NAME:LAYOUT:SEED:EFFECT[;EFFECT] an extra case (repeatable)"
    )
    ap.add_argument("--out", help="JSON-lines file of the probe records (appended)")
    ap.add_argument("--print", dest="print_file", help="print the probe file FILE and stop")
    ap.add_argument("--results", help="also the battery's record of each case (JSON lines: --summary reads it)")
    ap.add_argument("--option", action="append", default=[], help="KEY=JSON diagnose option")
    a = ap.parse_args()
    if a.print_file:
        summary(a.print_file)
        return
    opts = {k: json.loads(v) for k, v in (o.split("=", 1) for o in a.option)}
    only = {int(x) for x in a.only.split(",") if x}
    cases = [
        c
        for c in make_cases(a.cases, a.seed, a.layouts.split(","), a.clean, a.pairs, a.step_min * 60.0)
        if c["id"] in only
    ]
    for e in a.extra:
        name, layout, seed, eff = e.split(":", 3)
        cases.append(
            {"id": name, "layout": layout, "step": a.step_min * 60.0, "seed": int(seed), "effects": eff.split(";")}
        )
    seen: list = []
    dst: list = []
    orig_gate = selection._gate

    def gate(c, o):
        orig_gate(c, o)
        if selection._is_holiday(c.term):
            seen.append(_holiday_record(c))
        if selection._is_dst(c.term):
            dst.append({"gate": c.status, "reason": c.reason, "delta_bic": c.test.get("delta_bic")})

    orig_dst = igs.dst_candidate

    def dst_screen(sig, W, options, exclude_dates=()):
        c = orig_dst(sig, W, options, exclude_dates=exclude_dates)
        ev = c.evidence or {}
        dst.append(
            {
                "status": c.status,
                "reason": c.reason,
                "retest": bool(options.get("_dst_retest")),
                "lag_h": ev.get("lag_h"),
                "step_given_weather": ev.get("step_given_weather"),
            }
        )
        return c

    selection._gate = gate
    igs.dst_candidate = dst_screen
    for c in cases:
        seen.clear()
        dst.clear()
        r = run_case(c, 16, **opts)
        rec = {
            "id": c["id"],
            "seed": a.seed,
            "layout": c["layout"],
            "effects": c["effects"],
            "found": r["found"],
            "missed": r["missed"],
            "unsupported": r["unsupported"],
            "findings": r["findings"],
            "candidates": r["candidates"],
            "holiday_candidates": list(seen),
            "dst_screens": list(dst),
            "diagnose_cpu_s": r["diagnose_cpu_s"],
        }
        with open(a.out, "a") as f:
            f.write(json.dumps(rec, default=str) + "\n")
        if a.results:
            with open(a.results, "a") as f:
                f.write(json.dumps(r, default=str) + "\n")
        print(c["id"], c["effects"], "found", r["found"], "false", r["unsupported"], flush=True)


if __name__ == "__main__":
    main()
