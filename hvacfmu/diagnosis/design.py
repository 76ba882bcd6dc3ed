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
extensions, solved as a bounded least-squares problem on the Gram matrix.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
from scipy.optimize import lsq_linear

from ..errors import DataError, FitError
from ..models.extended import (
    ActuationDelay,
    ExtendedModel,
    InternalGainSchedule,
    Reheat,
    SolarGain,
    SupplyAirBilinear,
    ThermalMass,
    ZoneCoupling,
    dst_active,
    ema_series,
    reheat_feature,
)
from ..models.linear import LinearZoneModel
from ..timeutil import n_time_of_week, time_of_week

MAX_DELAY = 4  #: largest actuation delay tested [steps]


@dataclasses.dataclass(frozen=True, eq=False)
class Signals:
    """Everything the regressions read, as numpy arrays on the model step.

    Attributes
    ----------
    index : DatetimeIndex
    zones : tuple of str
        Output names of the base model.
    Y : array (n, nz) [°C]
        Measured outputs.
    U : array (n, nz) [kg/s]
        Controlled inputs (zone airflows).
    V : dict str -> array (n,)
        ``T_out``, ``T_supply`` [°C], ``I_<o>`` [W/m²] when solar data exist.
    season : array (n,) of str
    week : array (n,) int
        Week number, -1 outside every week.
    train, test : arrays (n,) bool
    valid : array (n,) bool
        Rows k usable for a one-step equation (k and k+1 in the same week, every
        signal finite at k and k+1, airflow finite back to k - MAX_DELAY).
    group : array (n,) int
        Season × time-of-week slot id of each row.
    u_min : array (nz,) [kg/s]
        Minimum airflow of each zone (sum of its boxes' minima).
    facades : tuple of tuple of str
        Exterior facade orientations of each zone.
    neighbours : tuple of tuple of int
        Zones coupled to each zone in the base structure.
    base_q : array (n, nz) [K per step]
        Base model's internal-gain profile at each row.
    has_solar : bool
    """

    index: pd.DatetimeIndex
    zones: tuple
    Y: np.ndarray
    U: np.ndarray
    V: dict
    season: np.ndarray
    week: np.ndarray
    train: np.ndarray
    test: np.ndarray
    valid: np.ndarray
    group: np.ndarray
    tow: np.ndarray
    season_id: np.ndarray
    dst: np.ndarray
    seasons: tuple
    n_tow: int
    step: float
    u_min: np.ndarray
    volumes: np.ndarray
    facades: tuple
    neighbours: tuple
    base_q: np.ndarray
    base_profiles: dict
    has_solar: bool
    base: LinearZoneModel

    @property
    def nz(self) -> int:
        return len(self.zones)

    def rows(self, which: str = "train") -> np.ndarray:
        """Indices of valid one-step rows of the training ('train') or test ('test') weeks."""
        m = self.valid & (self.train if which == "train" else self.test)
        return np.flatnonzero(m)


def base_linear(model) -> LinearZoneModel:
    """The linear part of a base model (a LinearZoneModel, or an ExtendedModel's base)."""
    if isinstance(model, LinearZoneModel):
        return model
    if isinstance(model, ExtendedModel):
        return model.base
    raise FitError(
        f"diagnosis needs a Model A base (kinds 'zones' or 'lumped', or 'extended'), got kind {model.kind!r}"
    )


def make_signals(dataset, model) -> Signals:
    """Collect the arrays of ``dataset`` that the diagnosis of ``model`` needs."""
    base = base_linear(model)
    frame = dataset.frame
    b = dataset.building
    zones = tuple(base.outputs)
    missing = [c for c in [f"T_{z}" for z in base.measured_zones] + [f"m_{v}" for v in base.vavs]
               + ["T_out", "T_supply"] if c not in frame.columns]
    if missing:
        raise DataError(f"dataset lacks columns the base model needs: {missing}")
    Y = base.measured_outputs(frame)
    U = frame[[f"m_{v}" for v in base.vavs]].to_numpy(dtype=float) @ base.input_map.T
    has_solar = bool(getattr(dataset, "has_solar", False)) and all(f"I_{o}" in frame.columns for o in "NESW")
    V = {c: frame[c].to_numpy(dtype=float) for c in ("T_out", "T_supply")}
    if has_solar:
        for o in "NESW":
            V[f"I_{o}"] = frame[f"I_{o}"].to_numpy(dtype=float)
    n = len(frame)
    week = np.asarray(dataset.week_of_row) if hasattr(dataset, "week_of_row") else _week_of_row(dataset)
    train_weeks = {w.number for w in dataset.weeks if w.train}
    test_weeks = {w.number for w in dataset.weeks if not w.train}
    train = np.isin(week, list(train_weeks))
    test = np.isin(week, list(test_weeks))
    season = np.full(n, "", dtype=object)
    for w in dataset.weeks:
        season[week == w.number] = w.season
    # one-step validity
    fin = np.isfinite(Y).all(axis=1) & np.isfinite(U).all(axis=1)
    for c in V.values():
        fin &= np.isfinite(c)
    valid = np.zeros(n, dtype=bool)
    if n > MAX_DELAY + 1:
        ok = fin[:-1] & fin[1:] & (week[:-1] == week[1:]) & (week[:-1] >= 0)
        ufin = np.isfinite(U).all(axis=1)
        for d in range(1, MAX_DELAY + 1):
            lag = np.zeros(n - 1, dtype=bool)
            lag[d:] = ufin[: n - 1 - d]
            ok &= lag
        valid[:-1] = ok
    # gains groups
    n_tow = n_time_of_week(dataset.step)
    seasons = tuple(s for s in dataset.building.season_names if s in set(season[week >= 0]))
    s_id = np.array([seasons.index(s) if s in seasons else -1 for s in season]) if n else np.zeros(0, int)
    tow = time_of_week(frame.index, dataset.step) % n_tow
    group = np.where(s_id >= 0, s_id * n_tow + tow, -1)
    base_profiles = {}
    base_q = np.zeros((n, len(zones)))
    for s in seasons:
        prof = _profile_for(base, s, n_tow)
        base_profiles[s] = prof
        m = season == s
        base_q[m] = prof[tow[m]]
    # structure
    if base.kind == "zones":
        volumes = np.array([b.zone(z).volume if z in b.zone_names else 1.0 for z in zones])
        facades = tuple(b.zone(z).orientations if z in b.zone_names else () for z in zones)
        u_min = np.array([sum(v.m_min for v in b.vavs_of(z)) for z in zones])
    else:
        volumes = np.full(len(zones), sum(z.volume for z in b.zones))
        facades = (tuple(o for o in "NESW" if any(o in z.orientations for z in b.zones)),) * len(zones)
        u_min = np.array([sum(v.m_min for v in b.vavs) * float(base.input_map[i].max()) for i in range(len(zones))])
    adj = np.abs(base.A) > 0
    if base.kind == "zones":
        zi = {z: i for i, z in enumerate(zones)}
        for p, q in b.adjacency_pairs():
            if p in zi and q in zi:
                adj[zi[p], zi[q]] = adj[zi[q], zi[p]] = True
    neighbours = tuple(tuple(j for j in range(len(zones)) if j != i and adj[i, j]) for i in range(len(zones)))
    return Signals(
        index=frame.index, zones=zones, Y=Y, U=U, V=V, season=season, week=week, train=train, test=test,
        valid=valid, group=group, tow=tow, season_id=s_id, dst=dst_active(frame.index), seasons=seasons,
        n_tow=n_tow, step=float(dataset.step), u_min=u_min, volumes=volumes,
        facades=facades, neighbours=neighbours, base_q=base_q, base_profiles=base_profiles,
        has_solar=has_solar, base=base,
    )


def _week_of_row(dataset):
    out = np.full(len(dataset.frame), -1, dtype=np.int64)
    idx = dataset.frame.index
    for w in dataset.weeks:
        out[idx.searchsorted(w.start) : idx.searchsorted(w.end)] = w.number
    return out


def _profile_for(base, season, n_tow):
    if season in base.gains:
        return np.asarray(base.gains[season])
    g = [np.asarray(v) for v in base.gains.values()]
    return np.mean(g, axis=0) if g else np.zeros((n_tow, base.n_states))


# ----------------------------------------------------------------------------
# regressors
# ----------------------------------------------------------------------------
def shifted(a: np.ndarray, d: int) -> np.ndarray:
    """``a(k - d)`` (NaN for the first d rows)."""
    out = np.full_like(a, np.nan, dtype=float)
    if d == 0:
        return np.asarray(a, dtype=float).copy()
    out[d:] = a[:-d]
    return out


def effective_inputs(sig: Signals, terms) -> np.ndarray:
    """Zone airflows after actuation delays [kg/s], (n, nz)."""
    U = sig.U
    for t in terms:
        if isinstance(t, ActuationDelay):
            U = U.copy() if U is sig.U else U
            zi = sig.zones.index(t.zone)
            U[:, zi] = shifted(sig.U[:, zi], t.delay)
    return U


def term_features(sig: Signals, term, U_eff: np.ndarray) -> list:
    """Features of one term: list of (zone index, column name, array (n,), lower, upper).

    The term's contribution to zone z's equation is Σ coef · feature.
    """
    Y, V, zi = sig.Y, sig.V, {z: i for i, z in enumerate(sig.zones)}
    if isinstance(term, SolarGain):
        return [(zi[term.zone], "coef", V[f"I_{term.facade}"], 0.0, np.inf)]
    if isinstance(term, SupplyAirBilinear):
        i = zi[term.zone]
        return [(i, "coef", U_eff[:, i] * (V["T_supply"] - Y[:, i]), 0.0, np.inf)]
    if isinstance(term, ZoneCoupling):
        # one conductance shared by both zones: coef_ab = k V̄/V_a, coef_ba = k V̄/V_b
        a, b = zi[term.zone_a], zi[term.zone_b]
        ra, rb = coupling_ratios(sig, a, b)
        d = Y[:, b] - Y[:, a]
        return [(a, "k", d * ra, 0.0, 1.0), (b, "k", -d * rb, 0.0, 1.0)]
    if isinstance(term, ThermalMass):
        i = zi[term.zone]
        return [(i, "beta", ema_series(Y[:, i], term.alpha) - Y[:, i], 0.0, 1.0)]
    if isinstance(term, Reheat):
        i = zi[term.zone]
        return [(i, "coef", reheat_feature(U_eff[:, i], V["T_out"], term.u_min, term.T_threshold), 0.0, np.inf)]
    if isinstance(term, InternalGainSchedule):
        unit = dataclasses.replace(term, coef=tuple(1.0 for _ in sig.zones), zone_names=sig.zones)
        adj = np.zeros((len(Y), sig.nz))
        for s in sig.seasons:
            m = sig.season == s
            if m.any():
                adj[m] = unit.adjustment(sig.index[m], sig.base_profiles[s], sig.step)
        return [(i, f"coef[{z}]", adj[:, i], 0.0, 2.0) for i, z in enumerate(sig.zones)]
    if isinstance(term, ActuationDelay):
        return []
    raise TypeError(f"unknown term {term!r}")


def coupling_ratios(sig: Signals, a: int, b: int):
    """``V̄/V_a, V̄/V_b``: a symmetric conductance raises the smaller zone's temperature more."""
    va, vb = float(sig.volumes[a]), float(sig.volumes[b])
    vm = 0.5 * (va + vb)
    return vm / va, vm / vb


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
    bilinear = any(isinstance(t, SupplyAirBilinear) and t.zone == sig.zones[z] for t in terms)
    add("b", U_eff[:, z], -np.inf, np.inf if bilinear else 0.0)
    for c in base_disturb:
        if c in ("T_out", "T_supply"):
            add(f"c[{c}]", sig.V[c], 0.0, np.inf)
        elif c.startswith("I_") and c in sig.V and base_solar(sig, z, c[2:]) != 0.0:
            # solar paths the base model uses are part of its structure (refitted, c >= 0)
            add(f"c[{c}]", sig.V[c], 0.0, np.inf)
    for ti, t in enumerate(terms):
        fl = feats[ti] if feats is not None else term_features(sig, t, U_eff)
        for (zz, name, col, low, high) in fl:
            if zz == z:
                add(name, col, low, high, ti)
    return ZoneDesign(names, np.column_stack(cols), np.array(lo), np.array(hi), owner, offset)


def base_solar(sig: Signals, z: int, facade: str) -> float:
    """The base model's coefficient of ``I_<facade>`` in zone ``z`` [K/step per W/m²] (0 if absent)."""
    c = f"I_{facade}"
    if c in sig.base.disturbances:
        return float(sig.base.C[z, sig.base.disturbances.index(c)])
    return 0.0


# ----------------------------------------------------------------------------
# within transform and bounded least squares
# ----------------------------------------------------------------------------
class Within:
    """Subtract per-group means (season × time-of-week slot) over a fixed row set."""

    def __init__(self, group: np.ndarray, rows: np.ndarray):
        g = group[rows]
        self.rows = rows
        uniq, self.inv = np.unique(g, return_inverse=True)
        self.groups = uniq
        self.counts = np.bincount(self.inv).astype(float)
        self.n_groups = len(uniq)

    def means(self, A: np.ndarray) -> np.ndarray:
        """Group means (n_groups, p) of rows ``A[self.rows]``."""
        A = A[self.rows]
        if A.ndim == 1:
            return np.bincount(self.inv, weights=A) / self.counts
        return np.stack([np.bincount(self.inv, weights=A[:, j]) / self.counts for j in range(A.shape[1])], axis=1)

    def __call__(self, A: np.ndarray) -> np.ndarray:
        return A[self.rows] - self.means(A)[self.inv]


@dataclasses.dataclass
class LSResult:
    theta: np.ndarray
    rss: float
    n: int
    cov: np.ndarray
    sigma2: float


def bounded_ls(Xw: np.ndarray, yw: np.ndarray, lower, upper, dof_extra: int = 0) -> LSResult:
    """min ‖Xw θ − yw‖² subject to lower ≤ θ ≤ upper, solved on the Cholesky factor of the Gram matrix.

    ``cov`` is the unconstrained asymptotic covariance σ² (XᵀX)⁻¹ with σ² the residual
    variance after ``dof_extra`` further degrees of freedom (the group means).
    """
    n, p = Xw.shape
    scale = np.sqrt(np.maximum((Xw * Xw).sum(axis=0), 1e-300))
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
    theta = ts / scale
    res = yw - Xw @ theta
    rss = float(res @ res)
    dof = max(n - p - dof_extra, 1)
    sigma2 = rss / dof
    Ginv = np.linalg.inv(G + ridge * np.eye(p))
    cov = sigma2 * Ginv / np.outer(scale, scale)
    return LSResult(theta, rss, n, cov, sigma2)


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


def fit_structure(sig: Signals, terms, rows=None, within: Within | None = None) -> StructureFit:
    """Refit base structure + ``terms`` jointly on the training rows; returns an ExtendedModel."""
    rows = sig.rows("train") if rows is None else rows
    if len(rows) < 50:
        raise FitError(f"only {len(rows)} usable one-step rows in the training weeks; need at least 50")
    W = within or Within(sig.group, rows)
    U_eff = effective_inputs(sig, terms)
    feats = [term_features(sig, t, U_eff) for t in terms]
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
        bf = fit_block(sig, W, block, terms, U_eff, feats, target_next)
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
    new_base = dataclasses.replace(base, A=A, B=B, C=C, gains=gains,
                                   meta={**{k: v for k, v in base.meta.items() if k != "uncertainty"},
                                         "refit": "diagnosis within-LS"})
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


def fit_block(sig: Signals, W: Within, block, terms, U_eff, feats, target_next) -> BlockFit:
    """Fit the equations of the zones in ``block`` jointly (stacked within-transformed rows)."""
    designs = {z: zone_design(sig, z, terms, U_eff, feats) for z in block}
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
            X[i * n:(i + 1) * n, keys.index(key)] = Xw[:, j]
        y[i * n:(i + 1) * n] = W(target_next[:, z] - D.offset)
    ls = bounded_ls(X, y, lo, hi, dof_extra=W.n_groups * len(block))
    sd = np.sqrt(np.maximum(np.diag(ls.cov), 0.0))
    res = y - X @ ls.theta
    zone_ls, resid = {}, {}
    for i, z in enumerate(block):
        r = res[i * n:(i + 1) * n]
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
    if isinstance(t, (SolarGain, SupplyAirBilinear, Reheat)):
        return dataclasses.replace(t, coef=coefs.get("coef", 0.0), std={"coef": stds.get("coef", 0.0)})
    if isinstance(t, ZoneCoupling):
        ra, rb = coupling_ratios(sig, zones.index(t.zone_a), zones.index(t.zone_b))
        k, sk = coefs.get("k", 0.0), stds.get("k", 0.0)
        return dataclasses.replace(t, coef_ab=k * ra, coef_ba=k * rb, std={"coef_ab": sk * ra, "coef_ba": sk * rb})
    if isinstance(t, ThermalMass):
        return dataclasses.replace(t, beta=coefs.get("beta", 0.0), std={"beta": stds.get("beta", 0.0)})
    if isinstance(t, InternalGainSchedule):
        c = tuple(float(coefs.get(f"coef[{z}]", 0.0)) for z in zones)
        return dataclasses.replace(t, zone_names=tuple(zones), coef=c,
                                   std={"coef": {z: float(stds.get(f"coef[{z}]", 0.0)) for z in zones}})
    return t
