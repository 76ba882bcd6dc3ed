"""Signals, regressors and the joint refit of Model A's structure plus extension terms.

The refit estimates, per zone equation,

    x_z(k+1) = θᵀ φ_z(k) + q_z[season(k), tow(k)] + e_z(k)

by least squares on the training weeks, where ``φ_z`` holds Model A's regressors
(own temperature, adjacent temperatures, own airflow, ``T_out``, ``T_supply``,
the zone's facade irradiance) and the features of the extension terms, and
``q_z`` is a free internal-gain value per season and time-of-week slot — the
seasonal profile of Model A (eq. qig_estimation of Zhou, Hu & Tomlin). The
profile is eliminated exactly by the within transformation (subtracting each
regressor's mean over the training rows of the same season and slot), so the
coefficients are those of the fixed-effects estimator; the profile is then
the slot mean of the remaining residual. Coefficients carry Model A's sign
constraints (0 ≤ a_zz ≤ 1, a_zj ≥ 0, b ≤ 0, c ≥ 0) and physical signs for the
extensions, solved as a bounded least-squares problem on the Gram matrix, plus the
dominant diagonal ``a_zj ≤ a_zz`` (:func:`dominance_pairs`): a zone's memory is its own.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.optimize import lsq_linear

from ..errors import FitError
from ..models.causes.signals import (
    MAX_DELAY,
    Signals,
    Within,
    base_solar,
    coupling_ratios,
    effective_inputs,
    shifted,
)
from ..models.causes.signals import make_signals as _make_signals
from ..models.datadriven import bound_rows
from ..models.extended import ExtendedModel, ZoneCoupling
from ..models.linear import LinearZoneModel


def base_linear(model) -> LinearZoneModel:
    """The linear part of a base model (a LinearZoneModel, or an ExtendedModel's base)."""
    if isinstance(model, ExtendedModel):
        model = model.base
    if getattr(model, "seasonal", False):
        raise FitError(
            f"diagnosis refits one Model A over the whole year; this model holds one coefficient set per season "
            f"({', '.join(model.seasons)}, fit option memory_select='season'): let diagnose fit its own base "
            "(default), or pass one season's set (model.for_season(season) saved to a file)"
        )
    if isinstance(model, LinearZoneModel):
        if model.beta is not None:
            raise FitError(
                "diagnosis refits Model A in its airflow form; this model uses the delivered-heat form "
                "(Td_/inlet columns): let diagnose fit its own base (default) or fit the base with "
                "heat='airflow' — measured discharge temperatures are then tested as the reheat / "
                "unused_input causes"
            )
        return model
    raise FitError(
        f"diagnosis needs a Model A base (kinds 'zones' or 'lumped', or 'extended'), got kind {model.kind!r}"
    )


def make_signals(dataset, model) -> Signals:
    """Collect the arrays of ``dataset`` that the diagnosis of ``model`` needs (its linear part)."""
    return _make_signals(dataset, base_linear(model))


# ----------------------------------------------------------------------------
# regressors
# ----------------------------------------------------------------------------
def term_features(sig: Signals, term, U_eff: np.ndarray) -> list:
    """Features of one term (its cause module's ``features``): list of (zone index, name, array, lower, upper)."""
    return term.features(sig, U_eff)


@dataclasses.dataclass
class ZoneDesign:
    """Design of one zone equation: names, raw columns, bounds and owners (term index or -1 for base)."""

    names: list
    X: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    owner: list
    offset: np.ndarray  #: fixed part of the prediction (base solar terms) [K per step]


def zone_design(sig: Signals, z: int, terms, U_eff=None, feats=None) -> ZoneDesign:
    """Regressor matrix (n, p) of zone ``z``'s equation under base structure + ``terms``."""
    U_eff = effective_inputs(sig, terms) if U_eff is None else U_eff
    names, cols, lo, hi, owner = [], [], [], [], []

    def add(name, col, low, high, own=-1):
        names.append(name)
        cols.append(col)
        lo.append(low)
        hi.append(high)
        owner.append(own)

    base_disturb = sig.base.disturbances
    offset = np.zeros(len(sig.Y))
    add("a_self", sig.Y[:, z], 0.0, 1.0)
    for j in sig.neighbours[z]:
        add(f"a[{sig.zones[j]}]", sig.Y[:, j], 0.0, 1.0)
    # airflow cools (b <= 0) with or without a supply_air_bilinear term: with one, b·u is the part of the
    # airflow's effect the bilinear product does not explain; a b > 0 there (airflow that warms the zone) is
    # reheat's physics, screened as its own cause. The screen (fast path: the current design plus the term's
    # columns) keeps this bound, so the refit must too: a freedom the screen never charged for is no gain
    # of the bilinear term's (benchmarks/diagnosis_bsign_s14.md).
    add("b", U_eff[:, z], -np.inf, 0.0)
    for c in base_disturb:
        if c in ("T_out", "T_supply"):
            add(f"c[{c}]", sig.V[c], 0.0, np.inf)
        elif c.startswith("I_") and c in sig.V and base_solar(sig, z, c[2:]) != 0.0:
            # solar paths the base model uses are part of its structure (refitted, c >= 0)
            add(f"c[{c}]", sig.V[c], 0.0, np.inf)
    for ti, t in enumerate(terms):
        fl = feats[ti] if feats is not None else term_features(sig, t, U_eff)
        for zz, name, col, low, high in fl:
            if zz == z:
                add(name, col, low, high, ti)
    return ZoneDesign(names, np.column_stack(cols), np.array(lo), np.array(hi), owner, offset)


# ----------------------------------------------------------------------------
# within transform and bounded least squares
# ----------------------------------------------------------------------------
@dataclasses.dataclass
class LSResult:
    theta: np.ndarray
    rss: float
    n: int
    cov: np.ndarray
    sigma2: float


#: Slack of the dominance constraint ``a_zj <= a_zz`` (a violation below it is not re-solved).
DOMINANCE_TOL = 1e-9


def dominance_pairs(names) -> list:
    """Column pairs ``(own, neighbour)`` of a zone design for ``a[neighbour] <= a_self``.

    Why (RC physics): a zone's one-step row of A is ``I − Δt C⁻¹K`` to first order, so ``a_zz ≈ 1 − Δt K_zz / C_z``
    and ``a_zj = Δt k_zj / C_z``; over a step shorter than the zone's own time constant every coupling is
    smaller than the zone's memory, and the exact discretisation ``exp(−Δt C⁻¹K)`` has a positive spectrum (a
    pair of equal zones: ``a_zz − a_zj`` is its fast eigenvalue, ``> 0``). One-step least squares does not
    know this when a neighbour's temperature is nearly collinear with the zone's own (mirror twins,
    correlation 0.9999): it may put the zone's memory on the twin (``a_zz = 0``, ``a_zj = 0.7``), a state
    matrix with negative eigenvalues whose pair, simulated together, feeds its own errors
    (``benchmarks/twins_s18.md``).
    """
    names = list(names)
    if "a_self" not in names:
        return []
    i = names.index("a_self")
    return [(i, j) for j, nm in enumerate(names) if isinstance(nm, str) and nm.startswith("a[")]


def bounded_ls(Xw: np.ndarray, yw: np.ndarray, lower, upper, dof_extra: int = 0, dominance=()) -> LSResult:
    """min ‖Xw θ − yw‖² subject to lower ≤ θ ≤ upper, solved on the Cholesky factor of the Gram matrix.

    ``dominance``: column pairs ``(i, j)`` with ``θ_j ≤ θ_i`` (:func:`dominance_pairs`); a bounded solution
    that violates one is re-solved as a quadratic programme (Clarabel) with every pair's constraint, the
    constrained optimum of the convex problem (the same solution when no pair binds).
    ``cov`` is the unconstrained asymptotic covariance σ² (XᵀX)⁻¹ with σ² the residual
    variance after ``dof_extra`` further degrees of freedom (the group means).
    """
    n, p = Xw.shape
    ss = (Xw * Xw).sum(axis=0)
    zero = ~(ss > 1e-300)  # a regressor that is zero on every row (e.g. in one fold): not identified
    scale = np.where(zero, 1.0, np.sqrt(np.where(zero, 1.0, ss)))
    Xs = Xw / scale
    G = Xs.T @ Xs
    r = Xs.T @ yw
    ridge = 1e-10 * np.trace(G) / max(p, 1)
    try:
        L = np.linalg.cholesky(G + ridge * np.eye(p))
    except np.linalg.LinAlgError:
        L = np.linalg.cholesky(G + 1e-6 * np.eye(p))
    rhs = np.linalg.solve(L, r)
    lo, hi = np.asarray(lower) * scale, np.asarray(upper) * scale
    free = np.linalg.solve(L.T, rhs)
    if np.all(free >= lo) and np.all(free <= hi):
        ts = free
    else:
        sol = lsq_linear(L.T, rhs, bounds=(lo, hi), method="bvls", lsmr_tol=None)
        ts = sol.x
    pairs = [(i, j) for i, j in dominance if ts[j] / scale[j] > ts[i] / scale[i] + DOMINANCE_TOL]
    if pairs:
        ts = _dominant_qp(G + ridge * np.eye(p), r, lo, hi, scale, list(dominance), ts)
    theta = ts / scale
    res = yw - Xw @ theta
    rss = float(res @ res)
    dof = max(n - p - dof_extra, 1)
    sigma2 = rss / dof
    Ginv = np.linalg.inv(G + ridge * np.eye(p))
    cov = sigma2 * Ginv / np.outer(scale, scale)
    if zero.any():  # its variance is unbounded; said so without an overflow in the division
        cov[zero, :] = 0.0
        cov[:, zero] = 0.0
        cov[zero, zero] = np.inf
    return LSResult(theta, rss, n, cov, sigma2)


def _dominant_qp(G, r, lo, hi, scale, pairs, fallback) -> np.ndarray:
    """min ½ tsᵀ G ts − rᵀ ts over the scaled coefficients, within the bounds and ``θ_j ≤ θ_i`` for every pair."""
    import qpsolvers
    import scipy.sparse

    p = G.shape[0]
    rows, h = [], []
    for i, j in pairs:  # θ_j − θ_i ≤ 0, θ = ts / scale
        g = np.zeros(p)
        g[j], g[i] = 1.0 / scale[j], -1.0 / scale[i]
        rows.append(g)
        h.append(0.0)
    more_rows, more_h = bound_rows(lo, hi)
    Gm = np.array(rows + more_rows)
    h += more_h
    norm = max(float(np.max(np.abs(np.diag(G)))), 1e-300)
    try:
        ts = qpsolvers.solve_qp(
            scipy.sparse.csc_matrix(0.5 * (G + G.T) / norm),
            -r / norm,
            G=scipy.sparse.csc_matrix(Gm),
            h=np.array(h, float),
            solver="clarabel",
        )
    except Exception:  # noqa: BLE001 - a solver failure: keep the bounded solution, said by the plausibility check
        ts = None
    if ts is None or not np.all(np.isfinite(ts)):
        return fallback
    return np.clip(ts, lo, hi)


# ----------------------------------------------------------------------------
# joint refit -> ExtendedModel
# ----------------------------------------------------------------------------
@dataclasses.dataclass
class StructureFit:
    """Result of :func:`fit_structure`: the model, and per zone its LS result and design names."""

    model: ExtendedModel
    zone_ls: list
    zone_names: list
    n: int
    resid: np.ndarray  # (n_rows, nz) within residuals on training rows


@dataclasses.dataclass
class Prepared:
    """What :func:`fit_structure` builds from ``sig`` and ``terms`` alone, whatever its rows: the effective
    airflows, the terms' features and the zones' (untransformed) designs, filled as they are needed. Shared by
    the refits of the cross-validation folds (one set of columns, fold after fold on other rows)."""

    U_eff: np.ndarray
    feats: list
    designs: dict = dataclasses.field(default_factory=dict)


def prepare_structure(sig: Signals, terms) -> Prepared:
    """The fold-independent part of :func:`fit_structure` for ``terms`` on ``sig``."""
    U_eff = effective_inputs(sig, terms)
    return Prepared(U_eff, [term_features(sig, t, U_eff) for t in terms])


def fit_structure(
    sig: Signals, terms, rows=None, within: Within | None = None, only_zones=None, prepared: Prepared | None = None
) -> StructureFit:
    """Refit base structure + ``terms`` jointly on the training rows; returns an ExtendedModel.

    ``only_zones`` (zone indices): fit only the equations of the coupled blocks holding them
    (cross-validation of a local term, where every other zone is measured); the other zones'
    equations are then left at zero and must not be simulated. ``prepared``: the result of
    :func:`prepare_structure` for the same ``sig`` and ``terms`` (reused by several refits).
    """
    rows = sig.rows("train") if rows is None else rows
    if len(rows) < 50:
        raise FitError(f"only {len(rows)} usable one-step rows in the training weeks; need at least 50")
    W = within or Within(sig.group, rows)
    prepared = prepare_structure(sig, terms) if prepared is None else prepared
    U_eff, feats = prepared.U_eff, prepared.feats
    base = sig.base
    nz = sig.nz
    A = np.zeros((nz, nz))
    B = np.zeros_like(base.B)
    C = np.zeros_like(base.C)
    coefs = [dict() for _ in terms]
    stds = [dict() for _ in terms]
    lss, names = [None] * nz, [None] * nz
    resid = np.zeros((len(rows), nz))
    target_next = np.vstack([sig.Y[1:], np.full((1, nz), np.nan)])
    yhat_wo_q = np.zeros((len(sig.Y), nz))
    for block in coupled_blocks(sig, terms):
        if only_zones is not None and not set(block) & set(only_zones):
            continue
        bf = fit_block(sig, W, block, terms, U_eff, feats, target_next, prepared.designs)
        for z in block:
            D = bf.designs[z]
            th = bf.theta_of(z)
            lss[z] = bf.zone_ls[z]
            names[z] = D.names
            resid[:, z] = bf.resid[z]
            with np.errstate(invalid="ignore"):
                yhat_wo_q[:, z] = D.X @ th + D.offset
            sd = bf.std_of(z)
            for k, (nm, own) in enumerate(zip(D.names, D.owner)):
                if own >= 0:
                    coefs[own][nm] = float(th[k])
                    stds[own][nm] = float(sd[k])
                elif nm == "a_self":
                    A[z, z] = th[k]
                elif nm.startswith("a["):
                    A[z, sig.zones.index(nm[2:-1])] = th[k]
                elif nm == "b":
                    B[z, z] = th[k]
                else:
                    C[z, base.disturbances.index(nm[2:-1])] = th[k]
    gains = _gains_from_fit(sig, rows, target_next - yhat_wo_q, W)
    new_base = dataclasses.replace(
        base,
        A=A,
        B=B,
        C=C,
        gains=gains,
        meta={**{k: v for k, v in base.meta.items() if k != "uncertainty"}, "refit": "diagnosis within-LS"},
    )
    new_terms = [_with_coefs(sig, t, coefs[i], stds[i], sig.zones) for i, t in enumerate(terms)]
    model = ExtendedModel(base=new_base, terms=tuple(new_terms))
    return StructureFit(model, lss, names, len(rows), resid)


def coupled_blocks(sig: Signals, terms) -> list:
    """Zone index groups whose equations share a parameter (zones joined by a coupling term)."""
    parent = list(range(sig.nz))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for t in terms:
        if isinstance(t, ZoneCoupling):
            a, b = find(sig.zones.index(t.zone_a)), find(sig.zones.index(t.zone_b))
            parent[a] = b
    blocks = {}
    for i in range(sig.nz):
        blocks.setdefault(find(i), []).append(i)
    return sorted(blocks.values())


@dataclasses.dataclass
class BlockFit:
    """Joint least squares of several zone equations with shared term parameters."""

    designs: dict
    keys: list
    cols: dict  # zone -> column keys of its design
    theta: np.ndarray
    sd: np.ndarray
    zone_ls: dict  # zone -> LSResult-like (rss, n, sigma2) for LR tests
    resid: dict

    def theta_of(self, z):
        return np.array([self.theta[self.keys.index(k)] for k in self.cols[z]])

    def std_of(self, z):
        return np.array([self.sd[self.keys.index(k)] for k in self.cols[z]])


def fit_block(sig: Signals, W: Within, block, terms, U_eff, feats, target_next, cache=None) -> BlockFit:
    """Fit the equations of the zones in ``block`` jointly (stacked within-transformed rows).

    ``cache``: a dict of zone designs under the same ``terms`` (filled with those it lacks).
    """
    cache = {} if cache is None else cache
    for z in block:
        if z not in cache:
            cache[z] = zone_design(sig, z, terms, U_eff, feats)
    designs = {z: cache[z] for z in block}
    keys, lo, hi, cols = [], [], [], {}
    for z in block:
        D = designs[z]
        cols[z] = []
        for nm, own, lw, up in zip(D.names, D.owner, D.lower, D.upper):
            key = (own, nm) if own >= 0 else (-1, z, nm)
            cols[z].append(key)
            if key not in keys:
                keys.append(key)
                lo.append(lw)
                hi.append(up)
    n = len(W.rows)
    X = np.zeros((n * len(block), len(keys)))
    y = np.empty(n * len(block))
    for i, z in enumerate(block):
        D = designs[z]
        Xw = W(D.X)
        for j, key in enumerate(cols[z]):
            X[i * n : (i + 1) * n, keys.index(key)] = Xw[:, j]
        y[i * n : (i + 1) * n] = W(target_next[:, z] - D.offset)
    dom = []
    for z in block:  # the block's columns of each zone's own and adjacent temperatures
        dom += [(keys.index(cols[z][i]), keys.index(cols[z][j])) for i, j in dominance_pairs(designs[z].names)]
    ls = bounded_ls(X, y, lo, hi, dof_extra=W.n_groups * len(block), dominance=dom)
    sd = np.sqrt(np.maximum(np.diag(ls.cov), 0.0))
    res = y - X @ ls.theta
    zone_ls, resid = {}, {}
    for i, z in enumerate(block):
        r = res[i * n : (i + 1) * n]
        resid[z] = r
        rss = float(r @ r)
        zone_ls[z] = LSResult(None, rss, n, None, rss / max(n - len(cols[z]) - W.n_groups, 1))
    return BlockFit(designs, keys, cols, ls.theta, sd, zone_ls, resid)


def _gains_from_fit(sig, rows, r, W: Within) -> dict:
    """Season profiles (n_tow, nz): slot means of the residual without internal gains."""
    means = W.means(r)  # (n_groups, nz)
    out = {}
    for si, s in enumerate(sig.seasons):
        prof = np.full((sig.n_tow, sig.nz), np.nan)
        sel = (W.groups // sig.n_tow) == si
        prof[W.groups[sel] % sig.n_tow] = means[sel]
        out[s] = prof
    filled = {}
    for s, prof in out.items():
        if np.isnan(prof).all():
            continue
        filled[s] = _fill_cyclic(prof)
    if not filled:
        raise FitError("no training data to estimate internal gains")
    fallback = np.mean(list(filled.values()), axis=0)
    for s in sig.base.gains:  # keep every season the base model knows
        if s not in filled:
            filled[s] = fallback
    return filled


def _fill_cyclic(prof):
    """Fill NaN slots by linear interpolation along the (cyclic) week."""
    n = prof.shape[0]
    out = prof.copy()
    x = np.arange(n)
    for j in range(prof.shape[1]):
        ok = np.isfinite(prof[:, j])
        if ok.all():
            continue
        xs = np.concatenate([x[ok] - n, x[ok], x[ok] + n])
        ys = np.tile(prof[ok, j], 3)
        out[~ok, j] = np.interp(x[~ok], xs, ys)
    return out


def _with_coefs(sig, t, coefs: dict, stds: dict, zones):
    return t.with_fit(sig, coefs, stds)


__all__ = [
    "MAX_DELAY",
    "Prepared",
    "Signals",
    "StructureFit",
    "Within",
    "base_linear",
    "base_solar",
    "bounded_ls",
    "dominance_pairs",
    "coupled_blocks",
    "coupling_ratios",
    "effective_inputs",
    "fit_block",
    "fit_structure",
    "make_signals",
    "prepare_structure",
    "shifted",
    "term_features",
    "zone_design",
]
