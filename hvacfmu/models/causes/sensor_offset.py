"""Cause ``sensor_offset``: a zone's temperature column reads a constant offset from a date on.

A zone sensor re-calibrated or replaced, or a BMS point re-mapped, mid-file: the column reads ``+δ``
from the change on while the room (and the thermostat, which acts on the true room or another
sensor) is unchanged. Every model otherwise fits it as best it can. Term: a dated step
``coef · 1[start <= t < end]`` into the zone's equation [K per step] (``end`` empty: to the end of the
data), carried like a holiday through the internal gains (``gain_adjustment``, :meth:`ExtendedModel.gains_at`):
a calendar term, no time-invariant matrix form (the pythonfmu FMU and the MPC read it through
``gains_at``). The zone's steady reading moves by about ``coef / (1 − a_zz)``.

Screen (training rows only): per zone, its *level* — the reading minus the median of the other zones' (their
mean with two), which a change of weather or schedule moves little — averaged per local day; the candidate
change is the day boundary that best splits those day means in two (largest Welch t, at least
:data:`MIN_SIDE_DAYS` training days each side), placed at the row after the largest one-step residual
(``_resid_all``, NaN outside the training folds) of the move's sign within a day of it. Not a change-point in
the one-step residual's mean: the refit absorbs a step of the reading in ``a_zz`` (measured on quad4 seed 5,
+2.5 K in NE: ``a_zz`` 0.993, the residual's day means move 0.02 K while the jump leaves a 2.3 K residual).
Cause-specific evidence, all required (otherwise "no evidence"):

- *a split*: Welch t of the day means ≥ :data:`MIN_SPLIT_T`;
- *abrupt*: the mean of the :data:`LOCAL_DAYS` training days just after the change minus that of the days
  just before is at least :data:`MIN_LOCAL_SHARE` of the whole shift (a drift or a season is gradual);
- *persistent*: each half of the days after the change keeps at least :data:`MIN_PERSIST_SHARE` of the shift;
- *one zone*: no other zone moves against the rest at the same split by :data:`MAX_OTHER_SHARE` of the
  zone's jump or more, and no other zone's one-step residual at the jump's step reaches that share of it
  (the whole floor moving is weather or schedule);
- *a jump*: a one-step residual of at least :data:`SPIKE_Z` robust standard deviations and
  :data:`MIN_JUMP_SHARE` of the level's move, of its sign, in the training rows within a day of the split (a
  reading that steps by ``δ`` leaves about ``δ``; a room that warms does not jump in one step). Where the
  split falls between training days (a held-out week, a gap), the jump cannot be seen: the change is then
  *bracketed* (location ``after``: the last training row before, ``start`` the first after) and needs instead
  Welch t ≥ :data:`MIN_GAP_T`, a move ≥ :data:`MIN_GAP_OFFSET_K` and ≥ :data:`MIN_GAP_LOCAL_SHARE` of the shift;
- *large enough*: the level's move is at least :data:`MIN_OFFSET_K`;
- *the same at every hour*: each quarter of the local day keeps :data:`MIN_HOUR_SHARE` of the move over the
  :data:`MIN_SIDE_DAYS` training days each side (a heater on cold nights, or a loop holding the room by day, moves
  some hours only).

A set point changed at that date gives the same reading (the room truly warmer by ``δ``): the airflow's
mean before/after is reported, and the finding names both explanations.

A second change (session 21): a zone without an accepted change is also screened for a change and its *return*
(:func:`interval_candidate`: a sensor re-calibrated and put back; one term with an ``end``), named instead of the one
change when it passes the same evidence at both ends and the one change fails, or describes the day means better
(BIC). A zone with an accepted change is screened again between its accepted dates (``bounds``: a further change).
Both read the day means with each day of the week's own mean taken out (zones differ in their weekend loads); the
first search is session 20's, unchanged.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import ClassVar

import numpy as np
import pandas as pd

from ...errors import ModelError
from ...timeutil import local_seconds
from .base import Candidate, EquationParts, Term, num, zone_of

#: training days each side of a candidate change
MIN_SIDE_DAYS = 7
#: smallest offset named [K] (the level's jump at the split)
MIN_OFFSET_K = 0.5
#: Welch t of the day means before/after the change
MIN_SPLIT_T = 4.0
#: training days each side for the local jump
LOCAL_DAYS = 3
#: share of the shift the local jump must reach (abrupt)
MIN_LOCAL_SHARE = 0.5
#: share of the shift each half of the after-period must keep (persistent)
MIN_PERSIST_SHARE = 0.5
#: another zone moving against the rest at the split (or jumping at the step), as a share of the zone's move: the
#: floor, not one zone
MAX_OTHER_SHARE = 0.5
#: a one-step residual this many robust standard deviations out marks the jump's row
SPIKE_Z = 6.0
#: the jump's one-step residual as a share of the level's move (a stepping reading leaves about all of it)
MIN_JUMP_SHARE = 0.5
#: every quarter of the day (0-6, 6-12, 12-18, 18-24 h local) keeps this share of the level's move over the
#: :data:`MIN_SIDE_DAYS` training days each side (a reading offset is the same at every hour; a heater that runs on
#: cold nights, or a loop that holds the room by day, moves some hours only: the default building's seed 1 with
#: a 4-kW heater in S moved its level +0.72 K at the heating season's start, which passed every other test)
MIN_HOUR_SHARE = 0.5
#: a change between training days (a held-out week, a gap), where no jump can be seen: Welch t of the split, the
#: level's move [K] and its share of the whole shift, all required instead of the jump
MIN_GAP_T = 10.0
#: (the clean battery's core zones move up to 1.15 K, t 16, across the held-out week at the heating season's
#: start: core9 case 3's C, stopped there only by the one-zone rule, SE and SW moving 0.76 / 0.64 K against 0.58)
MIN_GAP_OFFSET_K = 1.5
MIN_GAP_LOCAL_SHARE = 0.8
#: a change and its return (a sensor put back): the days after it differ from the days before by at most this share
#: of the shift (else it is two changes, searched one after the other)
MAX_RETURN_SHARE = 0.5


@dataclasses.dataclass(frozen=True)
class SensorOffset(Term):
    """``coef · 1[start <= t < end]`` into ``zone`` (``coef`` in K per step; ``end`` "" = open)."""

    cause: ClassVar[str] = "sensor_offset"
    description: ClassVar[str] = "a zone's temperature reads an offset from a date on (sensor re-calibrated/replaced)"
    calendar: ClassVar[bool] = True
    zone: str = ""
    start: str = ""
    end: str = ""
    coef: float = 0.0
    zone_names: tuple = ()

    def zones(self):
        return (self.zone,)

    def location(self):
        loc = {"zone": self.zone, "start": self.start}
        if self.end:
            loc["end"] = self.end
        return loc

    def coefficients(self):
        return {"coef": float(self.coef)}

    def indicator(self, index) -> np.ndarray:
        """1.0 where ``start <= t < end`` on a tz-aware ``index``."""
        index = pd.DatetimeIndex(index)
        on = index >= pd.Timestamp(self.start)
        if self.end:
            on &= index < pd.Timestamp(self.end)
        return np.asarray(on, dtype=float)

    def gain_adjustment(self, index, profile, step, holidays=()):
        out = np.zeros((len(index), np.asarray(profile).shape[1]))
        if self.zone in self.zone_names:
            out[:, self.zone_names.index(self.zone)] = self.coef * self.indicator(index)
        return out

    def add_equations(self, e: EquationParts) -> None:
        raise ModelError(
            f"sensor_offset ({self.zone} from {self.start}) depends on the date: it has no time-invariant "
            "equations; use the model's gains_at with a start time"
        )

    def features(self, sig, U_eff):
        return [(sig.zones.index(self.zone), "coef", self.indicator(sig.index), -np.inf, np.inf)]

    def with_fit(self, sig, coefs, stds):
        return dataclasses.replace(
            self, coef=float(coefs.get("coef", 0.0)), zone_names=tuple(sig.zones), std={"coef": stds.get("coef", 0.0)}
        )

    @classmethod
    def from_dict(cls, d, zone_names, problems, std):
        what = f"extension term {cls.cause}"
        out = {}
        for key in ("start", "end"):
            v = d.get(key, "" if key == "end" else None)
            if key == "end" and v in ("", None):
                out[key] = ""
                continue
            try:
                t = pd.Timestamp(v)
                ok = t is not pd.NaT and t.tzinfo is not None
            except (TypeError, ValueError):
                ok = False
            if not ok:
                problems.append(f"{what}: {key!r} must be an ISO time with its UTC offset, got {v!r}")
            out[key] = str(v)
        return cls(
            zone=zone_of(d, "zone", zone_names, what, problems),
            start=out["start"],
            end=out["end"],
            coef=num(d, "coef", what, problems),
            zone_names=tuple(zone_names),
            std=std,
        )

    # --- diagnosis ---------------------------------------------------------------------
    @classmethod
    def screen(cls, sig, terms, W, resid, options):
        R = options.get("_resid_all")
        if R is None:
            return []
        out = []
        for zi, z in enumerate(sig.zones):
            # a zone with an accepted change: a further one is searched between the accepted dates (a second
            # re-calibration); the first search also tries a change and its return (a sensor put back)
            bounds = [b for t in terms if isinstance(t, SensorOffset) and t.zone == z for b in (t.start, t.end) if b]
            c = offset_candidate(sig, np.asarray(R, float), zi, bounds=bounds)
            if c is not None:
                out.append(c)
        return out


def _day_means(day: np.ndarray, r: np.ndarray, min_rows: int):
    """Days (sorted) with at least ``min_rows`` finite values of ``r``, their means and row counts."""
    ok = np.isfinite(r)
    d, r = day[ok], r[ok]
    if not len(d):
        return np.zeros(0, int), np.zeros(0), np.zeros(0)
    u, inv, cnt = np.unique(d, return_inverse=True, return_counts=True)
    s = np.bincount(inv, weights=r)
    keep = cnt >= min_rows
    return u[keep], (s / cnt)[keep], cnt[keep]


def _welch(a: np.ndarray, b: np.ndarray) -> float:
    if len(a) < 2 or len(b) < 2:
        return 0.0
    se = np.sqrt(a.var(ddof=1) / len(a) + b.var(ddof=1) / len(b))
    return float((b.mean() - a.mean()) / se) if se > 0 else 0.0


def best_split(days: np.ndarray, means: np.ndarray, min_side: int = MIN_SIDE_DAYS) -> tuple[int, float]:
    """Index ``s`` (days ``[:s]`` before, ``[s:]`` after) of the largest |Welch t| of the day means, and that t."""
    best, bt = -1, 0.0
    for s in range(min_side, len(means) - min_side + 1):
        t = _welch(means[:s], means[s:])
        if abs(t) > abs(bt):
            best, bt = s, t
    return best, bt


def best_interval(means: np.ndarray, min_side: int = MIN_SIDE_DAYS) -> tuple[int, int, float]:
    """Indices ``(s1, s2)`` of the days ``[s1:s2]`` whose mean differs most (Welch t, inside against the days before
    and after together) from the rest, at least ``min_side`` days in each of the three parts, and that t
    (``(-1, -1, 0.0)`` when there are too few days)."""
    n = len(means)
    if n < 3 * min_side:
        return -1, -1, 0.0
    c1 = np.concatenate([[0.0], np.cumsum(means)])
    c2 = np.concatenate([[0.0], np.cumsum(means**2)])
    s1, s2 = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    ok = (s1 >= min_side) & (s2 - s1 >= min_side) & (n - s2 >= min_side)
    ni = (s2 - s1).astype(float)
    no = n - ni
    si, qi = c1[s2] - c1[s1], c2[s2] - c2[s1]
    so, qo = c1[n] - si, c2[n] - qi
    with np.errstate(divide="ignore", invalid="ignore"):
        mi, mo = si / ni, so / no
        vi = (qi - ni * mi**2) / (ni - 1)
        vo = (qo - no * mo**2) / (no - 1)
        t = (mi - mo) / np.sqrt(vi / ni + vo / no)
    t = np.where(ok & np.isfinite(t), t, 0.0)
    k = int(np.argmax(np.abs(t)))
    a, b = divmod(k, n + 1)
    return (a, b, float(t[a, b])) if t[a, b] != 0.0 else (-1, -1, 0.0)


def _rest(Y: np.ndarray, idx: list) -> np.ndarray:
    """The other zones' reading: their median (one of them offset moves it little), their mean with two."""
    sub = Y[:, idx]
    return np.median(sub, axis=1) if len(idx) >= 3 else sub.mean(axis=1)


@dataclasses.dataclass
class _Level:
    """A zone's level against the others (training rows) and its training days' means."""

    Y: np.ndarray
    R: np.ndarray
    zi: int
    index: pd.DatetimeIndex
    train: np.ndarray
    others: list
    level: np.ndarray
    seconds: np.ndarray
    day: np.ndarray
    days: np.ndarray
    means: np.ndarray

    @functools.cached_property
    def weekly(self) -> np.ndarray:
        """The day means with each day of the week's own mean taken out (:func:`_weekly`), computed once."""
        return _weekly(self.days, self.means)


def _level(sig, R: np.ndarray, zi: int) -> _Level:
    Y = np.asarray(sig.Y, float)
    train = np.zeros(len(Y), bool)
    train[sig.rows("train")] = True
    others = [j for j in range(sig.nz) if j != zi]
    level = np.where(train, Y[:, zi] - _rest(Y, others), np.nan)
    seconds = local_seconds(sig.index)
    day = seconds // 86400
    per_day = max(1, int(round(86400.0 / sig.step)))
    days, means, _ = _day_means(day, level, per_day // 2)
    return _Level(Y, R, zi, pd.DatetimeIndex(sig.index), train, others, level, seconds, day, days, means)


def _weekly(days: np.ndarray, means: np.ndarray) -> np.ndarray:
    """Day means with each day of the week's own mean taken out (zones differ in their weekend loads)."""
    dow = (days + 3) % 7  # local days since 1970-01-01, a Thursday: 0 = Monday
    by_dow = np.array([means[dow == d].mean() if np.any(dow == d) else 0.0 for d in range(7)])
    return means - by_dow[dow] + means.mean()


def _edge(sig, L: _Level, days: np.ndarray, means: np.ndarray, s: int, sign: float, weekly: bool = False) -> dict:
    """The change between training days ``days[s - 1]`` and ``days[s]`` (of ``days``, one segment's days) in the
    direction ``sign``: the local jump, the other zones' moves, the move by quarter of the day, the jump's one-step
    residual and its row (or the bracket of days without training rows). ``weekly``: the other zones' moves read
    their day means with each day of the week's mean taken out (as ``means`` then are)."""
    Y, R, zi, day, train, others = L.Y, L.R, L.zi, L.day, L.train, L.others
    local = float(means[s : s + LOCAL_DAYS].mean() - means[max(0, s - LOCAL_DAYS) : s].mean())
    # one zone: each other zone's own local jump against the rest (the zone itself left out)
    lo, hi = days[max(0, s - LOCAL_DAYS)], days[min(len(days) - 1, s + LOCAL_DAYS - 1)]
    pre_rows = train & (day >= lo) & (day < days[s])
    post_rows = train & (day >= days[s]) & (day <= hi)
    jumps = {}
    for j in others:
        y = Y[:, j] - (_rest(Y, [o for o in others if o != j]) if len(others) > 1 else 0.0)
        if weekly and len(others) > 1:
            dj, mj, _ = _day_means(day, np.where(train, y, np.nan), 1)
            mj = _weekly(dj, mj)
            a, b = mj[np.isin(dj, days[max(0, s - LOCAL_DAYS) : s])], mj[np.isin(dj, days[s : s + LOCAL_DAYS])]
        else:
            a, b = y[pre_rows], y[post_rows]
            a, b = a[np.isfinite(a)], b[np.isfinite(b)]
        if len(a) and len(b):
            jumps[sig.zones[j]] = float(b.mean() - a.mean()) if len(others) > 1 else float("nan")
    # the same at every hour: the level's move by quarter of the local day, MIN_SIDE_DAYS training days each side
    wlo, whi = days[max(0, s - MIN_SIDE_DAYS)], days[min(len(days) - 1, s + MIN_SIDE_DAYS - 1)]
    quarter = (L.seconds % 86400) // 21600
    hour_moves = []
    for qd in range(4):
        a = L.level[(day >= wlo) & (day < days[s]) & (quarter == qd)]
        b = L.level[(day >= days[s]) & (day <= whi) & (quarter == qd)]
        a, b = a[np.isfinite(a)], b[np.isfinite(b)]
        hour_moves.append(float(b.mean() - a.mean()) if len(a) and len(b) else float("nan"))
    # the change's row: the jump's one-step residual within a day of the split (training rows)
    r = R[:, zi]
    fin = r[np.isfinite(r)]
    mad = 1.4826 * float(np.median(np.abs(fin - np.median(fin)))) if len(fin) else 0.0
    win = np.flatnonzero((day >= days[s - 1]) & (day <= days[s]) & np.isfinite(r))
    spike = None
    k0 = int(np.flatnonzero(day >= days[s])[0])
    if len(win):
        k = int(win[int(np.argmax(sign * r[win]))])
        if mad > 0 and sign * r[k] >= SPIKE_Z * mad:
            spike, k0 = float(r[k]), k + 1  # row k's residual is the step to k + 1: the new reading starts there
    # a split across days without training rows (a held-out week, a gap): a jump inside them is not seen
    bracket = None
    if days[s] - days[s - 1] > 1 and (spike is None or abs(spike) < MIN_JUMP_SHARE * abs(local)):
        last = np.flatnonzero(train & (day == days[s - 1]))
        first = np.flatnonzero(train & (day == days[s]))
        if len(last) and len(first):
            bracket, spike, k0 = sig.index[last[-1]].isoformat(), None, int(first[0])
    k0 = min(k0, len(sig.index) - 1)
    others_at_jump = {}
    if spike is not None:
        for j in others:
            v = R[k0 - 1, j]
            others_at_jump[sig.zones[j]] = None if not np.isfinite(v) else float(v)
    e = {
        "start": sig.index[k0].isoformat(),
        "local_jump_K": local,
        "move_by_quarter_day_K": hour_moves,
        "others_local_jump_K": jumps,
        "jump_residual_K": spike,
        "others_residual_at_jump_K": others_at_jump,
        "residual_mad_K": mad,
        "_k0": k0,
    }
    u = np.asarray(sig.U, float)[:, zi]
    pre, post = pre_rows & np.isfinite(u), post_rows & np.isfinite(u)
    if pre.any() and post.any():
        # a set point moved by the offset changes the airflow; a sensor read by no controller does not
        e["airflow_local_before"] = float(u[pre].mean())
        e["airflow_local_after"] = float(u[post].mean())
    if bracket is not None:
        e["after"] = bracket  # the change lies between the last training row before and ``start``
    return e


def _abrupt_fails(e: dict, shift: float, sign: float, what: str = "") -> list:
    """Size and abruptness of one change (``e`` from :func:`_edge`) against the whole shift ``shift``."""
    local = e["local_jump_K"]
    fails = []
    if abs(local) < MIN_OFFSET_K:
        fails.append(f"{what}the level moves {local:+.2f} K at the split, under {MIN_OFFSET_K:g} K")
    if sign * local < MIN_LOCAL_SHARE * abs(shift):
        fails.append(
            f"{what}gradual: the {LOCAL_DAYS} training days each side differ by {local:+.2f} K, under "
            f"{MIN_LOCAL_SHARE:g} of the shift {shift:+.2f} K"
        )
    return fails


def _shape_fails(e: dict, t: float, shift: float, sign: float, what: str = "") -> list:
    """The same at every hour, one zone, and a jump (or a clear split across a bracket) at one change."""
    local, hour_moves, jumps = e["local_jump_K"], e["move_by_quarter_day_K"], e["others_local_jump_K"]
    spike, bracket, start = e["jump_residual_K"], e.get("after"), e["start"]
    fails = []
    uneven = [q for q, m in enumerate(hour_moves) if not sign * m >= MIN_HOUR_SHARE * abs(local)]
    if uneven:
        fails.append(
            f"{what}not the same at every hour: over {MIN_SIDE_DAYS} training days each side the level moves "
            + ", ".join(f"{6 * q:02d}-{6 * q + 6:02d} h {m:+.2f} K" for q, m in enumerate(hour_moves))
            + f"; under {MIN_HOUR_SHARE:g} of the jump {local:+.2f} K at "
            + ", ".join(f"{6 * q:02d}-{6 * q + 6:02d}" for q in uneven)
            + " (an offset of the reading moves every hour alike; a heater or a control loop moves some)"
        )
    floor = [o for o, v in jumps.items() if np.isfinite(v) and abs(v) >= MAX_OTHER_SHARE * abs(local)]
    if floor:
        fails.append(
            f"{what}zone(s) {', '.join(floor)} move against the rest at that date too (not one zone's reading)"
        )
    if bracket is not None:
        # no jump to see: a stricter split stands in for it (see MIN_GAP_OFFSET_K)
        if abs(t) < MIN_GAP_T or abs(local) < MIN_GAP_OFFSET_K or sign * local < MIN_GAP_LOCAL_SHARE * abs(shift):
            fails.append(
                f"{what}the split falls on days without training rows ({bracket[:10]} .. {start[:10]}), where the "
                f"jump cannot be seen, and is not clear enough without it (t {t:.1f}, needs {MIN_GAP_T:g}; move "
                f"{local:+.2f} K, needs {MIN_GAP_OFFSET_K:g} K and {MIN_GAP_LOCAL_SHARE:g} of the shift {shift:+.2f} K)"
            )
    elif spike is None:
        fails.append(
            f"{what}no jump: no one-step residual of {SPIKE_Z:g} robust standard deviations "
            f"({SPIKE_Z * e['residual_mad_K']:.2f} K) in the training rows within a day of the split (a reading that "
            "steps leaves one)"
        )
    else:
        if abs(spike) < MIN_JUMP_SHARE * abs(local):
            fails.append(
                f"{what}the one-step residual at the jump {spike:+.2f} K is under {MIN_JUMP_SHARE:g} of the level's "
                f"move {local:+.2f} K (a reading that steps by δ leaves a residual of about δ)"
            )
        others = e["others_residual_at_jump_K"]
        big = [o for o, v in others.items() if v is not None and abs(v) >= MAX_OTHER_SHARE * abs(spike)]
        if big:
            fails.append(f"{what}zone(s) {', '.join(big)} jump at the same step (the floor, not one sensor)")
    return fails


def _day_bic(means: np.ndarray, cuts: list, k: int) -> float:
    """BIC of the day means as piecewise constant between ``cuts`` (indices), with ``k`` parameters. Two cuts: the
    days between them against the days outside (one mean for before and after: a return)."""
    if len(cuts) == 1:
        parts = [means[: cuts[0]], means[cuts[0] :]]
    else:
        parts = [means[cuts[0] : cuts[1]], np.concatenate([means[: cuts[0]], means[cuts[1] :]])]
    rss = sum(float(((p - p.mean()) ** 2).sum()) for p in parts)
    n = len(means)
    return float(n * np.log(max(rss, 1e-12) / n) + k * np.log(n))


def _segment(L: _Level, bounds, means: np.ndarray) -> tuple[np.ndarray, np.ndarray, int, float]:
    """The segment of training days between accepted change dates (``bounds``, ISO) holding the best split, its days
    and means, the split's index in it and its t (``-1`` when no segment has :data:`MIN_SIDE_DAYS` days each side)."""
    edges = []
    for b in bounds:
        at = np.flatnonzero(np.asarray(L.index >= pd.Timestamp(b)))
        if len(at):
            edges.append(L.day[at[0]])
    cut = np.searchsorted(L.days, sorted(set(edges)))
    best = (L.days[:0], means[:0], -1, 0.0)
    for lo, hi in zip(np.concatenate([[0], cut]), np.concatenate([cut, [len(L.days)]])):
        d, m = L.days[lo:hi], means[lo:hi]
        s, t = best_split(d, m)
        if s >= 0 and abs(t) > abs(best[3]):
            best = (d, m, s, t)
    return best


def offset_candidate(sig, R: np.ndarray, zi: int, bounds=()) -> Candidate | None:
    """The ``sensor_offset`` candidate of zone ``zi`` (training rows only), or None when the data cannot place one.

    ``R`` (n, nz): one-step residuals, NaN outside the training rows. The level is the zone's reading minus the
    median of the other zones' (a change of weather or schedule moves every zone); its training days' means are
    split where they differ most (Welch t), and the change's row is the jump's one-step residual within a day of
    that split (see the module docstring for the evidence). ``bounds``: the zone's accepted change dates (ISO); the
    split is then searched between them (a second change), on day means with each day of the week's own mean taken
    out (the 3-day windows of a change on a Monday otherwise compare a weekend with weekdays: quad4 2078's second
    change, +1.5 K in SE, moved +0.52 K locally and its neighbours 0.45-0.78 K; with them taken out +1.04 K and
    0.06-0.21 K). Without them, a change and its return (:func:`interval_candidate`, a sensor put back) is tried and
    named when it passes its evidence and the one change does not, or describes the day means better.
    """
    z = sig.zones[zi]
    if sig.nz < 2:
        return None
    L = _level(sig, R, zi)
    if len(L.days) < 2 * MIN_SIDE_DAYS:
        return None
    if bounds:  # a further change: day means with each day of the week's own mean taken out, as for a return
        days, means, s, t = _segment(L, bounds, L.weekly)
    else:
        days, means, s, t = L.days, L.means, *best_split(L.days, L.means)
    if s < 0:
        return None
    before, after = means[:s], means[s:]
    shift = float(after.mean() - before.mean())
    sign = 1.0 if shift >= 0 else -1.0
    e = _edge(sig, L, days, means, s, sign, weekly=bool(bounds))
    start, local = e["start"], e["local_jump_K"]
    half = len(after) // 2
    persist = [float(after[:half].mean() - before.mean()), float(after[half:].mean() - before.mean())]
    ev = {
        "start": start,
        "split_t": float(t),
        "offset_K": shift,
        "local_jump_K": local,
        "days_before": int(len(before)),
        "days_after": int(len(after)),
        "persist_halves_K": persist,
        **{k: v for k, v in e.items() if k not in ("start", "local_jump_K", "_k0")},
    }
    if bounds:
        ev["between_changes"] = [str(days[0]), str(days[-1])]  # the segment searched (local day numbers)
        ev["accepted_changes"] = list(bounds)
    loc = {"zone": z, "start": start}
    if e.get("after") is not None:
        loc["after"] = e["after"]
    c = Candidate(SensorOffset.cause, loc, [SensorOffset(zone=z, start=start)], 1, evidence=ev)
    fails = []
    if abs(t) < MIN_SPLIT_T:
        fails.append(f"the best split of the zone's level against the others has t {t:.1f} < {MIN_SPLIT_T:g}")
    fails += _abrupt_fails(e, shift, sign)
    if min(sign * p for p in persist) < MIN_PERSIST_SHARE * abs(local):
        fails.append(
            f"not persistent: the halves after it keep {persist[0]:+.2f} / {persist[1]:+.2f} K of the jump {local:+.2f} K"
        )
    fails += _shape_fails(e, t, shift, sign)
    if not bounds:
        # a change and its return: named instead when it passes its evidence and describes the days better (a
        # put-back can pass as one change at either end when the days between are a large share of the data)
        iv = interval_candidate(sig, L)
        if iv is not None and iv.status != "no evidence":
            wk = L.weekly
            one = _day_bic(wk, [s], 3)
            two = _day_bic(wk, iv.evidence["split_day_index"], 4)
            iv.evidence["day_bic_one_change"], iv.evidence["day_bic_change_and_return"] = one, two
            if fails or two < one:
                return iv
            ev["change_and_return"] = {"location": iv.location, "day_bic": [one, two]}
        elif iv is not None:  # its numbers, for the record (how close a clean zone comes)
            keep = ("split_t", "offset_K", "local_jump_K", "persist_halves_K", "return_K", "jump_residual_K")
            ev["change_and_return"] = {"location": iv.location, "reason": iv.reason}
            ev["change_and_return"].update({k: iv.evidence.get(k) for k in keep})
            back = iv.evidence["at_return"]
            ev["change_and_return"]["at_return"] = {k: back.get(k) for k in ("local_jump_K", "jump_residual_K")}
    if fails:
        c.status = "no evidence"
        c.reason = "; ".join(fails)
    return c


def interval_candidate(sig, L: _Level) -> Candidate | None:
    """A change and its return (a sensor re-calibrated, then put back): the days ``[s1:s2]`` whose level differs
    most from the days before and after (:func:`best_interval`), named as one term ``1[start <= t < end]``. The
    evidence of a change holds at both ends (abrupt, the same at every hour, one zone, a jump of its sign or a clear
    bracket), the days inside keep the shift over both halves, and the days after come back: they differ from the
    days before by less than :data:`MAX_RETURN_SHARE` of the shift (otherwise it is two changes, searched one at a
    time). The search and its evidence read the day means with each day of the week's own mean taken out."""
    z = sig.zones[L.zi]
    # the level's mean by day of the week taken out (zones differ in their weekend loads, which moves the ends of
    # a search over days by a weekend): each weekday holds about the same share of the days inside
    days, means = L.days, L.weekly
    s1, s2, t = best_interval(means)
    if s1 < 0:
        return None
    inside, outside = means[s1:s2], np.concatenate([means[:s1], means[s2:]])
    shift = float(inside.mean() - outside.mean())
    sign = 1.0 if shift >= 0 else -1.0
    e1 = _edge(sig, L, days, means, s1, sign, weekly=True)
    e2 = _edge(sig, L, days, means, s2, -sign, weekly=True)
    local = e1["local_jump_K"]
    half = len(inside) // 2
    persist = [float(inside[:half].mean() - outside.mean()), float(inside[half:].mean() - outside.mean())]
    returned = float(means[s2:].mean() - means[:s1].mean())
    ev = {
        "start": e1["start"],
        "end": e2["start"],
        "split_t": float(t),
        "offset_K": shift,
        "local_jump_K": local,
        "days_before": int(s1),
        "days_inside": int(s2 - s1),
        "days_after": int(len(means) - s2),
        "persist_halves_K": persist,
        "return_K": returned,
        **{k: v for k, v in e1.items() if k not in ("start", "local_jump_K", "_k0")},
        "at_return": {k: v for k, v in e2.items() if k != "_k0"},
        "split_day_index": [int(s1), int(s2)],  # of the training days
    }
    loc = {"zone": z, "start": e1["start"], "end": e2["start"]}
    if e1.get("after") is not None:
        loc["after"] = e1["after"]
    if e2.get("after") is not None:
        loc["end_after"] = e2["after"]
    term = SensorOffset(zone=z, start=e1["start"], end=e2["start"])
    c = Candidate(SensorOffset.cause, loc, [term], 2, evidence=ev)
    fails = []
    if abs(t) < MIN_SPLIT_T:
        fails.append(f"a change and its return: the days inside against the rest have t {t:.1f} < {MIN_SPLIT_T:g}")
    fails += _abrupt_fails(e1, shift, sign, "at the change: ")
    fails += _abrupt_fails(e2, shift, -sign, "at the return: ")
    if min(sign * p for p in persist) < MIN_PERSIST_SHARE * abs(local):
        fails.append(
            f"not persistent: the halves between the change and the return keep {persist[0]:+.2f} / "
            f"{persist[1]:+.2f} K of the jump {local:+.2f} K"
        )
    if abs(returned) > MAX_RETURN_SHARE * abs(shift):
        fails.append(
            f"no return: the days after differ from the days before by {returned:+.2f} K, over "
            f"{MAX_RETURN_SHARE:g} of the shift {shift:+.2f} K"
        )
    fails += _shape_fails(e1, t, shift, sign, "at the change: ")
    fails += _shape_fails(e2, t, shift, -sign, "at the return: ")
    if fails:
        c.status = "no evidence"
        c.reason = "; ".join(fails)
    return c
