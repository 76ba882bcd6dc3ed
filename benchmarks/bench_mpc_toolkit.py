"""Benchmark: our MPC against CasADi + IPOPT on the identical per-step problem (issue 18 p.6).

Needs CasADi (``pip install -e '.[bench]'``).

Both solve, at every step of a closed-loop week (the model as its own plant,
exact state, perfect forecast), the same problem built from the same
``model.equations()`` matrices:

    min  Σ_k ||u(k)||²  +  ρ Σ eps  +  c Σ s
    s.t. model dynamics (linear or bilinear), u held over the move blocks,
         u_min - eps <= u(k) <= u_max + eps,  eps >= 0,  u(k) >= 0,
         T_min - s <= y(k) <= T_max + s,  s >= 0

(the exact ℓ1-penalty form, ``formulation="qp"``: smooth for IPOPT). CasADi's
NLP is built once (single shooting, parameters: state, disturbance and gain
previews) and warm-started with the previous step's primal and dual values;
one thread. The plant follows our move; on the compared steps both start
from the same state, their first moves must agree within ``--move-tol``
[kg/s] and the exact costs of their plans (one function,
:meth:`~harness.mpc.controller.MPCController.merit`: the cost on the model's
own trajectory with the slacks each plan needs) within ``--cost-tol``
(relative); the solvers' own objective values are printed beside it (each
carries its solver's tolerance: 1e-9 K of band violation accepted is 1e-5
of cost under the 1e4 comfort penalty). Prints week times (CPU time of the per-step
calls, the fair measure on a shared machine; wall time beside it), the
ratio, our QP solver (``--solver``, default ``auto``: the dense active set
DAQP for these QPs, clarabel if it is not installed), the largest
differences and any failure.

Model A (six-zone ``fit_zones``) at N = 3 and N = 12 runs the whole week on
both; Model B (``fit_physics``, 269 states, bilinear, Newton SCP) at N = 12
runs IPOPT on ``--b-steps`` evenly spaced steps and extrapolates its week
time (said in the output).

Usage::

    python3 benchmarks/bench_mpc_toolkit.py [--steps 672] [--only A3 A12 B12] [--b-steps 12] [--solver auto]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_mpc import fitted, load_dataset, week_signals  # noqa: E402

from harness.mpc import MPCController, MPCSettings, input_limits  # noqa: E402
from harness.mpc.predict import model_equations  # noqa: E402


class CasadiMPC:
    """The per-step problem of :class:`~harness.mpc.controller.MPCController` (``formulation="qp"``) in CasADi + IPOPT."""

    def __init__(self, eq, u_min, u_max, settings: MPCSettings):
        try:
            import casadi as ca
        except ImportError:
            raise SystemExit(
                "this benchmark compares with CasADi + IPOPT: install it with  pip install -e '.[bench]'  "
                "(or pip install casadi)"
            ) from None

        s = settings
        lengths = np.asarray(s.block_lengths)
        N, nb = int(lengths.sum()), len(lengths)
        nx, nu, nv = eq.n_states, len(eq.inputs), len(eq.disturbances)
        nq, ny = eq.Bq.shape[1], eq.C.shape[0]
        per_step = s.slack == "per_step"
        ne = nb * nu if per_step else nu
        Ub, eps, sl = ca.MX.sym("U", nb * nu), ca.MX.sym("eps", ne), ca.MX.sym("s", N * ny)
        x0, Vp, Qp = ca.MX.sym("x0", nx), ca.MX.sym("V", N * nv), ca.MX.sym("Q", N * nq)
        dm = lambda M: ca.DM(np.asarray(M.toarray() if hasattr(M, "toarray") else M, dtype=float))  # noqa: E731
        A, Bu, Bv, Bq, C = (dm(M) for M in (eq.A, eq.Bu, eq.Bv, eq.Bq, eq.C))
        from scipy import sparse

        Bxu = [ca.DM(sparse.csc_matrix(M)) for M in eq.Bxu]
        Bvu = [ca.DM(sparse.csc_matrix(M)) for M in eq.Bvu]
        # products with a disturbance (wind infiltration: A_k = A + sum_j v_j Bxv_j), exact as in harness.mpc
        Bxv = [ca.DM(sparse.csc_matrix(M)) for M in getattr(eq, "Bxv", ())]
        Bvv = [ca.DM(sparse.csc_matrix(M)) for M in getattr(eq, "Bvv", ())]
        blk = np.repeat(np.arange(nb), lengths)
        x, Y, cost = x0, [], 0
        for k in range(N):
            u = Ub[blk[k] * nu : (blk[k] + 1) * nu]
            v, q = Vp[k * nv : (k + 1) * nv], Qp[k * nq : (k + 1) * nq]
            xn = ca.mtimes(A, x) + ca.mtimes(Bu, u) + ca.mtimes(Bv, v) + ca.mtimes(Bq, q)
            for i in range(len(Bxu)):
                xn = xn + u[i] * (ca.mtimes(Bxu[i], x) + ca.mtimes(Bvu[i], v))
            for j in range(len(Bxv)):
                xn = xn + v[j] * ca.mtimes(Bxv[j], x)
            for j in range(len(Bvv)):
                xn = xn + v[j] * ca.mtimes(Bvv[j], v)
            x = xn
            Y.append(ca.mtimes(C, x))
            cost = cost + ca.sumsqr(u)
        Y = ca.vertcat(*Y)
        w_eps = np.repeat(lengths, nu).astype(float) if per_step else np.ones(nu)
        cost = cost + s.rho * ca.dot(ca.DM(w_eps), eps) + s.comfort_penalty * ca.sum1(sl)
        E = eps if per_step else ca.repmat(eps, nb, 1)
        g = ca.vertcat(Y - sl, Y + sl, Ub - E, Ub + E)
        self.lbg = np.concatenate(
            [np.full(N * ny, -np.inf), np.full(N * ny, s.T_min), np.full(nb * nu, -np.inf), np.tile(u_min, nb)]
        )
        self.ubg = np.concatenate(
            [np.full(N * ny, s.T_max), np.full(N * ny, np.inf), np.tile(u_max, nb), np.full(nb * nu, np.inf)]
        )
        nz = nb * nu + ne + N * ny
        self.lbx = np.zeros(nz)  # U >= 0 (u_floor), eps >= 0, s >= 0
        self.ubx = np.full(nz, np.inf)
        opts = {
            "ipopt.print_level": 0,
            "print_time": False,
            "ipopt.tol": 1e-9,
            "ipopt.sb": "yes",
            "ipopt.constr_viol_tol": 1e-9,
            "ipopt.warm_start_init_point": "yes",
            "ipopt.warm_start_bound_push": 1e-9,
            "ipopt.warm_start_mult_bound_push": 1e-9,
            "ipopt.mu_init": 1e-6,
        }
        self.solver = ca.nlpsol(
            "mpc", "ipopt", {"x": ca.vertcat(Ub, eps, sl), "p": ca.vertcat(x0, Vp, Qp), "f": cost, "g": g}, opts
        )
        self.N, self.nb, self.nu, self.lengths = N, nb, nu, lengths
        self.z0 = np.concatenate([np.tile(u_min, nb), np.zeros(ne + N * ny)])
        self.lam_x = self.lam_g = None

    def plan(self, x0, V, Q):
        """Planned moves (N, nu), objective, solver success and (CPU, wall) time [s]."""
        p = np.concatenate([x0, V[: self.N].ravel(), Q[: self.N].ravel()])
        kw = {} if self.lam_x is None else {"lam_x0": self.lam_x, "lam_g0": self.lam_g}
        t0, c0 = time.perf_counter(), time.process_time()
        r = self.solver(x0=self.z0, p=p, lbx=self.lbx, ubx=self.ubx, lbg=self.lbg, ubg=self.ubg, **kw)
        dt = (time.process_time() - c0, time.perf_counter() - t0)
        ok = bool(self.solver.stats()["success"])
        z = np.asarray(r["x"]).ravel()
        if ok:
            self.z0, self.lam_x, self.lam_g = z, np.asarray(r["lam_x"]).ravel(), np.asarray(r["lam_g"]).ravel()
        Ub = z[: self.nb * self.nu].reshape(self.nb, self.nu)
        return np.repeat(Ub, self.lengths, axis=0), float(r["f"]), ok, dt


def compare(label, model, u_min, u_max, settings, V, Q, x0, steps, ipopt_steps, move_tol, cost_tol):
    """Lockstep week: ours every step, IPOPT on ``ipopt_steps`` (indices), same state."""
    ours = MPCController(model, u_min, u_max, settings)
    eq = model_equations(model)
    t0 = time.perf_counter()
    tk = CasadiMPC(eq, u_min, u_max, settings)
    build = time.perf_counter() - t0
    N = ours.N
    x = np.asarray(x0, dtype=float)
    t_ours, t_tk, dmove, dcost, dexact, fails_tk, fails_ours = [], [], [], [], [], 0, 0  # times: (CPU, wall) [s]
    compared = set(int(k) for k in ipopt_steps)
    for k in range(steps):
        Vk, Qk = V[k : k + N], Q[k : k + N]
        t, c = time.perf_counter(), time.process_time()
        plan = ours.plan(x, Vk, Qk)
        t_ours.append((time.process_time() - c, time.perf_counter() - t))
        ours._plan = plan if plan.found else None  # warm start of the next step's SCP
        fails_ours += not plan.found
        u = np.clip(plan.U[0], u_min, u_max)
        if k in compared:
            U_tk, f_tk, ok, dt = tk.plan(x, Vk, Qk)
            t_tk.append(dt)
            fails_tk += not ok
            if ok and plan.found:
                dmove.append(float(np.max(np.abs(U_tk[0] - plan.U[0]))))
                # each solver's own objective value (IPOPT's on the exact bilinear trajectory, ours its merit)
                f_ours = plan.merit if np.isfinite(getattr(plan, "merit", np.nan)) else plan.obj
                dcost.append((f_ours - f_tk) / max(abs(f_tk), 1e-12))
                # both plans' exact cost, one function: the model's own trajectory, the slacks each plan needs
                # (no solver tolerance: 1e-9 K of band violation accepted by a solver is 1e-5 of cost each)
                m_ours = ours.merit(plan.U, ours.pred.simulate(x, plan.U, Vk, Qk))
                m_tk = ours.merit(U_tk, ours.pred.simulate(x, U_tk, Vk, Qk))
                dexact.append((m_ours - m_tk) / max(abs(m_tk), 1e-12))
        x = model.step_state(x, u, V[k], Q[k])
    week_ours = np.sum(t_ours, axis=0) * 672 / steps  # (CPU, wall)
    week_tk = np.mean(t_tk, axis=0) * 672 if t_tk else np.full(2, np.nan)
    extrap = "" if len(t_tk) == steps == 672 else f" (IPOPT extrapolated from {len(t_tk)} steps)"
    problem = ours._problem
    solver = "daqp" if getattr(problem, "dense", None) is not None else "clarabel"
    fallbacks = int(getattr(problem, "n_solver_fallbacks", 0))
    dm = max(dmove, default=float("nan"))
    dc = max(dcost, key=abs, default=float("nan"))
    de = max(dexact, key=abs, default=float("nan"))
    agree = dm <= move_tol and abs(de) <= cost_tol and fails_tk == 0 and fails_ours == 0
    print(
        f"{label:<10} ours ({solver}) {week_ours[0]:8.3f} s/week CPU ({week_ours[1]:.3f} wall)  CasADi+IPOPT "
        f"{week_tk[0]:9.2f} s/week CPU ({week_tk[1]:.2f} wall){extrap}  ratio {week_tk[0] / week_ours[0]:6.1f}x CPU "
        f"({week_tk[1] / week_ours[1]:.1f}x wall)  (IPOPT build {build:.1f} s)",
        flush=True,
    )
    print(
        f"{'':<10} first moves max |Δu| {dm:.1e} kg/s (tol {move_tol:g}), exact cost of the plans (ours - IPOPT)/"
        f"IPOPT {de:+.1e} (tol {cost_tol:g}; solvers' own objectives {dc:+.1e}) on {len(dmove)} steps; "
        f"failures ours {fails_ours} (solver fallbacks "
        f"{fallbacks}), IPOPT {fails_tk}  "
        f"{'AGREE' if agree else 'DISAGREE'}",
        flush=True,
    )
    return agree


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=672)
    ap.add_argument("--only", nargs="+", choices=["A3", "A12", "B12"], default=["A3", "A12", "B12"])
    ap.add_argument("--b-steps", type=int, default=12, help="steps IPOPT solves for Model B (extrapolated)")
    ap.add_argument("--solver", choices=["auto", "clarabel", "daqp"], default="auto", help="our QP solver")
    ap.add_argument("--move-tol", type=float, default=5e-4, help="[kg/s] first-move agreement")
    ap.add_argument(
        "--cost-tol",
        type=float,
        default=1e-4,
        help="relative agreement of the plans' exact costs (MPCController.merit of each plan on the model)",
    )
    args = ap.parse_args(argv)
    print(
        f"our MPC vs CasADi + IPOPT, identical per-step problem (qp form), {args.steps} steps; "
        f"machine load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"
    )
    dataset = load_dataset()
    ok = True
    for key in args.only:
        kind = "zones" if key.startswith("A") else "physics"
        model, _ = fitted(kind, dataset)
        u_min, u_max = input_limits(model, dataset.building)
        N = int(key[1:])
        V, Q, x0, week = week_signals(model, dataset, N)
        if kind == "zones":
            settings = MPCSettings(horizon=N, formulation="qp", solver=args.solver)
            idx = np.arange(args.steps)
        else:
            settings = MPCSettings(
                horizon=N,
                formulation="qp",
                blocks="auto",
                linearisation="newton",
                slack="per_step",
                tol=1e-6,
                solver=args.solver,
            )
            idx = np.linspace(0, args.steps - 1, args.b_steps).round().astype(int)
        ok &= compare(
            f"{'Model ' + key[0]} N={N}",
            model,
            u_min,
            u_max,
            settings,
            V,
            Q,
            x0,
            args.steps,
            idx,
            args.move_tol,
            args.cost_tol,
        )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
