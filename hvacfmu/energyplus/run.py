"""Run an IDF through EnergyPlus's Python API and collect BMS-like step averages.

One EnergyPlus process state per run (``pyenergyplus`` API). Values are read in
callbacks: node airflows and temperatures at the end of every HVAC (system)
time step, averaged over the zone time step weighted by the system step length;
zone mean air temperatures and site weather at the end of the zone time step
(EnergyPlus's zone-step averages). Sizing and warm-up days are skipped
(``warmup_flag``, ``kind_of_sim`` = 3 is the weather-file run period).

EnergyPlus's clock is standard time at the end of the step (late by up to half a
step after HVAC sub-steps in some IDFs: snapped back to the zone-step grid);
:func:`step_times` turns it into the UTC start of each step. An exception inside a callback would
be swallowed by ctypes, so callbacks keep it, stop the run and it is re-raised
after ``run_energyplus`` returns.
"""

from __future__ import annotations

import calendar
import dataclasses
import datetime as _dt
import logging
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import DataError

log = logging.getLogger(__name__)
RUN_PERIOD_WEATHER = 3


@dataclasses.dataclass(frozen=True)
class Probe:
    """One value to record: output ``column``, EnergyPlus output ``variable`` and ``key``, averaged over system steps
    (``system=True``) or read at the zone-step end."""

    column: str
    variable: str
    key: str
    system: bool = False


def load_api():
    """The ``pyenergyplus`` API, or a clear error when the optional extra is missing."""
    try:
        from pyenergyplus.api import EnergyPlusAPI
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise DataError(
            f"EnergyPlus is not installed: pip install 'hvacfmu[energyplus]' (the pyenergyplus-lbnl package) ({exc})"
        ) from None
    return EnergyPlusAPI()


class CallbackError(RuntimeError):
    """Raised after a run whose callback failed; ``__cause__`` is the original exception.

    ``steps_after_error``: zone steps EnergyPlus still ran after the failure (0 when it stopped at once)."""

    steps_after_error = 0


class _Recorder:
    """Collects probes' values per zone time step (see module docstring)."""

    def __init__(self, api, probes, on_step=None):
        self.api, self.probes, self.on_step = api, probes, on_step
        self.handles = None
        self.rows, self.times = [], []
        self.sys_sum = np.zeros(len(probes))
        self.sys_dt = 0.0
        self.error = None
        self.steps_after_error = 0

    def _ready(self, state) -> bool:
        x = self.api.exchange
        if not x.api_data_fully_ready(state) or x.warmup_flag(state) or x.kind_of_sim(state) != RUN_PERIOD_WEATHER:
            return False
        if self.handles is None:
            self.handles = [x.get_variable_handle(state, p.variable, p.key) for p in self.probes]
            bad = [f"{p.variable} of {p.key!r}" for p, h in zip(self.probes, self.handles) if h < 0]
            if bad:
                raise DataError(
                    "EnergyPlus has no output variable "
                    + "; ".join(bad[:5])
                    + (f" (and {len(bad) - 5} more)" if len(bad) > 5 else "")
                    + ": check the node/zone names in the IDF"
                )
        return True

    def _guard(self, state, fn):
        if self.error is not None:
            return
        try:
            fn(state)
        except BaseException as exc:  # noqa: BLE001 - kept and re-raised after the run
            self.error = exc
            self.api.runtime.stop_simulation(state)

    def system_step(self, state):
        self._guard(state, self._system_step)

    def _system_step(self, state):
        if not self._ready(state):
            return
        x = self.api.exchange
        dt = x.system_time_step(state)
        for i, (p, h) in enumerate(zip(self.probes, self.handles)):
            if p.system:
                self.sys_sum[i] += x.get_variable_value(state, h) * dt
        self.sys_dt += dt

    def zone_step(self, state):
        if self.error is not None:
            self.steps_after_error += 1
        self._guard(state, self._zone_step)

    def _zone_step(self, state):
        if not self._ready(state):
            return
        x = self.api.exchange
        row = np.empty(len(self.probes))
        for i, (p, h) in enumerate(zip(self.probes, self.handles)):
            if p.system and self.sys_dt > 0:
                row[i] = self.sys_sum[i] / self.sys_dt
            else:
                row[i] = x.get_variable_value(state, h)
        self.sys_sum[:] = 0.0
        self.sys_dt = 0.0
        self.rows.append(row)
        self.times.append((x.calendar_year(state), x.day_of_year(state), x.current_time(state)))
        if self.on_step is not None:
            self.on_step(state, self.api, len(self.rows) - 1, row)


def simulate(idf_path, epw_path, workdir, probes, *, on_step=None, extra_callbacks=()) -> tuple:
    """Run EnergyPlus on ``idf_path`` with weather ``epw_path`` in ``workdir``.

    Parameters
    ----------
    probes : sequence of Probe
    on_step : callable, optional
        ``on_step(state, api, k, row)`` at the end of every recorded zone step (after the row is stored).
    extra_callbacks : sequence of (registration name, callable(state))
        More runtime callbacks, e.g. ``("callback_begin_system_timestep_before_predictor", f)``; exceptions in them
        stop the run as for the recorder's own.

    Returns
    -------
    (values, times, eio_text)
        ``values`` (n_steps, n_probes); ``times`` list of (year, day of year, end hour [h, standard time]).

    Raises
    ------
    CallbackError
        When a callback raised (original exception chained).
    DataError
        When EnergyPlus exits with an error (the end of ``eplusout.err`` is quoted).
    """
    api = load_api()
    state = api.state_manager.new_state()
    api.runtime.set_console_output_status(state, False)
    rec = _Recorder(api, probes, on_step)
    for p in probes:
        api.exchange.request_variable(state, p.variable, p.key)
    api.runtime.callback_end_system_timestep_after_hvac_reporting(state, rec.system_step)
    api.runtime.callback_end_zone_timestep_after_zone_reporting(state, rec.zone_step)
    wrapped = []
    for reg, fn in extra_callbacks:

        def cb(s, fn=fn):
            rec._guard(s, fn)

        wrapped.append(cb)
        getattr(api.runtime, reg)(state, cb)
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    code = api.runtime.run_energyplus(state, ["-d", str(workdir), "-w", str(epw_path), str(idf_path)])
    api.state_manager.delete_state(state)
    if rec.error is not None:
        err = CallbackError(
            f"EnergyPlus run of {idf_path} stopped: a callback raised {type(rec.error).__name__}: {rec.error}"
        )
        err.steps_after_error = rec.steps_after_error
        raise err from rec.error
    if code != 0:
        err = workdir / "eplusout.err"
        tail = err.read_text(errors="replace").splitlines()[-15:] if err.exists() else []
        raise DataError(f"EnergyPlus failed on {idf_path} (exit code {code}); end of {err}:\n" + "\n".join(tail))
    eio = workdir / "eplusout.eio"
    return np.array(rec.rows), rec.times, eio.read_text(errors="replace") if eio.exists() else ""


def step_start(year: int, doy: int, hour: float, tz_hours: float, step_hours: float) -> _dt.datetime:
    """Naive UTC start of an EnergyPlus step from (calendar year, day of year, end hour [h, standard time]).

    At the last step of 31 December (end hour 24) EnergyPlus already reports the next calendar year. An end hour
    past the zone-step grid (the clock of the step's last HVAC sub-step) belongs to the step that ended on the grid
    before it.
    """
    # the clock at the end of a zone step can run late by the HVAC sub-steps EnergyPlus took (129 to 450 s in 12 %
    # of the DOE reference supermarket's steps, 58 % of the reference small office's): the step ended on the grid
    hour = np.floor(hour / step_hours + 1e-6) * step_hours
    if hour >= 24.0 - 1e-9 and doy == (366 if calendar.isleap(year - 1) else 365):
        year -= 1
    end = _dt.datetime(int(year), 1, 1) + _dt.timedelta(days=int(doy) - 1, hours=float(hour))
    return end - _dt.timedelta(hours=step_hours + tz_hours)


def step_times(times, tz_hours: float, step_hours: float) -> pd.DatetimeIndex:
    """UTC start of each step from EnergyPlus's (calendar year, day of year, end hour in standard time).

    Parameters
    ----------
    tz_hours : float [h]
        Standard time offset from UTC of the weather file's site (e.g. -7 for Denver).
    step_hours : float [h]
        Zone time step.
    """
    starts = [step_start(y, d, h, tz_hours, step_hours) for y, d, h in times]
    return pd.DatetimeIndex(starts).round("1s").tz_localize("UTC")
