"""Modal form of a model's equations for the native FMU: diagonal dynamics, few dense columns.

A large model (Model B: 269 states) spends almost all of its native step in the
dense product ``A x``. When ``A = V diag(lam) W`` (``W = V^-1``) has real
eigenvalues, the native FMU runs in modal coordinates ``z = W x``::

    z+ = lam * z + P w,    w = [u, v, q, a, s]
    a_r = sum_t alpha_t u_i(t) src_t         (bilinear coefficients)
    xs  = S z                                (the physical states the step needs)

Each bilinear column ``Bxu_i[:, c]`` / ``Bvu_i[:, c]`` is a multiple ``alpha`` of
one representative column ``r`` (Model B: all boxes of a zone share the zone's
column, with opposite signs for ``x`` and ``v``), so its contribution is
``(W r) * sum_t alpha_t u_i src_t`` with ``src_t`` a physical state (from
``xs``) or a disturbance. ``P`` holds ``W`` times the non-zero columns of
``Bu``, ``Bv``, ``Bq``, the representatives and the switch gains; ``S`` the rows
of ``V`` of the output states and of the states the bilinear terms read. The
step costs ``nx * (1 + n_columns + n_needed)`` multiply-adds instead of ``nx^2``
(Model B: about 25 x 269 instead of 269 x 269).

The form is used only when it reproduces the physical equations: the
eigen-decomposition must reconstruct ``A`` to 1e-12 relative, and a simulation
of :data:`VERIFY_STEPS` steps with random inputs must agree with the physical
step to :data:`VERIFY_TOL` relative (checked at export); otherwise the FMU keeps
the physical form.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import breadth_first_order, minimum_spanning_tree

#: models with more states than this run in modal form (below, the dense product is cheap)
MODAL_ABOVE = 24
#: steps and relative tolerance of the export-time check of the modal form against the physical step
VERIFY_STEPS = 300
VERIFY_TOL = 1e-11


@dataclasses.dataclass(frozen=True)
class ModalForm:
    """Tables of the modal step (see the module docstring); ``None`` fields are never used.

    Attributes
    ----------
    lam : array (nx,)
        Discrete-time eigenvalues.
    V, W : array (nx, nx)
        ``A = V diag(lam) W``, ``W = V^-1`` (initialisation and state conversion).
    P : array (nx, nw)
        Input columns in modal coordinates.
    P_src : array (nw,) of int
        Index of each column's signal in ``w = [u, v, q, a, s]``.
    S_state : array (ns,) of int
        Physical states recomputed each step; ``S = V[S_state]``.
    out_xs : array (ny,) of int
        Position in ``S_state`` of each output state.
    bt_input, bt_src, bt_rep : arrays (nt,) of int
        Bilinear terms: input index, source (``>= 0``: position in ``S_state``;
        ``< 0``: disturbance ``-1 - src``), representative column.
    bt_alpha : array (nt,)
        Multiple of the representative.
    n_rep : int
    """

    lam: np.ndarray
    V: np.ndarray
    W: np.ndarray
    P: np.ndarray
    P_src: np.ndarray
    S_state: np.ndarray
    out_xs: np.ndarray
    bt_input: np.ndarray
    bt_src: np.ndarray
    bt_rep: np.ndarray
    bt_alpha: np.ndarray
    n_rep: int

    @property
    def S(self) -> np.ndarray:
        return self.V[self.S_state]


def symmetrizing_scale(A):
    """Positive ``d`` with ``diag(d) A diag(1/d)`` symmetric to 1e-13 relative, or None.

    An RC network's ``A`` (and its exponential) is of this kind: ``d = sqrt(c)``
    with the nodal capacities ``c``. ``d`` is carried along a maximum spanning
    tree of the pairs ``min(|A_ij|, |A_ji|)`` (the strongest couplings carry the
    least relative rounding), ``d_j = d_i sqrt(A_ij / A_ji)``, one connected
    block at a time; then the symmetry is checked on every entry.
    """
    A = np.asarray(A, dtype=float)
    n = A.shape[0]
    top = max(float(np.max(np.abs(A))), 1e-300)
    weight = np.minimum(np.abs(A), np.abs(A.T))
    np.fill_diagonal(weight, 0.0)
    weight[weight < 1e-9 * top] = 0.0
    tree = minimum_spanning_tree(csr_matrix(np.where(weight > 0, top / np.where(weight > 0, weight, 1.0), 0.0)))
    tree = tree + tree.T
    d = np.zeros(n)
    for root in range(n):
        if d[root]:
            continue
        order, pred = breadth_first_order(tree, root, directed=False)
        d[root] = 1.0
        for j in order[1:]:
            i = pred[j]
            ratio = A[i, j] / A[j, i]
            if not ratio > 0:
                return None
            d[j] = d[i] * np.sqrt(ratio)
    S = d[:, None] * A / d[None, :]
    if not np.all(np.isfinite(S)) or np.max(np.abs(S - S.T)) > 1e-13 * top * max(1.0, float(np.max(np.abs(S))) / top):
        return None
    return d


def real_eigen(A):
    """``(lam, V, W)`` with ``A = V diag(lam) W``, ``W = V^-1``, real and exact to 1e-12 relative, or None.

    A symmetrisable ``A`` (:func:`symmetrizing_scale`) uses the symmetric
    eigen-decomposition (orthogonal modes, well conditioned); another ``A``
    qualifies when it has real eigenvalues and a well-conditioned eigenvector
    basis.
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):  # a few hundred states: threads only slow it down on a shared machine
        return _real_eigen(np.asarray(A, dtype=float))


def _real_eigen(A):
    d = symmetrizing_scale(A)
    try:
        if d is not None:
            S = d[:, None] * A / d[None, :]
            lam, Q = np.linalg.eigh(0.5 * (S + S.T))
            V, W = Q / d[:, None], Q.T * d[None, :]
        else:
            lam, V = np.linalg.eig(A)
            if np.max(np.abs(lam.imag)) > 0 or np.max(np.abs(V.imag)) > 0:
                return None
            lam, V = lam.real, V.real
            if np.linalg.cond(V) > 1e6:
                return None
            W = np.linalg.inv(V)
    except np.linalg.LinAlgError:
        return None
    if not (np.all(np.isfinite(V)) and np.all(np.isfinite(W))):
        return None
    err = np.max(np.abs((V * lam) @ W - A))
    if err > 1e-12 * max(float(np.max(np.abs(A))), 1e-300):
        return None
    return lam, V, W


def _bilinear_columns(eq):
    """Each non-zero column of Bxu_i / Bvu_i: list of (input i, ("x" or "v", index), column vector)."""
    cols = []
    for i in range(len(eq.inputs) if eq.bilinear else 0):
        for key, mats in (("x", eq.Bxu), ("v", eq.Bvu)):
            if not mats:
                continue
            M = np.asarray(mats[i], dtype=float)
            for c in np.flatnonzero(np.any(M != 0, axis=0)):
                cols.append((i, (key, int(c)), M[:, c]))
    return cols


def _representatives(columns):
    """Group columns that are exact multiples of one another: (reps list, [(rep index, alpha)] per column)."""
    reps: list[np.ndarray] = []
    which: list[tuple[int, float]] = []
    for col in columns:
        p = int(np.argmax(np.abs(col)))
        for r_i, r in enumerate(reps):
            if r[p] != 0:
                alpha = col[p] / r[p]
                if np.array_equal(alpha * r, col):
                    which.append((r_i, float(alpha)))
                    break
        else:
            reps.append(col)
            which.append((len(reps) - 1, 1.0))
    return reps, which


def modal_form(eq, out_states) -> ModalForm | None:
    """The modal form of ``eq`` with outputs ``x[out_states]``, or None when the physical form must stay
    (also for products with a disturbance, ``Bxv``/``Bvv``, which the modal runtime does not hold)."""
    if eq.n_states <= MODAL_ABOVE or getattr(eq, "disturbance_products", False):
        return None
    eig = real_eigen(eq.A)
    if eig is None:
        return None
    lam, V, W = eig
    nu, nv, nq = len(eq.inputs), len(eq.disturbances), eq.Bq.shape[1]
    bcols = _bilinear_columns(eq)
    reps, which = _representatives([c for _, _, c in bcols])
    needed = list(out_states) + sorted({c for _, (key, c), _ in bcols if key == "x"} - set(out_states))
    pos = {s: k for k, s in enumerate(needed)}
    blocks = [np.asarray(eq.Bu, float), np.asarray(eq.Bv, float), np.asarray(eq.Bq, float)]
    blocks.append(np.column_stack(reps) if reps else np.zeros((eq.n_states, 0)))
    blocks.append(
        np.column_stack([np.asarray(s.gain, float) for s in eq.switches]) if eq.switches else blocks[-1][:, :0]
    )
    full = np.concatenate(blocks, axis=1)
    active = np.flatnonzero(np.any(full != 0, axis=0))
    n_terms = len(bcols)
    form = ModalForm(
        lam=lam,
        V=V,
        W=W,
        P=W @ full[:, active],
        P_src=active.astype(int),
        S_state=np.asarray(needed, dtype=int),
        out_xs=np.arange(len(out_states), dtype=int),
        bt_input=np.asarray([i for i, _, _ in bcols], dtype=int).reshape(n_terms),
        bt_src=np.asarray([pos[c] if key == "x" else -1 - c for _, (key, c), _ in bcols], dtype=int).reshape(n_terms),
        bt_rep=np.asarray([r for r, _ in which], dtype=int).reshape(n_terms),
        bt_alpha=np.asarray([a for _, a in which], dtype=float).reshape(n_terms),
        n_rep=len(reps),
    )
    assert full.shape[1] == nu + nv + nq + len(reps) + len(eq.switches)
    return form if verify(eq, form) else None


def signals_w(eq, form: ModalForm, u, v, q, xs):
    """The vector ``w = [u, v, q, a, s]`` of one step (numpy; mirrors the C runtime)."""
    a = np.zeros(form.n_rep)
    for i, src, rep, alpha in zip(form.bt_input, form.bt_src, form.bt_rep, form.bt_alpha):
        a[rep] += alpha * u[i] * (xs[src] if src >= 0 else v[-1 - src])
    s = np.zeros(len(eq.switches))
    for k, sw in enumerate(eq.switches):
        if sw.active(np.asarray(u), np.asarray(v)):
            s[k] = 1.0 if sw.scale_by is None else v[sw.scale_by]
    return np.concatenate([u, v, q, a, s])


def physical_step(eq, x, u, v, q):
    """One step of the physical equations (numpy)."""
    xn = eq.A @ x + eq.Bu @ u + eq.Bv @ v + eq.Bq @ q
    for i in range(len(u) if eq.bilinear else 0):
        xn = xn + u[i] * ((eq.Bxu[i] @ x if eq.Bxu else 0.0) + (eq.Bvu[i] @ v if eq.Bvu else 0.0))
    for sw in eq.switches:
        if sw.active(np.asarray(u), np.asarray(v)):
            xn = xn + (1.0 if sw.scale_by is None else v[sw.scale_by]) * np.asarray(sw.gain, float)
    return xn


def verify(eq, form: ModalForm, steps: int = VERIFY_STEPS, seed: int = 0) -> bool:
    """True when the modal step follows the physical one for ``steps`` random steps within :data:`VERIFY_TOL`."""
    rng = np.random.default_rng(seed)
    nu, nv = len(eq.inputs), len(eq.disturbances)
    table = np.asarray(next(iter(eq.gains.values())), dtype=float)
    x = np.full(eq.n_states, 20.0)
    z = form.W @ x
    worst = 0.0
    for k in range(steps):
        u, v = rng.uniform(0.0, 0.5, nu), rng.uniform(0.0, 30.0, nv)
        q = table[k % len(table)]
        xs = form.S @ z
        w = signals_w(eq, form, u, v, q, xs)
        z = form.lam * z + form.P @ w[form.P_src]
        x = physical_step(eq, x, u, v, q)
        if not np.all(np.isfinite(x)):
            return False
        worst = max(worst, float(np.max(np.abs(form.V @ z - x)) / max(1.0, float(np.max(np.abs(x))))))
    return worst <= VERIFY_TOL


def _c_ints(name, values):
    values = [int(v) for v in values] or [0]
    return f"static const int {name}[{len(values)}] = {{{','.join(map(str, values))}}};\n"


def header_tables(form: ModalForm, c_double) -> str:
    """C tables of the modal form (``HV_MODAL`` branch of ``hvacfmu_native.c``); ``c_double`` formats a double."""

    def doubles(name, values):
        values = list(values) or [0.0]
        return f"static const double {name}[{len(values)}] = {{{','.join(c_double(v) for v in values)}}};\n"

    nx, nw = form.P.shape
    out = f"#define HV_NW {nw}\n#define HV_NS {len(form.S_state)}\n#define HV_NREP {form.n_rep}\n"
    out += f"#define HV_NBT {len(form.bt_input)}\n"
    out += doubles("hv_lam", form.lam)
    out += doubles("hv_P", form.P.T.ravel())  # column-major: column k contiguous
    out += _c_ints("hv_P_src", form.P_src)
    out += doubles("hv_ST", form.S.T.ravel())  # row j: S[:, j]
    out += _c_ints("hv_S_state", form.S_state)
    out += _c_ints("hv_out_xs", form.out_xs)
    out += _c_ints("hv_bt_input", form.bt_input)
    out += _c_ints("hv_bt_src", form.bt_src)
    out += _c_ints("hv_bt_rep", form.bt_rep)
    out += doubles("hv_bt_alpha", form.bt_alpha)
    out += doubles("hv_V", form.V.ravel())  # row-major
    out += doubles("hv_W", form.W.ravel())
    return out


__all__ = ["MODAL_ABOVE", "ModalForm", "header_tables", "modal_form", "physical_step", "real_eigen", "verify"]
