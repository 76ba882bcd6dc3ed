"""Variable layout of the FMU of a zone model (any :class:`~hvacfmu.models.ZoneModel` kind).

How box airflows map to the model's inputs (:func:`input_matrix`), whether the
model's gains follow a calendar (:func:`calendar_dependent`), and the layout
itself (:func:`zone_model_layout`): box airflow inputs, disturbance inputs, the
optional ``time_of_week`` input, zone temperature outputs and the parameters.
"""

from __future__ import annotations

import numpy as np

from hvacfmu.fmu_slave.names import (
    BOUNDS,
    SLAVE_API_VERSION,
    box_entry,
    box_limits,
    check_unique,
    entry,
    sanitize_name,
    signal_description,
    signal_entry,
    zone_entries,
)

WEEK = 7 * 86400.0  # [s]


def box_names(model) -> tuple:
    """VAV box names of a model: ``model.vavs``, ``model.base.vavs`` or ``model.building.vav_names``."""
    for get in (lambda m: m.vavs, lambda m: m.base.vavs, lambda m: m.building.vav_names):
        try:
            names = tuple(get(model) or ())
        except AttributeError:
            continue
        if names:
            return names
    return ()


def input_matrix(model) -> tuple[np.ndarray | None, tuple]:
    """The linear map from VAV-box airflows to the model's controlled inputs.

    Probes ``model.signals`` with unit airflows, so it works for every model
    kind that sums (or passes through) box airflows. Box names come from
    :func:`box_names`.

    Returns
    -------
    M : array (n_inputs, n_vavs) or None
        ``u = M @ m_vav``; None when the model has no per-box airflows.
    vavs : tuple of str
        Box names (empty when M is None).
    """
    import pandas as pd

    vavs = box_names(model)
    if not vavs:
        return None, ()
    n = len(vavs)
    idx = pd.date_range("2025-09-01", periods=n + 2, freq=f"{int(model.step)}s", tz="UTC")
    rng = np.random.default_rng(0)
    m = np.vstack([np.zeros(n), np.eye(n), rng.uniform(0.0, 1.0, n)])
    cols = {f"m_{b}": m[:, j] for j, b in enumerate(vavs)}
    for d in model.disturbances:
        cols[d] = np.full(n + 2, 1.0)
    for z in model.outputs:
        cols.setdefault(f"T_{z}", np.full(n + 2, 21.0))
    for z in getattr(model, "measured_zones", ()) or ():
        cols.setdefault(f"T_{z}", np.full(n + 2, 21.0))
    try:
        u, _ = model.signals(pd.DataFrame(cols, index=idx))
    except KeyError:
        return None, ()
    u = np.asarray(u, dtype=float)
    if u.shape != (n + 2, model.n_inputs) or np.any(u[0] != 0.0):
        return None, ()
    M = (u[1 : n + 1] - u[0]).T
    if not np.allclose(M @ m[-1], u[-1], rtol=1e-12, atol=1e-12):
        return None, ()
    return M, vavs


def output_matrix(model) -> np.ndarray:
    """C (n_outputs, n_states) of the linear output map (:func:`hvacfmu.models.state.output_matrix`)."""
    from hvacfmu.models.state import output_matrix as _output_matrix

    return _output_matrix(model)


def state_from_outputs(model, y0, u=None, v=None, q=None) -> np.ndarray:
    """Initial state with outputs ``y0`` [°C] (:func:`hvacfmu.models.state.state_from_outputs`)."""
    from hvacfmu.models.state import state_from_outputs as _state_from_outputs

    return _state_from_outputs(model, y0, u, v, q)


def calendar_dependent(model) -> bool:
    """True if the model's internal gains depend on the date, not only on the time of week.

    That is a model overriding :meth:`~hvacfmu.models.ZoneModel.gains_at` with
    calendar terms: an ``internal_gain_schedule`` term (holidays, daylight-saving
    shift) or a ``sensor_offset`` (``Term.calendar``), or gains that differ from the seasonal time-of-week profile on some
    day of a year in UTC; or a model with a holiday calendar (``holidays``, the
    dataset's :class:`~hvacfmu.data.holidays.HolidayCalendar`).
    """
    import pandas as pd

    from hvacfmu.models.base import ZoneModel
    from hvacfmu.timeutil import time_of_week

    if getattr(model, "holidays", ()):
        return True
    if type(model).gains_at is ZoneModel.gains_at:
        return False
    if any(getattr(t, "calendar", False) for t in getattr(model, "terms", ())):
        return True
    index = pd.date_range("2025-01-06", "2026-01-05", freq=f"{int(model.step)}s", tz="UTC", inclusive="left")
    for season, prof in model.gains.items():
        prof = np.asarray(prof)
        plain = prof[time_of_week(index, model.step) % len(prof)]
        if not np.array_equal(np.asarray(model.gains_at(index, season)), plain):
            return True
    return False


def without_holidays(model):
    """``model`` without its holiday calendar (an extended model: its base's); the model itself if it has none."""
    import dataclasses

    if not getattr(model, "holidays", ()):
        return model
    if getattr(model, "seasonal", False):
        return model.map_sets(lambda m: dataclasses.replace(m, holidays=()))
    if hasattr(model, "base") and getattr(model.base, "holidays", ()):
        return dataclasses.replace(model, base=dataclasses.replace(model.base, holidays=()))
    return dataclasses.replace(model, holidays=())


def zone_model_layout(
    model, timezone: str | None = None, boxes: dict | None = None, season_dates=None
) -> tuple[dict, np.ndarray | None]:
    """Variable layout of the FMU of a zone model, and the box-to-input matrix.

    Parameters
    ----------
    model : ZoneModel
    timezone : str, optional
        IANA time zone of the building (e.g. ``America/Los_Angeles``). Given for a
        :func:`calendar_dependent` model, the layout gets the parameter
        ``start_time`` [s, Unix epoch] and the key ``timezone`` (see
        :mod:`hvacfmu.fmu_slave`); ignored for other models.
    boxes : dict, optional
        Box name -> ``{"zone", "m_min", "m_max"}`` (:func:`~hvacfmu.fmu_slave.names.box_limits`):
        airflow inputs get ``max = M_MAX_MARGIN * m_max``, ``nominal = m_max`` and the
        zone in their description; stored as ``boxes`` in the layout. Default: the
        model's own building when it has one (physics), else generic bounds.
    season_dates : sequence of (name, "MM-DD", "MM-DD"), optional
        The building's seasons by date (:attr:`hvacfmu.building.Building.seasons`), with ``timezone``: stored as
        ``season_dates``; the parameter ``season`` then also takes 0, "follow the calendar" (the season, its
        gains profile and coefficient set switch at the boundaries; needs ``start_time``, which the layout gets).
        Ignored (no season 0) unless the model has a gains profile for every one of these seasons.

    Returns
    -------
    layout : dict
        JSON-ready: ``variables`` (in value-reference order) and model facts.
    M : array (n_inputs, n_vavs) or None
        ``u = M @ m_vav`` (see :func:`input_matrix`).
    """
    M, vavs = input_matrix(model)
    step = float(model.step)
    seasons = [str(s) for s in model.gains]
    boxes = {str(k): dict(v) for k, v in (boxes if boxes is not None else box_limits(model)).items()}
    calendar = timezone is not None and calendar_dependent(model)
    table = None
    if timezone is not None and season_dates:
        table = [[str(n), str(a), str(b)] for n, a, b in season_dates]
        if not {row[0] for row in table} <= set(seasons):
            table = None
    var = _airflow_entries(model, M, vavs, boxes)
    var += [signal_entry(name) for name in model.disturbances]
    var.append(_time_of_week_input())
    label = "the floor (area-weighted mean)" if model.kind == "lumped" else "zone"
    var += zone_entries(model.outputs, label)
    var += _gain_parameters(seasons, timezone if calendar or table else None, table, calendar)
    check_unique(var)
    layout = {
        "slave_api": SLAVE_API_VERSION,
        "kind": model.kind,
        "step": step,
        "seasons": seasons,
        "n_states": int(model.n_states),
        "description": (
            f"hvacfmu {model.kind} zone model: {model.n_outputs} zone temperature(s), {model.n_states} states, "
            f"model step {step:g} s (communication steps must be whole multiples of it). "
            "Runs in the host's Python, which needs the hvacfmu package."
        ),
        "variables": var,
    }
    if getattr(model, "seasonal", False):  # the season parameter also picks the coefficients
        layout["description"] += (
            " The model holds one coefficient set per season (A, B, C fitted per season): the season parameter "
            "selects the set as well as the internal-gain profile."
        )
        for e in var:
            if e["role"] == "season":
                e["description"] += "; it also selects the coefficient set (one per season)"
    idle = idle_supply_layout(model, M, vavs)
    if idle is not None:
        layout["description"] += " " + idle.describe(model.outputs)
        layout["idle_supply"] = idle.to_dict()
        targets = {sanitize_name(idle.names[i]) for i in range(len(idle))}
        for e in var:
            if e["role"] == "v" and e["name"] in targets:
                e["description"] += (
                    "; the raw measured value: replaced inside the FMU while every box of its unit is off "
                    "(idle supply rule, see the model description)"
                )
    if calendar or table:
        layout["timezone"] = str(timezone)
    if table:
        layout["season_dates"] = table
        layout["calendar"] = bool(calendar)  # start_time also places calendar gains (holidays...), not only seasons
        layout["description"] += (
            " It holds the building's seasons by date: season = 0 follows them (with start_time set), switching "
            "season at each boundary within one run."
        )
    if boxes:
        layout["boxes"] = {b: boxes[b] for b in sorted(boxes)}
    return layout, M


def idle_supply_layout(model, M, vavs):
    """The model's idle supply rule on the FMU's inputs (:class:`hvacfmu.data.idle.IdleStep`), or None.

    A model that stores one (an extended model of ``diagnose``, ``meta["idle_supply"]``) gets it applied inside
    the FMU at every model step; it needs the box airflow inputs (``M`` not None). ValueError otherwise.
    """
    from hvacfmu.data.idle import idle_step

    meta = getattr(model, "meta", None)
    if not (isinstance(meta, dict) and meta.get("idle_supply")):
        return None
    if M is None:
        raise ValueError("the model's idle supply rule needs per-box airflow inputs, which this model lacks")
    return idle_step(meta, model.disturbances, vavs, model.outputs)


def _airflow_entries(model, M, vavs, boxes) -> list:
    """Inputs ``m_<vav>`` per box (models with a box map), else one per ``model.inputs`` entry."""
    if M is not None:
        return [box_entry(b, boxes.get(b)) for b in vavs]
    return [
        box_entry(name[2:], boxes.get(name[2:]))
        if name.startswith("m_") and name[2:] in boxes
        else entry("m", sanitize_name(name), "Real", "input", 0.0, "kg/s", signal_description(name), BOUNDS["kg/s"])
        for name in model.inputs
    ]


def _time_of_week_input() -> dict:
    return entry(
        "tow_in",
        "time_of_week",
        "Real",
        "input",
        -1.0,
        "s",
        "Optional: local time of week at the start of the step [s since Monday 00:00]; when >= 0 it "
        "places the internal-gain profile instead of the FMU clock (follow daylight-saving time); "
        "-1 (default): use start_time_of_week + time",
        (-1.0, WEEK),
    )


def _gain_parameters(seasons, timezone: str | None, table=None, calendar: bool = True) -> list:
    """Parameters ``season``, ``start_time_of_week`` and, with a time zone (calendar gains or a season table),
    ``start_time``."""
    mapping = ", ".join(f"{i + 1} = {s}" for i, s in enumerate(seasons))
    follow = ""
    if table:
        dates = ", ".join(f"{n} {a} .. {b}" for n, a, b in table)
        follow = (
            f"; 0 = follow the calendar: each model step runs the season of its local day in {timezone} "
            f"({dates}), switching gains profile and coefficient set at the boundaries with the state carried "
            "over (needs start_time)"
        )
    out = [
        entry(
            "season",
            "season",
            "Integer",
            "parameter",
            1,
            None,
            f"Season of the internal-gain profile: {mapping}{follow}",
            (0 if table else 1, len(seasons)),
        ),
        entry(
            "tow",
            "start_time_of_week",
            "Real",
            "parameter",
            0.0,
            "s",
            "Local time of week at FMU time 0 [s since Monday 00:00]; places the internal-gain "
            "profile: slot = floor((start_time_of_week + time)/step) mod slots",
            (0.0, WEEK),
        ),
    ]
    if timezone is not None:
        what = (
            f"the model's calendar (holidays, daylight saving time in {timezone})"
            if calendar
            else f"the local time in {timezone} (daylight saving time)"
        )
        out.append(
            entry(
                "t_abs",
                "start_time",
                "Real",
                "parameter",
                -1.0,
                "s",
                "Absolute time at FMU time 0 [s since 1970-01-01T00:00:00Z, Unix epoch]; when >= 0 the "
                f"internal gains follow {what} at start_time + time, and start_time_of_week and the "
                "time_of_week input are ignored; "
                + ("needed by season = 0 (follow the calendar's seasons); " if table else "")
                + "-1 (default): time-of-week profile without the calendar",
                (-1.0, None),
            )
        )
    return out
