"""Benchmark: a closed-loop week (672 steps of 15 min) of energy-efficient MPC with Model A and Model B.

Each model is its own plant (pure-Python closed loop, state feedback every
step; Model B's walls come from the Kalman filter), over the first held-out
week of the default emulator dataset, disturbances previewed from the data
(perfect forecast, as in the paper). Prints, per configuration, the week's
wall time (median over ``--repeat`` runs), per-step controller time
(median, max), solver failures, SCP iterations, cost, energy proxy and
comfort violation, and the ratio to the paper's ~20 hours for a week with
Model B at N = 3 (Model A: to its "< 5 minutes", an upper bound).

Models: Model A (``fit_zones``) and Model B (``fit_physics``) identified on
the default emulator dataset (``hvacfmu.emulator.cached_dataset()``) and
cached in ``$HVACFMU_CACHE/bench_mpc/``; ``--synthetic`` (or a failed fit)
uses a random 289-state RC network with 21 boxes instead
(``harness.mpc.synthetic``), and the output says which.

Targets (issue #6): Model A, N = 3: < 2 s; Model B: < 20 s (N = 3),
< 60 s (N = 12), < 5 min (N = 96); zero solver failures. ``A12``, ``A48``
and ``B48`` run the harness's ``"plant"`` preset (what ``hvacfmu demo`` and
``hvacfmu cosim --controller mpc`` use; issue 18 p.7: week times at N = 12 and 48).

Usage::

    python3 benchmarks/bench_mpc.py [--steps 672] [--repeat 1] [--synthetic] [--only A|A12|A48|B3|B12|B48|B96]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

# small dense algebra (≤ 300 states): one BLAS thread is faster and does not fight the solver
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from harness.mpc import MPCController, MPCSettings, closed_loop, input_limits  # noqa: E402
from harness.mpc.adapter import preset_options  # noqa: E402

PAPER_WEEK_B_S = 20 * 3600.0  #: the paper's week of MPC with Model B at N = 3 [s]
PAPER_WEEK_A_S = 5 * 60.0  #: the paper's week with Model A: "< 5 minutes" [s]


def cache_dir() -> Path:
    d = Path(os.environ.get("HVACFMU_CACHE", Path.home() / ".cache" / "hvacfmu")) / "bench_mpc"
    d.mkdir(parents=True, exist_ok=True)
    return d


def load_dataset():
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset()
    return prepare(paths.measurements, paths.building)


def fitted(kind, dataset):
    """Model ``kind`` fitted on the dataset, cached by the data file's hash."""
    from hvacfmu.models import load_model

    path = cache_dir() / f"{kind}-{dataset.sha256[:12]}.json"
    if path.exists():
        return load_model(path), "cached"
    t0 = time.perf_counter()
    if kind == "zones":
        from hvacfmu.models.datadriven import fit_zones

        model = fit_zones(dataset)
    else:
        from hvacfmu.models.physics import fit_physics

        model = fit_physics(dataset, progress=False)
    model.save(path)
    return model, f"fitted in {time.perf_counter() - t0:.0f} s"


def week_signals(model, dataset, N):
    """Disturbances, gains (n + N rows) and the initial plant state for the first held-out week."""
    frame = dataset.frame
    week = dataset.test_weeks()[0]
    k0 = int(frame.index.get_indexer([week.start])[0])
    n = 672
    rows = frame.iloc[k0 : k0 + n + N]
    _, V = model.signals(rows)
    V = np.asarray(V, dtype=float)
    if np.isnan(V).any():  # disturbance gaps: hold the last value
        import pandas as pd

        V = pd.DataFrame(V).ffill().bfill().to_numpy()
    if hasattr(model, "gains_for_rows"):
        Q = model.gains_for_rows(rows.index)
    else:
        Q = model.gains_at(rows.index, week.season)
    if len(rows) < n + N:  # hold the last row past the end of the data
        pad = n + N - len(rows)
        V = np.vstack([V, np.repeat(V[-1:], pad, axis=0)])
        Q = np.vstack([Q, np.repeat(Q[-1:], pad, axis=0)])
    x0 = np.asarray(model.initial_state(frame, k0), dtype=float)
    return V, np.asarray(Q, dtype=float), x0, week


def synthetic_case(N):
    from harness.mpc.synthetic import random_rc_network, steady_state_at, synthetic_week

    m = random_rc_network(6, 21, 289, seed=0)
    V, Q = synthetic_week(m, 672 + N, seed=0)
    return m, V, Q, steady_state_at(m, V[0], Q[0], 21.0)


def run(label, model, u_min, u_max, settings, V, Q, x0, steps, repeat, paper_s=PAPER_WEEK_B_S):
    walls, cpus, res = [], [], None
    for _ in range(repeat):
        c = MPCController(model, u_min, u_max, settings)
        if c.reduced:
            c.pred.reduced_model(settings.rom_tol)  # one-off model reduction: set-up, not per step
        c.reset(x0=x0 if c.bilinear else None)
        t0, c0 = time.perf_counter(), time.process_time()
        res = closed_loop(c, model, x0, V, Q, steps)
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    s = res.summary()
    st = c.stats()
    wall = statistics.median(walls)
    solver = "daqp" if getattr(c._problem, "dense", None) is not None else "clarabel"
    extra = f"  solver {solver} (fallbacks {st['solver_fallbacks']})"
    if c.reduced:
        rom = c.pred.reduced_model(settings.rom_tol)
        extra += f"  ROM order {rom['order']}, Markov error {c.pred.reduced_error(c.N, settings.rom_tol):.1e}"
    print(
        f"{label:<34} week {wall:7.2f} s (CPU {statistics.median(cpus):7.2f} s)  step median {1e3 * s['step_time_median_s']:7.1f} ms "
        f"max {1e3 * s['step_time_max_s']:7.1f} ms  failures {s['failures']}  iters {s['iterations_mean']:.2f}  "
        f"cost {s['cost']:9.2f}  Σu² {s['energy_sum_u2']:8.2f}  air {s['airflow_kg'] / 1e3:7.1f} t  "
        f"viol {s['comfort_violation_Kh']:6.2f} K·h  paper/ours {paper_s / wall:7.0f}x{extra}",
        flush=True,
    )
    if c.bilinear:
        n = max(st["steps"], 1)
        print(
            f"   SCP converged (max |Δu| < {settings.tol:g} kg/s within {settings.max_iter} iterations) on "
            f"{n - st['not_converged']}/{n} steps ({100 * (1 - st['not_converged'] / n):.1f} %); "
            f"the rest applied the best iterate by merit",
            flush=True,
        )
    print(
        f"   limits: {st['projected_steps']} steps projected onto [u_min, u_max] "
        f"(largest {st['projected_max']:.3g} kg/s); applied excess {s['input_excess_max']:.1e} kg/s",
        flush=True,
    )
    return wall, s


def rom_prediction_error(model, u_min, u_max, V, Q, x0, N=96, tol=1e-3, seed=0):
    """Max output error [K] of the reduced forced response vs the full model over N steps, random airflows."""
    c = MPCController(model, u_min, u_max, MPCSettings(horizon=N, prediction="reduced", rom_tol=tol))
    pred = c.pred
    rng = np.random.default_rng(seed)
    U = rng.uniform(u_min, u_max, (N, pred.nu))
    X = pred.simulate(x0, U, V[:N], Q[:N])
    y0, beta, _ = pred.reduced_prediction(x0, V[:N], Q[:N], Xbar=X, tol=tol)
    rom = pred.reduced_model(tol)
    Ar = np.diag(rom["Ar"]) if rom["Ar"].ndim == 1 else rom["Ar"]
    xi, Y = np.zeros(rom["order"]), np.empty((N, pred.ny))
    for k in range(N):
        w = beta[k] @ U[k]
        xi = Ar @ xi + rom["Br"] @ w
        Y[k] = rom["Cr"] @ xi + rom["D0"] @ w
    Y += y0.reshape(N, pred.ny)
    return float(np.abs(Y - X[1:] @ pred.C.T).max())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=672)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--synthetic", action="store_true", help="Model B: the random 289-state RC network")
    ap.add_argument("--only", choices=["A", "A12", "A48", "B3", "B12", "B48", "B96"], action="append")
    args = ap.parse_args(argv)
    only = set(args.only or ["A", "A12", "A48", "B3", "B12", "B48", "B96"])
    print(
        f"closed-loop week of MPC, {args.steps} steps, median of {args.repeat} run(s); "
        f"2-core machine load {os.getloadavg()[0]:.1f}"
    )
    dataset = None if (args.synthetic and not only & {"A", "A12", "A48"}) else load_dataset()
    for key, N in (("A12", 12), ("A48", 48)):  # the horizons the demo and the harness run: the plant preset
        if key not in only:
            continue
        model, how = fitted("zones", dataset)
        u_min, u_max = input_limits(model, dataset.building)
        V, Q, x0, week = week_signals(model, dataset, N)
        opts = preset_options("plant", N, bilinear=False)
        run(
            f"A  N={N:<3} plant preset",
            model,
            u_min,
            u_max,
            MPCSettings(horizon=N, **opts),
            V,
            Q,
            x0,
            args.steps,
            args.repeat,
            paper_s=PAPER_WEEK_A_S,
        )
    if "A" in only:
        model, how = fitted("zones", dataset)
        u_min, u_max = input_limits(model, dataset.building)
        V, Q, x0, week = week_signals(model, dataset, 3)
        print(f"Model A: six-zone LinearZoneModel ({how}), held-out week {week.number} ({week.season})")
        for form in ("socp", "qp"):
            run(
                f"A  N=3   {form}",
                model,
                u_min,
                u_max,
                MPCSettings(horizon=3, formulation=form),
                V,
                Q,
                x0,
                args.steps,
                args.repeat,
                paper_s=PAPER_WEEK_A_S,
            )
    # Long horizons: move blocking; per-step slack (a shared slack lets one future step that needs it open
    # the limits for every step); the exact ℓ1 penalty (ρ‖ε‖₂ over n steps costs only ρ e √n for a slack e
    # at every step, so the SOCP spreads slack over long horizons: 2x the cost at N = 96);
    # N = 96: reduced-order prediction and one convex iteration per step (real-time iteration).
    cases = [
        ("B3", 3, dict()),
        ("B12", 12, preset_options("plant", 12, bilinear=True)),
        ("B48", 48, preset_options("plant", 48, bilinear=True)),
        ("B96", 96, dict(blocks="auto", max_iter=1, slack="per_step", formulation="qp")),
    ]
    cases = [c for c in cases if c[0] in only]
    if not cases:
        return 0
    model = None
    if not args.synthetic:
        try:
            model, how = fitted("physics", dataset)
            u_min, u_max = input_limits(model, dataset.building)
            desc = f"PhysicsModel of the default emulator dataset ({model.n_states} states, {len(model.inputs)} boxes, {how})"
        except Exception as exc:  # noqa: BLE001 - fall back to the synthetic network, and say so
            print(f"Model B: PhysicsModel unavailable ({type(exc).__name__}: {exc}); using the synthetic network")
            model = None
    if model is None:
        model, V, Q, x0 = synthetic_case(96)
        u_min, u_max = model.m_min, model.m_max
        desc = "synthetic random RC network (289 states, 21 boxes, 6 zones)"
    else:
        V, Q, x0, week = week_signals(model, dataset, 96)
        desc += f", held-out week {week.number} ({week.season})"
    print(f"Model B: {desc}")
    for key, N, kw in cases:
        s = MPCSettings(horizon=N, **kw)
        tag = (
            f"B  N={N:<3} {s.linearisation}/{'reduced' if (N > 24) else 'condensed'}"
            + (f" blocks {len(s.block_lengths)}" if s.blocks else "")
            + (" eps/step" if s.slack == "per_step" else "")
            + (f" {s.formulation}")
        )
        run(tag, model, u_min, u_max, s, V, Q, x0, args.steps, args.repeat)
        if N > 24:
            err = rom_prediction_error(model, u_min, u_max, V, Q, x0)
            print(f"   reduced model: 96-step output error vs the full model, random airflows: {err:.3f} K")
    return 0


if __name__ == "__main__":
    sys.exit(main())
