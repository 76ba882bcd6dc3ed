"""Model B step 2: the gain profile's day types (``gain_days``) against the time-of-week mean, per data set.

One step-1 fit per data set (``fit_physics``, ``"week"``), then step 2 redone with every value of
``GAIN_DAYS`` (``refit_gains``: step 1 does not depend on it), ``"auto"`` included (the profile chosen by
blocked cross-validation over the training weeks), and the 24-h open-loop evaluation. Prints, per data
set and profile, the worst zone over all test windows, the worst zone-season cell (margin against the
time-of-week mean [%], 1 - model/baseline) and the mean RMS [K]; for ``"auto"`` its choice and CV scores;
then one line per data set with the worst-cell margins (``ROW``). The README table "A profile between
the two" comes from this script.

Rule for the default (stated before the ``auto`` column was measured): ``"auto"`` becomes the default
only if, over the rows measured, (a) its worst-cell margin is >= the ``week`` margin in at least 3 of 4
rows (75 %), and (b) no row that ``week`` wins (worst cell > +1 %) is lost by ``auto`` (worst cell < 0);
and (c) the reheat16 seed-0 assertion of ``tests/test_delivered_emulator.py`` (every zone-season cell
below the time-of-week mean) still holds with it.

Data sets (generated once into the cache): ``bms<seed>`` the README's BMS export (10 weeks from
2025-11-03, reheat-dual, cold, °F/CFM, naive local, outages, 15-min), ``floor8`` the default floor 8
weeks, ``reheat16`` / ``reheat16s<seed>`` the 16-week reheat data of ``tests/test_delivered_emulator.py``,
``office`` the EnergyPlus medium office (mid floor, a year), ``restaurant`` the fast-food restaurant (a
year; both need pyenergyplus, minutes on first use).

Usage::

    python3 benchmarks/bench_gain_days.py [bms0 bms1 ... floor8 reheat16 reheat16s1 office restaurant]
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

DEFAULT = ("bms0", "bms1", "bms2", "floor8", "bms3", "bms4", "reheat16", "reheat16s1", "reheat16s2")
BMS = dict(
    weeks=10,
    hvac="reheat-dual",
    climate="cold",
    units="us",
    clock="naive-local",
    faults=("outages",),
    start="2025-11-03",
    export_step=900,
)


def paths_of(name: str):
    """Measurement and building file of a named data set (cached)."""
    from hvacfmu.emulator import cached_dataset

    if name.startswith("bms"):
        return cached_dataset(seed=int(name[3:]), **BMS)
    if name == "floor8":
        return cached_dataset(weeks=8, seed=0)
    if name.startswith("reheat16"):
        seed = int(name[len("reheat16s") :]) if name.startswith("reheat16s") else 0
        return cached_dataset(weeks=16, seed=seed, hvac="reheat", start="2025-11-03T00:00:00")
    if name == "office":
        from hvacfmu.energyplus import cached_export

        return cached_export("ASHRAE901_OfficeMedium_STD2019_Denver", floor="mid", weeks=None)
    if name == "restaurant":
        from hvacfmu.energyplus import cached_export

        return cached_export("ASHRAE901_RestaurantFastFood_STD2019_Denver", floor=None, weeks=None)
    raise SystemExit(
        f"unknown data set {name!r}; known: bms<seed>, floor8, reheat16, reheat16s<seed>, office, restaurant"
    )


def run(name: str) -> None:
    from hvacfmu.data import prepare
    from hvacfmu.evaluation import evaluate
    from hvacfmu.models.physics import fit_physics, refit_gains
    from hvacfmu.models.physics.identification import GAIN_DAYS

    paths = paths_of(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(paths.measurements, paths.building)
        t0 = time.perf_counter()
        model = fit_physics(ds, progress=False, gain_days="week")
        t_fit = time.perf_counter() - t0
        models = [refit_gains(model, ds, g) for g in GAIN_DAYS]
        res = evaluate(models, ds, names=list(GAIN_DAYS))
    print(f"\n=== {name}: {len(ds.weeks)} weeks, fit {t_fit:.0f} s wall")
    worst = {}
    for g in GAIN_DAYS:
        rms = res.table(g)
        zones = [c for c in rms.columns if c != "mean"]
        margin = 100 * (1 - rms / res.table(g, which="time-of-week mean").loc[rms.index, rms.columns])
        cells = margin.drop(index="all")[zones].stack()
        zone = margin.loc["all", zones].idxmin()
        (season, czone) = cells.idxmin()
        worst[g] = cells.min()
        print(
            f"  {g:9s} worst zone {zone} {margin.loc['all', zone]:+6.1f} %, worst cell {season} {czone} "
            f"{cells.min():+6.1f} %, mean RMS {rms.loc['all', 'mean']:.3f} K"
        )
    auto = models[GAIN_DAYS.index("auto")].meta["gains"]["auto"]
    print(
        f"  auto chose {auto['chosen']} ({auto['folds']} folds, {auto['windows']} windows, {auto['seconds']} s): CV RMS "
        + ", ".join(f"{g} {v:.4f}" for g, v in auto["cv_rms"].items())
        + " K"
    )
    print(f"ROW {name} " + " ".join(f"{g}={worst[g]:+.1f}" for g in GAIN_DAYS) + f" chose={auto['chosen']}")


if __name__ == "__main__":
    for n in sys.argv[1:] or DEFAULT:
        run(n)
