"""The MPC controller in the co-simulation harness (``hvacfmu cosim --controller mpc``).

:func:`cosim_controller` wraps :class:`~harness.mpc.controller.MPCController`
in the controller protocol of :mod:`harness.controllers`: it maps the FMU's
outputs to the model's measured outputs, previews disturbances and internal
gains from the run's prepared data (a perfect forecast, as in the paper), and
maps the model's inputs to VAV box commands.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pandas as pd

from hvacfmu.errors import HvacfmuError, HvacfmuWarning, ModelError

from ..controllers import BoxLimiter, default_horizon
from .controller import MPCController, input_limits, input_mapping
from .heating import HEAT_WEIGHT, box_inlets, discharge_commands, heat_plan, reheat_disturbances
from .predict import make_predictor, state_from_outputs
from .problem import MPCSettings

_SETTING_NAMES = {f.name for f in dataclasses.fields(MPCSettings)}

#: presets of :class:`CosimMPC` (options given explicitly win)
PRESETS = ("plant", "paper")


def preset_options(preset: str, horizon: int, bilinear: bool) -> dict:
    """MPC options of a preset for a horizon [steps] and a linear or bilinear model.

    ``"paper"``: none (:class:`MPCSettings` defaults, the paper's problem).
    ``"plant"`` (the harness default): what a model that is not the building
    needs, measured on the emulator's plant FMU (``benchmarks/bench_mpc_plant.py``,
    README "MPC"): offset-free estimation (``offset_gain=0.6``), move
    suppression (``move_penalty=20``), a 0.4 K back-off from the band edges,
    input-gain adaptation (``gain_adapt=0.05``: a plant that responds several times
    more strongly than the model to a move no longer makes the plan cycle between
    full reheat and maximum airflow),
    and for horizons over 3 steps move blocking, per-step slack and the ℓ1
    penalty QP (a shared slack or ρ‖ε‖₂ spread slack over long horizons);
    bilinear models up to 24 steps use the Newton linearisation, longer horizons
    (reduced-order prediction) one convex iteration per step (real-time
    iteration: the first step is exact, the plan is refined at the next steps).
    """
    if preset not in PRESETS:
        raise HvacfmuError(f"unknown MPC preset {preset!r}; choose one of {PRESETS}")
    if preset == "paper":
        return {}
    out = {"offset_gain": 0.6, "move_penalty": 20.0, "back_off": 0.4, "gain_adapt": 0.05}
    if horizon > 3:
        out.update(blocks="auto", slack="per_step", formulation="qp")
        if bilinear and horizon <= 24:
            out["linearisation"] = "newton"
        elif bilinear:  # reduced-order prediction: one convex iteration per step (real-time iteration)
            out["max_iter"] = 1
    return out


def settings_from_options(band=None, **options) -> tuple[MPCSettings, dict]:
    """MPCSettings from ``KEY=VALUE`` harness options; returns (settings, remaining options).

    ``comfort_penalty=none`` keeps the band hard, ``blocks=auto`` selects
    :func:`~harness.mpc.problem.default_blocks`, ``blocks=1/1/2`` gives explicit lengths.
    """
    kw, rest = {}, {}
    for key, value in options.items():
        if key not in _SETTING_NAMES:
            rest[key] = value
            continue
        if isinstance(value, str) and value.lower() in ("none", "null", "hard"):
            value = None
        if key == "blocks" and isinstance(value, str) and value != "auto":
            value = tuple(int(x) for x in value.replace(",", "/").split("/"))
        kw[key] = value
    if band is not None:
        kw.setdefault("T_min", float(band[0]))
        kw.setdefault("T_max", float(band[1]))
    return MPCSettings(**kw), rest


class CosimMPC:
    """Energy-efficient MPC following the harness controller protocol.

    Parameters
    ----------
    model : ZoneModel (Model A or Model B)
    building : Building or None (the harness passes the run's building at reset)
    failure_dir : path or None
        Where failed problems are saved for replay.
    kalman_q_std, kalman_r_std : float [K]
    init : {"outputs", "model"}
        Initial estimate of hidden states (see :meth:`_initial_estimate`).
    heating : bool
        Where the plant takes discharge air commands (``context.discharge``), decide
        a reheat per box (or per zone for Model A) as well (:mod:`harness.mpc.heating`);
        ``False`` commands airflows only.
    preset : {"plant", "paper"}
        Defaults under the explicit options (:func:`preset_options`): ``"plant"``
        (offset-free, move suppression, back-off; the model is not the building)
        or ``"paper"`` (the paper's problem as stated).
    **options : MPCSettings fields (``horizon``, ``rho``, ``formulation``, ...)
        Without ``horizon``: :data:`DEFAULT_HORIZON_H` (3 h) in steps of the run's data
        (:func:`default_horizon`: of the model's step here, of the run's step at :meth:`reset`).
    """

    name = "mpc"

    def __init__(
        self,
        model,
        building=None,
        failure_dir=None,
        kalman_q_std=0.05,
        kalman_r_std=0.05,
        init="outputs",
        preset="plant",
        heating=True,
        **options,
    ):
        if init not in ("outputs", "model"):
            raise HvacfmuError(f"init must be 'outputs' or 'model', got {init!r}")
        self.init = init
        self.preset = preset
        self.heating = bool(heating)
        self.model = model
        #: the model as given: with one coefficient set per season, :meth:`reset` runs the set of the run's season
        self.loaded = model
        self.building = building
        self.failure_dir = failure_dir
        self.kalman = (float(kalman_q_std), float(kalman_r_std))
        self.options = dict(options)
        _, unknown = settings_from_options(**self.options)
        if unknown:
            raise HvacfmuError(f"unknown MPC option(s) {sorted(unknown)}; known: {sorted(_SETTING_NAMES)}")
        self._explicit = self.options
        # a model with one coefficient set per season: every set has the same structure (linear or bilinear)
        first = model.for_season(model.seasons[0]) if getattr(model, "seasonal", False) else model
        self._bilinear = not make_predictor(first).linear
        self._configure(model.step)
        self.settings, _ = settings_from_options(**self.options)
        self.mpc = None

    def _configure(self, step) -> None:
        """:attr:`options`: the preset's under the explicit ones, the horizon defaulted at ``step`` [s] if not given."""
        self.horizon_default = "horizon" not in self._explicit
        horizon = default_horizon(step) if self.horizon_default else int(self._explicit["horizon"])
        self.step_s = float(step)
        self.options = {
            **preset_options(self.preset, horizon, self._bilinear),
            **self._explicit,
            **({"horizon": horizon} if self.horizon_default else {}),
        }

    # ----- protocol ------------------------------------------------------
    def reset(self, context) -> None:
        if getattr(self.loaded, "seasonal", False):  # the run's season's coefficient set (refused without one)
            if context.season is None:
                raise ModelError(
                    "the MPC's model holds one coefficient set per season "
                    f"({', '.join(self.loaded.seasons)}) and this run names no season: give the run's season"
                )
            self.model = self.loaded.for_season(context.season)
        model = self.model
        self._configure(context.step)  # a default horizon in steps of the run's data
        self.settings, _ = settings_from_options(band=context.band, **self.options)
        building = context.building if context.building is not None else self.building
        u_min, u_max = input_limits(model, building)
        self.n_air = u_min.size
        controlled, weights, hard, self.heat = model, None, None, None
        if self.heating and context.discharge:
            controlled, self.heat, _ = heat_plan(
                model, building, context.vavs, context.discharge, context.heating_limits(), context.frame
            )
            T_ref = float(np.nanmedian(context.frame["T_supply"].to_numpy(float)))
            h_max = self.heat.limits(T_ref)  # [kW] at the run's median supply air (applied: clipped per box)
            u_min, u_max = np.concatenate([u_min, np.zeros_like(h_max)]), np.concatenate([u_max, h_max])
            weights = np.concatenate([np.ones(self.n_air), np.full(h_max.size, HEAT_WEIGHT)])
            # a coil's capacity is hard (a soft comfort band keeps the problem feasible); the airflow limits stay
            # softened as in the paper, and a hard band keeps the reheat's softened too (else a cold start
            # could have no solution)
            hard = np.arange(u_min.size) >= self.n_air if self.settings.comfort_penalty is not None else None
            self._td_boxes = [list(context.vavs).index(b) for b in context.discharge]
        self.mpc = MPCController(
            controlled,
            u_min,
            u_max,
            self.settings,
            kalman_q_std=self.kalman[0],
            kalman_r_std=self.kalman[1],
            failure_dir=self.failure_dir,
            input_weights=weights,
            hard_inputs=hard,
            schedule=getattr(context, "off", None) is not None,
        )
        N = self.mpc.N
        frame = context.frame
        # previews: the run's rows, then the last row held for the horizon past the end
        idx = pd.date_range(
            frame.index[0], periods=len(frame) + N, freq=pd.Timedelta(seconds=context.step), tz=frame.index.tz
        )
        ext = frame.reindex(idx).ffill()
        # columns an extended model derives (the reheat heat of a zone, Qrh_<zone>): derived here even when the
        # run's data carry them (``run_cosim`` adds them for a model FMU's inputs), 0 where this run commands the
        # discharge air
        derived = reheat_disturbances(model, ext, context.discharge or ())
        ext = ext.assign(**{c: q for c, q in derived.items() if c in model.disturbances})
        missing = [c for c in model.disturbances if c not in ext]
        if missing:
            raise ModelError(f"the run's data lack disturbance column(s) {missing} that the model needs")
        self.V = ext[list(model.disturbances)].to_numpy(dtype=float)
        self._T_supply = ext["T_supply"].to_numpy(dtype=float) if "T_supply" in ext else None
        self.replaced_inlets = self._commanded_inlets(context, ext)
        self._idle, self._idle_boxes, self._idle_last = self._idle_rule(context), None, None
        if self._idle is not None:
            box = {b: i for i, b in enumerate(context.vavs)}
            self._idle_boxes = np.array([box.get(b, -1) for b in model.base.vavs])
        if hasattr(model, "gains_for_rows"):
            self.Q = np.asarray(model.gains_for_rows(idx), dtype=float)
        else:
            season = context.season if context.season in model.gains else next(iter(model.gains))
            self.Q = np.asarray(model.gains_at(idx, season), dtype=float)
        self._context = context
        self._output_map(context)
        self._input_map(context, building)
        x0 = self._initial_estimate(frame) if self.mpc.estimated else None
        self.mpc.reset(x0=x0)

    def _initial_estimate(self, frame):
        """Initial state estimate of a model with hidden states (walls).

        ``init="outputs"`` (default): hidden states at their steady state for
        the first measured outputs, inputs, disturbances and gains held — how
        the model FMUs start (:func:`harness.mpc.predict.state_from_outputs`), so
        an MPC run against its own model's FMU starts from the FMU's state.
        ``init="model"``: the model's own estimate (``model.initial_state``,
        a Kalman filter over the run's first rows). Either way the Kalman
        filter then corrects the walls from the measured zone temperatures.
        """
        model = self.model
        row = frame.iloc[:1]
        if self.init == "model" and hasattr(model, "initial_state"):
            return np.asarray(model.initial_state(frame, 0), dtype=float)
        u, v = model.signals(row)
        y0 = model.measured_outputs(row)[0]
        if not (np.all(np.isfinite(y0)) and np.all(np.isfinite(u)) and np.all(np.isfinite(v))):
            return None  # gaps at the start: the controller's own steady-state initialisation
        u0 = np.concatenate([u[0], np.zeros(self.mpc.pred.nu - u.shape[1])])  # no reheat
        return state_from_outputs(self.mpc.pred, y0, u0, v[0], self.Q[0])

    def __call__(self, k, t, y, v):
        y = np.asarray(y, dtype=float)
        y_model = self._W @ y
        V = self.V[k : k + self.mpc.N]
        if self._idle is not None:
            V = self._idle_preview(k, V, y_model)
        u = self.mpc.step(y_model, V, self.Q[k : k + self.mpc.N], self._off_inputs(k))
        m = self.limiter(self._split_offset + self._split @ u[: self.n_air], self._context.off_at(k))
        if self.heat is None:
            return m
        T_supply = float(v["T_supply"]) if "T_supply" in v else float(self._T_supply[k])
        return np.concatenate([m, discharge_commands(self.heat, u[self.n_air :], m, T_supply, self._td_boxes)])

    def _idle_rule(self, context):
        """The model's stored idle supply rule (``meta["idle_supply"]``, :class:`hvacfmu.data.idle.IdleStep`) when the
        run follows a schedule (``context.off``), else None.

        A model fitted on data whose idle supply temperature was held (``diagnose``'s extended model: airflow-form
        Model A, where ``T_supply`` enters linearly and acts at zero airflow too) reads, in an off step, the value
        the rule gives, not the idle duct reading; its FMUs apply the same rule to their input
        (:mod:`hvacfmu.fmu_slave`), and a plant with no airflow gets no heat from the supply air, which the rule's
        ``"zone"`` mode (the unit's zones' mean air temperature) reproduces in the model.
        """
        if getattr(context, "off", None) is None or not hasattr(self.model, "idle_step"):
            return None
        return self.model.idle_step()

    def _idle_preview(self, k, V, y_model):
        """The disturbance preview from step ``k`` with the idle rule applied in the schedule's off steps.

        :meth:`hvacfmu.data.idle.IdleStep.apply`, the FMUs' own: a box is off in a row where the schedule has it
        off (the plant then gets 0 airflow), the zone temperatures are the ones measured now (at row 0 exactly what
        a model FMU as plant uses; held over the horizon), ``"last"`` keeps its memory across steps as the FMU does.
        """
        off = self._context.off
        rows = np.minimum(np.arange(k, k + len(V)), len(off) - 1)
        boxes = np.where(self._idle_boxes >= 0, self._idle_boxes, 0)
        shut = off[rows][:, boxes] | (self._idle_boxes < 0)  # a box the plant lacks has no airflow
        m = np.where(shut, 0.0, np.inf)
        out = np.array(V, dtype=float)
        last = self._idle_last
        for j in range(len(out)):
            out[j], last = self._idle.apply(out[j], m[j], y_model, last)
            if j == 0:
                self._idle_last = last  # the memory after this step, as the plant's
        return out

    def _off_inputs(self, k):
        """``(N, nu)`` bool: model inputs off over the horizon from step ``k`` (None without a schedule).

        An airflow input is off where every box it drives is off (the building's schedule,
        ``ControlContext.off``); a reheat input where every box is off. Past the run's end the last row holds.
        """
        off = self._context.off
        if off is None:
            return None
        N = self.mpc.N
        rows = np.minimum(np.arange(k, k + N), len(off) - 1)
        boxes = off[rows]  # (N, n_boxes)
        drives = self._split != 0.0  # (n_boxes, n_air)
        air = np.stack([boxes[:, drives[:, i]].all(axis=1) for i in range(self.n_air)], axis=1)
        n_heat = self.mpc.pred.nu - self.n_air
        heat = np.repeat(boxes.all(axis=1)[:, None], n_heat, axis=1)
        return np.concatenate([air, heat], axis=1)

    def stats(self) -> dict:
        """The horizon, the MPC's statistics (:meth:`MPCController.stats`) and the box clipping (:class:`BoxLimiter`).

        Horizon keys: ``horizon`` [steps], ``horizon_h`` [h] and ``horizon_default`` (True: not given, so
        :data:`DEFAULT_HORIZON_H` at the run's step).
        """
        if self.mpc is None:
            return {}
        N = self.mpc.N
        horizon = {"horizon": N, "horizon_h": N * self.step_s / 3600.0, "horizon_default": self.horizon_default}
        return {**horizon, **self.mpc.stats(), **self.limiter.stats()}

    # ----- mappings ------------------------------------------------------
    def _commanded_inlets(self, context, ext) -> list:
        """Preview the plant's discharge air, not the data's, for the boxes whose discharge the run commands.

        A model that reads each box's measured discharge air ``Td_<vav>`` (Model A's delivered-heat form,
        Model B with measured inlets) takes it as a disturbance; on a plant that takes discharge commands the
        recorded ``Td`` (the building's own reheat) never reaches the plant: the box discharges its supply air
        plus this controller's reheat (its ``h`` inputs, :mod:`harness.mpc.heating`) or, without them, its supply
        air. Those columns of the preview become the run's ``T_supply``, and a recorded reheat signal ``rh_<vav>`` of
        such a box (an input the diagnosis found) becomes 0. Returns the replaced columns.
        """
        if not context.discharge or self._T_supply is None:
            return []
        inlet = box_inlets(self.model)
        names = list(self.model.disturbances)
        replaced = []
        for box in context.discharge:
            col = inlet.get(box)
            if col is not None and col.startswith("Td_") and col in names:
                self.V[:, names.index(col)] = self._T_supply
                replaced.append(col)
            # a recorded reheat signal the diagnosis took as an input (``unused_input`` on ``rh_<vav>``): the
            # building's own reheat, which the commanded box does not get
            if f"rh_{box}" in names:
                self.V[:, names.index(f"rh_{box}")] = 0.0
                replaced.append(f"rh_{box}")
        return replaced

    def _output_map(self, context):
        """``y_model = W y_fmu``: model outputs from the FMU outputs."""
        outs = list(context.outputs)
        model = self.model
        W = np.zeros((len(model.outputs), len(outs)))
        src = model if hasattr(model, "measured_zones") else getattr(model, "base", model)  # extended: its base
        problems = []
        zone_out = {}
        for j, zs in enumerate(context.output_zones):
            if len(zs) == 1:
                zone_out[zs[0]] = j
        for i, o in enumerate(model.outputs):
            if f"T_{o}" in outs:
                W[i, outs.index(f"T_{o}")] = 1.0
            elif hasattr(src, "measured_zones") and hasattr(src, "output_weights"):
                for z, w in zip(src.measured_zones, src.output_weights[i]):
                    if w != 0.0 and z not in zone_out:
                        problems.append(f"model output {o!r} needs zone {z!r}, which no FMU output measures")
                    elif w != 0.0:
                        W[i, zone_out[z]] = w
            else:
                problems.append(f"no FMU output for model output {o!r} (FMU outputs: {outs})")
        if problems:
            raise HvacfmuError("MPC cannot read the plant's outputs: " + "; ".join(problems))
        merged = [(o, [outs[j] for j in np.flatnonzero(W[i])]) for i, o in enumerate(model.outputs)]
        merged = [(o, js) for o, js in merged if len(js) > 1]
        if merged:
            # a lumped model on a multi-zone plant: one prediction, one decision for every box; round 2 of fleet sweep
            # s10 measured 306 and 178 K*h in two days (corners above the band, the core below) against 3.3 and 1.1
            # with the zones model, and said nothing before the run
            warnings.warn(
                "the model predicts "
                + "; ".join(
                    f"{o!r} as the weighted mean of {len(js)} plant outputs ({', '.join(js)})" for o, js in merged
                )
                + ": the MPC keeps that mean in the band, not each zone, so single zones may leave it on both sides "
                "(control with a zones model, hvacfmu fit --model zones, to hold each zone)",
                HvacfmuWarning,
                stacklevel=3,
            )
        self._W = W

    def _input_map(self, context, building):
        """``m_vav = offset + S u``: box commands from the model's inputs.

        Model A's zone (or total) airflow is split affinely so that the summed
        limits map onto every box's own ``[m_min, m_max]``.
        """
        vavs = list(context.vavs)
        m_min, m_max = context.box_limits()
        model = self.model
        nu = self.n_air
        S = np.zeros((len(vavs), nu))
        off = np.zeros(len(vavs))
        mapped = input_mapping(model)
        self.limiter = BoxLimiter(m_min, m_max, vavs)
        if mapped is not None:
            m_vavs, input_map = mapped
            for i in range(nu):
                boxes = [vavs.index(b) for b, w in zip(m_vavs, input_map[i]) if w != 0.0 and b in vavs]
                if not boxes:
                    raise HvacfmuError(f"model input {model.inputs[i]!r} drives no box of the plant")
                lo, hi = m_min[boxes], m_max[boxes]
                span = max(float(np.sum(hi - lo)), 1e-12)
                S[boxes, i] = (hi - lo) / span
                off[boxes] = lo - (hi - lo) / span * float(np.sum(lo))
        else:
            names = [n[2:] if n.startswith("m_") else n for n in model.inputs]
            missing = [n for n in names if n not in vavs]
            if missing:
                raise HvacfmuError(f"model inputs {missing} are not boxes of the plant")
            for i, n in enumerate(names):
                S[vavs.index(n), i] = 1.0
        self._split, self._split_offset = S, off


def cosim_controller(model, building=None, **options) -> CosimMPC:
    """The MPC controller for :func:`harness.cosim.make_controller` (``--controller mpc``)."""
    return CosimMPC(model, building, **options)
