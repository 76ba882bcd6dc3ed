"""Red team of the data path, session 16: session 15's 55 variants plus new ones, through check, fit, evaluate.

Same protocol as ``benchmarks/redteam_s15.py`` (whose variants, clean export and scoring it reuses): each
variant of one real-world-like export goes through ``check``, then ``hvacfmu fit --model zones`` and
``hvacfmu evaluate`` when ``check`` lets it through, and every fitted model is also scored on the clean export.
Session 16 adds zone temperature columns swapped in other ways (another far pair, the core with a perimeter
zone, three columns rotated), frozen outdoor sensors of other shapes (one week, slow drift), weather columns
late on their own and a units row under a two-column header.

Run: ``python3 benchmarks/redteam_s16.py [--out DIR] [--only NAME ...]``; ``--table BEFORE AFTER`` prints the
markdown table of two results files and the totals; ``--false-alarms DIR ...`` runs the session-16 checks on
clean exports; ``HVACFMU_CODE=/path/to/checkout`` runs another checkout's code (e.g. main, for "before").
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import redteam_s15 as s15  # noqa: E402


def zones_swapped_far_s_ne(f, b, rng):
    """T_S and T_NE labels exchanged (not adjacent)."""
    return f.assign(T_S=f["T_NE"], T_NE=f["T_S"]), b


def zones_swapped_core(f, b, rng):
    """The core zone T_C exchanged with the perimeter zone T_S (adjacent; the core has no facade)."""
    return f.assign(T_C=f["T_S"], T_S=f["T_C"]), b


def zones_rotated_three(f, b, rng):
    """Three zone columns rotated (NW <- E, E <- S, S <- NW)."""
    return f.assign(T_NW=f["T_E"], T_E=f["T_S"], T_S=f["T_NW"]), b


def t_out_stuck_noisy_week(f, b, rng):
    """T_out frozen for one week with ±0.2 °F noise."""
    out = f.copy()
    sl = slice(1500, 1500 + 96 * 7)
    n = len(out.loc[sl, "T_out"])
    out.loc[sl, "T_out"] = out.loc[1500, "T_out"] + rng.choice([-0.2, -0.1, 0.0, 0.1, 0.2], n)
    return out, b


def t_out_frozen_drifting(f, b, rng):
    """T_out frozen for 10 days, drifting 0.3 °F a day (a sensor losing its signal), with ±0.1 °F noise."""
    out = f.copy()
    sl = slice(800, 800 + 96 * 10)
    n = len(out.loc[sl, "T_out"])
    out.loc[sl, "T_out"] = out.loc[800, "T_out"] + 0.3 * np.arange(n) / 96 + rng.choice([-0.1, 0.0, 0.1], n)
    return out, b


def units_row_two_headers(f, b, rng):
    """A units row under the header, with the time column's cell naming its format (a Niagara-style export)."""
    got, b = s15.units_row(f, b, rng)
    got.iloc[0, 0] = "yyyy-mm-dd hh:mm"
    return got, b


NEW = [
    zones_swapped_far_s_ne, zones_swapped_core, zones_rotated_three, t_out_stuck_noisy_week, t_out_frozen_drifting,
    units_row_two_headers,
]  # fmt: skip
s15.VARIANTS = s15.VARIANTS + NEW

#: Fragments of the messages the session-16 checks added (a false alarm is one of them on a clean export).
NEW_MESSAGES = ("look swapped: the temperature changes", "a frozen outdoor sensor?")


def false_alarms(dirs, out: Path) -> None:
    """``prepare`` (where both new checks run) on clean exports; any :data:`NEW_MESSAGES` is a false alarm."""
    import time
    import warnings

    from hvacfmu.data import prepare
    from hvacfmu.errors import DataError

    with open(out, "a") as fh:
        for d in map(Path, dirs):
            data = next(iter(sorted(d.glob("measurements.*"))), None)
            if data is None or not (d / "building.toml").exists():
                continue
            t = time.time()
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    ds = prepare(data, d / "building.toml")
                messages, status = list(ds.warnings), "prepared"
            except DataError as exc:
                messages, status = str(exc).splitlines(), "refused"
            hits = [m for m in messages if any(f in m for f in NEW_MESSAGES)]
            r = {"export": d.name, "status": status, "new_messages": hits, "seconds": round(time.time() - t, 1)}
            if status == "prepared":
                r.update(pair_margins(ds.frame, ds.building))
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            print(
                f"{d.name}: {status}, new messages {len(hits)}",
                *hits[:1],
                {k: r.get(k) for k in ("worst_lead", "detectable", "pairs")},
                flush=True,
            )


def pair_margins(frame, building) -> dict:
    """How close the clean pairs come to the swap test's thresholds, and how many swapped pairs it would flag.

    ``lead``: min over the two columns of (evidence for the other zone's drivers - for its own), ``share``: the
    exchanged mapping's share of the pair's evidence. For a clean export, the pair with the largest lead (a false
    alarm needs lead >= SWAP_MARGIN and share >= SWAP_SHARE); exchanging a pair's columns swaps the roles, so
    the same numbers tell which swaps would be flagged (``detectable``: of ``pairs``; ``adjacent`` pairs apart).
    """
    from hvacfmu.data import boxmap

    ev = boxmap.zone_pair_evidence(frame, building)
    if ev is None:
        return {"pairs": 0}
    zones = list(ev.gain)
    worst, det, det_adj, n_adj = None, 0, 0, 0
    for i, a in enumerate(zones):
        for b in zones[i + 1 :]:
            g = ev.gain if a in ev.sunlit and b in ev.sunlit else ev.boxes_only
            aa, ab, ba, bb = g[a][a], g[a][b], g[b][a], g[b][b]
            total = max(aa + ab + ba + bb, 1e-9)
            lead, share = min(ab - aa, ba - bb), (ab + ba) / total
            if worst is None or lead > worst[0]:
                worst = (lead, share, a, b)
            hit = min(aa - ab, bb - ba) >= boxmap.SWAP_MARGIN and (aa + bb) / total >= boxmap.SWAP_SHARE
            adj = b in building.zone(a).adjacent or a in building.zone(b).adjacent
            det += hit
            det_adj += hit and adj
            n_adj += adj
    n = len(zones) * (len(zones) - 1) // 2
    return {
        "pairs": n,
        "worst_lead": round(worst[0], 1),
        "worst_share": round(worst[1], 3),
        "worst_pair": worst[2:],
        "detectable": det,
        "adjacent_pairs": n_adj,
        "detectable_adjacent": det_adj,
    }


def totals(path: Path) -> str:
    """'n refused, n warned, n silent (n silent and wrong)' of one results file."""
    rs = [json.loads(x) for x in path.read_text().splitlines()]
    count = {k: sum(r["outcome"] == k for r in rs) for k in ("refused", "warned", "silent")}
    wrong = sum(r["outcome"] == "silent" and bool(r.get("wrong")) for r in rs)
    return (
        f"{len(rs)} variants: {count['refused']} refused, {count['warned']} warned, {count['silent']} silent, "
        f"of which {wrong} silent and wrong"
    )


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    if "--false-alarms" in argv:
        i = argv.index("--false-alarms")
        res = argv[argv.index("--results") + 1] if "--results" in argv else "/tmp/redteam_s16_false_alarms.jsonl"
        false_alarms([a for a in argv[i + 1 :] if not a.startswith("--") and a != res], Path(res))
        return
    if "--out" not in argv:
        argv += ["--out", "/tmp/redteam_s16"]
    s15.main(argv)
    if "--table" in argv:
        i = argv.index("--table")
        for p in argv[i + 1 : i + 3]:
            print(f"{p}: {totals(Path(p))}")


if __name__ == "__main__":
    main()
