"""Benchmark: MPC with and without the wind-infiltration term on the plant FMU (issue 15 p.6, issue 18 p.4).

An emulator dataset with a wind column and ``wind_infiltration`` injected in one zone (8 weeks from
November, ``ua`` [W/K per m/s] given); the six-zone Model A fitted on its training weeks; two control
models refitted on that base (:func:`hvacfmu.diagnosis.control.terms_on_base`): **base** (no term, its
gain profiles re-estimated) and **wind** (the ``wind_infiltration`` term in the injected zone). Until
session 13 the wind term had no matrix form and the control model left it out, so **base** is what
MPC controlled with before. Each held-out week runs ``cosim --controller mpc`` (preset "plant", horizon
``--horizon``) on the plant FMU of the dataset with both models. Printed per run: Σu² [(kg/s)²], reheat
[kWh], K·h outside [20, 22] °C (total and in the wind zone), steps, failures, not converged, the
controller's median time per step and the run's wall time.

Usage::

    python3 benchmarks/bench_wind_mpc.py [--ua 150] [--zone NW] [--weeks 8] [--horizon 12] [--days 7]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ua", type=float, default=150.0, help="injected leak [W/K per m/s] (emulator default 40)")
    ap.add_argument("--zone", default="NW")
    ap.add_argument("--weeks", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--horizon", type=int, default=12)
    ap.add_argument("--days", type=float, default=7.0)
    args = ap.parse_args(argv)

    import pandas as pd

    from harness.cosim import make_controller, run_cosim
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis.control import terms_on_base
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.errors import HvacfmuWarning
    from hvacfmu.fmu import export_plant_fmu
    from hvacfmu.models.causes import WindInfiltration
    from hvacfmu.models.datadriven import fit_zones

    effect = f"wind_infiltration:zone={args.zone},ua={args.ua:g}"
    p = cached_dataset(weeks=args.weeks, seed=args.seed, effects=[effect], start="2025-11-03", wind="m/s")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        ds = prepare(p.measurements, p.building)
        base = fit_zones(ds)
        models = {
            "base": terms_on_base(ds, base, [], heat="airflow"),
            "wind": terms_on_base(ds, base, [WindInfiltration(zone=args.zone)], heat="airflow"),
        }
    wt = models["wind"].terms[0]
    print(f"effect {effect}; fitted coef {wt.coef:.4g} ± {wt.std.get('coef', float('nan')):.2g} K/step per (m/s K)")
    with tempfile.TemporaryDirectory() as tmp:
        plant = export_plant_fmu(p.truth, Path(tmp) / "Plant.fmu")
        print(
            f"{'week':>10} {'model':>5} {'sum_u2':>8} {'reheat':>7} {'K*h':>7} {f'K*h {args.zone}':>8} "
            f"{'steps':>5} {'fail':>4} {'n.conv':>6} {'ctrl ms':>7} {'wall s':>7}"
        )
        for week in ds.test_weeks():
            for name, model in models.items():
                ctrl = make_controller("mpc", model, ds.building, {"horizon": args.horizon})
                t0 = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", HvacfmuWarning)
                    r = run_cosim(
                        plant,
                        ds,
                        ctrl,
                        model=model,
                        start=week.start,
                        stop=week.start + pd.Timedelta(days=args.days),
                    )
                wall = time.perf_counter() - t0
                s = r.summary
                st = s.get("controller_stats") or {}
                zone_kh = sum(s["comfort_by_output"].get(args.zone, [0.0, 0.0]))
                print(
                    f"{str(week.start.date()):>10} {name:>5} {s['energy_proxy']:8.2f} {s.get('heating_kWh', 0.0):7.1f} "
                    f"{s['comfort_violation_Kh']:7.2f} {zone_kh:8.2f} {s['steps_completed']:5d} "
                    f"{st.get('failures', -1):4d} {st.get('not_converged', -1):6d} "
                    f"{1e3 * s['controller_time_median']:7.2f} {wall:7.1f}"
                )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
