"""Compare two battery results files case by case (session 19, ``holgrow_s19.md``).

For every case of ``NEW``: the holiday days found (true days of the injected weeks / other days) with each holiday
finding's days, cross-validated gain and t, the number of findings and of false ones, and the findings gained (+)
or lost (-) against ``REF``, term by term (cause and location). Records of ``holiday_s19.py --results`` and of
``bench_diagnosis_battery.py`` (``case``) and the main reruns of ``holiday_s19.md`` (``id`` at the top) are read.

Run::

    python3 benchmarks/holgrow_s19.py benchmarks/holiday_s19_q2026_results.jsonl benchmarks/holgrow_s19_q2026_results.jsonl
"""

from __future__ import annotations

import json
import re
import sys

import pandas as pd


def load(path: str) -> dict:
    out = {}
    for line in open(path):
        r = json.loads(line)
        c = r["case"] if "case" in r else r
        out[c["id"]] = (c, r)
    return out


def true_days(effects, start: str = "2025-09-01") -> set:
    """ISO weekdays of the injected holiday weeks (the emulator's weeks count from ``start``)."""
    s, out = pd.Timestamp(start), set()
    for e in effects:
        m = re.search(r"kind=holiday,weeks=([0-9+]+)", e)
        if m:
            for w in m.group(1).split("+"):
                out |= {(s + pd.Timedelta(days=7 * int(w) + d)).date().isoformat() for d in range(5)}
    return out


def key(f: dict) -> str:
    return f["cause"] + ":" + json.dumps(f["location"], sort_keys=True)


def describe(c: dict, r: dict) -> str:
    td = true_days(c["effects"])
    hs = [
        f for f in r["findings"] if f["cause"] == "internal_gain_schedule" and f["location"].get("variant") == "holiday"
    ]
    days = {d for f in hs for d in f["location"]["dates"]}
    terms = ", ".join(f"{len(f['location']['dates'])} d {f['cv_gain_percent']:+.1f} % t {f['cv_t']:.1f}" for f in hs)
    return (
        f"holiday {len(days & td)}/{len(td)} true days, {len(days - td)} other [{terms}]; "
        f"{len(r['findings'])} findings, {len(r['unsupported'])} false"
    )


def main(ref_path: str, new_path: str) -> None:
    ref, new = load(ref_path), load(new_path)
    for cid in sorted(new):
        c, r = new[cid]
        print(f"case {cid} {c['effects'] or 'clean'}")
        if cid in ref:
            print("   ref:", describe(*ref[cid]))
        print("   new:", describe(c, r))
        if cid in ref:
            rk, nk = {key(f) for f in ref[cid][1]["findings"]}, {key(f) for f in r["findings"]}
            for k in sorted(nk - rk):
                print("     +", k)
            for k in sorted(rk - nk):
                print("     -", k)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
