"""Benchmark: MPC against the rule-based controller on the emulator's plant FMU (issue 18 p.3, p.7).

For a summer, a winter and a shoulder (spring or fall) week of the default
emulator dataset, runs ``hvacfmu cosim``'s machinery (:func:`harness.cosim.run_cosim`)
on the plant FMU (a building that is neither model) with the rule-based PI
controller (a VAV reheat sequence through the plant's ``Td_<vav>`` inputs) and
with MPC on Model A (six zones) and Model B (physics), which decide airflow and
reheat, at the given horizons (the harness's ``"plant"`` preset unless
``--preset paper``). Prints per run the fan/cooling energy proxy Σu²
[(kg/s)²], the supplied air [t], the commanded reheat [kWh], the comfort
violation [K·h] outside the band, the controller's week time and its
statistics (failures, not converged, projected moves, clipped box commands),
then whether each MPC used less fan/cooling energy and no more reheat than the
rule with no more violation.

Usage::

    python3 benchmarks/bench_mpc_plant.py [--models A B] [--horizons 12 48] [--seasons summer winter shoulder]
        [--preset plant|paper]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_mpc import fitted, load_dataset  # noqa: E402

from harness.controllers import RuleController  # noqa: E402
from harness.cosim import make_controller, run_cosim  # noqa: E402


def pick_weeks(dataset, seasons):
    """The first held-out week of each season (a training week if the season has no test week)."""
    out = {}
    for name in seasons:
        wanted = ("spring", "fall") if name == "shoulder" else (name,)
        weeks = [w for w in dataset.test_weeks() if w.season in wanted] or [
            w for w in dataset.weeks if w.season in wanted
        ]
        if weeks:
            out[name] = weeks[0]
    return out


def run(fmu, dataset, controller, week, model=None):
    t0 = time.perf_counter()
    r = run_cosim(fmu, dataset, controller, week=week.number, model=model, progress=False)
    wall = time.perf_counter() - t0
    s = r.summary
    return {
        "energy": s["energy_proxy"],
        "air_t": s["total_airflow_kg"] / 1e3,
        "viol": s["comfort_violation_Kh"],
        "heat": s.get("heating_kWh", 0.0),
        "wall": wall,
        "covered": s["covered"],
        "stats": s.get("controller_stats") or {},
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", nargs="+", choices=["A", "B"], default=["A", "B"])
    ap.add_argument("--horizons", nargs="+", type=int, default=[12])
    ap.add_argument("--seasons", nargs="+", default=["summer", "winter", "shoulder"])
    ap.add_argument(
        "--preset",
        choices=["plant", "paper"],
        default="plant",
        help="MPC options (harness.mpc.adapter.preset_options): 'plant' (default: offset-free, move "
        "suppression, back-off) or 'paper' (the paper's problem, blocks/per-step slack/QP beyond N = 3 "
        "not included)",
    )
    args = ap.parse_args(argv)
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.fmu import export_plant_fmu

    dataset = load_dataset()
    fmu = export_plant_fmu(cached_dataset().truth, Path(tempfile.mkdtemp()) / "Plant.fmu")
    models = {k: fitted("zones" if k == "A" else "physics", dataset)[0] for k in args.models}
    print(f"plant FMU, default emulator dataset; machine load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    better = []
    for season, week in pick_weeks(dataset, args.seasons).items():
        print(f"{season}: week {week.number} ({week.season}, {week.start:%Y-%m-%d})", flush=True)
        rule = run(fmu, dataset, RuleController(), week)
        rows = [("rule", rule)]
        for key, model in models.items():
            for N in args.horizons:
                opts = {"horizon": N, "preset": args.preset}
                rows.append(
                    (
                        f"MPC {key} N={N}",
                        run(fmu, dataset, make_controller("mpc", model, dataset.building, opts), week, model),
                    )
                )
        for name, r in rows:
            st = r["stats"]
            extra = ", ".join(
                f"{k} {st[k]}" for k in ("failures", "not_converged", "projected_steps", "clipped_box_steps") if k in st
            )
            print(
                f"  {name:<12} Σu² {r['energy']:8.1f}  air {r['air_t']:7.1f} t  reheat {r['heat']:7.1f} kWh  "
                f"outside band {r['viol']:6.1f} K·h  "
                f"week {r['wall']:6.1f} s  {'' if r['covered'] else 'NOT COVERED '}{extra}",
                flush=True,
            )
            if name != "rule":
                ok = r["energy"] < rule["energy"] and r["heat"] <= rule["heat"] and r["viol"] <= rule["viol"]
                better.append(ok)
                print(
                    f"  {'':<12} -> "
                    + (
                        "less fan/cooling and reheat, no more violation than the rule"
                        if ok
                        else "NOT better than the rule"
                    )
                )
    print(f"MPC better than the rule in {sum(better)} of {len(better)} runs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
