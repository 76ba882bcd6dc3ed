"""Controllers for the co-simulation harness, and the protocol every controller follows.

Controller protocol
-------------------
A controller is any object with::

    name : str
    reset(context: ControlContext) -> None
    __call__(k: int, t: pandas.Timestamp, y: ndarray, v: Mapping[str, float]) -> ndarray
    stats() -> dict            # optional: numbers reported in the result (e.g. solver failures)

- :meth:`reset` is called once before the first step with a
  :class:`ControlContext`: the run's prepared data (``context.frame``, one row
  per communication step, disturbances gap-filled; a controller may read
  future rows as a perfect forecast), the building (box limits
  ``m_min``/``m_max``), the order of the commands (``context.vavs``) and of
  the measurements (``context.outputs`` with their zones), the comfort band,
  the season and the model step.
- ``__call__(k, t, y, v)`` is called at the start of step ``k`` (row ``k`` of
  ``context.frame``, local time ``t``) with the FMU's outputs ``y``
  [°C] (order ``context.outputs``) at that time and that row's disturbances
  ``v`` (``T_out``, ``T_supply`` [°C], ``I_N`` ... [W/m²]). It returns the
  airflow of every VAV box [kg/s] in the order of ``context.vavs``; the
  harness holds it for the step. When the plant takes discharge air
  commands (``context.discharge``: the plant FMU's ``Td_<vav>`` inputs), it
  may append one discharge air temperature [°C] per box of
  ``context.discharge`` (its reheat: ``m c_p (Td - T_supply)``; at or below
  the supply air, or not given: no reheat). Returning NaN or raising stops
  the run (the harness reports it).

The MPC controllers of :mod:`harness.mpc` plug in through
``harness.mpc.cosim_controller(model, building, **options)`` (see
:func:`harness.cosim.make_controller`).
"""

from __future__ import annotations

import dataclasses
from typing import Mapping, Protocol, runtime_checkable

import numpy as np
import pandas as pd

from hvacfmu.errors import HvacfmuError

#: heating limit of the discharge air [°C] when the building file gives no ``T_supply_max``
#: (the emulator's reheat mode uses 35 °C; warmer air stratifies under the ceiling)
DEFAULT_T_DISCHARGE_MAX = 35.0

#: The harness's MPC horizon when no ``horizon`` option is given [h]: a duration, what a controls engineer would
#: use for a building's slow response (issue 18 p.7; ``hvacfmu demo`` runs it), converted to steps of the run's
#: data by :func:`default_horizon` (12 at 15-min steps, 36 at 5-min). The paper's N = 3 (45 min at 15-min steps)
#: stays available as ``horizon=3``.
DEFAULT_HORIZON_H = 3.0


def default_horizon(step: float) -> int:
    """The default MPC horizon [steps]: :data:`DEFAULT_HORIZON_H` at a step of ``step`` [s] (at least 1).

    12 at 900 s, 36 at 300 s. The one place the harness's default is decided: :class:`harness.mpc.CosimMPC`
    (so ``hvacfmu cosim --controller mpc``, :func:`harness.cosim`, :func:`harness.cosim.make_controller` and
    :func:`harness.mpc.cosim_controller`) and ``hvacfmu demo`` call it.
    """
    step = float(step)
    if not (np.isfinite(step) and step > 0.0):
        raise HvacfmuError(f"the MPC horizon needs a positive step [s], got {step!r}")
    return max(1, int(round(DEFAULT_HORIZON_H * 3600.0 / step)))


@dataclasses.dataclass(frozen=True)
class ControlContext:
    """What a controller learns before the first step.

    Attributes
    ----------
    frame : DataFrame
        Prepared data over the run (``n_steps`` rows, tz-aware local index):
        ``T_<zone>`` (measured, may be NaN), ``m_<vav>`` (measured), ``T_out``,
        ``T_supply`` [°C], facade irradiance [W/m²] (gap-filled).
    building : hvacfmu.building.Building
    vavs : tuple of str
        Box names; the order of the commands.
    outputs : tuple of str
        FMU output names (``T_<zone>`` or ``T_floor``); the order of ``y``.
    output_zones : tuple of tuple of str
        Zones each output stands for (all zones for ``T_floor``).
    step : float [s]
    band : (float, float) [°C]
        Comfort band (T_min, T_max).
    season : str or None
        Season of the run (selects a model's gains profile).
    model : ZoneModel or None
        The model given to the harness (e.g. the MPC's own model), if any.
    discharge : tuple of str
        Boxes whose discharge air temperature the controller may command
        (the plant FMU's ``Td_<vav>`` inputs); empty when the plant has none.
    off : array (n_steps, n_boxes) of bool, optional
        The building's schedule (:mod:`harness.schedule`): box ``j`` is off
        in step ``k`` (its air handler off in the data). The harness applies
        0 airflow and no reheat there whatever the controller returns; a
        controller should plan with it. None: the system runs in every step
        (``--system always-on``, or data without off periods).
    """

    frame: pd.DataFrame
    building: object
    vavs: tuple
    outputs: tuple
    output_zones: tuple
    step: float
    band: tuple = (20.0, 22.0)
    season: str | None = None
    model: object = None
    discharge: tuple = ()
    off: np.ndarray | None = None

    def off_at(self, k: int) -> np.ndarray:
        """Boxes (in :attr:`vavs` order) that are off in step ``k`` (all False without a schedule)."""
        if self.off is None or k >= len(self.off):
            return np.zeros(len(self.vavs), dtype=bool)
        return np.asarray(self.off[k], dtype=bool)

    @property
    def n_steps(self) -> int:
        return len(self.frame)

    def box_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """``m_min``, ``m_max`` [kg/s] of the boxes in :attr:`vavs` order."""
        by_name = {b.name: b for b in self.building.vavs}
        return (
            np.array([by_name[v].m_min for v in self.vavs], dtype=float),
            np.array([by_name[v].m_max for v in self.vavs], dtype=float),
        )

    def heating_limits(self, boxes=None) -> np.ndarray:
        """Heating limit of the discharge air [°C] of ``boxes`` (default :attr:`discharge`).

        The box's air handler's ``T_supply_max`` from the building file; :data:`DEFAULT_T_DISCHARGE_MAX`
        where the building gives none.
        """
        out = []
        for b in self.discharge if boxes is None else boxes:
            ahu = self.building.ahu_of(b)
            limit = getattr(ahu, "T_supply_max", None)
            out.append(DEFAULT_T_DISCHARGE_MAX if limit is None else float(limit))
        return np.array(out, dtype=float)

    def box_output(self) -> np.ndarray:
        """Index into ``y`` of the output measuring each box's zone."""
        by_name = {b.name: b for b in self.building.vavs}
        out = []
        for v in self.vavs:
            zone = by_name[v].zone
            hits = [i for i, zs in enumerate(self.output_zones) if zone in zs]
            if not hits:
                raise HvacfmuError(f"no FMU output measures zone {zone!r} of box {v!r}; outputs: {self.outputs}")
            out.append(hits[0])
        return np.array(out, dtype=int)


@runtime_checkable
class Controller(Protocol):
    """The controller protocol (see the module docstring)."""

    name: str

    def reset(self, context: ControlContext) -> None: ...

    def __call__(self, k: int, t: pd.Timestamp, y: np.ndarray, v: Mapping[str, float]) -> np.ndarray: ...


class BoxLimiter:
    """Keeps box commands inside the building's ``[m_min, m_max]`` (or at 0 where the box is off) and counts
    what it had to clip.

    Every controller passes its commands through one: a VAV box cannot deliver
    less than its minimum or more than its maximum airflow, so neither may the
    plant; a box whose air handler is off (the building's schedule,
    ``off``) delivers none. Clipping is reported, never silent (:meth:`stats`).

    Parameters
    ----------
    m_min, m_max : arrays (n_boxes,) [kg/s]
    vavs : sequence of str, box names (for the report)
    tol : float [kg/s]
        Differences up to ``tol`` (solver rounding) are clipped without being counted.
    """

    def __init__(self, m_min, m_max, vavs=(), tol=1e-9):
        self.m_min = np.asarray(m_min, dtype=float)
        self.m_max = np.asarray(m_max, dtype=float)
        self.vavs = tuple(vavs)
        self.tol = float(tol)
        self.n_clipped = np.zeros(self.m_min.size, dtype=int)  # box-steps clipped, per box
        self.max_clipped = 0.0  # [kg/s]
        self.n_calls = 0
        self.n_off = 0  # box-steps set to 0 because the box was off

    def __call__(self, m, off=None) -> np.ndarray:
        """``m`` clipped to ``[m_min, m_max]``; 0 where ``off`` (bool per box) is True (not counted as clipping)."""
        m = np.asarray(m, dtype=float)
        out = np.clip(m, self.m_min, self.m_max)
        if off is not None and np.any(off):
            off = np.asarray(off, dtype=bool)
            out = np.where(off, 0.0, out)
            m = np.where(off, 0.0, m)
            self.n_off += int(off.sum())
        diff = np.abs(m - out)
        diff = np.where(np.isfinite(diff), diff, np.inf)
        self.n_clipped += diff > self.tol
        self.max_clipped = max(self.max_clipped, float(diff.max(initial=0.0)))
        self.n_calls += 1
        return out

    def stats(self) -> dict:
        """``clipped_box_steps`` (total), ``clipped_max`` [kg/s], ``clipped_boxes`` {box: box-steps}."""
        per_box = {(self.vavs[i] if i < len(self.vavs) else str(i)): int(n) for i, n in enumerate(self.n_clipped) if n}
        out = {
            "clipped_box_steps": int(self.n_clipped.sum()),
            "clipped_max": self.max_clipped,
            "clipped_boxes": per_box,
        }
        if self.n_off:
            out["off_box_steps"] = self.n_off
        return out


class ReplayController:
    """Replays the measured airflows of the data (the building's own controller).

    Gaps in a box's measured airflow are filled with its last value (the
    box's ``m_min`` before the first one); measured airflows outside the
    building file's ``[m_min, m_max]`` are clipped to them. :meth:`stats`
    counts both (``filled_airflows``, ``clipped_box_steps`` ...). In the
    steps the run's schedule marks off (:attr:`ControlContext.off`: the
    data's unit off, its boxes reading at most their off bound) the box
    replays 0 (``off_box_steps``; ``off_reading_max``: the largest reading
    there, sensor noise).
    """

    name = "replay"
    #: the measured airflows come with the boxes' own (unmeasured) reheat: the plant FMU keeps its loops
    fmu_start_values = {"local_reheat": 1}

    def reset(self, context: ControlContext) -> None:
        cols = [f"m_{v}" for v in context.vavs]
        missing = [c for c in cols if c not in context.frame]
        if missing:
            raise HvacfmuError(f"replay needs measured airflow columns, missing: {missing}")
        m = context.frame[cols]
        self.n_filled = int(m.isna().to_numpy().sum())
        m_min, _ = context.box_limits()
        self._m = m.ffill().fillna(pd.Series(m_min, index=cols)).to_numpy(dtype=float)
        self.limiter = BoxLimiter(*context.box_limits(), context.vavs)
        self.context = context
        self.off_max = (
            float(np.max(self._m[: len(context.off)][context.off], initial=0.0)) if context.off is not None else 0.0
        )

    def __call__(self, k, t, y, v):
        return self.limiter(self._m[k], self.context.off_at(k))

    def stats(self) -> dict:
        out = {"filled_airflows": self.n_filled, **self.limiter.stats()}
        if self.limiter.n_off:
            out["off_reading_max"] = self.off_max
        return out


class _PI:
    """A PI loop with output ``clip(kp e + I, 0, 1)`` and the integral frozen while the output saturates."""

    def __init__(self, n, kp, ti, dt):
        self.kp, self.k_i = float(kp), float(kp) * float(dt) / float(ti)
        self.integral = np.zeros(n)

    def __call__(self, e) -> np.ndarray:
        f_unsat = self.kp * e + self.integral
        grow = self.k_i * e
        free = (f_unsat > 0.0) & (f_unsat < 1.0) | ((f_unsat <= 0.0) & (grow > 0)) | ((f_unsat >= 1.0) & (grow < 0))
        self.integral = np.where(free, np.clip(self.integral + grow, -1.0, 2.0), self.integral)
        return np.clip(f_unsat, 0.0, 1.0)


class RuleController:
    """A PI controller per zone driving the zone's boxes between ``m_min`` and ``m_max``; a VAV heating sequence
    where the plant takes discharge air commands.

    Airflow: the airflow fraction of each box is ``f = clip(Kp e + I, 0, 1)``,
    ``m = m_min + f (m_max - m_min)``, with ``e = T_zone - T_set`` when the
    supply air is colder than the zone (cooling) and ``e = T_set - T_zone``
    when it is warmer (more air heats); the integral ``I`` (time constant
    ``Ti``) is frozen while the output saturates (anti-windup).

    With discharge commands, heating follows a single-maximum VAV reheat
    sequence: a second PI loop on ``T_heat - T_zone`` (``T_heat = T_set -
    heating_offset``) sets the reheat fraction ``h``; while it heats the box
    stays at minimum airflow and discharges at ``Td = T_supply + h (Td_max -
    T_supply)``, ``Td_max`` the box's heating limit
    (:meth:`ControlContext.heating_limits`); otherwise ``Td`` is the supply
    temperature (no reheat).

    Off steps of the building's schedule (:attr:`ControlContext.off`): the
    box is off (0 airflow, no reheat: discharge command 0 °C, below any
    supply air) and its loops hold their integrals until the unit restarts.

    Parameters
    ----------
    setpoint : float [°C], optional
        Cooling setpoint. Default: the middle of the comfort band.
    kp : float [1/K]
        Proportional gain on the airflow (and reheat) fraction.
    ti : float [s]
        Integral time.
    heating_offset : float [K]
        Heating setpoint below the cooling setpoint (the dead band).
    heating_kp : float [1/K]
        Proportional gain on the reheat fraction. Full reheat (35 °C at minimum airflow) warms a small
        perimeter zone of the emulated building by ~2.5 K in 15 minutes: with the airflow loop's 0.5 the
        two loops cycle between full reheat and full cooling every step (measured, summer nights).
    """

    name = "rule"

    def __init__(self, setpoint=None, kp=0.5, ti=3600.0, heating_offset=0.5, heating_kp=0.1):
        self.setpoint = setpoint
        self.kp = float(kp)
        self.ti = float(ti)
        self.heating_offset = float(heating_offset)
        self.heating_kp = float(heating_kp)

    def reset(self, context: ControlContext) -> None:
        self.m_min, self.m_max = context.box_limits()
        self.out_of_box = context.box_output()
        self.dt = float(context.step)
        self.T_set = float(np.mean(context.band)) if self.setpoint is None else float(self.setpoint)
        self.cool = _PI(len(context.vavs), self.kp, self.ti, self.dt)
        self.heat = _PI(len(context.vavs), self.heating_kp, self.ti, self.dt)
        self.td_boxes = np.array([list(context.vavs).index(b) for b in context.discharge], dtype=int)
        self.td_max = context.heating_limits() if len(self.td_boxes) else np.zeros(0)
        self.n_heating = 0  # box-steps with reheat
        self.context = context
        self.n_off = 0  # box-steps off (the building's schedule)
        # a delivered-heat model's FMU has no T_supply input (its boxes take Td_<vav> or T_supply_<ahu>):
        # the heating/cooling sign then comes from the prepared data's supply temperature
        frame = context.frame
        self.supply = frame["T_supply"].to_numpy(float) if "T_supply" in frame.columns else None

    def _supply(self, k, v) -> float:
        if "T_supply" in v:
            return float(v["T_supply"])
        if self.supply is not None:
            return float(self.supply[min(k, len(self.supply) - 1)])
        raise KeyError(
            "the rule controller needs the supply air temperature: neither the FMU's inputs "
            "nor the data hold a 'T_supply' column"
        )

    def __call__(self, k, t, y, v):
        off = self.context.off_at(k)
        if off.any():
            return self._off_step(k, t, y, v, off)
        return self._command(k, y, v)

    def _command(self, k, y, v):
        T = np.asarray(y, dtype=float)[self.out_of_box]
        T_supply = self._supply(k, v)
        sign = np.where(T_supply <= T, 1.0, -1.0)  # supply air warmer than the zone: more air heats
        f = self.cool(sign * (T - self.T_set))
        if not len(self.td_boxes):  # airflow only
            return self.m_min + f * (self.m_max - self.m_min)
        h = self.heat(self.T_set - self.heating_offset - T)
        heating = h > 0.0
        f = np.where(heating, 0.0, f)  # the sequence: reheat only at minimum airflow
        self.n_heating += int(np.sum(heating[self.td_boxes]))
        Td = T_supply + h[self.td_boxes] * np.maximum(self.td_max - T_supply, 0.0)
        return np.concatenate([self.m_min + f * (self.m_max - self.m_min), Td])

    def _off_step(self, k, t, y, v, off):
        """A step where some boxes are off: those at 0 (no reheat), their integrals held; the others as usual."""
        held = (self.cool.integral.copy(), self.heat.integral.copy())
        if off.all():
            self.n_off += int(off.sum())
            return np.zeros(len(off) + len(self.td_boxes))
        m = self._command(k, y, v)
        self.cool.integral = np.where(off, held[0], self.cool.integral)
        self.heat.integral = np.where(off, held[1], self.heat.integral)
        self.n_off += int(off.sum())
        m = np.array(m, dtype=float)
        m[: len(off)][off] = 0.0
        if len(self.td_boxes):
            m[len(off) :][off[self.td_boxes]] = 0.0
        return m

    def stats(self) -> dict:
        out = {"setpoint": self.T_set, "kp": self.kp, "ti": self.ti}
        if getattr(self, "n_off", 0):
            out["off_box_steps"] = self.n_off
        if len(getattr(self, "td_boxes", ())):
            out.update(heating_setpoint=self.T_set - self.heating_offset, heating_box_steps=self.n_heating)
        return out


__all__ = [
    "DEFAULT_HORIZON_H",
    "DEFAULT_T_DISCHARGE_MAX",
    "BoxLimiter",
    "ControlContext",
    "Controller",
    "ReplayController",
    "RuleController",
    "default_horizon",
]
