"""Session 21, issue 15: the fresh checked battery (seeds 2101-2103, never used before) summed up.

The runs themselves are ``bench_diagnosis_battery.py --detectable`` (commands in ``fresh_s21.md``); this script
reads their records and prints the combined confusion matrix, the recall over effects that pass the
detectability gate, every miss and false finding with the oracle's gain of the true term, and the recall by
oracle gain (the issue's own hidden effects gained 13-27 %).

    python3 benchmarks/fresh_s21.py
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

#: draw: (results file, detectability records, battery command's seed / layouts / step)
DRAWS = {
    "a": ("fresh_s21_results_a.jsonl", "fresh_s21_checked_a.jsonl", "seed 2101, quad4/row4/ell5, 15 min"),
    "b": ("fresh_s21_results_b.jsonl", "fresh_s21_checked_b.jsonl", "seed 2102, quad4/row4, 5 min"),
    "c": ("fresh_s21_results_c.jsonl", "fresh_s21_checked_c.jsonl", "seed 2103, row4/ell5/quad4, 15 min"),
}


def _lines(path: Path) -> list:
    return [json.loads(x) for x in path.read_text().splitlines() if x.strip()] if path.exists() else []


def main() -> None:
    import bench_diagnosis_battery as bdb

    allres = []
    bins = {"gain < 3 %": [0, 0], "3-13 %": [0, 0], ">= 13 %": [0, 0]}
    for key, (res, chk, what) in DRAWS.items():
        results = sorted(_lines(HERE / res), key=lambda r: r["case"]["id"])
        gate = {r["case"]["id"]: r for r in _lines(HERE / chk)}
        print(f"\n=== draw {key}: {what}: {len(results)} cases")
        for r in results:
            c = r["case"]
            g = gate.get(c["id"])
            last = {x["name"]: x for x in (g["tries"][-1]["gate"] if g else [])}
            for name, hit in [(e, True) for e in r["found"]] + [(e["name"], False) for e in r["missed"]]:
                o = last.get(name)
                if o is None:
                    continue
                if not o["passes"]:
                    print(f"  case {c['id']:2d} {name}: fails the detectability gate ({o['gain_percent']:+.1f} %)")
                    continue
                b = "gain < 3 %" if o["gain_percent"] < 3 else "3-13 %" if o["gain_percent"] < 13 else ">= 13 %"
                bins[b][0] += 1
                bins[b][1] += hit
                if not hit:
                    eff = next(e for e in c["effects"] if e.startswith(name))
                    print(
                        f"  MISS case {c['id']:2d} {c['layout']} {c['step'] / 60:.0f} min seed {c['seed']}: {eff} "
                        f"(oracle {o['gain_percent']:+.1f} %, t {o['t']:.1f})"
                    )
            for f in r["unsupported"]:
                fd = next(x for x in r["findings"] if x["cause"] == f["cause"] and x["location"] == f["location"])
                print(
                    f"  FALSE case {c['id']:2d} {c['layout']} {c['step'] / 60:.0f} min seed {c['seed']} "
                    f"({'clean' if not c['effects'] else '+'.join(e.split(':')[0] for e in c['effects'])}): "
                    f"{f['cause']} {f['location']}: {fd['reason']}"
                )
        # draw-specific ids: keep them apart in the combined matrix
        for r in results:
            r = dict(r, case=dict(r["case"], id=f"{key}{r['case']['id']}"))
            allres.append(r)
    print("\n=== all draws")
    bdb.print_summary(allres)
    print("recall by the oracle's gain of the true term (effects passing the gate):")
    for b, (n, f) in bins.items():
        print(f"  {b:12s} {f}/{n}")


if __name__ == "__main__":
    main()
