"""The building's operating schedule in a co-simulation: steps where the data's air handler is off.

Office BMS data often have the air handler off at night and at weekends: every box of the unit at (near)
zero airflow and the unit's logged supply temperature reading an idle duct node (about room air). The rule
is :mod:`hvacfmu.data.idle`'s, the one ``diagnose``, ``fit --heat auto`` and the FMUs use: a unit is off in
a row where every box it feeds is measured and reads at most ``max(1e-6 kg/s, 50 % of m_min)``
(:func:`hvacfmu.data.idle.unit_off_bounds`, :data:`~hvacfmu.data.idle.UNIT_OFF_FRACTION`). A running box
reads at least its minimum; the emulator's shut boxes read 0–0.01 kg/s of sensor noise, which a 5 % bound
(the ``reheat`` cause's box-off bound, :data:`~hvacfmu.data.idle.BOX_OFF_FRACTION`) would count as running
for an ``m_min`` under 0.2 kg/s (133 of 2016 rows of a three-week ``--schedule night-off`` dataset). The
summary counts the off steps where a shut box reads above that 5 % bound (``off_steps_noise``).

A run follows one of two systems (:data:`SYSTEMS`):

- ``"schedule"`` (default): the building's own schedule. In the steps where the data's unit is off, every
  box of the unit gets 0 airflow and no reheat (what the plant does with the unit off); controllers are told
  (:attr:`harness.controllers.ControlContext.off`), and the harness applies 0 there whatever a controller
  returns (counted). A box is then either off at 0 or inside ``[m_min, m_max]``.
- ``"always-on"``: the system runs through the off periods (every box inside ``[m_min, m_max]``); the unit's
  supply temperature in its off steps is its last running value in the data
  (:func:`hvacfmu.data.idle.hold_idle_supply`, mode ``"last"``), never the idle duct reading.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from hvacfmu.data.idle import (
    BOX_OFF_FRACTION,
    OFF_FLOOR,
    UNIT_OFF_FRACTION,
    box_off_bounds,
    hold_idle_supply,
    idle_rows,
    idle_supply_rule,
    unit_off_bounds,
)
from hvacfmu.errors import HvacfmuError

SYSTEMS = ("schedule", "always-on")
#: the rule in words (for the run's summary)
RULE = (
    f"hvacfmu.data.idle.unit_off_bounds: a unit is off where every box it feeds reads at most "
    f"max({OFF_FLOOR:g} kg/s, {100 * UNIT_OFF_FRACTION:g} % of m_min)"
)


def unit_of_boxes(building, vavs) -> list:
    """Name of the air handler feeding each box of ``vavs`` (``"T_supply"`` for the implicit single unit)."""
    out = []
    for b in vavs:
        ahu = building.ahu_of(b)
        out.append("T_supply" if ahu is None else ahu.name)
    return out


def unit_off_rows(frame: pd.DataFrame, building) -> tuple:
    """``({unit: rows off (bool)}, noise rows)`` of the air handlers (``"T_supply"``: the implicit single unit).

    A unit is off in a row where every box it feeds has a measured airflow at or below its
    :func:`hvacfmu.data.idle.unit_off_bounds` (:func:`hvacfmu.data.idle.idle_rows`); ``noise`` (bool rows) marks
    the off rows (some unit) where a box reads above its 5 % box-off bound (shut-box sensor noise). A unit any of
    whose boxes has no airflow column is never off.
    """
    bounds = unit_off_bounds(building)
    shut = box_off_bounds(building, BOX_OFF_FRACTION, OFF_FLOOR)
    members: dict = {}
    for b, u in zip(building.vav_names, unit_of_boxes(building, building.vav_names)):
        members.setdefault(u, []).append(f"m_{b}")
    unit_off = {}
    noise = np.zeros(len(frame), dtype=bool)
    for u, cols in members.items():
        if all(c in frame.columns for c in cols):
            off = idle_rows(frame, {c: bounds[c] for c in cols})
            unit_off[u] = off
            noise |= off & ~idle_rows(frame, {c: shut[c] for c in cols})
        else:
            unit_off[u] = np.zeros(len(frame), dtype=bool)
    return unit_off, noise


def off_steps(frame: pd.DataFrame, building, vavs) -> tuple:
    """``(off, noise)``: ``off`` (rows, boxes) bool, box ``j`` of ``vavs`` off in a row where its unit is off
    (:func:`unit_off_rows`); ``noise`` the number of off rows where a shut box reads above its 5 % box-off
    bound."""
    unit_off, noise = unit_off_rows(frame, building)
    own = unit_of_boxes(building, vavs)
    if not own:
        return np.zeros((len(frame), 0), dtype=bool), int(noise.sum())
    return np.column_stack([unit_off[u] for u in own]), int(noise.sum())


def running_supply(frame: pd.DataFrame, building) -> tuple:
    """``frame`` with each unit's supply temperature replaced, in its off rows, by its last running value.

    The off rows are :func:`unit_off_rows`'; the value is the column's last finite value in a row where the
    unit ran (before the unit first runs: its first running value), as
    :func:`hvacfmu.data.idle.hold_idle_supply` (mode ``"last"``, which this calls). Columns: ``T_supply`` (the implicit
    unit, or with ``[[ahus]]`` the mean of all units: off where every unit is off) and each unit's
    ``T_supply_<ahu>``. Returns ``(frame, {column: rows replaced})``.
    """
    rule = idle_supply_rule(building, frame.columns, unit_off_bounds(building), mode="last")
    # the supply columns only (a box's own Td_ is not the unit's), of units whose every box is measured
    rule = {c: r for c, r in rule.items() if not c.startswith("Td_") and set(r["flows"]) <= set(frame.columns)}
    out, counts = hold_idle_supply(frame, rule)
    return out, {c: n for c, n in counts.items() if n}


@dataclasses.dataclass(frozen=True)
class RunSchedule:
    """The schedule of one run.

    Attributes
    ----------
    system : str
        ``"schedule"`` or ``"always-on"`` (:data:`SYSTEMS`).
    off : array (n_steps, n_boxes) of bool
        Box ``j`` is off in step ``k`` in the data (its unit off).
    held : dict
        ``{supply column: steps replaced by the last running value}`` (always-on only).
    noise : int
        Off steps where a shut box reads above its 5 % box-off bound (sensor noise).
    units : tuple of str
        The air handler of each box (column of ``off``), when known: the summary then counts each unit's off steps.
    """

    system: str
    off: np.ndarray
    held: dict = dataclasses.field(default_factory=dict)
    noise: int = 0
    units: tuple = ()

    @property
    def enforced(self) -> bool:
        """True when the run applies the schedule (off boxes at 0)."""
        return self.system == "schedule"

    def summary(self, index) -> dict:
        """What the run's summary says of the schedule (steps off, the rule, the option)."""
        any_off = self.off.any(axis=1) if self.off.size else np.zeros(len(index), dtype=bool)
        return {
            "system": self.system,
            "rule": RULE,
            "off_steps": int(any_off.sum()),
            "off_box_steps": int(self.off.sum()),
            "off_steps_noise": self.noise,
            "off_periods": _periods(index, any_off),
            "held_supply": dict(self.held),
            "unit_off_steps": self.unit_off_steps(),
        }

    def unit_off_steps(self) -> dict:
        """``{unit: steps off}`` of every unit of the run's boxes (empty when the units are not known)."""
        if len(self.units) != self.off.shape[1]:
            return {}
        out: dict = {}
        for j, u in enumerate(self.units):
            out[u] = int(self.off[:, j].sum())  # every box of a unit is off in the same steps
        return out


def check_system(system: str) -> str:
    if system not in SYSTEMS:
        raise HvacfmuError(f"unknown system {system!r}; choose one of {SYSTEMS}")
    return system


def _periods(index, mask) -> list:
    """``[[first, end], ...]`` of the runs of True in ``mask`` (``end``: the start of the next row)."""
    out = []
    mask = np.asarray(mask, dtype=bool)
    if not len(index):
        return out
    step = index[1] - index[0] if len(index) > 1 else pd.Timedelta(0)
    k, n = 0, len(mask)
    while k < n:
        if mask[k]:
            j = k
            while j + 1 < n and mask[j + 1]:
                j += 1
            out.append([str(index[k]), str(index[j] + step)])
            k = j + 1
        else:
            k += 1
    return out


__all__ = [
    "RULE",
    "SYSTEMS",
    "RunSchedule",
    "check_system",
    "off_steps",
    "running_supply",
    "unit_of_boxes",
    "unit_off_rows",
]
