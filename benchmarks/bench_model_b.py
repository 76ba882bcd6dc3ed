"""Benchmark Model B (physics): assembly, a year's simulation, initial states, full identification.

Uses the emulator's default 51-week dataset (generated once into the cache).
Prints medians over ``--repeat`` runs.

    python3 benchmarks/bench_model_b.py [--repeat 3] [--skip-fit]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np


def median_time(fn, repeat):
    times = []
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--skip-fit", action="store_true", help="skip the identification benchmark")
    args = parser.parse_args(argv)

    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.errors import HvacfmuWarning
    from hvacfmu.models.physics import PhysicsModel, assemble, fit_physics

    warnings.simplefilter("ignore", HvacfmuWarning)
    paths = cached_dataset()
    dataset = prepare(paths.measurements, paths.building)
    building = dataset.building
    nominal = building.physics["physics"]["nominal"]

    t, net = median_time(lambda: assemble(building, nominal, solar=True), args.repeat)
    print(f"assembly (continuous, sparse):        {1e3 * t:8.2f} ms   ({net.n_states} states)")
    gains = {s: np.zeros((672, 7)) for s in building.season_names}  # six zones [W], the storeys [°C]
    t, model = median_time(lambda: PhysicsModel(building, nominal, gains, solar=True), args.repeat)
    print(f"assembly + discretisation (model):    {1e3 * t:8.2f} ms")

    frame = dataset.frame.iloc[: 365 * 96]
    u, v = (np.nan_to_num(a) for a in model.signals(frame))
    q = model.gains_for_rows(frame.index)
    x0 = model.network.wall_steady_state(np.full(6, 21.0), 15.0)
    t, _ = median_time(lambda: model.simulate(x0, u, v, q), args.repeat)
    print(f"simulate one year ({len(frame)} steps):    {t:8.3f} s  (states returned)")
    rng = np.random.default_rng(0)
    starts = np.sort(rng.choice(np.arange(200, len(frame) - 100), 35, replace=False))
    t, _ = median_time(lambda: [model.initial_state(frame, int(k)) for k in starts], args.repeat)
    print(f"initial_state, 35 windows (48 h warm-up): {t:8.3f} s  ({1e3 * t / 35:.1f} ms each)")
    t, _ = median_time(lambda: model.initial_states(frame, starts), args.repeat)
    print(f"initial_states, 35 windows batched:   {t:8.3f} s")

    if not args.skip_fit:
        t, fitted = median_time(lambda: fit_physics(dataset, progress=False), args.repeat)
        print(f"fit_physics, default dataset:         {t:8.2f} s  (target < 60 s)")
        print(fitted.summary())


if __name__ == "__main__":
    main()
