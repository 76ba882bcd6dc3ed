"""Which zone each VAV box heats or cools, read from the data: a box mapped to the wrong zone is flagged.

A box delivers ``m c_p (T_in - T_zone)`` [kW] (``T_in``: its discharge air
``Td_<vav>``, else its unit's supply air) to the zone it serves, and that heat moves
the temperature of *that* zone, not the others'. Per zone, the central change
``T(k+1) - T(k-1)`` (blind to whether a logger stamps an interval's mean at its
start or its end: EnergyPlus and the emulator differ by a step) is regressed on a
baseline (hour of the day on working days and weekends, the zone's own temperature,
the other zones' mean, ``T_out``, facade irradiance) plus the heat of each other box
the building file maps to it, one coefficient each. The *evidence* that box ``v``
acts on zone ``z`` is the log-likelihood gained by adding ``v``'s heat,
``n/2 log(RSS without / RSS with)``, 0 when its coefficient comes out negative
(delivered heat cannot cool a zone). A box mapped to the wrong zone gains little in
its mapped zone and much in the zone it serves. In its own zone a box is weighed
against the baseline alone (a sibling box with the same airflow pattern would take its
evidence). ``zone_t`` also gives a day-clustered t of the difference; it is reported,
not used: the evidence of real swaps is concentrated in few days (t 1.7-4.7 on an
8-week emulator export for differences of 150-320 units).

Boxes that say nothing of their own (session 16): in another zone a box is weighed against that zone's own
boxes *and their supply air* (each box's inlet air, its central change and its airflow, free coefficients): a
small room held by the air its box blows in is explained by that air, not by a box sharing the air handler. A
box whose airflow is proportional to its air handler's other boxes' summed airflow (or both constant), or to the
airflow of a box of the other zone on the same unit (correlation from :data:`SAME_FLOW`), is not weighed in
another zone at all
(its heat differs from a sibling's only through its discharge air; a zone that swings with the unit's on/off
cycles seemed to follow any box of it: 33 false warnings on an EnergyPlus outpatient, now 0). Zone columns
whose boxes are all such boxes of one unit are not tested for an exchange among themselves
(:func:`check_zone_swaps`).

Thresholds (measured, README "What gets refused"): no box of a correct mapping in
the cached EnergyPlus and emulator exports passes them; see :func:`check_box_zones`.
The per-box map does not test a swapped ``Td_`` column: in EnergyPlus exports a box's heat
computed with another box's discharge air explains its zone better than its own in 3 of 12
correct files (a kitchen fed by transfer air from the dining room), as much as in real swaps.
:func:`check_discharge_swaps` (session 16) requires it both ways: box a's zone follows a's heat
computed with ``Td_b``, *and* box b's zone with ``Td_a`` (largest clean lead 37.9 units on 96
emulator and EnergyPlus exports, flagged from 50; benchmarks/tdswap_s16.md).

Zone temperature columns exchanged between two zones (:func:`check_zone_swaps`, session 16): per column and
per zone, the log-likelihood the zone's drivers (its boxes' summed heat computed with that column, its
facades' irradiance) gain over a baseline without irradiance. Exchanged columns ``T_a`` and ``T_b`` each
follow the other zone's drivers; a correct pair rarely has even one column doing so, never both (largest
lead of a clean pair 7.8 units on 105 EnergyPlus and emulator exports, flagged from 50).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

#: Specific heat of air [kJ/(kg K)]: box heat in kW from airflow in kg/s.
CP_KJ = 1.005
#: Boxes whose airflow and inlet have a value in fewer than this share of the usable rows are left out.
MIN_BOX_COVERAGE = 0.8
#: Rows with every zone's step change needed before the test runs (2 weeks of 15-minute steps).
MIN_ROWS = 1344
#: Evidence [log-likelihood units] that the other zone must gain over the mapped one before a box is flagged ...
ZONE_MARGIN = 50.0
#: ... and the least share of the box's evidence in the two zones that the other one must hold ...
ZONE_SHARE = 0.8
#: ... and more than this share of its evidence summed over every zone (a majority): a box whose heat "explains"
#: several zones alike follows what they share (its unit's schedule), not one zone it serves. Session 21: the DOE
#: 2004 large hotel's laundry box (1.8-3.8 kg/s, evidence 0 in the laundry) scored 398 in Storage, 254 in Mech, 161
#: in Retail_1 and 83 in Cafe and was flagged as serving Storage (44 % of its evidence); on 30 cached EnergyPlus
#: exports (4 weeks) the two remaining clean false alarms held 27 % and 24 %, and 69 random box swaps went from 27
#: to 23 detections (lost: two that named the right zone at 45 % and 29 %, two that named a wrong zone anyway).
ZONE_CONCENTRATION = 0.5


@dataclasses.dataclass
class BoxZoneEvidence:
    """Result of :func:`box_zone_evidence`.

    ``zone[v][z]``: evidence that box ``v``'s heat moves zone ``z``'s temperature;
    ``rows``: rows used; ``boxes``: the boxes tested; ``zone_t[v]``: ``(zone, t)`` for
    a box whose evidence is larger in another zone than in its own: that zone and
    the day-clustered t of the difference.
    """

    zone: dict
    rows: int
    boxes: tuple
    zone_t: dict


def _baseline(frame: pd.DataFrame, zone_cols: list, j: int) -> np.ndarray:
    """Regressors every zone's step change is explained by before any box: hour x day type, own, others, weather."""
    idx = frame.index
    n = len(frame)
    slot = np.asarray(idx.hour) + 24 * np.asarray(idx.day_of_week >= 5)
    dummies = np.zeros((n, 48))
    dummies[np.arange(n), slot] = 1.0
    cols = [dummies, frame[zone_cols[j]].to_numpy(dtype=float)[:, None]]
    others = [c for i, c in enumerate(zone_cols) if i != j]
    if others:
        cols.append(frame[others].to_numpy(dtype=float).mean(axis=1)[:, None])
    for c in ("T_out", "I_N", "I_E", "I_S", "I_W"):
        if c in frame.columns:
            cols.append(frame[c].to_numpy(dtype=float)[:, None])
    return np.hstack(cols)


def _inlet(frame: pd.DataFrame, building, vav: str) -> np.ndarray | None:
    td = f"Td_{vav}"
    if td in frame.columns and np.isfinite(frame[td].to_numpy(dtype=float)).mean() >= 0.5:
        return frame[td].to_numpy(dtype=float)
    for c in (building.supply_column(vav), "T_supply"):
        if c in frame.columns:
            return frame[c].to_numpy(dtype=float)
    return None


def _rss(G: np.ndarray, W: np.ndarray) -> float:
    """Residual sum of squares of column 0 regressed on the combinations ``W`` of the other columns (Gram ``G``)."""
    if W.shape[1] == 0:
        return float(G[0, 0])
    A = W.T @ G[1:, 1:] @ W
    b = W.T @ G[1:, 0]
    coef = np.linalg.lstsq(A, b, rcond=1e-10)[0]
    return float(G[0, 0] - b @ coef)


def _gain(G: np.ndarray, base: np.ndarray, x: np.ndarray, n: int) -> float:
    """Log-likelihood gained by adding combination ``x`` to combinations ``base``; 0 for a coefficient <= 0."""
    both = np.column_stack([base, x])
    A = both.T @ G[1:, 1:] @ both
    b = both.T @ G[1:, 0]
    coef = np.linalg.lstsq(A, b, rcond=1e-10)[0]
    if not coef[-1] > 0:
        return 0.0
    rss0, rss1 = _rss(G, base), float(G[0, 0] - b @ coef)
    if not (rss0 > 0 and rss1 > 0):
        return 0.0
    return max(0.0, 0.5 * n * float(np.log(rss0 / rss1)))


def _usable(frame: pd.DataFrame, building):
    """Zones, zone temperatures, central changes, usable rows, baselines and the boxes' airflow and inlet air.

    None without two zones and their columns or without :data:`MIN_ROWS` usable rows or any box.
    """
    zones = list(building.zone_names)
    zone_cols = [f"T_{z}" for z in zones]
    if len(zones) < 2 or any(c not in frame.columns for c in zone_cols):
        return None
    T = frame[zone_cols].to_numpy(dtype=float)
    dT = np.full_like(T, np.nan)
    dT[1:-1] = T[2:] - T[:-2]
    ok = np.isfinite(dT).all(axis=1) & np.isfinite(T).all(axis=1)
    base = [_baseline(frame, zone_cols, j) for j in range(len(zones))]
    for X in base:
        ok &= np.isfinite(X).all(axis=1)
    if ok.sum() < MIN_ROWS:
        return None
    m, tin = {}, {}
    for v in building.vavs:
        col = f"m_{v.name}"
        inlet = _inlet(frame, building, v.name)
        if col not in frame.columns or inlet is None:
            continue
        flow = frame[col].to_numpy(dtype=float)
        have = np.isfinite(flow) & np.isfinite(inlet)
        if have[ok].mean() >= MIN_BOX_COVERAGE:
            m[v.name], tin[v.name] = flow, inlet
    for v in m:
        ok &= np.isfinite(m[v]) & np.isfinite(tin[v])
    if int(ok.sum()) < MIN_ROWS or not m:
        return None
    return zones, T, dT, ok, base, m, tin


def box_zone_evidence(frame: pd.DataFrame, building) -> BoxZoneEvidence | None:
    """Evidence of each box's heat in each zone (see the module); None without enough rows or boxes."""
    got = _usable(frame, building)
    if got is None:
        return None
    zones, T, dT, ok, base, m, tin = got
    n = int(ok.sum())
    boxes = tuple(m)
    mapped = {z: [v for v in boxes if building.vav(v).zone == z] for z in zones}
    day = frame.index[ok].normalize().asi8
    zone_ev = {v: {} for v in boxes}
    shared = _shared_flow(m, ok, building)
    same = _same_pattern(np.column_stack([m[v][ok] for v in boxes]))
    unit = np.array([building.supply_column(v) for v in boxes])
    same &= unit[:, None] == unit[None, :]  # boxes on different units differ by their units' supply air
    fits = {}
    for j, z in enumerate(zones):
        Tz = T[ok, j]
        supply = _supply_drivers(m, tin, ok, mapped[z])
        Z = np.column_stack([dT[ok, j], *(CP_KJ * m[v][ok] * (tin[v][ok] - Tz) for v in boxes), supply])
        q, _ = np.linalg.qr(base[j][ok])
        Zx = Z - q @ (q.T @ Z)
        fits[z] = (Zx, Zx.T @ Zx)
        G = fits[z][1]
        k, e = len(boxes), supply.shape[1]
        own_drivers = np.vstack([np.zeros((k, e)), np.eye(e)])
        for i, v in enumerate(boxes):
            # in its own zone a box is weighed against the baseline alone: a sibling box with the same airflow
            # pattern would otherwise take its evidence; elsewhere against that zone's own boxes and their supply
            # air (its level and its change, and the boxes' airflow, free coefficients): a zone whose air follows
            # the air its own boxes blow in (a small room at constant flow) is explained by it, not by a box that
            # shares its air handler
            if building.vav(v).zone == z:
                zone_ev[v][z] = _gain(G, np.zeros((k + e, 0)), _unit(k + e, i), n)
            else:
                here = np.vstack([_others(boxes, mapped[z], v), np.zeros((e, len(mapped[z]) - (v in mapped[z])))])
                same_flow = shared[v] or any(same[i, boxes.index(w)] for w in mapped[z])
                zone_ev[v][z] = 0.0 if same_flow else _gain(G, np.hstack([here, own_drivers]), _unit(k + e, i), n)
    zone_t = {}
    for i, v in enumerate(boxes):
        z0 = building.vav(v).zone
        alt = max((z for z in zones if z != z0), key=lambda z: zone_ev[v][z])
        if zone_ev[v][alt] > zone_ev[v][z0]:
            d = _row_gain(fits[alt], boxes, mapped[alt], v, i) - _row_gain(fits[z0], boxes, [], v, i)
            zone_t[v] = (alt, _clustered_t(d, day))
    return BoxZoneEvidence(zone=zone_ev, rows=n, boxes=boxes, zone_t=zone_t)


def _supply_drivers(m: dict, tin: dict, ok: np.ndarray, here: list) -> np.ndarray:
    """Per box of a zone: its inlet air, the central change of it, and its airflow (rows ``ok``), one column each."""
    cols = []
    for v in here:
        t = tin[v]
        d = np.full_like(t, np.nan)
        d[1:-1] = t[2:] - t[:-2]
        cols += [t[ok], np.nan_to_num(d[ok]), m[v][ok]]
    return np.column_stack(cols) if cols else np.zeros((int(ok.sum()), 0))


#: Correlation of two boxes' airflow from which they are taken to share one pattern (a schedule at fixed flow).
SAME_FLOW = 0.99


def _shared_flow(m: dict, ok: np.ndarray, building) -> dict:
    """Per box: whether its airflow follows the summed airflow of its air handler's other boxes (or both are constant).

    Such a box (every box of a unit at fixed flow, the unit cycling on and off) says nothing of its own about
    where its air goes: its heat differs from any sibling's only through its discharge air, and a zone that
    swings with the unit's cycles seems to follow it. Its heat is not weighed in another zone. A box alone on its
    unit is never shared: at constant flow, its unit's supply air is its own (a packaged single-zone unit).
    """
    unit = {v: building.supply_column(v) for v in m}
    shared = {}
    for v in m:
        rest = [m[w][ok] for w in m if unit[w] == unit[v] and w != v]
        shared[v] = bool(rest) and _collinear(m[v][ok], np.sum(rest, axis=0))
    return shared


def _same_pattern(flows: np.ndarray) -> np.ndarray:
    """Boolean matrix: whether the airflows of boxes i and j (columns) are proportional (see :func:`_collinear`)."""
    sd = flows.std(axis=0)
    const = sd == 0
    z = (flows - flows.mean(axis=0)) / np.where(const, 1.0, sd)
    same = (z.T @ z) / len(flows) >= SAME_FLOW
    same[np.ix_(const, const)] = True
    same[np.ix_(const, ~const)] = False
    same[np.ix_(~const, const)] = False
    return same


def _collinear(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether airflows ``a`` and ``b`` are proportional to each other (correlation from :data:`SAME_FLOW`)."""
    return bool(_same_pattern(np.column_stack([a, b]))[0, 1])


def _unit(k: int, i: int) -> np.ndarray:
    u = np.zeros(k)
    u[i] = 1.0
    return u


def _others(boxes: tuple, here: list, v: str) -> np.ndarray:
    """The heat of each box the zone has besides ``v``, one column each (selections of the boxes' heat columns)."""
    k = len(boxes)
    rest = [boxes.index(w) for w in here if w != v]
    w = np.zeros((k, len(rest)))
    w[rest, np.arange(len(rest))] = 1.0
    return w


def _row_gain(fit, boxes, here, v, col) -> np.ndarray:
    """Per-row log-likelihood gained by adding column ``col`` to the zone's other boxes (0 for a coefficient <= 0)."""
    Zx, _ = fit
    y = Zx[:, 0]
    base = _others(boxes, here, v)
    A0 = Zx[:, 1 : 1 + len(boxes)] @ base
    r0 = y - A0 @ np.linalg.lstsq(A0, y, rcond=None)[0] if base.shape[1] else y
    A1 = np.column_stack([A0, Zx[:, 1 + col]])
    coef = np.linalg.lstsq(A1, y, rcond=None)[0]
    if not coef[-1] > 0:
        return np.zeros(len(y))
    r1 = y - A1 @ coef
    return (r0 * r0 - r1 * r1) / (2.0 * float(np.mean(r0 * r0)))


def _clustered_t(d: np.ndarray, day: np.ndarray) -> float:
    """Sum of per-row differences over its standard error with days as independent clusters."""
    _, inv = np.unique(day, return_inverse=True)
    sums = np.bincount(inv, weights=d)
    k = len(sums)
    if k < 2:
        return 0.0
    se = np.sqrt(k / (k - 1) * float(np.sum((sums - sums.mean()) ** 2)))
    return float(d.sum() / se) if se > 0 else 0.0


def check_box_zones(frame: pd.DataFrame, building) -> list[str]:
    """Warnings for boxes whose delivered heat moves another zone's temperature far more than their mapped zone's.

    A box is flagged when, against its mapped zone, another zone gains at least
    :data:`ZONE_MARGIN` more evidence, holds at least :data:`ZONE_SHARE` of the box's
    evidence in the two and :data:`ZONE_CONCENTRATION` of its evidence in all zones.
    """
    ev = box_zone_evidence(frame, building)
    if ev is None:
        return []
    notes = []
    for v in ev.boxes:
        if v not in ev.zone_t:
            continue
        alt, t = ev.zone_t[v]
        z0 = building.vav(v).zone
        own, other = ev.zone[v][z0], ev.zone[v][alt]
        if other - own < ZONE_MARGIN or other < ZONE_SHARE * (own + other):
            continue
        if other < ZONE_CONCENTRATION * sum(ev.zone[v].values()):
            continue
        notes.append(
            f"box {v}: its delivered heat m_{v} c_p (T_in - T_zone) explains the temperature changes of zone {alt} "
            f"far better than those of zone {z0}, the zone the building file gives it (evidence {other:.0f} against "
            f"{own:.0f} log-likelihood units over {ev.rows} steps, day-clustered t = {t:.1f}; flagged from "
            f"{ZONE_MARGIN:g} more and a {100 * ZONE_SHARE:g} % share): is box {v} mapped to the wrong "
            f'zone? If it serves {alt}, set zone = "{alt}" in its [[vavs]] entry (name = "{v}") of the building '
            f"file; otherwise check that columns m_{v} and T_{z0} / T_{alt} are mapped to the right points"
        )
    return notes


@dataclasses.dataclass
class ZonePairEvidence:
    """Result of :func:`zone_pair_evidence`.

    ``gain[a][z]``: log-likelihood that zone ``z``'s drivers gain in explaining the central change of column
    ``T_a``: its boxes' delivered heat (computed with ``T_a``), and the irradiance of its facades;
    ``boxes_only[a][z]``: the same with the heat alone; ``sunlit``: the zones with facades whose irradiance
    is in the data; ``rows``: rows used; ``one_pattern[z]``: the air handler of zone ``z`` when all its boxes are
    on one unit at that unit's airflow pattern (see :func:`_shared_flow`).
    """

    gain: dict
    boxes_only: dict
    sunlit: frozenset
    rows: int
    one_pattern: dict = dataclasses.field(default_factory=dict)

    def swap(self, a: str, b: str) -> tuple[float, float]:
        """(own, swapped): evidence of the mapping as declared and with columns ``T_a`` and ``T_b`` exchanged.

        The sun counts only when both zones have facades: an interior zone has no irradiance of its own, and
        any column gains a little from a facade's irradiance (it moves with the weather and the day).
        """
        g = self.gain if a in self.sunlit and b in self.sunlit else self.boxes_only
        return g[a][a] + g[b][b], g[a][b] + g[b][a]


def zone_pair_evidence(frame: pd.DataFrame, building) -> ZonePairEvidence | None:
    """How well each zone column's changes follow each zone's drivers; None without enough rows or boxes.

    Per column ``T_a``, the central change is regressed on the baseline of :func:`box_zone_evidence` without
    irradiance, then on one zone's drivers at a time: the sum of its boxes' heat ``m c_p (T_in - T_a)`` (one
    coefficient) and the irradiance ``I_<o>`` of each of its facades; coefficients are kept non-negative (heat
    delivered and sun on a facade warm a zone).
    """
    from scipy.optimize import nnls

    got = _usable(frame, building)
    if got is None:
        return None
    zones, T, dT, ok, base, m, tin = got
    n = int(ok.sum())
    irr = [c for c in ("I_N", "I_E", "I_S", "I_W") if c in frame.columns]
    sun = {z: [irr.index(f"I_{o}") for o in building.zone(z).orientations if f"I_{o}" in irr] for z in zones}
    # a zone's heat with column T_a is c_p (sum m T_in - T_a sum m): two sums per zone serve every column
    boxes = {z: [v for v in m if building.vav(v).zone == z] for z in zones}
    shared = _shared_flow(m, ok, building)
    units = {z: {building.supply_column(v) for v in boxes[z]} for z in zones}
    one_pattern = {z: next(iter(units[z])) for z in zones if len(units[z]) == 1 and all(shared[v] for v in boxes[z])}
    flow = np.column_stack([sum((m[v][ok] for v in boxes[z]), np.zeros(n)) for z in zones])
    flow_in = np.column_stack([sum((m[v][ok] * tin[v][ok] for v in boxes[z]), np.zeros(n)) for z in zones])
    sunlight = np.column_stack([frame[c].to_numpy(dtype=float)[ok] for c in irr]) if irr else np.zeros((n, 0))

    def gain(G, g, yy, cols):
        """Log-likelihood of the non-negative fit of y on the columns ``cols`` (Gram ``G``, ``g`` = D'y)."""
        A, b = G[np.ix_(cols, cols)], g[cols]
        scale = np.sqrt(np.diag(A))
        if not (scale > 0).all():
            return 0.0
        A, b = A / np.outer(scale, scale), b / scale
        try:
            L = np.linalg.cholesky(A + 1e-12 * np.eye(len(cols)))
        except np.linalg.LinAlgError:
            return 0.0
        c = np.linalg.solve(L, b)
        x, r = nnls(L.T, c)  # ||L'x - c||^2 = x'Ax - 2 x'b + c'c
        rss1 = yy - float(c @ c) + float(r * r)
        return max(0.0, 0.5 * n * float(np.log(yy / rss1))) if yy > 0 and rss1 > 0 else 0.0

    full: dict = {}
    heat_only: dict = {}
    nz = len(zones)
    for j, a in enumerate(zones):
        q, _ = np.linalg.qr(base[j][ok][:, : base[j].shape[1] - len(irr)])  # the baseline ends with irradiance
        D = np.column_stack([dT[ok, j], CP_KJ * (flow_in - T[ok, j][:, None] * flow), sunlight])
        D = D - q @ (q.T @ D)
        G = D.T @ D
        yy, G, g = float(G[0, 0]), G[1:, 1:], G[1:, 0]
        full[a], heat_only[a] = {}, {}
        for k, z in enumerate(zones):
            cols = ([k] if boxes[z] else []) + [nz + i for i in sun[z]]
            full[a][z] = gain(G, g, yy, cols) if cols else 0.0
            heat_only[a][z] = gain(G, g, yy, [k]) if boxes[z] else 0.0
    return ZonePairEvidence(
        gain=full, boxes_only=heat_only, sunlit=frozenset(z for z in zones if sun[z]), rows=n, one_pattern=one_pattern
    )


#: Evidence [log-likelihood units] by which *each* of two zone columns must follow the other zone's drivers
#: better than its own before the pair is flagged as swapped ...
SWAP_MARGIN = 50.0
#: ... and the least share of the pair's evidence (both columns, both mappings) the exchanged mapping must hold.
SWAP_SHARE = 0.6


def check_zone_swaps(frame: pd.DataFrame, building) -> list[str]:
    """Warnings for zone temperature columns that look exchanged (see :func:`zone_pair_evidence`).

    Columns ``T_a`` and ``T_b`` are flagged when ``T_a`` follows zone ``b``'s drivers better than zone ``a``'s
    by at least :data:`SWAP_MARGIN` and ``T_b`` follows zone ``a``'s better than its own by as much, and the
    exchanged mapping holds at least :data:`SWAP_SHARE` of the pair's evidence. One column needs the other to
    prefer it back: a box whose heat moves every zone a little (a big core box on a shared air handler) makes
    one column prefer it, never both. Three columns rotated (``T_a`` holds b, ``T_b`` holds c, ``T_c`` holds a)
    are flagged by the same rule around the cycle. A zone is named once at most: the exchange whose columns gain
    most in all (sum of the leads) first.
    """
    ev = zone_pair_evidence(frame, building)
    if ev is None:
        return []
    zones = list(ev.gain)

    def edge(a, b):
        """(lead of column T_a for zone b over zone a, evidence for b, for a, with the sun counted)."""
        g = ev.gain if a in ev.sunlit and b in ev.sunlit else ev.boxes_only
        return g[a][b] - g[a][a], g[a][b], g[a][a], g is ev.gain

    found = []
    for i, a in enumerate(zones):
        for b in zones[i + 1 :]:
            found.append((a, b))
    strong = {(a, b) for a in zones for b in zones if a != b and edge(a, b)[0] >= SWAP_MARGIN}
    for a, b in strong:
        for c in zones:
            if (b, c) in strong and (c, a) in strong and c != a and a == min(a, b, c):
                found.append((a, b, c))
    cycles = []
    for cyc in found:
        if len({ev.one_pattern.get(z) for z in cyc}) == 1 and cyc[0] in ev.one_pattern:
            # every box of these zones on one unit at its airflow pattern: their drivers differ only by the boxes'
            # discharge air (a small room swinging with the unit's cycles follows any of them)
            continue
        steps = [edge(x, cyc[(k + 1) % len(cyc)]) for k, x in enumerate(cyc)]
        lead = min(e[0] for e in steps)
        theirs, own = sum(e[1] for e in steps), sum(e[2] for e in steps)
        if lead >= SWAP_MARGIN and theirs >= SWAP_SHARE * (theirs + own):
            cycles.append((sum(e[0] for e in steps), cyc, steps))
    notes, named = [], set()
    for _gain, cyc, steps in sorted(cycles, key=lambda x: -x[0]):  # the exchange that explains most first
        if named & set(cyc):
            continue
        named |= set(cyc)
        col = {z: building.column_for(f"T_{z}") for z in cyc}
        nxt = {z: cyc[(k + 1) % len(cyc)] for k, z in enumerate(cyc)}
        sun = all(e[3] for e in steps)
        drivers = "the heat its boxes deliver" + (" and the sun on its facades" if sun else "")
        a, b = cyc[0], cyc[1]
        (_, ab, aa, _), rest = steps[0], steps[1:]
        others = "; ".join(
            f"those in column {col[z]!r} follow zone {nxt[z]}'s ({e[1]:.0f} against {e[2]:.0f})"
            for z, e in zip(cyc[1:], rest)
        )
        what = "look swapped" if len(cyc) == 2 else "look rotated"
        names = (
            " and ".join(f"{col[z]!r} (T_{z})" for z in cyc)
            if len(cyc) == 2
            else (", ".join(f"{col[z]!r} (T_{z})" for z in cyc))
        )
        fix = ", ".join(f'T_{nxt[z]} = "{col[z]}"' for z in cyc)
        notes.append(
            f"columns {names} {what}: the temperature changes in column {col[a]!r} follow zone {b}'s drivers "
            f"({drivers}) far better than zone {a}'s (evidence {ab:.0f} against {aa:.0f} log-likelihood units over "
            f"{ev.rows} steps), and {others}; flagged when each column prefers the other zone by {SWAP_MARGIN:g} or "
            f"more. If the sensors' points are exchanged in the export or the mapping, map them the other way round "
            f"in the building's [columns] table ({fix}); otherwise check that the boxes of zones "
            f"{', '.join(cyc[:-1])} and {cyc[-1]} are mapped to the right zones in [[vavs]]"
        )
    return notes


@dataclasses.dataclass
class DischargePairEvidence:
    """Result of :func:`discharge_pair_evidence`.

    ``own[v]``: log-likelihood that box ``v``'s heat ``m_v c_p (Td_v - T_zone)`` gains in explaining its zone's
    central change, over the zone's other boxes; ``other[v][w]``: the same with box ``w``'s discharge air
    ``Td_w`` in place of ``Td_v`` (boxes ``w`` of other zones); ``rows``: rows used.
    """

    own: dict
    other: dict
    rows: int

    def lead(self, a: str, b: str) -> tuple[float, float]:
        """(lead of ``Td_b`` over ``Td_a`` in box a's zone, lead of ``Td_a`` over ``Td_b`` in box b's zone)."""
        return self.other[a][b] - self.own[a], self.other[b][a] - self.own[b]


def discharge_pair_evidence(frame: pd.DataFrame, building) -> DischargePairEvidence | None:
    """How well each box's heat explains its zone with its own discharge column and with each other zone's box's.

    Per zone, the central change and its boxes' heat are projected off the baseline of :func:`box_zone_evidence`
    (as there, with irradiance), then off the zone's other boxes; box ``v``'s heat computed with ``Td_v`` and with
    each ``Td_w`` of a box in another zone is then added alone: ``n/2 log(RSS without / RSS with)``, 0 for a
    coefficient <= 0. Only boxes whose inlet air is their own ``Td_`` column take part; None without two of them
    in different zones, or without enough rows.
    """
    got = _usable(frame, building)
    if got is None:
        return None
    zones, T, dT, ok, base, m, tin = got
    # boxes whose inlet air is their own Td_ column (see _inlet)
    td = [v for v in m if f"Td_{v}" in frame.columns and np.isfinite(frame[f"Td_{v}"].to_numpy(float)).mean() >= 0.5]
    zone_of = {v: building.vav(v).zone for v in m}
    if len({zone_of[v] for v in td}) < 2:
        return None
    n = int(ok.sum())
    own, other = {}, {}
    for j, z in enumerate(zones):
        here = [v for v in m if zone_of[v] == z]
        if not any(v in td for v in here):
            continue
        Tz = T[ok, j]
        q, _ = np.linalg.qr(base[j][ok])
        H = np.column_stack([dT[ok, j], *(CP_KJ * m[v][ok] * (tin[v][ok] - Tz) for v in here)])
        H = H - q @ (q.T @ H)
        for i, a in enumerate(here):
            if a not in td:
                continue
            rest = [k for k in range(len(here)) if k != i]
            alts = [w for w in td if zone_of[w] != z]
            X = np.column_stack([H[:, 1 + i], *(CP_KJ * m[a][ok] * (tin[w][ok] - Tz) for w in alts)])
            X[:, 1:] -= q @ (q.T @ X[:, 1:])
            y = H[:, 0]
            if rest:
                q2, _ = np.linalg.qr(H[:, [1 + k for k in rest]])
                y = y - q2 @ (q2.T @ y)
                X = X - q2 @ (q2.T @ X)
            rss0 = float(y @ y)
            c, xx = X.T @ y, np.einsum("ij,ij->j", X, X)
            with np.errstate(divide="ignore", invalid="ignore"):
                rss1 = rss0 - np.where(xx > 0, c * c / xx, 0.0)
                g = np.where((c > 0) & (rss1 > 0), 0.5 * n * np.log(rss0 / rss1), 0.0) if rss0 > 0 else 0.0 * c
            own[a] = float(g[0])
            other[a] = {w: float(x) for w, x in zip(alts, g[1:])}
    return DischargePairEvidence(own=own, other=other, rows=n)


#: Evidence [log-likelihood units] by which *each* of two boxes' heat must explain its zone better with the other
#: box's discharge column than with its own before the pair is flagged as swapped ...
TD_SWAP_MARGIN = 50.0
#: ... and the least share of the pair's evidence (both boxes, both columns) the exchanged columns must hold.
TD_SWAP_SHARE = 0.6


def check_discharge_swaps(frame: pd.DataFrame, building) -> list[str]:
    """Warnings for discharge-air columns ``Td_a`` and ``Td_b`` of boxes in different zones that look exchanged.

    Box a's heat computed with ``Td_b`` explains a's zone better than with ``Td_a`` by at least
    :data:`TD_SWAP_MARGIN`, *and* box b's with ``Td_a`` explains b's zone better than with ``Td_b`` by as much,
    and the exchanged columns hold at least :data:`TD_SWAP_SHARE` of the pair's evidence (see
    :func:`discharge_pair_evidence`). One direction is not enough: a zone fed by transfer air from another
    (an EnergyPlus kitchen from its dining room) follows that zone's box's discharge air. A box is named once
    at most: the pair with the largest summed lead first.
    """
    ev = discharge_pair_evidence(frame, building)
    if ev is None:
        return []
    pairs = []
    boxes = list(ev.own)
    for i, a in enumerate(boxes):
        for b in boxes[i + 1 :]:
            if b not in ev.other[a] or a not in ev.other[b]:
                continue
            la, lb = ev.lead(a, b)
            theirs, mine = ev.other[a][b] + ev.other[b][a], ev.own[a] + ev.own[b]
            if min(la, lb) >= TD_SWAP_MARGIN and theirs >= TD_SWAP_SHARE * (theirs + mine):
                pairs.append((la + lb, a, b))
    notes, named = [], set()
    for _lead, a, b in sorted(pairs, key=lambda p: -p[0]):
        if {a, b} & named:
            continue
        named |= {a, b}
        ca, cb = building.column_for(f"Td_{a}"), building.column_for(f"Td_{b}")
        za, zb = building.vav(a).zone, building.vav(b).zone
        notes.append(
            f"columns {ca!r} (Td_{a}) and {cb!r} (Td_{b}) look swapped: box {a}'s delivered heat m_{a} c_p "
            f"(Td - T_{za}) explains the temperature changes of its zone {za} far better with column {cb!r} than "
            f"with its own (evidence {ev.other[a][b]:.0f} against {ev.own[a]:.0f} log-likelihood units over "
            f"{ev.rows} steps), and box {b}'s explains zone {zb} better with column {ca!r} ({ev.other[b][a]:.0f} "
            f"against {ev.own[b]:.0f}); flagged when each box prefers the other's column by {TD_SWAP_MARGIN:g} or "
            f"more. If the discharge sensors' points are exchanged in the export or the mapping, map them the other "
            f'way round in the building\'s [columns] table (Td_{a} = "{cb}", Td_{b} = "{ca}"); otherwise check '
            f"that boxes {a} and {b} are mapped to the right zones in [[vavs]]"
        )
    return notes
