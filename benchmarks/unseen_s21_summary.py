"""Session 21, issue 13: per case, model kind, zone and season, the 24-h open-loop RMS against persistence and the
time-of-week mean, from `hvacfmu evaluate --json` files (see benchmarks/unseen_s21.md).

    python3 benchmarks/unseen_s21_summary.py CASE=eval.json ... [--jsonl OUT]

Prints per kind the season means, the margins and the zone-seasons behind each baseline; --jsonl writes one row
per (case, kind, zone, season).
"""

from __future__ import annotations

import argparse
import json


def rows(case: str, path: str) -> list[dict]:
    d = json.load(open(path))
    return [
        {
            "case": case,
            "kind": s["model"],
            "zone": s["output"],
            "season": s["season"],
            "rms": round(s["rms"], 4),
            "persistence": round(s["persistence"], 4),
            "time_of_week": round(s["time_of_week"], 4),
        }
        for s in d["verdict"]["seasons"]
    ]


def summary(case: str, path: str) -> None:
    d = json.load(open(path))
    print(f"## {case} ({path})")
    behind: dict = {}
    for r in rows(case, path):
        k = behind.setdefault(r["kind"], {"n": 0, "p": [], "t": []})
        k["n"] += 1
        label = f"{r['zone']} {r['season']} {r['rms']:.3f}"
        if r["rms"] >= r["persistence"]:
            k["p"].append(f"{label} vs {r['persistence']:.3f}")
        if r["rms"] >= r["time_of_week"]:
            k["t"].append(f"{label} vs {r['time_of_week']:.3f}")
    for m in d["models"]:
        t, bp, bt = m["table"], m["baselines"]["persistence"], m["baselines"]["time-of-week mean"]
        seasons = [s for s in t if s != "all"]
        wp = min(1 - t[s]["mean"] / bp[s]["mean"] for s in seasons)
        wt = min(1 - t[s]["mean"] / bt[s]["mean"] for s in seasons)
        k = behind[m["name"]]
        print(
            f"{m['name']}: "
            + " | ".join(f"{s} {t[s]['mean']:.3f}" for s in t)
            + f"; vs persistence {1 - t['all']['mean'] / bp['all']['mean']:+.0%} (worst season {wp:+.0%}),"
            f" vs time-of-week {1 - t['all']['mean'] / bt['all']['mean']:+.0%} (worst season {wt:+.0%});"
            f" zone-seasons {k['n']}: behind persistence {len(k['p'])}, behind time-of-week {len(k['t'])}"
        )
        for x in k["p"]:
            print("   behind persistence:", x)
        for x in k["t"]:
            print("   behind time-of-week:", x)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("cases", nargs="+", help="CASE=path/to/eval.json")
    p.add_argument("--jsonl")
    a = p.parse_args()
    out = []
    for c in a.cases:
        case, path = c.split("=", 1)
        summary(case, path)
        out += rows(case, path)
    if a.jsonl:
        with open(a.jsonl, "w") as f:
            f.writelines(json.dumps(r) + "\n" for r in out)


if __name__ == "__main__":
    main()
