"""FMU slave of the emulated building (``resources/truth.json``): :class:`PlantSlave`.

Executed into the slave script's namespace after :mod:`hvacfmu.fmu_slave.base`
(:func:`hvacfmu.fmu_slave.define_slave`), or imported as an ordinary module.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from pythonfmu import DefaultExperiment

from hvacfmu.fmu_slave.names import ZONE_BOUNDS
from hvacfmu.fmu_slave.plant_discharge import plant_discharge_reheat
from hvacfmu.fmu_slave.plant_layout import PLANT_STEP, plant_layout
from hvacfmu.fmu_slave.resources import INTERFACE_FILE, cached_setup, read_layout
from hvacfmu.fmu_slave.values import tuple_getter

if "HvacfmuSlaveBase" not in globals():  # imported as a module, not executed into a slave script
    from hvacfmu.fmu_slave.base import HvacfmuSlaveBase


class PlantSlave(HvacfmuSlaveBase):
    """FMU slave of the emulated building (``resources/truth.json``).

    Inputs ``m_<vav>`` [kg/s] for every box, ``T_out``, ``T_supply`` [°C],
    ``I_N`` ... ``I_W`` [W/m²], optional ``ghi`` [W/m²] (facades from it
    when >= 0), ``excitation`` (0/1) and ``Td_<vav>`` [°C] (discharge air commands,
    :mod:`hvacfmu.fmu_slave.plant_discharge`; unset: no reheat); outputs ``T_<zone>`` [°C]; parameters ``T_<zone>_start``
    [°C], ``local_reheat`` (0/1). FMU time is seconds since the dataset start.
    """

    TRUTH_FILE = "truth.json"

    def _setup(self):
        self.plant = None
        problem = None
        try:

            def build():
                from hvacfmu.emulator import Plant  # host environment

                truth = json.loads((Path(self.resources or ".") / self.TRUTH_FILE).read_text(encoding="utf-8"))
                plant = Plant.from_truth(truth)
                return plant, plant_layout(plant, truth)

            plant, layout = cached_setup("plant", self.resources, (self.TRUTH_FILE, INTERFACE_FILE), build)
            layout = json.loads(json.dumps(layout, default=float))  # each instance its own copy
        except Exception as exc:  # noqa: BLE001 - reported, never raised
            plant, layout = None, None
            problem = f"cannot use the FMU's plant file resources/{self.TRUTH_FILE}: {type(exc).__name__}: {exc}"
        layout, mismatch = read_layout(self.resources, layout, self.TRUTH_FILE)
        problem = problem or mismatch
        if problem:
            self._broken = problem
        if layout is None:
            return []
        self.description = layout["description"]
        self.default_experiment = DefaultExperiment(start_time=0.0, stop_time=7 * 86400.0, step_size=900.0)
        if plant is not None and not problem:
            self.plant = plant
        self._x = None
        return layout["variables"]

    def _initialize(self):
        v = self._values
        self._y_vrs = self.vrs_with_role("y")
        m_vrs, v_vrs = self.vrs_with_role("m"), self.vrs_with_role("v")
        self._get_m = tuple_getter(m_vrs)
        self._get_v = tuple_getter(v_vrs)
        y0 = [v[vr] for vr in self.vrs_with_role("y0")]
        lo, hi = ZONE_BOUNDS
        problems = [
            f"{self._spec[vr]['name']}={val!r} degC is outside [{lo}, {hi}]"
            for vr, val in zip(self.vrs_with_role("y0"), y0)
            if not (lo <= val <= hi)
        ]
        k0 = self._t_start / PLANT_STEP
        if abs(k0 - round(k0)) > 1e-9 * max(1.0, k0) or self._t_start < 0:
            problems.append(f"start time {self._t_start} s must be a non-negative multiple of {PLANT_STEP:g} s")
        (rh_vr,) = self.vrs_with_role("local_reheat")
        if v[rh_vr] not in (0, 1):
            problems.append(f"local_reheat={v[rh_vr]!r} must be 0 or 1")
        if problems:
            return problems
        self._run = self.plant.with_local_reheat(bool(v[rh_vr]))
        (self._ghi_vr,) = self.vrs_with_role("ghi")
        (self._exc_vr,) = self.vrs_with_role("exc")
        self._td_vrs = self.vrs_with_role("td")
        self._x = self._run.initial_state(np.asarray(y0, dtype=float))
        self._t = self._t_start
        for vr, val in zip(self._y_vrs, self.plant.zone_temperatures(self._x).tolist()):
            v[vr] = val
        return []

    def _advance(self, current_time, step_size):
        n = step_size / PLANT_STEP
        if n < 1 - 1e-9 or abs(n - round(n)) > self.STEP_RTOL * max(1.0, n):
            return self._refuse(
                f"communication step {step_size!r} s at t={current_time} s is not a whole multiple of the "
                f"plant step {PLANT_STEP:g} s; step refused"
            )
        if current_time + step_size > self.plant.horizon + 1e-6:
            return self._refuse(
                f"the step to t={current_time + step_size} s goes beyond the emulated span "
                f"({self.plant.horizon:g} s from the dataset start); step refused"
            )
        values = self._values
        w = self._get_v(values)
        t, dt = round(current_time / PLANT_STEP) * PLANT_STEP, round(n) * PLANT_STEP
        ghi = values[self._ghi_vr]
        irr = self._run.facades_from_ghi(t, dt, ghi) if ghi >= 0 else np.array(w[2:6], dtype=float)
        m = np.array(self._get_m(values), dtype=float)
        x, T = self._run.advance(
            self._x,
            t,
            dt,
            m,
            w[0],
            w[1],
            irr,
            reheat=plant_discharge_reheat(self._run, values, self._td_vrs, m, w[1]),
            excitation=values[self._exc_vr] >= 0.5,
        )
        self._x = x
        self._t = current_time + step_size
        for vr, val in zip(self._y_vrs, T.tolist()):
            values[vr] = val
        return True

    def _get_internal_state(self):
        return {"x": None if self._x is None else self._x.tolist()}

    def _set_internal_state(self, state):
        self._x = None if state["x"] is None else np.array(state["x"], dtype=float)
