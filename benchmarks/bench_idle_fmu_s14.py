"""The idle supply rule inside the FMUs (session 14): a diagnosed model of night-off data, its two FMUs on raw data.

Generates night-off emulator data (cold climate, winter), diagnoses it (the extended model stores
``meta["idle_supply"]``), exports the pythonfmu and the native FMU and runs each over the held-out weeks in
FMPy with the raw measured inputs (idle ``T_supply`` readings included). Prints, per FMU, the largest
difference to ``ExtendedModel.simulate_boxes`` (the rule with the model's own zone temperatures), to the
model fed the raw supply temperature, and to the model fed ``evaluate``'s substitution (measured zone
temperatures), and the time per step with and without the rule.

    python3 benchmarks/bench_idle_fmu_s14.py [--weeks 8] [--seed 0] [--out /tmp/idle_fmu]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time
import warnings
from pathlib import Path

import numpy as np


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--weeks", type=int, default=8)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default="/tmp/idle_fmu_s14")
    a = p.parse_args(argv)
    from fmpy import simulate_fmu

    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.emulator import generate
    from hvacfmu.errors import HvacfmuWarning
    from hvacfmu.fmu import export_fmu
    from hvacfmu.fmu_native import export_native_fmu
    from hvacfmu.fmu_slave import state_from_outputs
    from hvacfmu.timeutil import seconds_of_week

    out = Path(a.out)
    warnings.simplefilter("ignore", HvacfmuWarning)
    paths = generate(
        out / "data", weeks=a.weeks, seed=a.seed, fmt="csv", climate="cold", start="2025-11-03", schedule="night-off"
    )
    data = prepare(paths.measurements, paths.building)
    t0 = time.process_time()
    model = diagnose(data, progress=False).model
    print(
        f"diagnose: {time.process_time() - t0:.1f} CPU-s; terms {list(model.causes)}; rule {model.meta['idle_supply']}"
    )
    mp = model.save(out / "extended.json")
    plain = dataclasses.replace(model, meta={k: v for k, v in model.meta.items() if k != "idle_supply"})
    fmus = {
        "pythonfmu": export_fmu(mp, out / "idle.fmu"),
        "native": export_native_fmu(model, out / "idle_native.fmu"),
        "pythonfmu without rule": export_fmu(plain.save(out / "plain.json"), out / "plain.fmu"),
        "native without rule": export_native_fmu(plain, out / "plain_native.fmu"),
    }
    vavs = list(model.base.vavs)
    for week in data.test_weeks():
        f = data.week_frame(week).interpolate(method="time", limit_direction="both")
        n = len(f)
        m = f[[f"m_{b}" for b in vavs]].to_numpy(float)
        v = f[list(model.disturbances)].to_numpy(float)
        y0 = model.measured_outputs(f.iloc[:1])[0]
        q = model.gains_at(f.index, week.season)
        u = m @ np.asarray(model.base.input_map).T
        v0 = model.idle_step().apply(v[0], m[0], y0)[0]
        _, Y = model.simulate_boxes(state_from_outputs(model, y0, u[0], v0, q[0]), m, v, q)
        _, Yraw = model.simulate_boxes(state_from_outputs(model, y0, u[0], v[0], q[0]), m, v, q, idle=False)
        su, sv = model.signals(f)  # evaluate's substitution: the measured zone temperatures
        _, Yev = model.simulate(state_from_outputs(model, y0, su[0], sv[0], q[0]), su, sv, q)
        idle = float(
            np.mean(
                np.all(m <= np.array(list(model.meta["idle_supply"]["rule"]["T_supply"]["flows"].values())), axis=1)
            )
        )
        print(f"week {week.number} ({week.season}): {n} steps, unit idle in {100 * idle:.0f} %")
        meas = f[[f"T_{z}" for z in model.outputs]].to_numpy(float)

        def rms(Z, meas=meas, n=n):
            return float(np.sqrt(np.mean((Z[:n] - meas) ** 2)))

        print(
            f"  model: |own-zone rule - raw| max {np.abs(Y - Yraw).max():.3f} K, |own-zone rule - measured-zone "
            f"rule| max {np.abs(Y - Yev).max():.3f} K; week-long open-loop RMS vs measured: own-zone "
            f"{rms(Y):.3f} K, measured-zone {rms(Yev):.3f} K, raw {rms(Yraw):.3f} K"
        )
        cols = {
            **{f"m_{b}": m[:, j] for j, b in enumerate(vavs)},
            **{d: v[:, j] for j, d in enumerate(model.disturbances)},
        }
        sig = np.zeros(n, dtype=[("time", float)] + [(c, float) for c in cols])
        sig["time"] = np.arange(n) * data.step
        for c, x in cols.items():
            sig[c] = x
        sv0 = {f"T_{z}_start": float(y) for z, y in zip(model.outputs, y0)}
        sv0.update(
            season=list(model.gains).index(week.season) + 1, start_time_of_week=float(seconds_of_week(f.index[:1])[0])
        )
        for name, path in fmus.items():
            t = time.perf_counter()
            r = simulate_fmu(
                str(path),
                start_time=0.0,
                stop_time=(n - 1) * data.step,
                output_interval=data.step,
                input=sig,
                start_values=sv0,
                output=[f"T_{z}" for z in model.outputs],
            )
            dt = time.perf_counter() - t
            F = np.column_stack([r[f"T_{z}"] for z in model.outputs])
            ref = Yraw if "without" in name else Y
            print(
                f"  {name:24s} max |FMU - reference| {np.abs(F - ref[:n]).max():.1e} K; "
                f"{1e6 * dt / n:.0f} us/step (simulate_fmu, wall)"
            )
    print(f"load average {os.getloadavg()}")


if __name__ == "__main__":
    main()
