"""Compare two battery results files term by term, a holiday's terms taken together (session 20, ``holmerge_s20.md``).

For every case of ``NEW``: the holiday days found (true days of the injected weeks / other days), each holiday
finding's days, cross-validated gain and t, its merge record (the parts, the separate terms' gain over the merged
term) and the held-out weekdays named as looking like a holiday (true / other), then the findings gained (+) or
lost (-) against ``REF``. A holiday found as two terms in ``REF`` and as one in ``NEW`` on the same days is the same
finding (the holiday findings are compared by the union of their dates). Records of ``bench_diagnosis_battery.py``
and ``holiday_s19.py --results`` are read.

Run::

    python3 benchmarks/holmerge_s20.py benchmarks/diagnosis_battery_checked_results_s19.jsonl \\
        benchmarks/holmerge_s20_checked_results.jsonl
"""

from __future__ import annotations

import json
import sys

from holgrow_s19 import load, true_days


def _is_holiday(f: dict) -> bool:
    return f["cause"] == "internal_gain_schedule" and f["location"].get("variant") == "holiday"


def keys(findings: list) -> set:
    """Cause and location of each finding; the holiday findings as one key on the union of their dates."""
    out = {f["cause"] + ":" + json.dumps(f["location"], sort_keys=True) for f in findings if not _is_holiday(f)}
    days = sorted({d for f in findings if _is_holiday(f) for d in f["location"]["dates"]})
    if days:
        out.add(f"holiday:{days[0]}..{days[-1]} ({len(days)} d)")
    return out


def describe(c: dict, r: dict) -> list:
    td = true_days(c["effects"])
    hs = [f for f in r["findings"] if _is_holiday(f)]
    days = {d for f in hs for d in f["location"]["dates"]}
    terms = ", ".join(
        f"{len(f['location']['dates'])} d {f['cv_gain_percent']:+.1f} % t {f['cv_t']:.1f}"
        if f.get("cv_gain_percent") is not None
        else f"{len(f['location']['dates'])} d"
        for f in hs
    )
    out = [
        f"holiday {len(days & td)}/{len(td)} true days, {len(days - td)} other [{terms}]; "
        f"{len(r['findings'])} findings, {len(r['unsupported'])} false"
    ]
    for f in hs:
        m = f.get("holiday_merge")
        if m:
            a = m["apart_over_merged"]
            parts = "; ".join(
                f"{p['dates'][0]}..{p['dates'][-1]} when found {p['cv_when_found'].get('gain_percent', float('nan')):+.1f} %, "
                f"merged on its days {(p['merged_over_none_on_its_days'].get('gain_percent') or float('nan')):+.1f} %"
                for p in m["parts"]
            )
            out.append(
                f"  merge: {'merged' if m['merged'] else 'kept apart'}; apart over merged "
                f"{(a.get('gain_percent') or float('nan')):+.2f} ± {(a.get('se_percent') or float('nan')):.2f} % "
                f"t {(a.get('t') or float('nan')):.2f} over {a.get('n_days')} d; {parts}"
            )
        look = f.get("heldout_lookalike")
        if look and look.get("dates"):
            ld = set(look["dates"])
            out.append(
                f"  held-out lookalike: {len(ld & td)} true, {len(ld - td)} other days "
                + "; ".join(f"{w['dates'][0]}..{w['dates'][-1]} γ {w['gamma']:.2f}" for w in look["weeks"])
            )
    return out


def main(ref_path: str, new_path: str) -> None:
    ref, new = load(ref_path), load(new_path)
    for cid in sorted(new):
        c, r = new[cid]
        print(f"case {cid} {c['effects'] or 'clean'}")
        if cid in ref:
            print("   ref:", "\n        ".join(describe(*ref[cid])))
        print("   new:", "\n        ".join(describe(c, r)))
        if cid in ref:
            rk, nk = keys(ref[cid][1]["findings"]), keys(r["findings"])
            for k in sorted(nk - rk):
                print("     +", k)
            for k in sorted(rk - nk):
                print("     -", k)


if __name__ == "__main__":
    sys.path.insert(0, __file__.rsplit("/", 1)[0])
    main(sys.argv[1], sys.argv[2])
