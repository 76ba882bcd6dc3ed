"""Wind-driven infiltration on EnergyPlus data: does ``diagnose`` find it, and what does it gain against persistence?

The mid-rise apartments of ``energyplus_unseen3.md`` (case e: the eight flats of the middle floor, Sterling weather)
lose to persistence in winter; their infiltration is proportional to the wind speed (``ZoneInfiltration:DesignFlowRate``
C = 0.224). This exports the same year with the site wind speed as a ``wind`` column (``cached_export(..., wind=True)``:
a cache of its own, the export without it is unchanged), runs ``diagnose`` and scores on the held-out weeks, per season:
the zones model, the diagnosis' extended model, and that model without its ``wind_infiltration`` terms.

    python3 benchmarks/bench_wind_energyplus.py [--weeks N] [--prototype NAME:zone,...@weather]
"""

from __future__ import annotations

import argparse
import time
import warnings

APARTMENTS = (
    "ASHRAE901_ApartmentMidRise_STD2019_Denver:M_SW_Apartment,M_NW_Apartment,M_SE_Apartment,M_NE_Apartment,"
    "M_N1_Apartment,M_N2_Apartment,M_S1_Apartment,M_S2_Apartment@usa_va_sterling"
)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--prototype", default=APARTMENTS)
    ap.add_argument("--weeks", type=int, default=None)
    ap.add_argument("--save", help="folder for the diagnosis report (report.json) and its model (model.json)")
    args = ap.parse_args(argv)

    import numpy as np

    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.energyplus import cached_export
    from hvacfmu.evaluation import evaluate

    proto, _, weather = args.prototype.partition("@")
    name, _, zones = proto.partition(":")
    opts = {"weather": weather} if weather else {}
    if zones:
        opts["zones"] = zones.split(",")
    t0 = time.perf_counter()
    paths = cached_export(name, floor=None, weeks=args.weeks, wind=True, **opts)
    t_exp = time.perf_counter() - t0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(paths.measurements, paths.building)
        w = ds.frame["wind"].to_numpy()
        print(
            f"=== {args.prototype}: {len(ds.weeks)} weeks, export {t_exp:.0f} s incl. cache; wind mean {np.nanmean(w):.2f} "
            f"m/s, p95 {np.nanpercentile(w, 95):.2f} m/s, coverage {100 * np.isfinite(w).mean():.1f} %"
        )
        t0 = time.perf_counter()
        rep = diagnose(ds, progress=False)
        t_diag = time.perf_counter() - t0
        print(f"diagnose: {t_diag:.0f} s")
        if args.save:
            from pathlib import Path

            Path(args.save).mkdir(parents=True, exist_ok=True)
            rep.save_json(Path(args.save) / "report.json")
            rep.model.save(Path(args.save) / "model.json")
        for line in rep.heldout.get("verdict_lines", [])[:12]:
            print("  heldout verdict: " + line)
        print(rep.summary())
        for c in rep.candidates:
            if c["cause"] == "wind_infiltration":
                ev = c["evidence"]
                cv = c.get("cv") or {}
                print(
                    f"  wind_infiltration {c['location']}: {c['status']}; corr {ev.get('corr', float('nan')):+.3f}, "
                    f"partial beyond dT {ev.get('partial_corr_beyond_dT', float('nan')):+.3f}; "
                    f"CV gain {cv.get('gain_percent', float('nan')):.1f} % (t {cv.get('t', float('nan')):.1f}); "
                    f"held-out {((c.get('heldout') or {}).get('gain_percent', float('nan'))):.1f} %"
                    f"; ΔBIC {(c.get('test') or {}).get('delta_bic', float('nan')):.1f}"
                )
        ext = rep.model
        no_wind = ext.with_terms([t for t in ext.terms if t.cause != "wind_infiltration"])
        from hvacfmu.fitting import fit

        models = {"zones": fit(ds, "zones", progress=False), "extended": ext, "extended without wind": no_wind}
        res = evaluate(list(models.values()), ds, names=list(models))
    from hvacfmu.energyplus.checks import margins_table

    print(margins_table(res).to_string(float_format=lambda x: f"{x:.3f}"))
    for sv in res.verdict.seasons:
        if sv.season == "winter":
            print(f"  {sv.model:>22} {sv.output:>15} winter {sv.rms:10.3f} K, persistence {sv.persistence:.3f} K")
    losing = [sv for sv in res.verdict.seasons if sv.season == "winter" and not sv.beats_persistence]
    for name in models:
        lost = [sv.output for sv in losing if sv.model == name]
        print(f"{name}: winter zone-seasons lost to persistence: {len(lost)} {lost}")


if __name__ == "__main__":
    main()
