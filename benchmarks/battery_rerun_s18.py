"""Per-case diff of two diagnosis result files (session 18, `battery_rerun_s18.md`).

Reads two JSON-lines result files of ``bench_diagnosis_battery.py`` (or ``bench_diagnosis_energyplus.py``: records
with ``findings``) and prints, case by case, every finding gained or lost (cause, location, CV gain, t), every
finding whose CV gain moved by more than ``--tol`` points, and the change of the battery's verdicts (injected
effects found / missed, false findings). Cases present in only one file are listed as missing.

Run::

    python3 benchmarks/battery_rerun_s18.py OLD.jsonl NEW.jsonl [--tol 0.5]
"""

import argparse
import json


def _load(path: str) -> dict:
    out = {}
    with open(path) as f:
        for line in f:
            if line.strip():
                r = json.loads(line)
                out[r["case"]["id"]] = r
    return out


def _key(f: dict) -> str:
    loc = f["location"]
    return f["cause"] + ":" + ",".join(f"{k}={v}" for k, v in sorted(loc.items()))


def _fmt(f: dict) -> str:
    g, t = f.get("cv_gain_percent"), f.get("cv_t")
    cv = "no CV" if g is None else f"{g:+.1f} % t {t:.1f}"
    return f"{_key(f)} ({cv})"


def _false_keys(r: dict) -> set:
    return {_key(f) for f in r.get("unsupported", [])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--tol", type=float, default=0.5, help="report CV gain moves larger than this [points]")
    args = ap.parse_args()
    old, new = _load(args.old), _load(args.new)
    for i in sorted(set(old) | set(new)):
        if i not in new:
            print(f"case {i:3d}: MISSING in {args.new}")
            continue
        if i not in old:
            print(f"case {i:3d}: not in {args.old}")
            continue
        a, b = old[i], new[i]
        if a["case"] != b["case"]:
            print(f"case {i:3d}: different case spec: {a['case']} vs {b['case']}")
            continue
        fa = {_key(f): f for f in a["findings"]}
        fb = {_key(f): f for f in b["findings"]}
        false_b, false_a = _false_keys(b), _false_keys(a)
        lines = []
        for name in sorted(set(a.get("found", [])) - set(b.get("found", []))):
            lines.append(f"  LOST injected effect {name}")
        for name in sorted(set(b.get("found", [])) - set(a.get("found", []))):
            lines.append(f"  GAINED injected effect {name}")
        for k in sorted(false_b - false_a):
            lines.append(f"  NEW FALSE finding {_fmt(fb[k]) if k in fb else k}")
        for k in sorted(false_a - false_b):
            lines.append(f"  false finding gone {_fmt(fa[k]) if k in fa else k}")
        for k in sorted(set(fb) - set(fa)):
            tag = "false" if k in false_b else "supported"
            lines.append(f"  + {_fmt(fb[k])} [{tag}]")
        for k in sorted(set(fa) - set(fb)):
            tag = "was false" if k in false_a else "was supported"
            cand = [c for c in b.get("candidates", []) if _key(c) == k]
            now = f"; now {cand[0]['status']} {_fmt(cand[0])}" if cand else "; not a scored candidate now"
            lines.append(f"  - {_fmt(fa[k])} [{tag}{now}]")
        for k in sorted(set(fa) & set(fb)):
            ga, gb = fa[k].get("cv_gain_percent"), fb[k].get("cv_gain_percent")
            if ga is not None and gb is not None and abs(ga - gb) > args.tol:
                lines.append(f"  ~ {k}: {ga:+.1f} % t {fa[k]['cv_t']:.1f} -> {gb:+.1f} % t {fb[k]['cv_t']:.1f}")
        c = b["case"]
        if "layout" in c:
            what = f"{c['layout']:5s} {c['step'] / 60:.0f} min {'+'.join(e.split(':')[0] for e in c['effects']) or 'clean'}"
            counts = (
                f"found {len(a['found'])}->{len(b['found'])}, false {len(a['unsupported'])}->{len(b['unsupported'])}, "
            )
        else:
            what, counts = f"{c.get('weather', '')} {c.get('effect') or 'clean'}", ""
        head = f"case {i:3d} {what}: {counts}findings {len(fa)}->{len(fb)}"
        print(head + ("" if lines else " (same findings)"))
        for line in lines:
            print(line)


if __name__ == "__main__":
    main()
