"""EnergyPlus as the second source of truth: per prototype, model and season, 24-h RMS against the baselines.

Generates (cached) a year of 15-minute BMS-like data of each prototype through
EnergyPlus's Python API, fits every model kind on the training weeks and
evaluates it on the test weeks against persistence and the time-of-week mean.
Also reports the closed-loop identifiability check: the fitted airflow gains of
the zones model against the smallest physically plausible gain.

Usage::

    python3 benchmarks/bench_energyplus.py [--prototype NAME[:floor|:zone,zone,...][@weather]] ... [--unseen | --unseen2 | --unseen3] [--weather KEY]
        [--verdict] [--kinds lumped,zones,physics] [--weeks N]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hvacfmu.energyplus import cached_export
from hvacfmu.energyplus.checks import airflow_identifiability, margins_table

DEFAULT_PROTOTYPES = (
    "ASHRAE901_OfficeMedium_STD2019_Denver:mid",
    "ASHRAE901_RestaurantFastFood_STD2019_Denver",
    "ASHRAE901_OfficeSmall_STD2019_Denver",
)
#: Buildings and climates never used to design anything here (issue 13 point 8; benchmarks/energyplus_unseen.md);
#: run with --unseen. ``@KEY`` is the weather (pyenergyplus.dataset key).
UNSEEN_PROTOTYPES = (
    "ASHRAE901_RetailStandalone_STD2019_Denver",
    "ASHRAE901_OfficeMedium_STD2019_Denver:mid@usa_fl_miami",
    "ASHRAE901_OfficeMedium_STD2019_Denver:mid@usa_il_chicago",
    "RefBldgMediumOfficeNew2004_Chicago:mid",
)
#: Second round, chosen before any run (benchmarks/energyplus_unseen2.md); run with --unseen2.
UNSEEN2_PROTOTYPES = (
    "ASHRAE901_SchoolPrimary_STD2019_Denver:Pod_1",
    "ASHRAE901_OfficeLarge_STD2019_Denver:mid@usa_nj_newark",
    # replacement of the case above, whose data centre (held at exactly 27 C) is masked as a stuck sensor
    "ASHRAE901_OfficeLarge_STD2019_Denver:Core_mid,Perimeter_mid_ZN_1,Perimeter_mid_ZN_2,Perimeter_mid_ZN_3,"
    "Perimeter_mid_ZN_4@usa_nj_newark",
    "RefBldgSmallOfficeNew2004_Chicago",
    "ASHRAE901_RetailStripmall_STD2019_Denver@usa_fl_tampa",
    "ASHRAE901_OfficeMedium_STD2019_Denver:bot@usa_az_phoenix",
    "ASHRAE901_OfficeMedium_STD2019_Denver:top@usa_ca_san_francisco",
    "ASHRAE901_HotelLarge_STD2019_Denver:Flr_6",
)
#: Third round, chosen before any run (benchmarks/energyplus_unseen3.md); run with --unseen3.
UNSEEN3_PROTOTYPES = (
    "RefBldgSuperMarketNew2004_Chicago@usa_il_uiw",
    "ASHRAE901_Warehouse_STD2019_Denver@usa_nv_las_vegas",
    "ASHRAE901_Hospital_STD2019_Denver:PatRoom1_Mult10_Flr_3,PatRoom2_Flr_3,PatRoom3_Mult10_Flr_3,PatRoom4_Flr_3,"
    "PhysTherapy_Flr_3,NurseStn_Lobby_Flr_3,Lab_Flr_3,Corridor_SE_Flr_3@usa_fl_orlando",
    "ASHRAE901_SchoolSecondary_STD2019_Denver:Gym_ZN_1_FLR_1,Aux_Gym_ZN_1_FLR_1,Auditorium_ZN_1_FLR_1,"
    "Kitchen_ZN_1_FLR_1,Cafeteria_ZN_1_FLR_1,LIBRARY_MEDIA_CENTER_ZN_1_FLR_2,Lobby_ZN_1_FLR_1,"
    "Main_Corridor_ZN_1_FLR_1@usa_ok_oklahoma",
    "ASHRAE901_ApartmentMidRise_STD2019_Denver:M_SW_Apartment,M_NW_Apartment,M_SE_Apartment,M_NE_Apartment,"
    "M_N1_Apartment,M_N2_Apartment,M_S1_Apartment,M_S2_Apartment@usa_va_sterling",
)


def run(prototype: str, kinds, weeks, weather=None, verdict=False):
    from hvacfmu.data import prepare
    from hvacfmu.errors import FitError
    from hvacfmu.evaluation import evaluate
    from hvacfmu.fitting import fit

    prototype, _, at = prototype.partition("@")
    weather = at or weather
    name, _, floor = prototype.partition(":")
    zones = floor.split(",") if "," in floor else None  # NAME:zone,zone,... keeps those IDF zones
    floor = None if zones else floor
    t0 = time.perf_counter()
    # the slow tests use the same options; weather only when given, so the Denver/Chicago defaults keep their key
    opts = {"weather": weather} if weather else {}
    if zones:
        opts["zones"] = zones
    paths = cached_export(name, floor=floor or None, weeks=weeks, **opts)
    t_gen = time.perf_counter() - t0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(paths.measurements, paths.building)
        models, t_fit, refused = {}, {}, {}
        for k in kinds:
            t0 = time.perf_counter()
            try:
                models[k] = fit(ds, k, progress=False)
            except FitError as exc:  # one kind refused (e.g. Model B unstable): say why, score the others
                refused[k] = str(exc)
            t_fit[k] = time.perf_counter() - t0
        res = evaluate(list(models.values()), ds, names=list(models))
    print(
        f"\n=== {prototype}"
        + (f" with {weather}" if weather else "")
        + f": {len(ds.building.zones)} zones, {len(ds.building.vavs)} boxes, "
        f"{len(ds.building.ahus)} air handler(s), {len(ds.weeks)} weeks "
        f"(export {t_gen:.1f} s incl. cache; fit " + ", ".join(f"{k} {t:.1f} s" for k, t in t_fit.items()) + ")"
    )
    for k, why in refused.items():
        print(f"{k}: REFUSED by the fit: {why}")
    print(margins_table(res).to_string(float_format=lambda x: f"{x:.3f}"))
    if "zones" in models:
        for line in airflow_identifiability(models["zones"], ds.building):
            print("  " + line)
    if verdict and res.verdict is not None:
        print(res.verdict.format())
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--prototype", action="append", help="prototype[:floor][@weather] (repeatable)")
    ap.add_argument("--unseen", action="store_true", help="the buildings and climates never used here")
    ap.add_argument("--unseen2", action="store_true", help="the second round of them (energyplus_unseen2.md)")
    ap.add_argument("--unseen3", action="store_true", help="the third round of them (energyplus_unseen3.md)")
    ap.add_argument("--weather", help="EPW file or pyenergyplus.dataset weather key (default: the prototype's city)")
    ap.add_argument("--verdict", action="store_true", help="also print the verdict evaluate prints first")
    ap.add_argument("--kinds", default="lumped,zones,physics")
    ap.add_argument("--weeks", type=int, default=None, help="weeks from 1 January (default: the whole year)")
    args = ap.parse_args(argv)
    default = (
        UNSEEN3_PROTOTYPES
        if args.unseen3
        else UNSEEN2_PROTOTYPES
        if args.unseen2
        else UNSEEN_PROTOTYPES
        if args.unseen
        else DEFAULT_PROTOTYPES
    )
    for p in args.prototype or default:
        run(p, args.kinds.split(","), args.weeks, args.weather, args.verdict)


if __name__ == "__main__":
    main()
