"""Session 21, issue 15: couplings across storeys on ``stack4`` (``benchmarks/stack4_s21.md``).

Two tables from records already on disk (no diagnosis is run here):

1. ``--oracle``: how often a **clean** pair of zones gains alone with its partner measured (the detectability
   oracle's ``clean`` records, ``benchmarks/battery_oracle.py``: each zone's own conductance fitted, ≥ 3 % at t ≥ 2
   in both zones), by layout and by whether the two zones share a facade orientation. This is the measurement
   behind the shared-facade exclusion (README "couplings", session 16) and behind lifting it across storeys.
2. ``--records OLD NEW``: the coupling candidates of the true pair in each case with an injected
   ``zone_coupling``, before and after (status and reason, shortened), for battery result files of one draw.

Run::

    python3 benchmarks/stack4_s21.py --oracle benchmarks/battery_oracle_results.jsonl \
        benchmarks/layout_stack4_s20_oracle2060.jsonl benchmarks/layout_stack4_s20_oracle2061.jsonl \
        benchmarks/layout_stack4_s20_oracle2062.jsonl
    python3 benchmarks/stack4_s21.py --records benchmarks/layout_stack4_s20_branch2060.jsonl \
        benchmarks/stack4_s21_2060.jsonl
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import sys

sys.path.insert(0, os.path.dirname(__file__))


def oracle_table(paths) -> None:
    """Clean pairs passing alone in both zones, by layout and shared facade."""
    from bench_diagnosis_battery import _facades

    from hvacfmu.emulator.layouts import get_layout

    cnt: collections.Counter = collections.Counter()
    for path in paths:
        with open(path) as f:
            for line in f:
                r = json.loads(line)
                lay = get_layout(r["case"]["layout"])
                for c in r.get("clean", []):
                    if c["name"] != "zone_coupling":
                        continue
                    a, b = c["location"]["zones"]
                    shared = bool(set(_facades(lay, a)) & set(_facades(lay, b)))
                    ok = all(v.get("gain_percent", 0.0) >= 3.0 and v.get("t", 0.0) >= 2.0 for v in c["alone"].values())
                    cnt[(r["case"]["layout"], "shares a facade" if shared else "shares none", ok)] += 1
    print(f"{'layout':8s} {'pair':16s} {'pass alone':>10s} {'pairs':>6s}")
    for lay, sh in sorted({(k[0], k[1]) for k in cnt}):
        n = cnt[(lay, sh, True)] + cnt[(lay, sh, False)]
        print(f"{lay:8s} {sh:16s} {cnt[(lay, sh, True)]:10d} {n:6d}")


def _pair_candidates(r: dict) -> list:
    out = []
    for e in r["case"]["effects"]:
        if not e.startswith("zone_coupling"):
            continue
        zs = set(e.split("zones=")[1].split(",")[0].split("+"))
        found = any(f["cause"] == "zone_coupling" and set(f["location"].get("zones", [])) == zs for f in r["findings"])
        cands = [
            c for c in r["candidates"] if c["cause"] == "zone_coupling" and set(c["location"].get("zones", [])) == zs
        ]
        why = "found" if found else (cands[0]["status"] + ": " + (cands[0]["reason"] or "")[:110] if cands else "-")
        out.append((e, why))
    return out


def records_table(old: str, new: str) -> None:
    """The injected couplings' verdicts in two result files of one draw."""

    def load(p):
        with open(p) as f:
            return {json.loads(x)["case"]["id"]: json.loads(x) for x in f if x.strip()}

    a, b = load(old), load(new)
    for cid in sorted(set(a) & set(b)):
        for (e, w0), (_, w1) in zip(_pair_candidates(a[cid]), _pair_candidates(b[cid])):
            print(f"case {cid:2d} {e}\n   before: {w0}\n   after:  {w1}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--oracle", nargs="+", help="oracle record files (JSON lines)")
    ap.add_argument("--records", nargs=2, metavar=("OLD", "NEW"), help="two battery result files of one draw")
    args = ap.parse_args()
    if args.oracle:
        oracle_table(args.oracle)
    if args.records:
        records_table(*args.records)


if __name__ == "__main__":
    main()
