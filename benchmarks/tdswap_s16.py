"""False alarms and detection rate of the discharge-column swap test (``boxmap.check_discharge_swaps``).

``python3 benchmarks/tdswap_s16.py --results FILE DIR ...``: each DIR holds a clean export (``measurements.*``
and ``building.toml``); it is prepared (where the check runs) and the test's evidence recorded: any discharge
swap message (a false alarm), the clean pair that comes closest (``worst_lead``: min over the two boxes of the
lead of the other box's column over its own), and how many box pairs in different zones would be flagged if
their ``Td_`` columns were exchanged (exchanging swaps the roles of own and other evidence).
``python3 benchmarks/tdswap_s16.py --variants CLEAN_DIR``: ``check`` on every red-team variant
(benchmarks/redteam_s16.py) of the red team's clean CSV export in CLEAN_DIR; prints the exit code and any
discharge swap message per variant. See benchmarks/tdswap_s16.md.
"""

from __future__ import annotations

import json
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def margins(frame, building) -> dict:
    from hvacfmu.data import boxmap

    ev = boxmap.discharge_pair_evidence(frame, building)
    if ev is None:
        return {"pairs": 0}
    boxes = list(ev.own)
    worst, det, n = None, 0, 0
    for i, a in enumerate(boxes):
        for b in boxes[i + 1 :]:
            if b not in ev.other[a]:
                continue
            n += 1
            la, lb = ev.lead(a, b)
            if worst is None or min(la, lb) > worst[0]:
                worst = (min(la, lb), a, b)
            own, other = ev.own[a] + ev.own[b], ev.other[a][b] + ev.other[b][a]
            det += min(-la, -lb) >= boxmap.TD_SWAP_MARGIN and own >= boxmap.TD_SWAP_SHARE * (own + other)
    out = {"pairs": n, "detectable": det, "boxes": len(boxes), "rows": ev.rows}
    if worst is not None:
        out.update(worst_lead=round(worst[0], 1), worst_pair=worst[1:])
    return out


def variants(clean: Path) -> None:
    import numpy as np
    import pandas as pd

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import redteam_s15 as s15
    import redteam_s16  # noqa: F401  (adds session 16's variants to s15.VARIANTS)

    from hvacfmu.data import check

    f0, b0 = pd.read_csv(clean / "measurements.csv"), (clean / "building.toml").read_text()
    work = clean.parent / "tdswap_variants"
    for fn in s15.VARIANTS:
        out, b = fn(f0.copy(), b0, np.random.default_rng(0))
        d = work / fn.__name__
        d.mkdir(parents=True, exist_ok=True)
        (d / "building.toml").write_text(b)
        if isinstance(out, str):
            (d / "m.csv").write_text(out)
        else:
            out.to_csv(d / "m.csv", index=False)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rep = check(d / "m.csv", d / "building.toml")
        hits = [w[:160] for w in rep.warnings if "look swapped: box" in w]
        print(json.dumps({"variant": fn.__name__, "exit": rep.exit_code, "td_swap": hits}), flush=True)


def main(argv) -> None:
    if argv[:1] == ["--variants"]:
        variants(Path(argv[1]))
        return
    from hvacfmu.data import prepare
    from hvacfmu.errors import DataError

    res = Path(argv[argv.index("--results") + 1])
    dirs = [a for a in argv if a != "--results" and a != str(res)]
    with open(res, "a") as fh:
        for d in map(Path, dirs):
            data = next(iter(sorted(d.glob("measurements.*"))), None)
            if data is None or not (d / "building.toml").exists():
                continue
            t = time.time()
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    ds = prepare(data, d / "building.toml")
            except DataError as exc:
                r = {"export": d.name, "status": "refused", "why": str(exc).splitlines()[0][:200]}
            else:
                hits = [w for w in ds.warnings if "(Td_" in w and "look swapped" in w]
                r = {"export": d.name, "status": "prepared", "td_swap_messages": hits, **margins(ds.frame, ds.building)}
            r["seconds"] = round(time.time() - t, 1)
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            print(json.dumps(r)[:300], flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
