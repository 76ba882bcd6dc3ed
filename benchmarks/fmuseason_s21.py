"""A year of the two-season Model A's Python FMU (tests/test_fmuseason_s21.py) through FMPy, season = 0 against
the Python simulation of the season pieces (state carried over), and the per-step cost of each way to run it.

    PYTHONPATH=. python3 benchmarks/fmuseason_s21.py [--days 365] [--repeats 3]

Prints the largest difference [K] over the year (two boundaries: winter -> summer on 04-15, summer -> winter on
10-15, America/Los_Angeles) and the wall time per FMU step for: season 1 without start_time (time-of-week profile),
season 1 with start_time (local-time gains through the calendar path), season 0 (follows the calendar).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--days", type=int, default=365)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    from hvacfmu.fmu import export_fmu
    from hvacfmu.models.state import state_from_outputs
    from tests.test_fmu import Slave, run_fmu
    from tests.test_fmuseason_s21 import NAMES_IN, TZ, Y0, _building
    from tests.test_seasons_s21 import _signals, two_season

    sm, b = two_season(), _building()
    idx = pd.date_range("2025-01-06 00:00", periods=96 * args.days, freq="15min", tz=TZ)
    m, v = _signals(len(idx))
    U = np.hstack([m, v])
    with tempfile.TemporaryDirectory() as tmp:
        path = export_fmu(sm.save(Path(tmp) / "s.json"), Path(tmp) / "S.fmu", building=b)
        t0 = idx[0].timestamp()
        cases = {
            "season 1, no start_time": {"season": 1, "start_time_of_week": 0.0},
            "season 1, start_time": {"season": 1, "start_time": t0},
            "season 0 (follow)": {"season": 0, "start_time": t0},
        }
        out, cost = {}, {}
        for name, sv in cases.items():
            best = np.inf
            for r in range(args.repeats):
                s = Slave(path, f"b{r}{len(out)}")
                try:
                    s.init({**Y0, **sv}, inputs=(NAMES_IN, U[0]))
                    c = time.perf_counter()
                    out[name] = run_fmu(s, NAMES_IN, U, ["T_A", "T_B"])
                    best = min(best, time.perf_counter() - c)
                finally:
                    s.close()
            cost[name] = best / len(idx) * 1e6
    seasons = [b.season_of(t) for t in idx]
    models = {s: sm.for_season(s) for s in set(seasons)}
    gains = {s: np.asarray(models[s].gains_at(idx, s)) for s in models}
    x, ys = None, []
    for k in range(len(idx)):
        mod = models[seasons[k]]
        u, q = m[k] @ mod.input_map.T, gains[seasons[k]][k]
        if x is None:
            x = state_from_outputs(mod, np.array([21.0, 22.0]), u, v[k], q)
            ys.append(mod.output(x))
        x = mod.step_state(x, u, v[k], q)
        ys.append(mod.output(x))
    ref = np.array(ys)
    cuts = [k for k in range(1, len(idx)) if seasons[k] != seasons[k - 1]]
    print(f"{len(idx)} steps, boundaries at {[str(idx[k]) for k in cuts]}, load {os.getloadavg()[0]:.1f}")
    print(f"season 0 against the Python pieces: max |diff| = {np.abs(out['season 0 (follow)'] - ref).max():.3g} K")
    w = out["season 1, start_time"]
    print(f"season 1 all year against the pieces: max |diff| = {np.abs(w - ref).max():.3g} K (the silent error)")
    for name, us in cost.items():
        print(f"  {name:26s} {us:6.1f} us/step (best of {args.repeats})")


if __name__ == "__main__":
    main()
