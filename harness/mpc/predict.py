"""Predictions affine in the airflows, condensed over the horizon, and the state estimator.

Model A (linear) and Model B (bilinear in the VAV airflows) are both written as

    x(k+1) = A x(k) + w(k) + P β_k u(k)

with ``w(k)`` the disturbance and internal-gain terms, ``P`` (nx, r) a fixed
basis of the columns the airflows can reach and ``β_k`` (r, nu) the reduced
input matrix at step k. For Model A, ``P = I`` and ``β_k = B``. For Model B,
``β_k = Σ_i e_iᵀ ⊗ Pᵀ(B_xu,i x̄(k) + B_vu,i v(k))`` with the state frozen at a
reference trajectory ``x̄``. Airflows only act on the zone air nodes, so ``r``
is the number of zones (or the rank of the stacked bilinear matrices), not the
number of states: condensing costs ``O(N² ny r nu)`` whatever the wall
discretisation, and the Markov parameters ``C A^j P`` are computed once.

With the full linearisation (``"newton"``) the state matrix becomes
``A + P Θ_k`` with ``Θ_k = Σ_i ū_i(k) Pᵀ B_xu,i`` (rank r), and the condensed
sensitivity is ``G = H (I - L)⁻¹ diag(β)`` with ``L[k, m] = Θ_k A^(k-1-m) P``
strictly lower block triangular — still only (N r)-sized algebra.

Products of a disturbance with the state (``Bxv``, e.g. wind infiltration
``coef · wind · (T_out − T_zone)``) make the state matrix time-varying but known
from the forecast: ``A_k = A + P Θv_k`` with ``Θv_k = Σ_j v_j(k) Pᵀ B_xv,j`` (the
basis ``P`` spans those rows too). The same ``L`` takes ``Θ_k = Θv_k`` (frozen)
or ``Θu_k + Θv_k`` (newton), and the free response runs with ``A_k``, so the
prediction stays exact; ``Σ_j v_j Bvv_j v`` is part of the drift ``w(k)``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from scipy import sparse

from hvacfmu.errors import ModelError


def _dense(M) -> np.ndarray:
    return M.toarray() if sparse.issparse(M) else np.asarray(M, dtype=float)


class AffinePredictor:
    """Common condensing machinery; subclasses define the model.

    Attributes
    ----------
    A : array (nx, nx)
    C : array (ny, nx)
    basis : array (nx, r)
        Orthonormal (or coordinate) basis ``P`` of the airflow-reachable subspace.
    """

    A: np.ndarray
    C: np.ndarray
    basis: np.ndarray
    nu: int
    linear: bool = False

    def __init__(self):
        self._markov = {}
        #: estimated unmodelled drift (nx,) [K per step] added to every step (offset-free MPC), or None
        self.offset = None
        #: products with a disturbance: ``Pᵀ Bxv_j`` (nv, r, nx) and ``Bvv_j`` (nv, nx, nv), or None
        self.PtBxv = None
        self.Bvv = None

    def _set_disturbance_products(self, mats):
        """Keep the equations' ``Bxv``/``Bvv`` (after :attr:`basis` is set; the basis must span ``Bxv``'s rows)."""
        Bxv, Bvv = tuple(getattr(mats, "Bxv", ()) or ()), tuple(getattr(mats, "Bvv", ()) or ())
        if Bxv and any(np.any(_dense(M)) for M in Bxv):
            self.PtBxv = np.stack([self.basis.T @ _dense(M) for M in Bxv])
            err = max(float(np.abs(_dense(M) - self.basis @ P).max()) for M, P in zip(Bxv, self.PtBxv))
            if err > 1e-9 * max(max(float(np.abs(_dense(M)).max()) for M in Bxv), 1e-300):
                raise ModelError(f"the predictor's basis reproduces the disturbance-state products only to {err:.2e}")
        if Bvv and any(np.any(_dense(M)) for M in Bvv):
            self.Bvv = np.stack([_dense(M) for M in Bvv])

    @property
    def time_varying(self) -> bool:
        """True when a disturbance multiplies the state: ``A_k = A + Σ_j v_j(k) Bxv_j`` (known from the forecast)."""
        return self.PtBxv is not None

    def theta_v(self, V):
        """``Θv_k = Σ_j v_j(k) Pᵀ Bxv_j`` (N, r, nx) for disturbances V (N, nv), or None without products."""
        if self.PtBxv is None:
            return None
        V = np.atleast_2d(V)
        return (V @ self.PtBxv.reshape(V.shape[1], -1)).reshape(V.shape[0], self.r, self.nx)

    def _products(self, V):
        """``Σ_j v_j Bvv_j v`` (..., nx) for V (..., nv) (0 without products)."""
        if self.Bvv is None:
            return 0.0
        return np.einsum("...j,jxw,...w->...x", V, self.Bvv, V)

    def _with_products(self, W, V):
        """``W`` plus the disturbance-disturbance products of V."""
        return W if self.Bvv is None else W + self._products(V)

    def state_matrix(self, u=None, v=None) -> np.ndarray:
        """``A + Σ_j v_j Bxv_j`` at disturbances v (nv,) (``A`` when v is None); bilinear kinds add the airflows."""
        if v is None or self.PtBxv is None:
            return self.A
        return self.A + self.basis @ self.theta_v(np.asarray(v, dtype=float)[None])[0]

    def _offset(self, W):
        """``W`` plus the estimated drift :attr:`offset` (every row)."""
        return W if self.offset is None else W + self.offset

    @property
    def nx(self) -> int:
        return self.A.shape[0]

    @property
    def ny(self) -> int:
        return self.C.shape[0]

    @property
    def r(self) -> int:
        return self.basis.shape[1]

    # --- to be provided -----------------------------------------------------
    def drift(self, V, Qg, Ubar=None) -> np.ndarray:
        """w(k) (N, nx): disturbance, gain and switch terms, for v (N, nv), q (N, nq).

        Switches (piecewise terms of :class:`~hvacfmu.models.equations.ModelEquations`)
        are evaluated at the reference moves ``Ubar`` (N, nu) (the airflow
        floor ``u_min`` when None): a switch is data for one convex iteration.
        """
        raise NotImplementedError

    @property
    def state_is_output(self) -> bool:
        """True when ``y = x`` (the measured outputs are the whole state)."""
        return self.C.shape[0] == self.C.shape[1] and bool(np.array_equal(self.C, np.eye(self.C.shape[0])))

    def beta(self, Xbar, V) -> np.ndarray:
        """Reduced input matrices β_k (N, r, nu) at reference states ``Xbar`` (N, nx)."""
        raise NotImplementedError

    def theta(self, Ubar) -> np.ndarray:
        """``Θu_k = Σ_i ū_i(k) Pᵀ Bxu_i`` (N, r, nx) at reference moves Ubar (N, nu) (bilinear kinds)."""
        raise NotImplementedError

    def _theta_all(self, Ubar, V) -> np.ndarray:
        """``Θu_k + Θv_k``: the state-matrix perturbation of the full linearisation at (Ubar, V)."""
        Tu, Tv = self.theta(Ubar), self.theta_v(V)
        return Tu if Tv is None else Tu + Tv

    def step(self, x, u, v, q) -> np.ndarray:
        raise NotImplementedError

    # --- simulation ---------------------------------------------------------
    def simulate(self, x0, U, V, Qg) -> np.ndarray:
        """Exact model trajectory X (N+1, nx) for moves U (N, nu)."""
        N = U.shape[0]
        X = np.empty((N + 1, self.nx))
        X[0] = x0
        for k in range(N):
            X[k + 1] = self.step(X[k], U[k], V[k], Qg[k])
        return X

    def free_trajectory(self, x0, W, V=None) -> np.ndarray:
        """Trajectory of ``x+ = A_k x + w`` (N+1, nx) for drift W (N, nx); ``A_k = A + P Θv_k`` with the
        disturbances V (N, nv) when a disturbance multiplies the state (``A`` otherwise)."""
        N = W.shape[0]
        X = np.empty((N + 1, self.nx))
        X[0] = x0
        Th = self.theta_v(V) if V is not None else None
        for k in range(N):
            X[k + 1] = self.A @ X[k] + W[k]
            if Th is not None:
                X[k + 1] += self.basis @ (Th[k] @ X[k])
        return X

    # --- condensing -----------------------------------------------------------
    def markov(self, N):
        """``Q_j = A^j P`` (N, nx, r) and the block-Toeplitz ``H`` (N ny, N r), cached per N."""
        if N not in self._markov:
            Q = np.empty((N, self.nx, self.r))
            Q[0] = self.basis
            for j in range(1, N):
                Q[j] = self.A @ Q[j - 1]
            Hj = np.einsum("yn,jnr->jyr", self.C, Q)
            H = np.zeros((N, self.ny, N, self.r))
            for i in range(N):
                H[i, :, : i + 1, :] = np.moveaxis(Hj[i::-1], 0, 1)
            self._markov[N] = (Q, H.reshape(N * self.ny, N * self.r))
        return self._markov[N]

    def sensitivity(self, beta, lengths, theta=None) -> np.ndarray:
        """Condensed output sensitivity to the blocked moves, G (N ny, n_blocks nu).

        Parameters
        ----------
        beta : array (N, r, nu)
        lengths : sequence of int, move-blocking lengths
        theta : array (N, r, nx) or None
            State-matrix perturbations ``A + P Θ_k`` (full linearisation).
        """
        N, r, nu = beta.shape
        nb = len(lengths)
        Q, H = self.markov(N)
        blk = np.repeat(np.arange(nb), lengths)
        Bm = np.zeros((N, r, nb, nu))
        Bm[np.arange(N), :, blk, :] = beta
        Bm = Bm.reshape(N * r, nb * nu)
        if theta is not None:
            L = np.zeros((N, r, N, r))
            for k in range(1, N):
                # L[k, m] = Θ_k Q_{k-1-m}, m = 0..k-1
                L[k, :, :k, :] = np.moveaxis(theta[k] @ Q[k - 1 :: -1][:k], 0, 1)
            Lm = np.eye(N * r) - L.reshape(N * r, N * r)
            Bm = np.linalg.solve(Lm, Bm)  # (scipy's solve_triangular is ~100x slower at this size)
        return H @ Bm

    def affine_prediction(self, x0, V, Qg, lengths, Xbar=None, Ubar=None, mode="frozen"):
        """Prediction ``Y ≈ y0 + G U_b`` over the horizon.

        Parameters
        ----------
        x0 : array (nx,) current state estimate
        V, Qg : arrays (N, nv), (N, nq): disturbance and internal-gain previews
        lengths : move-blocking lengths
        Xbar : array (N+1, nx) or None
            Reference trajectory for the bilinear terms (row 0 is replaced by x0).
        Ubar : array (N, nu) or None
            Reference moves (``"newton"`` only).
        mode : {"frozen", "newton"}

        Returns
        -------
        y0 : array (N ny,) [°C]
        G : array (N ny, n_blocks nu)
        """
        N = V.shape[0]
        W = self.drift(V, Qg, Ubar)
        if self.linear or mode == "frozen":
            Xr = np.repeat(x0[None], N, axis=0) if Xbar is None else np.vstack([x0[None], Xbar[1:N]])
            beta = self.beta(Xr, V)
            G = self.sensitivity(beta, lengths, theta=self.theta_v(V))
            Xf = self.free_trajectory(x0, W, V)
            return (Xf[1:] @ self.C.T).ravel(), G
        if Ubar is None:
            raise ModelError("the full linearisation needs reference moves Ubar")
        X = self.simulate(x0, Ubar, V, Qg)
        beta = self.beta(X[:N], V)
        G = self.sensitivity(beta, lengths, theta=self._theta_all(Ubar, V))
        blk = np.cumsum(np.concatenate([[0], lengths]))[:-1]
        Ub = Ubar[blk].ravel()  # Ubar is blocked (constant within blocks)
        return (X[1:] @ self.C.T).ravel() - G @ Ub, G

    # --- reduced-order forced response -------------------------------------
    def reduced_model(self, tol=1e-3):
        """Balanced truncation of the airflow-to-output map ``(A, P, C)``, cached per ``tol``.

        The order is the smallest with ``2 Σ_{i>n_r} σ_i <= tol · σ_1`` (σ the
        Hankel singular values; the left side bounds the H∞ error). A
        feedthrough ``D0 = C P - C_r B_r`` makes the first Markov parameter exact,
        so the first predicted step (the one applied) is exact.

        Returns
        -------
        dict with ``Ar, Br, Cr, D0, T`` (x ≈ T ξ), ``hsv`` and ``order``.
        """
        key = ("rom", float(tol))
        if key not in self._markov:
            A, P, C = self.A, self.basis, self.C
            Wc = scipy.linalg.solve_discrete_lyapunov(A, P @ P.T)
            Wo = scipy.linalg.solve_discrete_lyapunov(A.T, C.T @ C)

            def sqrtm_psd(W):
                w, V = np.linalg.eigh(0.5 * (W + W.T))
                return V * np.sqrt(np.clip(w, 0.0, None))

            Lc, Lo = sqrtm_psd(Wc), sqrtm_psd(Wo)
            U, hsv, Vt = np.linalg.svd(Lo.T @ Lc)
            tail = 2.0 * np.cumsum(hsv[::-1])[::-1]  # tail[i] = 2 Σ_{j>=i} σ_j
            ok = np.flatnonzero(tail <= tol * hsv[0])
            order = int(ok[0]) if ok.size else hsv.size
            order = max(order, 1)
            s_inv = 1.0 / np.sqrt(hsv[:order])
            T = Lc @ Vt[:order].T * s_inv
            Ti = (U[:, :order] * s_inv).T @ Lo.T
            Ar, Br, Cr = Ti @ A @ T, Ti @ P, C @ T
            lam, S = np.linalg.eig(Ar)
            if np.all(np.abs(lam.imag) <= 1e-12 * np.abs(lam).max()) and np.linalg.cond(S) < 1e8:
                # RC networks have real modes: diagonal A_r keeps the problem rows sparse
                S = S.real
                Si = np.linalg.inv(S)
                Ar, Br, Cr, T = lam.real, Si @ Br, Cr @ S, T @ S
            self._markov[key] = {
                "Ar": Ar,
                "Br": Br,
                "Cr": Cr,
                "D0": C @ P - Cr @ Br,
                "T": T,
                "hsv": hsv,
                "order": order,
            }
        return self._markov[key]

    def reduced_error(self, N, tol=1e-3) -> float:
        """Largest Markov-parameter error of the reduced model over N steps, relative to the largest parameter."""
        rom = self.reduced_model(tol)
        Q, _ = self.markov(N)
        H = np.einsum("yn,jnr->jyr", self.C, Q)
        Hr = np.empty_like(H)
        Ar = np.diag(rom["Ar"]) if rom["Ar"].ndim == 1 else rom["Ar"]
        M = rom["Br"].copy()
        for j in range(N):
            Hr[j] = rom["Cr"] @ M + (rom["D0"] if j == 0 else 0.0)
            M = Ar @ M
        return float(np.abs(Hr - H).max() / np.abs(H).max())

    def reduced_prediction(self, x0, V, Qg, Xbar=None, Ubar=None, mode="frozen", tol=1e-3):
        """Prediction for :class:`~harness.mpc.problem.ReducedProblem`.

        Returns
        -------
        y0 : array (N ny,) [°C]
            Free response of the exact model or, for ``"newton"``, the exact
            response at Ubar minus the reduced model's forced response at Ubar.
        beta : array (N, r, nu)
        theta : array (N, r, nr) or None
            ``Θ_k T``: state feedback of the linearised bilinear terms (``"newton"``) and of the
            disturbance-state products (``Θv_k``, both modes); None for neither.
        """
        rom = self.reduced_model(tol)
        N = V.shape[0]
        if self.linear or mode == "frozen":
            Xr = np.repeat(x0[None], N, axis=0) if Xbar is None else np.vstack([x0[None], Xbar[1:N]])
            Xf = self.free_trajectory(x0, self.drift(V, Qg, Ubar), V)
            Tv = self.theta_v(V)
            theta_r = None if Tv is None else np.einsum("krn,nb->krb", Tv, rom["T"])
            return (Xf[1:] @ self.C.T).ravel(), self.beta(Xr, V), theta_r
        if Ubar is None:
            raise ModelError("the full linearisation needs reference moves Ubar")
        X = self.simulate(x0, Ubar, V, Qg)
        beta = self.beta(X[:N], V)
        theta = np.einsum("krn,nb->krb", self._theta_all(Ubar, V), rom["T"])
        Ar = np.diag(rom["Ar"]) if rom["Ar"].ndim == 1 else rom["Ar"]
        xi = np.zeros(rom["order"])
        Yf = np.empty((N, self.ny))
        for k in range(N):
            w = beta[k] @ Ubar[k] + theta[k] @ xi
            xi = Ar @ xi + rom["Br"] @ w
            Yf[k] = rom["Cr"] @ xi + rom["D0"] @ w
        return (X[1:] @ self.C.T - Yf).ravel(), beta, theta


class LinearPredictor(AffinePredictor):
    """Linear models: ``x+ = A x + Bu u + Bv v + Bq q``, ``y = C x``.

    Built from a :class:`~hvacfmu.models.equations.ModelEquations` without
    bilinear terms or switches (Model A: ``C = I``, the state is the measured
    output; linear extended models may carry hidden states, which the
    controller then estimates with a Kalman filter).
    """

    linear = True

    def __init__(self, eq):
        super().__init__()
        self.A = _dense(eq.A)
        self.B = _dense(eq.Bu)
        self.Bv = _dense(eq.Bv)
        self.Bq = _dense(eq.Bq)
        self.C = _dense(eq.C)
        self.basis = np.eye(self.A.shape[0])
        self.nu = self.B.shape[1]
        self._G = {}
        self._set_disturbance_products(eq)

    def drift(self, V, Qg, Ubar=None):
        return self._offset(self._with_products(V @ self.Bv.T + Qg @ self.Bq.T, V))

    def beta(self, Xbar, V):
        return np.broadcast_to(self.B, (V.shape[0],) + self.B.shape)

    def step(self, x, u, v, q):
        out = self.A @ x + self.B @ u + self.Bv @ v + self.Bq @ q
        if self.time_varying or self.Bvv is not None:
            v = np.asarray(v, dtype=float)
            out = self._with_products(out, v)
            if self.time_varying:
                out = out + self.theta_v(v[None])[0] @ x  # basis = I
        return self._offset(out)

    def simulate(self, x0, U, V, Qg) -> np.ndarray:
        """Exact model trajectory X (N+1, nx) for moves U (N, nu): the input terms of all steps at once."""
        return self.free_trajectory(x0, self.drift(V, Qg) + U @ self.B.T, V)

    #: largest N*nx for which the trajectory is one product with cached (N nx)-sized matrices
    LIFTED_MAX = 512

    def free_trajectory(self, x0, W, V=None) -> np.ndarray:
        """Trajectory of ``x+ = A x + w`` (N+1, nx): ``[x0; Φ x0 + Γ vec(W)]`` for small ``N nx``
        (``Φ = [A; ...; A^N]``, ``Γ`` block lower triangular of powers of A), the recursion otherwise
        (and always when the disturbances V make the state matrix time-varying)."""
        N, nx = W.shape[0], self.nx
        if N * nx > self.LIFTED_MAX or (V is not None and self.time_varying):
            return super().free_trajectory(x0, W, V)
        key = ("lifted", N)
        if key not in self._markov:
            Q, _ = self.markov(N + 1)  # Q_j = A^j (basis = I)
            Phi = Q[1:].reshape(N * nx, nx)
            Gam = np.zeros((N, nx, N, nx))
            for i in range(N):
                for j in range(i + 1):
                    Gam[i, :, j, :] = Q[i - j]
            self._markov[key] = (Phi, Gam.reshape(N * nx, N * nx))
        Phi, Gam = self._markov[key]
        X = np.empty((N + 1, nx))
        X[0] = x0
        X[1:] = (Phi @ x0 + Gam @ W.ravel()).reshape(N, nx)
        return X

    def affine_prediction(self, x0, V, Qg, lengths, Xbar=None, Ubar=None, mode="frozen"):
        """Prediction ``Y = y0 + G U_b`` (see :meth:`AffinePredictor.affine_prediction`; exact; G cached unless
        the state matrix varies with the disturbance forecast)."""
        Xf = self.free_trajectory(x0, self.drift(V, Qg), V)
        return (Xf[1:] @ self.C.T).ravel(), self.sensitivity(self.beta(None, V), lengths, theta=self.theta_v(V))

    def sensitivity(self, beta, lengths, theta=None):
        if theta is not None:  # time-varying A_k (disturbance-state products): G changes with the forecast
            return super().sensitivity(np.ascontiguousarray(beta), lengths, theta=theta)
        key = (beta.shape[0], tuple(lengths))
        if key not in self._G:  # constant: built once per horizon and blocking
            self._G[key] = super().sensitivity(np.ascontiguousarray(beta), lengths)
        return self._G[key]


class BilinearPredictor(AffinePredictor):
    """Bilinear models: ``x+ = A x + Bu u + Bv v + Bq q + Σ_i u_i (Bxu_i x + Bvu_i v) + switches``, ``y = C x``.

    Model B (``Bu = 0``), extended models with bilinear terms (supply-air
    terms, reheat switches) and the synthetic RC networks.

    Parameters
    ----------
    mats : ModelEquations or BilinearMatrices-like
        Fields ``A, Bv, Bq, Bxu, Bvu, C`` (``Bxu``/``Bvu`` lists of nu matrices,
        dense or scipy.sparse, or empty); optional ``Bu`` (nx, nu) and ``switches``.
    rank_tol : float
        Relative eigenvalue threshold on the Gram matrix ``Σ M Mᵀ`` of the
        input terms for the airflow-reachable basis (the projection is then
        checked to reproduce every term to 1e-9 relative).
    """

    def __init__(self, mats, rank_tol=1e-13):
        super().__init__()
        self.A = _dense(mats.A)
        self.Bv = _dense(mats.Bv)
        self.Bq = _dense(mats.Bq)
        self.C = _dense(mats.C)
        nx, nv = self.A.shape[0], self.Bv.shape[1]
        nu = max(len(mats.Bxu), len(mats.Bvu), np.shape(getattr(mats, "Bu", np.zeros((nx, 0))))[1])
        Bu = getattr(mats, "Bu", None)
        Bu = np.zeros((nx, nu)) if Bu is None else _dense(Bu)
        Bxu = [sparse.csr_matrix(M) for M in mats.Bxu] or [sparse.csr_matrix((nx, nx)) for _ in range(nu)]
        Bvu = [sparse.csr_matrix(M) for M in mats.Bvu] or [sparse.csr_matrix((nx, nv)) for _ in range(nu)]
        problems = []
        if not len(Bxu) == len(Bvu) == Bu.shape[1]:
            problems.append(f"{len(Bxu)} Bxu matrices, {len(Bvu)} Bvu matrices and {Bu.shape[1]} Bu columns")
        for name, Ms, shape in (("Bxu", Bxu, (nx, nx)), ("Bvu", Bvu, (nx, nv))):
            problems += [
                f"{name}[{i}] has shape {M.shape}, expected {shape}" for i, M in enumerate(Ms) if M.shape != shape
            ]
        if self.C.shape[1] != nx or self.Bq.shape[0] != nx or self.Bv.shape[0] != nx or Bu.shape[0] != nx:
            problems.append(
                f"C {self.C.shape}, Bv {self.Bv.shape}, Bq {self.Bq.shape}, Bu {Bu.shape} do not match nx = {nx}"
            )
        if problems:
            raise ModelError("bilinear matrices: " + "; ".join(problems))
        self.nu = len(Bxu)
        self.switches = tuple(getattr(mats, "switches", ()) or ())
        Bxv = [sparse.csr_matrix(_dense(M)) for M in (getattr(mats, "Bxv", ()) or ())]
        # every column the airflows (and the disturbance-state products) can add
        S = sparse.hstack([sparse.csr_matrix(Bu)] + Bxu + Bvu + Bxv, format="csr")
        if S.nnz > 0.2 * S.shape[0] * S.shape[1]:
            S = S.toarray()
        self.basis = self._reachable_basis(S, nx, rank_tol)
        self.PtBu = self.basis.T @ Bu  # (r, nu)
        self.PtBxu = np.stack([np.asarray((M.T @ self.basis).T) for M in Bxu])  # (nu, r, nx)
        self.PtBvu = np.stack([np.asarray((M.T @ self.basis).T) for M in Bvu])  # (nu, r, nv)
        # the projection must reproduce the bilinear terms exactly
        Sd = S.toarray() if sparse.issparse(S) else S
        scale = max(float(np.abs(Sd).max(initial=0.0)), 1e-300)
        err = float(np.abs(Sd - self.basis @ (self.basis.T @ Sd)).max(initial=0.0))
        if err > 1e-9 * scale:
            raise ModelError(f"airflow-reachable basis reproduces the bilinear terms only to {err:.2e}")
        self._set_disturbance_products(mats)

    @staticmethod
    def _reachable_basis(S, nx, rank_tol):
        rows = np.flatnonzero(np.abs(S).sum(axis=1))
        if rows.size <= max(nx // 4, 1):  # coordinate basis on the nodes the airflows touch
            P = np.zeros((nx, rows.size))
            P[rows, np.arange(rows.size)] = 1.0
            return P
        gram = S @ S.T  # range of [Bu Bxu_1 ... Bvu_n] = range of S Sᵀ
        gram = gram.toarray() if sparse.issparse(gram) else np.asarray(gram)
        w, V = np.linalg.eigh(gram)
        keep = w > rank_tol * max(w.max(), 1e-300)
        return V[:, keep]

    def _switch_terms(self, U, V) -> np.ndarray:
        """Σ_s [switch s on] scale_s g_s for moves U (..., nu) and disturbances V (..., nv)."""
        out = np.zeros(np.broadcast_shapes(U.shape[:-1], V.shape[:-1]) + (self.nx,))
        for sw in self.switches:
            scale = 1.0 if sw.scale_by is None else V[..., sw.scale_by : sw.scale_by + 1]
            out = out + sw.active(U, V)[..., None] * scale * np.asarray(sw.gain, dtype=float)
        return out

    def drift(self, V, Qg, Ubar=None):
        W = self._with_products(V @ self.Bv.T + Qg @ self.Bq.T, V)
        if self.switches:
            W = W + self._switch_terms(np.zeros((V.shape[0], self.nu)) if Ubar is None else Ubar, V)
        return self._offset(W)

    # contractions as matrix products (BLAS; einsum without path optimisation was 5-10x slower here)
    def beta(self, Xbar, V):
        nu, r = self.nu, self.r
        xt = (self.PtBxu.reshape(nu * r, -1) @ Xbar.T).reshape(nu, r, -1)
        vt = (self.PtBvu.reshape(nu * r, -1) @ V.T).reshape(nu, r, -1)
        return self.PtBu[None] + (xt + vt).transpose(2, 1, 0)

    def theta(self, Ubar):
        return (Ubar @ self.PtBxu.reshape(self.nu, -1)).reshape(Ubar.shape[0], self.r, self.nx)

    def step(self, x, u, v, q):
        bu = self.PtBu + (self.PtBxu @ x + self.PtBvu @ v).T
        out = self.A @ x + self.Bv @ v + self.Bq @ q + self.basis @ (bu @ u)
        if self.time_varying or self.Bvv is not None:
            v = np.asarray(v, dtype=float)
            out = self._with_products(out, v)
            if self.time_varying:
                out = out + self.basis @ (self.theta_v(v[None])[0] @ x)
        if self.switches:
            out = out + self._switch_terms(np.asarray(u, dtype=float), np.asarray(v, dtype=float))
        return self._offset(out)

    def state_matrix(self, u=None, v=None) -> np.ndarray:
        """``A + Σ_i u_i Bxu_i (+ Σ_j v_j Bxv_j)`` at airflows u (nu,) [kg/s] (and disturbances v)."""
        A = super().state_matrix(u, v)
        return A if u is None else A + self.basis @ np.einsum("i,irn->rn", u, self.PtBxu)


def dare_doubling(A, B, Q, R, tol=1e-12, max_iter=100):
    """Stabilising solution X of ``X = Aᵀ X A - Aᵀ X B (R + Bᵀ X B)⁻¹ Bᵀ X A + Q``.

    Structured doubling algorithm: quadratic convergence, O(n³) per iteration,
    far faster than the QZ-based :func:`scipy.linalg.solve_discrete_are` for
    the ~300-state RC networks (slow wall modes need ~20 doublings).

    References
    ----------
    E. K.-W. Chu, H.-Y. Fan, W.-W. Lin, "A structure-preserving doubling
    algorithm for continuous-time algebraic Riccati equations", and its
    discrete-time form (SDA), Linear Algebra Appl. 396 (2005).
    """
    n = A.shape[0]
    Ak = np.asarray(A, dtype=float).copy()
    Gk = B @ np.linalg.solve(R, B.T)
    Hk = np.asarray(Q, dtype=float).copy()
    I = np.eye(n)
    for _ in range(max_iter):
        W = I + Gk @ Hk
        AW = np.linalg.solve(W.T, Ak.T).T  # Ak W⁻¹
        G_new = Gk + AW @ Gk @ Ak.T
        H_new = Hk + Ak.T @ Hk @ np.linalg.solve(W, Ak)
        Ak = AW @ Ak
        done = np.abs(H_new - Hk).max() <= tol * max(np.abs(H_new).max(), 1.0)
        Gk, Hk = 0.5 * (G_new + G_new.T), 0.5 * (H_new + H_new.T)
        if done:
            return Hk
    raise ModelError(f"Riccati doubling did not converge in {max_iter} iterations")


class KalmanFilter:
    """Steady-state Kalman filter on the measured zone temperatures.

    The gain is designed for the model linearised at nominal airflows
    (``A + Σ u_nom,i Bxu_i``); prediction uses the exact bilinear model with
    the applied airflows, so the estimate tracks the bilinear plant.

    Parameters
    ----------
    predictor : AffinePredictor
    u_nom : array (nu,) [kg/s]
    q_std : float [K per step]  process noise standard deviation per state
    r_std : float [K]           measurement noise standard deviation
    """

    def __init__(self, predictor, u_nom, q_std=0.05, r_std=0.05):
        self.pred = predictor
        Au = (
            predictor.state_matrix(np.asarray(u_nom, dtype=float))
            if hasattr(predictor, "state_matrix")
            else predictor.A
        )
        C = predictor.C
        Qn = q_std**2 * np.eye(predictor.nx)
        Rn = r_std**2 * np.eye(predictor.ny)
        Pp = dare_doubling(Au.T, C.T, Qn, Rn)
        S = C @ Pp @ C.T + Rn
        self.gain = np.linalg.solve(S, C @ Pp).T  # (nx, ny), a-posteriori gain
        self.x = None

    def initialise(self, y, v, q, u):
        """Steady state of the model at (u, v, q), corrected to match the measurement y [°C]."""
        Au = self.pred.state_matrix(u, v) if hasattr(self.pred, "state_matrix") else self.pred.A
        c = self.pred.step(np.zeros(self.pred.nx), u, v, q)  # affine part at x = 0
        xs = np.linalg.solve(np.eye(self.pred.nx) - Au, c)
        C = self.pred.C
        self.x = xs + np.linalg.pinv(C) @ (np.asarray(y, dtype=float) - C @ xs)
        return self.x

    def correct(self, y):
        """Measurement update with y (ny,) [°C]; returns the a-posteriori estimate."""
        self.x = self.x + self.gain @ (np.asarray(y, dtype=float) - self.pred.C @ self.x)
        return self.x

    def predict(self, u, v, q):
        """Time update with the applied airflows u [kg/s] and disturbances."""
        self.x = self.pred.step(self.x, u, v, q)
        return self.x


def model_equations(model):
    """The model's :class:`~hvacfmu.models.equations.ModelEquations`, or None if it cannot give one.

    ``model.equations()`` when the kind implements it; otherwise (or when it
    refuses, e.g. an extended model's calendar terms, which act through
    ``gains_at`` and leave the step time-invariant), for zone models with
    ``step_state`` and ``gains``, the equations found by probing
    (:func:`probe_equations`, exact or refused with both reasons).
    """
    refused = None
    if hasattr(model, "equations"):
        try:
            return model.equations()
        except NotImplementedError:
            pass
        except ModelError as exc:  # e.g. calendar terms: no time-invariant equations, but a probed step may be
            refused = exc
            eq = equations_beside_calendar(model)
            if eq is not None:
                return eq
    if hasattr(model, "step_state") and hasattr(model, "gains") and hasattr(model, "n_states"):
        try:
            return probe_equations(model)
        except ModelError as exc:
            if refused is None:
                raise
            raise ModelError(f"{refused}; probing its step instead: {exc}") from None
    if refused is not None:
        raise refused
    return None


def equations_beside_calendar(model):
    """The equations of an extended model without its calendar terms (holidays, a daylight-saving shift), or None.

    Calendar terms act on the internal gains only (``gains_at``, which the controller's gain forecast reads: the
    adapter's ``Q``), not on the step: the model's ``step_state`` at given gains is that of the model without them.
    Their ``add_equations`` refuses because time-invariant equations alone would lose the calendar (an FMU exported
    from them); for a predictor fed the calendar's gains they are exact, and :func:`check_equations` verifies it
    against the full model's step. None when the model has no calendar term, or the rest gives no equations (a
    probed step then decides, as before). Needed where the rest has a switch the probe cannot read (the diagnosis's
    on/off reheat beside a holiday, ``benchmarks/holmerge_s20.md``).
    """
    import dataclasses

    import pandas as pd

    from hvacfmu.models.equations import check_equations

    terms = tuple(getattr(model, "terms", ()) or ())
    gains = getattr(model, "gains", None)
    if not terms or not gains or not dataclasses.is_dataclass(model):
        return None
    profile = np.zeros_like(np.asarray(next(iter(gains.values())), dtype=float))
    probe = pd.DatetimeIndex(["2025-01-06 00:00"], tz="UTC")
    calendar = [
        t
        for t in terms
        if getattr(t, "calendar", False) or t.gain_adjustment(probe, profile, float(model.step)) is not None
    ]
    if not calendar:
        return None
    try:
        eq = dataclasses.replace(model, terms=tuple(t for t in terms if all(t is not c for c in calendar))).equations()
        check_equations(model, eq)
    except (ModelError, NotImplementedError):
        return None
    return eq


def probe_equations(model):
    """:class:`~hvacfmu.models.equations.ModelEquations` of a model bilinear in its inputs, by probing ``step_state``.

    Evaluates ``step_state`` on unit vectors (``nx (nu + 1) + nv (nu + 1) + nq + nu`` points; with
    products of a disturbance and the state or another disturbance, such as wind infiltration,
    ``nx nv + nv (nv + 1) / 2`` more for ``Bxv``/``Bvv``) and verifies the result with
    :func:`hvacfmu.models.equations.check_equations` on random signals.
    Piecewise terms (switches such as reheat) are not bilinear: the check fails and the model is
    refused with the difference, so a kind with such terms must implement ``equations()``.
    """
    from hvacfmu.models.equations import ModelEquations, check_equations

    nx, nu, nv = int(model.n_states), len(model.inputs), len(model.disturbances)
    nq = np.asarray(next(iter(model.gains.values()))).shape[1]

    def f(x=None, u=None, v=None, q=None):
        z = lambda a, n: np.zeros(n) if a is None else a  # noqa: E731
        return np.asarray(model.step_state(z(x, nx), z(u, nu), z(v, nv), z(q, nq)), dtype=float)

    Ix, Iu, Iv, Iq = np.eye(nx), np.eye(nu), np.eye(nv), np.eye(nq)
    A = np.column_stack([f(x=e) for e in Ix])
    Bu = np.column_stack([f(u=e) for e in Iu]) if nu else np.zeros((nx, 0))
    Bv = np.column_stack([f(v=e) for e in Iv]) if nv else np.zeros((nx, 0))
    Bq = np.column_stack([f(q=e) for e in Iq]) if nq else np.zeros((nx, 0))
    Bxu = tuple(
        np.column_stack([f(x=e, u=ei) - A[:, j] - Bu[:, i] for j, e in enumerate(Ix)]) for i, ei in enumerate(Iu)
    )
    Bvu = tuple(
        np.column_stack([f(v=e, u=ei) - Bv[:, j] - Bu[:, i] for j, e in enumerate(Iv)]) if nv else np.zeros((nx, 0))
        for i, ei in enumerate(Iu)
    )
    scale = max(1.0, float(np.abs(A).max()))
    bilinear = any(np.abs(M).max(initial=0.0) > 1e-12 * scale for M in Bxu + Bvu)
    # products with a disturbance: v_j (Bxv_j x + Bvv_j v); f(v = e_j) = Bv_j + Bvv_j[:, j], f(2 e_j) = 2 Bv_j + 4 Bvv_j[:, j]
    Bxv = tuple(
        np.column_stack([f(x=e, v=ej) - A[:, c] - Bv[:, j] for c, e in enumerate(Ix)]) for j, ej in enumerate(Iv)
    )
    Bvv = [np.zeros((nx, nv)) for _ in range(nv)]
    for j in range(nv):
        Bvv[j][:, j] = 0.5 * (f(v=2.0 * Iv[j]) - 2.0 * Bv[:, j])
        Bv[:, j] -= Bvv[j][:, j]
    for j in range(nv):
        for w in range(j + 1, nv):  # the cross term v_j v_w, kept in Bvv_j
            Bvv[j][:, w] = f(v=Iv[j] + Iv[w]) - Bv[:, j] - Bv[:, w] - Bvv[j][:, j] - Bvv[w][:, w]
    products = any(np.abs(M).max(initial=0.0) > 1e-12 * scale for M in Bxv + tuple(Bvv))
    C = np.asarray(model.output(np.eye(nx)), dtype=float).T
    eq = ModelEquations(
        step=float(model.step),
        A=A,
        Bu=Bu,
        Bv=Bv,
        Bq=Bq,
        C=C,
        inputs=tuple(model.inputs),
        disturbances=tuple(model.disturbances),
        outputs=tuple(model.outputs),
        gains=dict(model.gains),
        Bxu=Bxu if bilinear else (),
        Bvu=Bvu if bilinear else (),
        Bxv=Bxv if products else (),
        Bvv=tuple(Bvv) if products else (),
    )
    try:
        check_equations(model, eq, atol=1e-8)
    except ModelError as exc:
        raise ModelError(
            f"MPC needs the equations of the {getattr(model, 'kind', '?')} model: its step is not "
            f"bilinear in its inputs when probed ({exc}); piecewise terms such as reheat need the "
            "kind's own equations()"
        ) from None
    return eq


def make_predictor(model):
    """Predictor for a zone model, from ``model.equations()`` (any linear or bilinear kind).

    Linear equations without switches give a :class:`LinearPredictor` (one QP
    per step; with products of a disturbance and the state its ``A_k`` follows the
    forecast, still exact); bilinear terms or switches a :class:`BilinearPredictor`
    (sequential convex programming). Objects without ``equations()`` but with
    ``discrete_matrices()`` (the synthetic RC networks) are bilinear.
    """
    eq = model_equations(model)
    if eq is not None:
        if not eq.bilinear and not eq.switches:
            return LinearPredictor(eq)
        return BilinearPredictor(eq)
    if hasattr(model, "discrete_matrices"):
        return BilinearPredictor(model.discrete_matrices())
    raise ModelError(
        f"no MPC predictor for model kind {getattr(model, 'kind', type(model).__name__)!r}: "
        "it provides neither equations() nor discrete_matrices()"
    )


def state_from_outputs(pred, y0, u, v, q) -> np.ndarray:
    """State with outputs ``y0`` [°C] and the unobserved states at their steady state.

    The steady state of ``x = A(u) x + c`` restricted to the states the outputs
    do not fix (``C x = y0`` held), for inputs ``u``, disturbances ``v`` and
    gains ``q`` held — how the model FMUs start. For ``y = x`` this is ``y0``.
    """
    y0 = np.asarray(y0, dtype=float)
    if pred.state_is_output:
        return y0.copy()
    C = pred.C
    Au = pred.state_matrix(u, v) if hasattr(pred, "state_matrix") else pred.A
    c = pred.step(np.zeros(pred.nx), u, v, q)  # affine part at x = 0
    xp = np.linalg.pinv(C) @ y0
    Nb = scipy.linalg.null_space(C)
    if Nb.shape[1] == 0:
        return xp
    R = Nb.T @ (Au - np.eye(pred.nx))  # steady state of the unobserved part: Nᵀ((A - I) x + c) = 0
    z = np.linalg.lstsq(R @ Nb, -(Nb.T @ c) - R @ xp, rcond=None)[0]
    return xp + Nb @ z
