"""FMU slave of any saved zone model (``resources/model.json``): :class:`ZoneModelSlave`.

Executed into the slave script's namespace after :mod:`hvacfmu.fmu_slave.base`
(:func:`hvacfmu.fmu_slave.define_slave`), or imported as an ordinary module.
"""

from __future__ import annotations

import json
import math
import traceback
from pathlib import Path

import numpy as np
from pythonfmu import DefaultExperiment
from pythonfmu.enums import Fmi2Status

from hvacfmu.fmu_slave.names import ZONE_BOUNDS
from hvacfmu.fmu_slave.resources import (
    INTERFACE_FILE,
    cached_setup,
    read_layout,
    stored_boxes,
    stored_season_dates,
    stored_timezone,
)
from hvacfmu.fmu_slave.values import contiguous, tuple_getter
from hvacfmu.fmu_slave.zone_layout import state_from_outputs, zone_model_layout

if "HvacfmuSlaveBase" not in globals():  # imported as a module, not executed into a slave script
    from hvacfmu.fmu_slave.base import HvacfmuSlaveBase


class ZoneModelSlave(HvacfmuSlaveBase):
    """FMU slave for any saved ZoneModel (``resources/model.json``).

    Variables (value references in this order):

    - inputs ``m_<vav>`` [kg/s] per VAV box (summed to the model's inputs with
      its input map), or the model's own inputs when it has no box map;
    - inputs for the model's disturbances (``T_out``, ``T_supply`` [°C],
      ``I_N`` ... ``I_W`` [W/m²] when used);
    - outputs ``T_<zone>`` [°C] (``T_floor`` for the lumped model);
    - parameters ``T_<zone>_start`` [°C], ``season`` (Integer, mapping in its
      description), ``start_time_of_week`` [s], and ``start_time`` [s, Unix
      epoch] for calendar-dependent models and FMUs exported with the building
      file (see the module docstring). Such an FMU holds the building's seasons by
      date (``season_dates`` in ``interface.json``): ``season = 0`` runs each model
      step in its local day's season (:meth:`_calendar_steps`), switching the model
      (coefficient set) and gains at a boundary with the state carried over.
    """

    #: model steps of internal gains computed at once from the calendar
    CALENDAR_CHUNK = 672

    MODEL_FILE = "model.json"

    def _setup(self):
        self.model = None
        problem = None
        try:

            def build():
                from hvacfmu.models import load_model  # host environment

                model = load_model(Path(self.resources or ".") / self.MODEL_FILE)
                return (model,) + zone_model_layout(
                    model,
                    stored_timezone(self.resources),
                    stored_boxes(self.resources),
                    stored_season_dates(self.resources),
                )

            model, layout, M = cached_setup("model", self.resources, (self.MODEL_FILE, INTERFACE_FILE), build)
            layout = json.loads(json.dumps(layout, default=float))  # each instance its own copy
        except Exception as exc:  # noqa: BLE001 - reported, never raised
            model, layout, M = None, None, None
            from hvacfmu.errors import HvacfmuError

            detail = str(exc) if isinstance(exc, HvacfmuError) else traceback.format_exc()
            problem = f"cannot use the FMU's model file resources/{self.MODEL_FILE}: {detail}"
        layout, mismatch = read_layout(self.resources, layout, self.MODEL_FILE)
        problem = problem or mismatch
        if problem:
            self._broken = problem
        if layout is None:
            return []
        self.description = layout["description"]
        self.default_experiment = DefaultExperiment(start_time=0.0, stop_time=7 * 86400.0, step_size=layout["step"])
        self.seasons = tuple(layout["seasons"])
        self._step = float(layout["step"])
        self._timezone = layout.get("timezone")
        #: the building's seasons by date ([[name, "MM-DD", "MM-DD"], ...], written at export with the building
        #: file): season = 0 follows them (:meth:`_season_numbers`)
        self._season_dates = layout.get("season_dates") or None
        # the model's gains follow a calendar (holidays, DST terms); an FMU without a season table has start_time
        # only for such a model
        self._calendar = bool(layout.get("calendar", True))
        self._follow = False  # season = 0: the season switches at the calendar's boundaries
        self._season_models: dict = {}  # season number -> its model (:meth:`_season_model`)
        self._abs0 = None  # start_time [s] when the calendar is used
        self._q_chunk = (None, None, None)  # (first model step, gains, season numbers) computed from the calendar
        if model is not None and not problem:
            self.model = model
            self._loaded = model  # a model with one coefficient set per season runs its season's (initialisation)
            self._M = M
            self._MT = None if M is None else np.ascontiguousarray(M.T)
        self._idle = None  # the model's idle supply rule on the inputs (hvacfmu.data.idle.IdleStep)
        if layout.get("idle_supply"):
            from hvacfmu.data.idle import IdleStep

            self._idle = IdleStep.from_dict(layout["idle_supply"])
        self._idle_last = None  # its memory ("last" mode): last running value of each replaced input
        self._x = None
        self._k = 0  # model steps taken since the start time
        self._slot0 = 0
        self._profile = None
        self._n_slots = None
        return layout["variables"]

    def _initialize(self):
        v = self._values
        self._y_vrs = self.vrs_with_role("y")
        self._y_start = self._y_vrs[0] if contiguous(self._y_vrs) else None
        self._y0_vrs = self.vrs_with_role("y0")
        m_vrs, v_vrs, c_vrs = self.vrs_with_role("m"), self.vrs_with_role("v"), self.vrs_with_role("tow_in")
        self._nm = len(m_vrs)
        self._nmv = len(m_vrs) + len(v_vrs)
        self._has_clock_input = bool(c_vrs)
        in_vrs = m_vrs + v_vrs + c_vrs
        self._w_ok = in_vrs == self._input_vrs  # the checked input block is (m, v, time_of_week) in this order
        if contiguous(in_vrs) and self._w_ok:
            a, b = in_vrs[0], in_vrs[0] + len(in_vrs)
            self._get_inputs = lambda values: values[a:b]
        else:
            self._get_inputs = tuple_getter(in_vrs)
        (season_vr,) = self.vrs_with_role("season")
        (tow_vr,) = self.vrs_with_role("tow")
        problems = []
        y0 = [v[vr] for vr in self._y0_vrs]
        lo, hi = ZONE_BOUNDS
        for vr, val in zip(self._y0_vrs, y0):
            if not (lo <= val <= hi):
                problems.append(f"{self._spec[vr]['name']}={val!r} degC is outside [{lo}, {hi}]")
        season = v[season_vr]
        follow = self._season_dates is not None and season == 0
        if not (isinstance(season, int) and (1 <= season <= len(self.seasons) or follow)):
            problems.append(
                f"season={season!r} is not one of "
                + ("0 (follow the calendar), " if self._season_dates is not None else "")
                + ", ".join(f"{i + 1} ({s})" for i, s in enumerate(self.seasons))
                + (
                    ""
                    if self._season_dates is not None or season != 0
                    else " (season = 0, follow the calendar, needs the building's seasons by date: export the "
                    "FMU with the building file, hvacfmu export -b BUILDING)"
                )
            )
        tow = v[tow_vr]
        if not (0.0 <= tow <= 7 * 86400.0):
            problems.append(f"start_time_of_week={tow!r} s is outside [0, 604800]")
        abs_vrs = self.vrs_with_role("t_abs")
        self._abs0 = None
        self._q_chunk = (None, None, None)
        self._follow = False
        if abs_vrs:
            t_abs = v[abs_vrs[0]]
            if t_abs == -1.0 and follow:
                problems.append(
                    "season=0 (follow the calendar's seasons) needs start_time, the absolute time at FMU time 0 "
                    "[s, Unix epoch]; it is not set (-1): set start_time, or choose one season (1.."
                    f"{len(self.seasons)}) for the whole run"
                )
            elif t_abs == -1.0:
                if self._calendar:  # (an FMU with a season table only: the time-of-week profile, no warning)
                    self.log(
                        "start_time is not set (-1): the internal gains follow the time-of-week profile "
                        "without the model's calendar (holidays, daylight saving time); set start_time "
                        "[s, Unix epoch] to the absolute time at FMU time 0",
                        Fmi2Status.warning,
                    )
            elif not (math.isfinite(t_abs) and t_abs >= 0.0):
                problems.append(f"start_time={t_abs!r} s is neither -1 (unset) nor a Unix epoch time >= 0")
            else:
                self._abs0 = float(t_abs)
        if problems:
            return problems
        if follow:
            self._follow = True
            season = int(self._calendar_steps(0, 1)[1][0])  # the calendar's season at FMU time 0
        self._season = season
        self._use_season(season)
        self._profile = np.asarray(self.model.gains[self.seasons[season - 1]], dtype=float)
        self._n_slots = self._profile.shape[0]
        # slot of model step k: floor((tow + t_start)/step) + k  (mod n_slots)
        self._slot0 = int(math.floor((tow + self._t_start) / self._step + 1e-9))
        # inputs set before fmi2ExitInitializationMode (FMPy applies the first input row) start the state
        w = np.array(self._get_inputs(v), dtype=float)
        nm, nmv = self._nm, self._nmv
        if not np.all(np.isfinite(w)):
            return ["inputs at initialisation are not finite"]
        u0 = w[:nm] @ self._MT if self._MT is not None else w[:nm]
        if self._abs0 is not None:
            q0 = self._calendar_gains(0, 1)[0]
        else:
            q0 = self._profile[self._slot(w, 0) % self._n_slots]
        v0 = w[nm:nmv]
        self._idle_last = None
        if self._idle is not None:
            v0 = self._idle.apply(v0, w[:nm], np.asarray(y0, dtype=float))[0]
            self._idle_last = [math.nan] * len(self._idle)
        self._x = state_from_outputs(self.model, np.asarray(y0, dtype=float), u0, v0, q0)
        self._k = 0
        self._t = self._t_start
        self._write_outputs(np.asarray(self.model.output(self._x), dtype=float).tolist())
        return []

    def _use_season(self, season):
        """Run the model of season number ``season`` (1-based): the loaded model's ``for_season`` (its own season's
        coefficient set when it holds one per season; the model itself otherwise)."""
        self.model = self._season_model(season)

    def _season_model(self, season):
        """The model of season number ``season`` (1-based), built once per instance."""
        from hvacfmu.models.base import season_model

        cache = self._season_models
        if season not in cache:
            cache[season] = season_model(self._loaded, self.seasons[season - 1])
        return cache[season]

    def _season_numbers(self, index):
        """Season number (1-based, :attr:`seasons`) of each local timestamp of ``index`` from the season table.

        ValueError naming the date when a day's season is not one the model has a profile for (the export writes
        the table only for a model that has every season of its building)."""
        from hvacfmu.building import Season

        table = [Season(*map(str, row)) for row in self._season_dates]
        key = index.month.to_numpy() * 100 + index.day.to_numpy()
        out = np.empty(len(key), dtype=np.int64)
        for kk in np.unique(key):
            hits = [t.name for t in table if t.contains(int(kk) // 100, int(kk) % 100)]
            if len(hits) != 1 or hits[0] not in self.seasons:
                raise ValueError(
                    f"the FMU's season table gives month-day {int(kk) // 100:02d}-{int(kk) % 100:02d} the "
                    f"season(s) {hits}; the model has profiles for {list(self.seasons)}"
                )
            out[key == kk] = self.seasons.index(hits[0]) + 1
        return out

    def _slot(self, w, k):
        """Gain-profile slot of model step ``k``: from the ``time_of_week`` input when set, else the clock."""
        if self._has_clock_input and w[self._nmv] >= 0.0:
            return int(math.floor(w[self._nmv] / self._step + 1e-9))
        return self._slot0 + k

    def _calendar_gains(self, k, n):
        """Internal gains (n, n_q) of model steps ``k .. k+n-1`` from the model's calendar (``gains_at``)."""
        return self._calendar_steps(k, n)[0]

    def _calendar_steps(self, k, n):
        """Internal gains (n, n_q) and season numbers (n,) of model steps ``k .. k+n-1`` from the calendar.

        The instants are ``start_time + t_start + j*step`` [s, Unix epoch], in
        the exported time zone, computed in whole milliseconds so that they
        equal the timestamps of a data index exactly. Each step's season is the
        run's (``season`` >= 1) or, following the calendar (``season = 0``), its
        local day's in the season table; its gains are that season's model's
        ``gains_at``. Computed for :attr:`CALENDAR_CHUNK` steps at a time and reused.
        """
        first, q, sn = self._q_chunk
        if q is None or k < first or k + n > first + len(q):
            import pandas as pd

            m = max(n, self.CALENDAR_CHUNK)
            t0_ms = int(round((self._abs0 + self._t_start) * 1000.0))
            ms = t0_ms + (k + np.arange(m, dtype=np.int64)) * int(round(self._step * 1000.0))
            index = pd.DatetimeIndex(pd.to_datetime(ms, unit="ms", utc=True)).tz_convert(self._timezone)
            if self._follow:
                sn = self._season_numbers(index)
                q = None
                for s in np.unique(sn):
                    rows = np.flatnonzero(sn == s)
                    qs = np.asarray(self._season_model(int(s)).gains_at(index[rows], self.seasons[s - 1]), dtype=float)
                    if q is None:
                        q = np.empty((m,) + qs.shape[1:], dtype=float)
                    q[rows] = qs
            else:
                q = np.asarray(self.model.gains_at(index, self.seasons[self._season - 1]), dtype=float)
                sn = np.full(m, self._season, dtype=np.int64)
            first = k
            self._q_chunk = (first, q, sn)
        return q[k - first : k - first + n], sn[k - first : k - first + n]

    def _write_outputs(self, y):
        a = self._y_start
        if a is not None:
            self._values[a : a + len(y)] = y
            return
        values = self._values
        for vr, val in zip(self._y_vrs, y):
            values[vr] = val

    def _advance(self, current_time, step_size):
        k = step_size / self._step
        n = int(round(k))
        if n < 1 or abs(k - n) > self.STEP_RTOL * max(1.0, k):
            return self._refuse(
                f"communication step {step_size!r} s at t={current_time} s is not a whole multiple of the "
                f"model step {self._step:g} s; step refused (use a step of k*{self._step:g} s, k >= 1)"
            )
        w = self._w if self._w_ok else None
        if w is None:
            w = np.array(self._get_inputs(self._values), dtype=float)
        nm = self._nm
        u = w[:nm] @ self._MT if self._MT is not None else w[:nm]
        vdist = w[nm : self._nmv]
        x, model, prof, ns = self._x, self.model, self._profile, self._n_slots
        if self._idle is not None:
            return self._advance_idle(current_time, n, w, u, vdist)
        if self._follow:
            gains, seasons = self._calendar_steps(self._k, n)
            for qj, sj in zip(gains, seasons):
                if sj != self._season:  # a season boundary between two model steps: the state carries over
                    self._season = int(sj)
                    model = self.model = self._season_model(self._season)
                x = model.step_state(x, u, vdist, qj)
        elif self._abs0 is not None:
            for qj in self._calendar_gains(self._k, n):
                x = model.step_state(x, u, vdist, qj)
        else:
            slot = self._slot(w, self._k)
            for j in range(n):
                x = model.step_state(x, u, vdist, prof[(slot + j) % ns])
        return self._commit(current_time, n, x)

    def _advance_idle(self, current_time, n, w, u, vdist):
        """:meth:`_advance` with the idle supply rule applied before every model step (own zone temperatures)."""
        x, model, rule, m = self._x, self.model, self._idle, w[: self._nm]
        last = np.array(self._idle_last, dtype=float)
        if self._abs0 is not None:
            gains, seasons = self._calendar_steps(self._k, n)
        else:
            slot = self._slot(w, self._k)
            gains = [self._profile[(slot + j) % self._n_slots] for j in range(n)]
            seasons = [self._season] * n
        for qj, sj in zip(gains, seasons):
            if sj != self._season:  # following the calendar: a season boundary (the state carries over)
                self._season = int(sj)
                model = self.model = self._season_model(self._season)
            vj, last = rule.apply(vdist, m, np.asarray(model.output(x), dtype=float), last)
            x = model.step_state(x, u, vj, qj)
        if not self._commit(current_time, n, x):
            return False
        self._idle_last = last.tolist()
        return True

    def _commit(self, current_time, n, x):
        """Take the state ``x`` after ``n`` model steps unless its outputs are non-finite (step refused)."""
        y = np.asarray(self.model.output(x), dtype=float).tolist()
        if not math.isfinite(sum(y)):
            return self._refuse(
                f"the zone temperatures became non-finite in the step from t={current_time} s; step refused"
            )
        self._x = x
        self._k += n
        self._t = self._t_start + self._k * self._step
        self._write_outputs(y)
        return True

    def _get_internal_state(self):
        return {
            "x": None if self._x is None else self._x.tolist(),
            "k": self._k,
            "slot0": self._slot0,
            "season": getattr(self, "_season", None),
            "follow": self._follow,
            "abs0": self._abs0,
            "idle_last": self._idle_last,
        }

    def _set_internal_state(self, state):
        x = None if state["x"] is None else np.array(state["x"], dtype=float)
        season = state["season"]
        if season is not None:
            self._use_season(season)
            self._profile = np.asarray(self.model.gains[self.seasons[season - 1]], dtype=float)
            self._n_slots = self._profile.shape[0]
            self._season = season
        self._x = x
        self._k = int(state["k"])
        self._slot0 = int(state["slot0"])
        self._abs0 = state.get("abs0")
        self._follow = bool(state.get("follow", False))
        self._idle_last = state.get("idle_last")
        self._q_chunk = (None, None, None)
