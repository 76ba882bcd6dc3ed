"""Supply air temperature while its air handler is off (issues #13/#15).

When every box of an air handler has (near) zero airflow, the unit's logged supply temperature reads an idle
duct node (EnergyPlus's idle supply node, the emulator's ``--schedule night-off``). A model that takes the
supply temperature as a linear input (Model A's airflow form, where ``C · T_supply`` and the ``A`` diagonal
linearise ``m c_p (T_supply − T)`` around the mean flow) then reads a temperature no air carries. Two
substitutions for those rows:

- ``"zone"``: the mean air temperature of the zones the unit serves (weighted by the boxes' ``m_max``): the
  mean-flow term ``m̄ c_p (T_supply − T)`` then vanishes, as the heat of a unit that moves no air does;
- ``"last"``: the unit's last running value: the term stays what it was while the unit last ran (a unit
  still blowing its mean flow at its last supply temperature).

The rule is plain data (JSON) so that a saved model can carry it and apply it to raw data.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from ..building import Building
from ..errors import DataError

MODES = ("zone", "last")

#: A box is shut at or below this fraction of its minimum airflow (with a floor, :func:`box_off_bounds`): the
#: box-off regime of the ``reheat`` cause (one box's own feature).
BOX_OFF_FRACTION = 0.05
#: An air handler is off in a row where every box it feeds is measured and reads at most this fraction of its
#: minimum airflow (:func:`unit_off_bounds`): a running box reads at least its minimum, a shut box reads sensor
#: noise (the emulator's: 0–0.01 kg/s, above 5 % of an ``m_min`` under 0.2 kg/s). The one rule of "the unit is
#: off": the idle rows of :func:`idle_supply_rule` (``diagnose``, both FMU kinds), ``fit(heat="auto")``'s
#: off share and the co-simulation's schedule (``harness.schedule``).
UNIT_OFF_FRACTION = 0.5
#: Floor of the off bound [kg/s] (a box with ``m_min`` 0 is off at 0 only).
OFF_FLOOR = 1e-6


def box_off_bounds(building: Building, fraction: float, floor: float) -> dict:
    """``{airflow column: bound [kg/s]}``: a box is off at or below ``max(floor, fraction · m_min)``.

    Measured airflow of a shut box is rarely exactly 0 (sensor noise: the emulator's reads up to ~0.01 kg/s).
    """
    return {f"m_{v.name}": max(float(floor), float(fraction) * float(v.m_min)) for v in building.vavs}


def unit_off_bounds(building: Building) -> dict:
    """``{airflow column: bound [kg/s]}`` of the unit-off rule: ``max(OFF_FLOOR, UNIT_OFF_FRACTION · m_min)``.

    An air handler is off in a row where every box it feeds is measured and at or below its bound
    (:func:`idle_rows`): :data:`UNIT_OFF_FRACTION`, :data:`OFF_FLOOR`.
    """
    return box_off_bounds(building, UNIT_OFF_FRACTION, OFF_FLOOR)


def idle_supply_rule(building: Building, columns, bounds: dict, mode: str = "zone") -> dict:
    """``{supply column: {"flows": {airflow column: off bound}, "zones": {T_<zone>: weight}}}``.

    ``T_supply`` (the single implicit unit, or the flow-weighted mean of several units) is idle only when every
    box is off; ``T_supply_<ahu>`` when every box of that unit is off; a measured discharge temperature
    ``Td_<vav>`` when its box is off. ``bounds``: :func:`unit_off_bounds` (the unit-off rule).
    ``mode`` ``"zone"`` adds the zones (weights: summed ``m_max`` of the unit's boxes in each zone); ``"last"``
    leaves them out (hold the last running value).
    """
    if mode not in MODES:
        raise ValueError(f"idle supply mode must be one of {MODES}, got {mode!r}")
    columns = set(columns)
    units = []
    if "T_supply" in columns:
        units.append(("T_supply", list(building.vavs)))
    for a in building.ahus:
        if a.supply_column in columns and a.supply_column != "T_supply":
            units.append((a.supply_column, [v for v in building.vavs if v.ahu == a.name]))
    # a shut box's measured discharge air Td_<vav> reads the same idle air (no airflow, no reheat)
    units += [(f"Td_{v.name}", [v]) for v in building.vavs if f"Td_{v.name}" in columns]
    rule = {}
    for col, vavs in units:
        if not vavs:
            continue
        spec: dict = {"flows": {f"m_{v.name}": bounds[f"m_{v.name}"] for v in vavs}}
        if mode == "zone":
            zones: dict = {}
            for v in vavs:
                zones[f"T_{v.zone}"] = zones.get(f"T_{v.zone}", 0.0) + float(v.m_max)
            spec["zones"] = zones
        rule[col] = spec
    return rule


def idle_rows(frame: pd.DataFrame, flows: dict) -> np.ndarray:
    """Rows where every airflow column of ``flows`` (``{column: bound}``) is measured and at most its bound."""
    m = frame[list(flows)].to_numpy(dtype=float)
    bound = np.array(list(flows.values()), dtype=float)
    return np.all(np.isfinite(m), axis=1) & np.all(m <= bound, axis=1)


def hold_idle_supply(frame: pd.DataFrame, rule: dict) -> tuple:
    """``frame`` with each supply column of ``rule`` replaced in its unit's idle rows.

    Idle rows: every airflow column of the unit measured and at most its bound (:func:`idle_supply_rule`).
    With ``zones``: the weighted mean of the zone temperatures measured in the row; otherwise (or where no zone
    temperature is measured) the column's last finite value in a row where a box of the unit had airflow
    (before the first such row: the first one). A unit that never runs is left as it is.

    Returns
    -------
    (DataFrame, dict)
        A copy with the substituted columns (the input when ``rule`` is empty) and ``{column: rows replaced}``.
    """
    if not rule:
        return frame, {}
    need = {c for col, spec in rule.items() for c in (col, *spec["flows"], *spec.get("zones", {}))}
    missing = sorted(need - set(frame.columns))
    if missing:
        raise DataError(f"replacing the idle supply temperature needs the frame columns {missing}")
    out = frame.copy()
    counts = {}
    for col, spec in rule.items():
        flows = spec["flows"]
        off = idle_rows(frame, flows)
        m = frame[list(flows)].to_numpy(dtype=float)
        ran = np.any(np.isfinite(m) & (m > np.array(list(flows.values()), dtype=float)), axis=1)
        t = frame[col].to_numpy(dtype=float)
        value = pd.Series(np.where(ran, t, np.nan), index=frame.index).ffill().bfill().to_numpy()
        zones = spec.get("zones")
        if zones:
            T = frame[list(zones)].to_numpy(dtype=float)
            w = np.where(np.isfinite(T), np.array(list(zones.values()), dtype=float), 0.0)
            with np.errstate(invalid="ignore", divide="ignore"):
                mean = np.nansum(T * w, axis=1) / w.sum(axis=1)
            value = np.where(np.isfinite(mean), mean, value)
        use = off & np.isfinite(value)
        if use.any():
            out[col] = np.where(use, value, t)
        counts[col] = int(use.sum())
    return out, counts


@dataclasses.dataclass(frozen=True)
class IdleStep:
    """An idle supply rule on one step's vectors: what the FMUs apply inside every model step.

    Built by :func:`idle_step`. Where :func:`hold_idle_supply` reads measured zone temperatures from a frame, a
    simulation (an FMU, :meth:`hvacfmu.models.extended.ExtendedModel.simulate_boxes`) has only its own: the
    zones' mean is then the weighted mean of the model's current zone temperatures (the outputs at the start
    of the step). ``"last"`` keeps the last running value in a small memory (NaN until the unit first runs:
    the raw value is used then, where :func:`hold_idle_supply` takes the first running value of the data).

    Attributes
    ----------
    mode : str
        ``"zone"`` or ``"last"`` (:data:`MODES`).
    target : tuple of int
        Index into the disturbance vector ``v`` of each replaced column.
    boxes, bounds : tuple of tuple
        Per replaced column: indices into the box airflow vector and their off bounds [kg/s].
    zones, weights : tuple of tuple
        Per replaced column: indices into the output vector and their weights (empty for ``"last"``).
    names : tuple of str
        The replaced columns.
    """

    mode: str
    target: tuple
    boxes: tuple
    bounds: tuple
    zones: tuple
    weights: tuple
    names: tuple

    def __len__(self) -> int:
        return len(self.target)

    def apply(self, v, m, T, last=None):
        """Disturbances ``v`` with each replaced column held while its unit is idle, and the new memory.

        Parameters
        ----------
        v : array (n_v,)
            Raw disturbances of the step (``T_supply`` ... as measured) [°C ...].
        m : array (n_box,)
            Box airflows of the step [kg/s].
        T : array (n_outputs,)
            The model's zone temperatures at the start of the step [°C].
        last : array (len(self),), optional
            Last running value of each replaced column (NaN: none yet; default all NaN).

        Returns
        -------
        (array (n_v,), array (len(self),))
            The disturbances to step with and the memory after this step.
        """
        v = np.array(v, dtype=float)
        raw = v.copy()
        m = np.asarray(m, dtype=float)
        T = np.asarray(T, dtype=float)
        last = np.full(len(self), np.nan) if last is None else np.array(last, dtype=float)
        for i, j in enumerate(self.target):
            off = bool(np.all(m[list(self.boxes[i])] <= np.asarray(self.bounds[i], dtype=float)))
            if not off:
                last[i] = raw[j]
                continue
            if self.zones[i]:
                w = np.asarray(self.weights[i], dtype=float)
                v[j] = float(np.sum(T[list(self.zones[i])] * w) / np.sum(w))
            elif np.isfinite(last[i]):
                v[j] = last[i]
        return v, last

    def to_dict(self) -> dict:
        """JSON-ready form (the FMUs' ``interface.json`` key ``idle_supply``)."""
        return {
            "mode": self.mode,
            "columns": [
                {
                    "name": self.names[i],
                    "target": int(self.target[i]),
                    "boxes": [int(b) for b in self.boxes[i]],
                    "bounds": [float(x) for x in self.bounds[i]],
                    "zones": [int(z) for z in self.zones[i]],
                    "weights": [float(w) for w in self.weights[i]],
                }
                for i in range(len(self))
            ],
        }

    @classmethod
    def from_dict(cls, d: dict) -> IdleStep:
        """The rule from :meth:`to_dict`."""
        cols = d["columns"]
        return cls(
            str(d["mode"]),
            tuple(int(c["target"]) for c in cols),
            tuple(tuple(int(b) for b in c["boxes"]) for c in cols),
            tuple(tuple(float(x) for x in c["bounds"]) for c in cols),
            tuple(tuple(int(z) for z in c["zones"]) for c in cols),
            tuple(tuple(float(w) for w in c["weights"]) for c in cols),
            tuple(str(c["name"]) for c in cols),
        )

    def describe(self, outputs=None) -> str:
        """One sentence for a model description: which inputs are replaced, when and by what."""
        parts = []
        for i, name in enumerate(self.names):
            what = (
                "the weighted mean of the FMU's own zone temperatures"
                + (f" ({', '.join(str(outputs[z]) for z in self.zones[i])})" if outputs is not None else "")
                if self.zones[i]
                else "its last value while a box of the unit ran"
            )
            parts.append(f"{name} by {what}")
        return (
            "Idle air handler (the model's idle_supply rule, as in its Python evaluation): in every model step "
            "where every box of a unit is at or below its off bound (the model's table; hvacfmu.data.idle."
            f"unit_off_bounds: max({OFF_FLOOR:g} kg/s, {100 * UNIT_OFF_FRACTION:g} % of m_min)), the FMU "
            "replaces its input " + "; ".join(parts) + " (the logged supply temperature of a unit that is off "
            "reads an idle duct no air carries); feed the raw measured values."
        )


def idle_step(meta, disturbances, boxes, outputs) -> IdleStep | None:
    """The idle rule of a model's ``meta["idle_supply"]`` on index positions, or None when it has none.

    Parameters
    ----------
    meta : dict or None
        A model's ``meta`` (``{"idle_supply": {"mode", "rule"}}``, written by ``diagnose``).
    disturbances : sequence of str
        The model's disturbance columns (a rule column that is not one of them is not an input: skipped).
    boxes : sequence of str
        Box names in the order of the airflow vector (``m_<box>`` columns).
    outputs : sequence of str
        The model's output names (zone ``z`` is column ``T_<z>``). A rule zone that is not an output maps to the
        single output of a one-output (lumped) model.

    Raises
    ------
    ValueError
        A rule's airflow column is not a box of ``boxes``, or a zone is not an output (several outputs).
    """
    idle = meta.get("idle_supply") if isinstance(meta, dict) else None
    if not idle or not idle.get("rule"):
        return None
    mode = idle.get("mode", "zone")
    if mode not in MODES:
        raise ValueError(f"idle supply mode must be one of {MODES}, got {mode!r}")
    vi = {c: i for i, c in enumerate(disturbances)}
    bi = {f"m_{b}": i for i, b in enumerate(boxes)}
    zi = {f"T_{z}": i for i, z in enumerate(outputs)}
    target, bx, bd, zs, ws, names = [], [], [], [], [], []
    for col, spec in idle["rule"].items():
        if col not in vi:
            continue
        unknown = [c for c in spec["flows"] if c not in bi]
        if unknown:
            raise ValueError(f"idle supply rule of {col}: airflow columns {unknown} are not boxes {list(boxes)}")
        zones = spec.get("zones") or {}
        if any(z not in zi for z in zones) and len(outputs) != 1:
            bad = [z for z in zones if z not in zi]
            raise ValueError(f"idle supply rule of {col}: zones {bad} are not outputs {list(outputs)}")
        merged: dict = {}
        for z, w in zones.items():
            k = zi.get(z, 0)
            merged[k] = merged.get(k, 0.0) + float(w)
        target.append(vi[col])
        bx.append(tuple(bi[c] for c in spec["flows"]))
        bd.append(tuple(float(x) for x in spec["flows"].values()))
        zs.append(tuple(merged))
        ws.append(tuple(merged.values()))
        names.append(col)
    if not target:
        return None
    return IdleStep(mode, tuple(target), tuple(bx), tuple(bd), tuple(zs), tuple(ws), tuple(names))


__all__ = [
    "BOX_OFF_FRACTION",
    "MODES",
    "OFF_FLOOR",
    "UNIT_OFF_FRACTION",
    "IdleStep",
    "box_off_bounds",
    "hold_idle_supply",
    "idle_rows",
    "idle_step",
    "idle_supply_rule",
    "unit_off_bounds",
]
