"""Signals the cause plugins and the diagnosis' regressions read, and shared signal helpers.

:class:`Signals` holds every array of a dataset on the model step (outputs, airflows,
disturbances, seasons, weeks, train/test rows, time-of-week groups, the base model's
structure); :class:`Within` is the season × time-of-week within transform that eliminates
Model A's internal-gain profile exactly (fixed-effects estimator).
"""

from __future__ import annotations

import dataclasses
import datetime as _dt

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from ...calendars import gain_slots
from ...errors import DataError
from ...timeutil import n_time_of_week
from ..linear import LinearZoneModel

MAX_DELAY_S = 3600.0  #: largest actuation delay tested [s] (one hour: 4 steps of 15 min, 12 of 5 min)
MAX_DELAY = 4  #: largest actuation delay tested at the 15-min step [steps] (see :func:`max_delay`)


def max_delay(step: float) -> int:
    """Largest actuation delay tested [steps] at model step ``step`` [s]: one hour, at least one step."""
    return max(1, int(round(MAX_DELAY_S / float(step))))


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
        signal finite at k and k+1, airflow finite back to k - max_delay(step)).
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
    extra : dict str -> array (n,)
        Measured columns the base model does not use (``Td_<vav>``, ``rh_<vav>``,
        ``T_supply_<ahu>``, ``ghi``, ``wind``), gaps held; ``Qrh_<zone>`` [kW] reheat heat where every
        box of the zone has ``Td_`` (also in ``V``).
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
    #: measured columns the base model ignores (gaps held, then 0) and the zones each concerns (() = all)
    extra: dict = dataclasses.field(default_factory=dict)
    extra_zones: dict = dataclasses.field(default_factory=dict)
    extra_coverage: dict = dataclasses.field(default_factory=dict)
    #: ``{vav: supply temperature column of its unit}`` (``T_supply_<ahu>`` when the frame has it)
    supply_of: dict = dataclasses.field(default_factory=dict)
    #: each output's ``(part, storey)`` from the building file's slabs between zones (:func:`zone_storeys`);
    #: ``()`` for a building without a slab between two of its zones (one storey, or not told)
    storeys: tuple = ()

    @property
    def nz(self) -> int:
        return len(self.zones)

    def rows(self, which: str = "train") -> np.ndarray:
        """Indices of valid one-step rows of the training ('train') or test ('test') weeks."""
        m = self.valid & (self.train if which == "train" else self.test)
        return np.flatnonzero(m)


def box_supply_columns(building, vavs) -> dict:
    """``{vav: supply temperature column of the unit feeding it}`` (``T_supply`` for a box the building
    does not know, or a building without per-unit columns)."""
    known = set(getattr(building, "vav_names", ()))
    has = hasattr(building, "supply_column")
    return {v: building.supply_column(v) if has and v in known else "T_supply" for v in vavs}


def make_signals(dataset, base: LinearZoneModel) -> Signals:
    """Collect the arrays of ``dataset`` that the diagnosis of the linear model ``base`` needs."""
    frame = dataset.frame
    b = dataset.building
    zones = tuple(base.outputs)
    missing = [
        c
        for c in [f"T_{z}" for z in base.measured_zones] + [f"m_{v}" for v in base.vavs] + ["T_out", "T_supply"]
        if c not in frame.columns
    ]
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
    valid = _one_step_valid(Y, U, V, week, dataset.step)
    n_tow, seasons, s_id, tow, group, base_profiles, base_q = _gain_groups(dataset, base, season, week)
    volumes, facades, u_min, neighbours = _structure(base, b, zones)
    extra, extra_zones, coverage = unused_columns(dataset, base)
    from .reheat import zone_reheat_columns

    supply_of = {v: c if c in frame.columns else "T_supply" for v, c in box_supply_columns(b, base.vavs).items()}
    for c, q in zone_reheat_columns(frame, base, supply_of).items():
        if np.isfinite(q).mean() >= MIN_COVERAGE:
            V[c] = pd.Series(q).ffill().bfill().fillna(0.0).to_numpy()
    return Signals(
        index=frame.index,
        zones=zones,
        Y=Y,
        U=U,
        V=V,
        season=season,
        week=week,
        train=train,
        test=test,
        valid=valid,
        group=group,
        tow=tow,
        season_id=s_id,
        dst=dst_active(frame.index),
        seasons=seasons,
        n_tow=n_tow,
        step=float(dataset.step),
        u_min=u_min,
        volumes=volumes,
        facades=facades,
        neighbours=neighbours,
        base_q=base_q,
        base_profiles=base_profiles,
        has_solar=has_solar,
        base=base,
        extra=extra,
        extra_zones=extra_zones,
        extra_coverage=coverage,
        supply_of=supply_of,
        storeys=zone_storeys(b, zones) if base.kind == "zones" else (),
    )


#: The films of a construction between two zones that make it a slab: side 1 the upper zone's floor, side 2 the
#: lower zone's ceiling (or the reverse), as the building file's ``intermediate_slab`` and EnergyPlus's interzone
#: floors are written.
SLAB_FILMS = {("floor", "ceiling"): 1, ("ceiling", "floor"): -1}


def zone_storeys(building, zones) -> tuple:
    """Each of ``zones``' ``(part, storey)`` from the building file's slabs between two zones; ``()`` when it
    has none or they contradict each other.

    A slab (an element between two zones whose construction's films are ``floor`` / ``ceiling``,
    :data:`SLAB_FILMS`) puts its floor side one storey above its ceiling side; zones joined by any other
    adjacency (a wall, ``adjacent``) share a storey. ``part`` numbers the groups of zones joined by walls and
    slabs: storeys (0 the lowest of its part) compare only within one part. A zone joined to no other has no
    storey told (``None``).
    """
    phys = getattr(building, "physics", None) or {}
    films = {
        c.get("name"): tuple(c.get("films", ()))
        for c in phys.get("constructions", ())
        if isinstance(c, dict) and isinstance(c.get("films"), list)
    }
    names = set(getattr(building, "zone_names", ()))
    edges: dict = {}
    slabs = set()
    for e in phys.get("elements", ()):
        if not isinstance(e, dict):
            continue
        s1, s2, up = e.get("side1"), e.get("side2"), SLAB_FILMS.get(films.get(e.get("construction"), ()))
        if up is None or s1 not in names or s2 not in names or s1 == s2:
            continue
        edges.setdefault(s1, []).append((s2, -up))  # storey(s2) = storey(s1) - up
        edges.setdefault(s2, []).append((s1, up))
        slabs.add(frozenset((s1, s2)))
    if not slabs:
        return ()
    for p, q in building.adjacency_pairs():
        if frozenset((p, q)) not in slabs:
            edges.setdefault(p, []).append((q, 0))
            edges.setdefault(q, []).append((p, 0))
    level: dict = {}
    part: dict = {}
    n_parts = 0
    for start in sorted(edges):
        if start in level:
            continue
        level[start], part[start] = 0, n_parts
        n_parts += 1
        todo = [start]
        comp = [start]
        while todo:
            z = todo.pop()
            for o, d in edges[z]:
                if o not in level:
                    level[o], part[o] = level[z] + d, part[start]
                    todo.append(o)
                    comp.append(o)
                elif level[o] != level[z] + d:
                    return ()  # a slab and a wall (or two slabs) that disagree: no storeys told
        low = min(level[z] for z in comp)
        for z in comp:
            level[z] -= low
    return tuple((part[z], level[z]) if z in level else None for z in zones)


def _one_step_valid(Y, U, V: dict, week, step) -> np.ndarray:
    """Rows whose one-step transition is usable: finite now and next, same week, inputs finite over the delays."""
    n = len(Y)
    fin = np.isfinite(Y).all(axis=1) & np.isfinite(U).all(axis=1)
    for c in V.values():
        fin &= np.isfinite(c)
    valid = np.zeros(n, dtype=bool)
    n_delay = max_delay(step)
    if n > n_delay + 1:
        ok = fin[:-1] & fin[1:] & (week[:-1] == week[1:]) & (week[:-1] >= 0)
        ufin = np.isfinite(U).all(axis=1)
        for d in range(1, n_delay + 1):
            lag = np.zeros(n - 1, dtype=bool)
            lag[d:] = ufin[: n - 1 - d]
            ok &= lag
        valid[:-1] = ok
    return valid


def _gain_groups(dataset, base, season, week) -> tuple:
    """Season x time-of-week groups of the rows and the base model's gains on every row.

    Returns ``(n_tow, seasons, season_id, tow, group, base_profiles, base_q)``.
    """
    frame = dataset.frame
    n, zones = len(frame), tuple(base.outputs)
    n_tow = n_time_of_week(dataset.step)
    seasons = tuple(s for s in dataset.building.season_names if s in set(season[week >= 0]))
    s_id = np.array([seasons.index(s) if s in seasons else -1 for s in season]) if n else np.zeros(0, int)
    # the slot the gains are read at: a holiday of the dataset's calendar reads Sunday's (hvacfmu.calendars)
    tow = gain_slots(frame.index, dataset.step, dataset.holidays.dates) % n_tow
    group = np.where(s_id >= 0, s_id * n_tow + tow, -1)
    base_profiles = {}
    base_q = np.zeros((n, len(zones)))
    for s in seasons:
        prof = _profile_for(base, s, n_tow)
        base_profiles[s] = prof
        m = season == s
        base_q[m] = prof[tow[m]]
    return n_tow, seasons, s_id, tow, group, base_profiles, base_q


def _structure(base, b, zones) -> tuple:
    """Per output: volume [m3], facades, minimum airflow [kg/s] and neighbours (model coupling or adjacency)."""
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
    return volumes, facades, u_min, neighbours


#: Smallest share of finite rows for a measured column to be screened.
MIN_COVERAGE = 0.8


def unused_columns(dataset, base):
    """Measured columns ``base`` ignores: ``{name: array}``, ``{name: zones}``, ``{name: coverage}``.

    ``wind`` (wind speed [m/s]) is in the arrays and coverages but not in ``{name: zones}``: the
    ``wind_infiltration`` cause reads it, ``unused_input`` (which screens the named columns) does not.
    """
    frame = dataset.frame
    used = set(base.disturbances) | {f"m_{v}" for v in base.vavs} | {f"T_{z}" for z in base.measured_zones}
    zone_of_vav = {}
    for j, v in enumerate(base.vavs):
        zone_of_vav[v] = tuple(base.outputs[i] for i in range(len(base.outputs)) if base.input_map[i, j] > 0)
    ahu_zones: dict = {}
    for v, col in box_supply_columns(dataset.building, base.vavs).items():
        ahu_zones.setdefault(col, set()).update(zone_of_vav[v])
    has_facades = all(f"I_{o}" in frame.columns for o in "NESW")
    extra, zones, coverage = {}, {}, {}
    for c in frame.columns:
        if c in used:
            continue
        if c.startswith(("Td_", "rh_")) and c[3:] in zone_of_vav:
            zs = zone_of_vav[c[3:]]
        elif c.startswith("T_supply_"):
            zs = tuple(sorted(ahu_zones.get(c, ())))
        elif c == "ghi" and not has_facades:
            zs = ()
        elif c == "wind":
            zs = None  # the wind_infiltration cause's column, not an unused_input candidate
        else:
            continue
        x = frame[c].to_numpy(dtype=float)
        cov = float(np.isfinite(x).mean()) if len(x) else 0.0
        if cov < MIN_COVERAGE:
            continue
        extra[c] = pd.Series(x).ffill().bfill().to_numpy()
        if zs is not None:
            zones[c] = zs
        coverage[c] = cov
    return extra, zones, coverage


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
# helpers
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
        d = t.delayed_input()
        if d is not None:
            U = U.copy() if U is sig.U else U
            zi = sig.zones.index(d[0])
            U[:, zi] = shifted(sig.U[:, zi], d[1])
    return U


def coupling_ratios(sig: Signals, a: int, b: int):
    """``V̄/V_a, V̄/V_b``: a symmetric conductance raises the smaller zone's temperature more."""
    va, vb = float(sig.volumes[a]), float(sig.volumes[b])
    vm = 0.5 * (va + vb)
    return vm / va, vm / vb


def base_solar(sig: Signals, z: int, facade: str) -> float:
    """The base model's coefficient of ``I_<facade>`` in zone ``z`` [K/step per W/m²] (0 if absent)."""
    c = f"I_{facade}"
    if c in sig.base.disturbances:
        return float(sig.base.C[z, sig.base.disturbances.index(c)])
    return 0.0


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


def dst_active(index: pd.DatetimeIndex) -> np.ndarray:
    """True where daylight-saving time is in effect at the timestamps of a tz-aware ``index``."""
    index = pd.DatetimeIndex(index)
    if index.tz is None or len(index) == 0:
        return np.zeros(len(index), dtype=bool)
    off = (index.tz_localize(None) - index.tz_convert("UTC").tz_localize(None)).total_seconds().to_numpy(dtype=float)
    # standard offset: the smaller of January's and July's offset in this time zone
    y = index[0].year
    jan = pd.Timestamp(_dt.datetime(y, 1, 15), tz=index.tz).utcoffset().total_seconds()
    jul = pd.Timestamp(_dt.datetime(y, 7, 15), tz=index.tz).utcoffset().total_seconds()
    return off > min(jan, jul)


def ema_series(y: np.ndarray, alpha: float) -> np.ndarray:
    """``s(k)`` of the filter ``s(k+1) = s(k) + alpha (y(k) − s(k))``, ``s(0) = y(0)``; gaps are held."""
    y = pd.Series(np.asarray(y, dtype=float)).ffill().bfill().to_numpy()
    if len(y) == 0:
        return y
    if not np.isfinite(y[0]):
        return np.full(len(y), np.nan)
    s = np.empty_like(y)
    s[0] = y[0]
    if len(y) > 1:
        zi = np.array([(1 - alpha) * y[0]])
        out, _ = lfilter([alpha], [1.0, -(1.0 - alpha)], y[:-1], zi=zi)
        s[1:] = out
    return s


def ema_last(hist: np.ndarray, alpha: float, fallback: float) -> float:
    """Filter state at the last row of ``hist`` (which is the start row); ``fallback`` without history."""
    hist = np.asarray(hist, dtype=float)
    if len(hist) == 0 or not np.isfinite(hist).any():
        return float(fallback)
    s = ema_series(hist, alpha)
    return float(s[-1]) if np.isfinite(s[-1]) else float(fallback)
