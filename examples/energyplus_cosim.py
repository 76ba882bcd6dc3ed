"""EnergyPlus hosts our FMU and our MPC: identify on the building's own export, then control it for a week.

    python3 examples/energyplus_cosim.py [--prototype office_small] [--weather KEY|EPW] [--start 2017-07-10] [--days 7]
        [--out DIR]

1. export a year of BMS-like data from the EnergyPlus building (cached);
2. fit the per-zone Model A on it, save it and export it as an FMU;
3. run EnergyPlus for the week twice, with the FMU in the loop both times: with EnergyPlus's own
   control, then with our MPC writing the zones' setpoints through actuators;
4. print energy and comfort of both, and check that EnergyPlus used every setpoint the MPC sent.
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import pandas as pd


def identify(prototype: str, out: Path, kind: str = "zones", weather=None):
    """Export (cached), prepare and fit; returns (dataset, model, FMU path)."""
    from hvacfmu.data import prepare
    from hvacfmu.energyplus import cached_export
    from hvacfmu.fitting import fit
    from hvacfmu.fmu import export_fmu

    paths = cached_export(prototype, **({"weather": weather} if weather else {}))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(paths.measurements, paths.building)
        model = fit(ds, kind, progress=False)
    out.mkdir(parents=True, exist_ok=True)
    model_path = model.save(out / f"{kind}.json")
    fmu = export_fmu(model_path, out / f"{kind}.fmu", timezone=ds.building.timezone)
    return ds, model, fmu


def run_week(prototype: str, ds, model, fmu, start: str, days: int, horizon: int = 24, weather=None):
    """Reference (EnergyPlus's own control) and MPC runs over ``days`` from local midnight ``start``."""
    from harness.energyplus_host import run_host
    from harness.mpc import cosim_controller

    lo = pd.Timestamp(start).tz_localize(ds.building.timezone)
    frame = ds.frame[(ds.frame.index >= lo) & (ds.frame.index < lo + pd.Timedelta(days=days))]
    ref = run_host(prototype, ds.building, frame, fmu=fmu, weather=weather)
    mpc = cosim_controller(model, ds.building, horizon=horizon)
    ctl = run_host(prototype, ds.building, frame, fmu=fmu, controller=mpc, model=model, weather=weather)
    return ref, ctl


def main(argv=None) -> int:
    from harness.energyplus_host import compare

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--prototype", default="ASHRAE901_OfficeSmall_STD2019_Denver")
    ap.add_argument(
        "--weather",
        help="weather file (EPW path or pyenergyplus.dataset key, as `hvacfmu generate --weather`; default: the IDF's city)",
    )
    ap.add_argument("--start", default="2017-07-10", help="local start date of the week (default 2017-07-10)")
    ap.add_argument("--days", type=int, default=7)
    ap.add_argument("--horizon", type=int, default=24, help="MPC horizon [15-min steps] (default 24)")
    ap.add_argument("--out", default="hvacfmu-energyplus", help="output folder")
    args = ap.parse_args(argv)
    out = Path(args.out)
    ds, model, fmu = identify(args.prototype, out, weather=args.weather)
    where = f" in {args.weather}" if args.weather else ""
    print(f"model: {model.kind} on {len(ds.weeks)} weeks of {args.prototype}{where}; FMU {fmu}")
    ref, ctl = run_week(args.prototype, ds, model, fmu, args.start, args.days, args.horizon, weather=args.weather)
    print(compare(ref, ctl))
    ref.table.to_csv(out / "energyplus_own_control.csv")
    ctl.table.to_csv(out / "energyplus_mpc.csv")
    return 0 if not ctl.mismatches else 1


if __name__ == "__main__":
    raise SystemExit(main())
