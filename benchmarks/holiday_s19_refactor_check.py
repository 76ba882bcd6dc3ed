"""Session 19 refactor check (``holiday_s19.md``): main's _holiday_week_gain and one_sided_departure against the
refactored ones (one helper, ``pooled_zone_departures``) on 3000 random day-departure sets, exact equality.

Run from the repository with git (main must exist): ``python3 benchmarks/holiday_s19_refactor_check.py``."""

import subprocess

import numpy as np

from hvacfmu.diagnosis.selection import _holiday_week_gain
from hvacfmu.models.causes.internal_gain_schedule import one_sided_departure

src_sel = subprocess.run(["git", "show", "main:hvacfmu/diagnosis/selection.py"], capture_output=True, text=True).stdout
src_igs = subprocess.run(
    ["git", "show", "main:hvacfmu/models/causes/internal_gain_schedule.py"], capture_output=True, text=True
).stdout
ns = {"np": np}
exec(src_sel[src_sel.index("def _holiday_week_gain") : src_sel.index("def _fails_scale_only")], ns)
exec(src_igs[src_igs.index("def one_sided_departure") : src_igs.index("def _pick_days")], ns)
rng = np.random.default_rng(0)
n = 0
for _trial in range(3000):
    nz = int(rng.integers(1, 6))
    deps = []
    for d in range(int(rng.integers(0, 12))):
        g = [None if rng.random() < 0.15 else float(rng.normal(0, 0.5)) for _ in range(nz)]
        w = [0.0 if rng.random() < 0.1 else float(rng.exponential()) for _ in range(nz)]
        rec = {"date": f"2025-10-{d + 1:02d}", "gamma_by_zone": g}
        if rng.random() < 0.8:
            rec["weight_by_zone"] = w
        deps.append(rec)
    dates = [f"2025-10-{d:02d}" for d in rng.choice(np.arange(1, 14), size=int(rng.integers(0, 8)), replace=False)]
    resid = rng.normal(size=(int(rng.integers(0, 30)), nz)) * rng.exponential(size=nz)
    a, b = ns["_holiday_week_gain"](deps, dates, resid), _holiday_week_gain(deps, dates, resid)
    c, d = ns["one_sided_departure"](deps, dates), one_sided_departure(deps, dates)
    assert a == b, (a, b)
    assert (np.isnan(c) and np.isnan(d)) or c == d, (c, d)
    n += 1
print("identical on", n, "random draws (exact ==)")
