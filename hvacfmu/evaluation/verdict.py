"""The verdict that opens every evaluation: per zone, does the model beat the baselines?

For each model and output (zone) over all evaluated windows:

- mean 24-hour open-loop RMS of the model against **persistence** and the
  **time-of-week mean** (the two baselines of the protocol), with the margin
  ``1 - RMS_model / RMS_baseline``;
- ASHRAE Guideline 14 hourly **NMBE** and **CV(RMSE)** of the predictions, hourly means
  of measured and predicted temperature over every window step, relative to the mean
  measured temperature [°C] (so they read small for temperatures), with the Guideline's
  calibration thresholds for hourly data: |NMBE| <= 10 % and CV(RMSE) <= 30 %;
- when the data lack an input the building needs (``Td_<vav>`` of boxes that report reheat,
  ``rh_<vav>``) and a model without it loses to either baseline in a zone, the verdict flags the
  model (``!!``), names the missing columns on its first line and says it is worse than the
  time-of-week mean where it is (:attr:`Verdict.missing`);
- when the model is worse than persistence in a zone (or in the case above), the **likely causes the data can
  test** (a missing input first): measured columns the model does not use that explain its residuals (``Td_*``
  discharge temperatures, ``rh_*`` reheat, ...), sparse columns, an airflow gain too small
  to be identified from closed-loop data, a LOESS bandwidth at the edge of its grid, and
  clock or unit warnings from loading.

References
----------
ASHRAE Guideline 14-2014, *Measurement of Energy, Demand, and Water Savings*, section 4.3
(calibration of simulation models: NMBE and CV(RMSE) with ``n - p`` degrees of freedom, p = 1).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ..models.base import season_model
from ..models.memory import SHORT_MEMORY_STEPS  # one constant with the fit's memory check
from ..models.plausibility import MIN_EFFECT_K

#: ASHRAE Guideline 14 calibration thresholds for hourly data [%]
G14_NMBE_MAX = 10.0
G14_CVRMSE_MAX = 30.0
#: |correlation| of an unused column with a zone's residuals that names it as a likely cause
CORRELATION_MIN = 0.3
#: a column with less than this share of finite values over the evaluated rows is "sparse"
SPARSE_SHARE = 0.8
#: an airflow gain whose effect (|B| times the airflow's standard deviation) is below this is not
#: identifiable from the data [K per step]
AIRFLOW_EFFECT_MIN = 0.01
#: a zone-season whose time-of-week mean predicts within this RMS [K] repeats its schedule to the
#: resolution of a BMS zone sensor (0.1-0.2 degF = 0.06-0.11 K; accuracy +-0.2..0.5 K): a control loop holds
#: it, and a model that loses to the schedule there loses by less than the sensor resolves
LOOP_HELD_TOW_K = 0.1


@dataclasses.dataclass(frozen=True)
class ZoneVerdict:
    """One model's verdict in one output (zone).

    Attributes
    ----------
    model, output : str
    rms, persistence, time_of_week : float [K]
        Mean 24-hour open-loop RMS of the model and of the baselines on the same windows.
    nmbe, cvrmse : float [%]
        ASHRAE Guideline 14 hourly NMBE and CV(RMSE) (NaN without data).
    n_hours : int
    """

    model: str
    output: str
    rms: float
    persistence: float
    time_of_week: float
    nmbe: float
    cvrmse: float
    n_hours: int

    @property
    def beats_persistence(self) -> bool:
        return bool(self.rms < self.persistence)

    @property
    def beats_time_of_week(self) -> bool:
        return bool(not np.isfinite(self.time_of_week) or self.rms < self.time_of_week)

    @property
    def calibrated(self) -> bool:
        """Within ASHRAE Guideline 14's hourly thresholds (|NMBE| <= 10 %, CV(RMSE) <= 30 %)."""
        return bool(abs(self.nmbe) <= G14_NMBE_MAX and self.cvrmse <= G14_CVRMSE_MAX)

    @property
    def status(self) -> str:
        if not self.beats_persistence:
            return "WORSE THAN PERSISTENCE"
        if not self.beats_time_of_week:
            return "worse than time-of-week mean"
        return "beats both baselines"

    def margin(self, baseline: float) -> float:
        """``1 - rms / baseline`` [-] (positive: the model is better)."""
        return float(1.0 - self.rms / baseline) if baseline and np.isfinite(baseline) else float("nan")

    def to_dict(self) -> dict:
        return {
            "model": self.model,
            "output": self.output,
            "status": self.status,
            "rms": _num(self.rms),
            "persistence": _num(self.persistence),
            "time_of_week": _num(self.time_of_week),
            "margin_persistence": _num(self.margin(self.persistence)),
            "margin_time_of_week": _num(self.margin(self.time_of_week)),
            "beats_persistence": self.beats_persistence,
            "beats_time_of_week": self.beats_time_of_week,
            "nmbe_percent": _num(self.nmbe),
            "cvrmse_percent": _num(self.cvrmse),
            "n_hours": self.n_hours,
            "g14_calibrated": self.calibrated,
        }


@dataclasses.dataclass(frozen=True)
class SeasonVerdict:
    """One model's mean 24-hour RMS in one output and season against persistence [K] (a model may beat
    persistence over the year and still lose in one season: that must show too)."""

    model: str
    output: str
    season: str
    rms: float
    persistence: float
    time_of_week: float
    n_windows: int
    n_weeks: int

    @property
    def beats_persistence(self) -> bool:
        return bool(self.rms < self.persistence)

    @property
    def beats_time_of_week(self) -> bool:
        return bool(self.rms < self.time_of_week)

    def margin(self) -> float:
        """``1 - rms / persistence`` [-]."""
        return float(1.0 - self.rms / self.persistence) if self.persistence else float("nan")

    def to_dict(self) -> dict:
        return {
            "model": self.model,
            "output": self.output,
            "season": self.season,
            "rms": _num(self.rms),
            "persistence": _num(self.persistence),
            "time_of_week": _num(self.time_of_week),
            "margin_persistence": _num(self.margin()),
            "beats_persistence": self.beats_persistence,
            "margin_time_of_week": _num(1.0 - self.rms / self.time_of_week if self.time_of_week else float("nan")),
            "beats_time_of_week": self.beats_time_of_week,
            "n_windows": self.n_windows,
            "n_weeks": self.n_weeks,
        }


@dataclasses.dataclass(frozen=True)
class Verdict:
    """Per-zone verdicts of every model and, per model that loses to persistence, the likely causes."""

    zones: tuple
    causes: dict
    #: model -> what the verdict stands on: scored windows per season, skipped windows, unscored test seasons
    coverage: dict = dataclasses.field(default_factory=dict)
    #: per model, output and season (:class:`SeasonVerdict`)
    seasons: tuple = ()
    #: model -> measured-input columns the data lack although the building needs them (``Td_<vav>`` of boxes
    #: that reheat), for models that lose to a baseline without them
    missing: dict = dataclasses.field(default_factory=dict)
    #: model -> what to try where a model beats persistence but not the time-of-week mean (:func:`gain_profile_hint`)
    hints: dict = dataclasses.field(default_factory=dict)
    #: model -> the zone-seasons it loses to a time-of-week mean that is within :data:`LOOP_HELD_TOW_K` (a control
    #: loop holds the zone on its schedule; :func:`schedule_held_line`)
    loop_held: dict = dataclasses.field(default_factory=dict)
    #: model -> the zone-seasons it loses to a persistence that is within :data:`LOOP_HELD_TOW_K` (the zone is held at
    #: one temperature; :func:`constant_held_line`)
    held_constant: dict = dataclasses.field(default_factory=dict)
    #: model -> the reasons :func:`season_causes` finds (without the drift, which reads a held zone) for zone-seasons
    #: the model loses to the time-of-week mean only, where that mean is above :data:`LOOP_HELD_TOW_K`
    behind_causes: dict = dataclasses.field(default_factory=dict)

    def losing(self, model: str | None = None) -> list:
        """Verdicts of the zones where a model (or ``model``) is worse than persistence."""
        return [z for z in self.zones if not z.beats_persistence and (model is None or z.model == model)]

    def losing_seasons(self, model: str | None = None) -> list:
        """:class:`SeasonVerdict` of every zone and season where a model (or ``model``) is worse than persistence."""
        return [v for v in self.seasons if not v.beats_persistence and (model is None or v.model == model)]

    def behind_time_of_week_seasons(self, model: str | None = None) -> list:
        """:class:`SeasonVerdict` of every zone and season where a model (or ``model``) is worse than the
        time-of-week mean (it may still beat persistence there)."""
        return [
            v
            for v in self.seasons
            if np.isfinite(v.time_of_week) and not v.beats_time_of_week and (model is None or v.model == model)
        ]

    def summary(self, model: str) -> str:
        """One line: in how many zones ``model`` beats each baseline and meets Guideline 14."""
        mine = [z for z in self.zones if z.model == model]
        n = len(mine)
        p = sum(z.beats_persistence for z in mine)
        t = sum(z.beats_time_of_week for z in mine)
        c = sum(z.calibrated for z in mine)
        lost = self.losing_seasons(model)
        flag = "!! " if p < n or lost or self.missing.get(model) else ""
        cov = self.coverage.get(model)
        on = ""
        if cov and cov["skipped"]:  # say what the verdict stands on when windows were skipped
            per = ", ".join(f"{s} {k}" for s, k in cov["windows"].items())
            on = f"; on {sum(cov['windows'].values())} of {cov['total']} test windows ({per})"
        seasons = ""
        if lost:
            zs = len({v.output for v in lost})
            seasons = (
                f"; worse than persistence in a season in {zs}/{n} ({', '.join(sorted({v.season for v in lost}))})"
            )
        behind = self.behind_time_of_week_seasons(model)
        tow = ""
        if behind:
            by: dict[str, list[str]] = {}
            for v in behind:
                by.setdefault(v.season, []).append(v.output)
            tow = (
                f"; behind the time-of-week mean in a season in {len({v.output for v in behind})}/{n} ("
                + "; ".join(f"{s_}: {', '.join(o)}" for s_, o in sorted(by.items()))
                + ")"
            )
        missing = ""
        if self.missing.get(model):
            missing = f"; missing input: {_names(self.missing[model])} not measured (discharge air unknown)"
        return (
            f"{flag}{model}: beats persistence in {p}/{n} zones, the time-of-week mean in {t}/{n}; "
            f"ASHRAE Guideline 14 hourly calibration met in {c}/{n}{on}{tow}{seasons}{missing}"
        )

    def missing_lines(self) -> list[str]:
        """``!!`` lines of the models that lose to a baseline without an input the building needs."""
        out = []
        for model, cols in self.missing.items():
            worse = [z for z in self.zones if z.model == model and z.beats_persistence and not z.beats_time_of_week]
            if worse:
                rms = ", ".join(f"{z.output} {z.rms:.3f} K against {z.time_of_week:.3f} K" for z in worse)
                out.append(f"!! {model}: WORSE THAN THE TIME-OF-WEEK MEAN in {rms}")
            named = {z.output for z in worse}
            seasons = [
                v
                for v in self.seasons
                if v.model == model
                and v.output not in named
                and v.beats_persistence
                and np.isfinite(v.time_of_week)
                and not v.beats_time_of_week
            ]
            if seasons:
                rms = ", ".join(
                    f"{v.output} in {v.season} {v.rms:.3f} K against {v.time_of_week:.3f} K" for v in seasons
                )
                out.append(f"!! {model}: WORSE THAN THE TIME-OF-WEEK MEAN in {rms}")
            out.append(
                f"!! {model}: the discharge air temperatures ({_names(cols)}) are not measured, so the heat the "
                "boxes deliver is unknown: the likely cause (see below)"
            )
        return out

    def thin(self, model: str) -> str:
        """A warning when most test windows were skipped or a test season has none scored, else ''."""
        cov = self.coverage.get(model)
        if not cov or not cov["skipped"]:
            return ""
        scored = sum(cov["windows"].values())
        if not cov["unscored_seasons"] and 2 * scored >= cov["total"]:
            return ""
        why = ", ".join(f"{v} {k}" for k, v in cov["skipped"].items())
        per = "; ".join(
            f"{s} {d['scored']}/{d['scored'] + sum(d['skipped'].values())}" for s, d in cov.get("by_season", {}).items()
        )
        none = (
            f"; none in {', '.join(cov['unscored_seasons'])}: this verdict says nothing about "
            f"{'that season' if len(cov['unscored_seasons']) == 1 else 'those seasons'}"
            if cov["unscored_seasons"]
            else ""
        )
        rules = cov.get("rules") or {}
        fill = rules.get("fill_inputs_h")
        hint = (
            f"inputs are {f'filled across gaps up to {fill:g} h' if fill else 'not filled'} and outputs must be measured in "
            f"{100 * rules.get('min_output_share', 0.75):g} % of a window's steps; `--fill-inputs HOURS` "
            "(evaluate(..., fill_inputs_h=)) allows longer input gaps"
            if fill is not None
            else "`--fill-inputs HOURS` fills longer input gaps"
        )
        return (
            f"!! {model}: only {scored} of {cov['total']} test windows scored ({why}; scored per season: {per})"
            f"{none}; {hint}"
        )

    def format(self) -> str:
        """Text, the losing zones and their likely causes first."""
        names = list(dict.fromkeys(z.model for z in self.zones))
        lines = [self.summary(m) for m in names]
        for z in self.losing():
            lines.append(
                f"!! {z.model}: WORSE THAN PERSISTENCE in {z.output}: {z.rms:.3f} K against "
                f"{z.persistence:.3f} K ({-100 * z.margin(z.persistence):.0f} % worse)"
            )
        for v in self.losing_seasons():
            week = f"{v.n_weeks} test week" + ("s" if v.n_weeks != 1 else "")
            lines.append(
                f"!! {v.model}: WORSE THAN PERSISTENCE in {v.output} in {v.season}: {v.rms:.3f} K against "
                f"{v.persistence:.3f} K ({-100 * v.margin():.0f} % worse; {v.n_windows} windows, {week})"
            )
        lines += self.missing_lines()
        thin: dict = {}  # models with the same windows share one line
        for m in names:
            if self.thin(m):
                thin.setdefault(self.thin(m).split(": ", 1)[1], []).append(m)
        lines += [f"!! {', '.join(ms)}: {text}" for text, ms in thin.items()]
        for model, causes in self.causes.items():
            if causes:
                lines.append(f"   likely causes for {model} (what the data can test):")
                lines += [f"   - {c}" for c in causes]
        for model, held in self.loop_held.items():
            lines += [f"   behind the time-of-week mean for {model}: {h}" for h in held]
        for model, held in self.held_constant.items():
            lines += [f"   behind persistence for {model}: {h}" for h in held]
        for model, why in self.behind_causes.items():
            if why:
                lines.append(f"   behind the time-of-week mean for {model}, what the data can test:")
                lines += [f"   - {c}" for c in why]
        for model, hints in self.hints.items():
            lines += [f"   to try for {model}: {h}" for h in hints]
        if lines:
            lines.append("")
        lines.append(
            "Verdict per zone: 24-h open-loop RMS [K] against the baselines; ASHRAE Guideline 14 hourly "
            f"NMBE / CV(RMSE) [%] (calibrated: |NMBE| <= {G14_NMBE_MAX:g}, CV <= {G14_CVRMSE_MAX:g})"
        )
        zw = max([8, *(len(z.output) for z in self.zones)])
        head = f"{'model':<22} {'zone':<{zw}} {'model':>7} {'persist':>7} {'tow':>7} {'NMBE':>6} {'CV':>6}  verdict"
        lines.append(head)
        for z in self.zones:
            g14 = "" if z.calibrated else " (G14: not calibrated)"
            lines.append(
                f"{z.model[:22]:<22} {z.output:<{zw}} {z.rms:7.3f} {z.persistence:7.3f} "
                f"{z.time_of_week:7.3f} {z.nmbe:6.2f} {z.cvrmse:6.2f}  {z.status}{g14}"
            )
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {
            "zones": [z.to_dict() for z in self.zones],
            "seasons": [v.to_dict() for v in self.seasons],
            "likely_causes": {k: list(v) for k, v in self.causes.items()},
            "hints": {k: list(v) for k, v in self.hints.items()},
            "loop_held": {k: list(v) for k, v in self.loop_held.items()},
            "held_constant": {k: list(v) for k, v in self.held_constant.items()},
            "time_of_week_causes": {k: list(v) for k, v in self.behind_causes.items()},
            "missing_inputs": {k: list(v) for k, v in self.missing.items()},
            "coverage": {k: dict(v) for k, v in self.coverage.items()},
            "thresholds": {
                "nmbe_percent": G14_NMBE_MAX,
                "cvrmse_percent": G14_CVRMSE_MAX,
                "correlation": CORRELATION_MIN,
            },
        }


# =============================================================================
# numbers
# =============================================================================
def g14_metrics(hourly: dict | None) -> tuple[np.ndarray, np.ndarray]:
    """ASHRAE Guideline 14 NMBE and CV(RMSE) [%] per output from :func:`hourly_statistics` sums.

    ``NMBE = 100 * sum(m - p) / ((n - 1) * mean(m))``,
    ``CV(RMSE) = 100 * sqrt(sum((m - p)^2) / (n - 1)) / mean(m)``.
    """
    ny = len(hourly["sum_error"]) if hourly else 0
    if not hourly or np.all(np.asarray(hourly["n"]) < 2):
        nan = np.full(ny, np.nan)
        return nan, nan
    n = np.where(np.asarray(hourly["n"]) >= 2, np.asarray(hourly["n"], float), np.nan)
    mean = np.asarray(hourly["sum_measured"], float) / n
    with np.errstate(divide="ignore", invalid="ignore"):
        nmbe = 100.0 * np.asarray(hourly["sum_error"], float) / ((n - 1) * mean)
        cv = 100.0 * np.sqrt(np.asarray(hourly["sum_sq_error"], float) / (n - 1)) / mean
    return nmbe, cv


def make_verdict(scores, models, dataset) -> Verdict:
    """The :class:`Verdict` of the scored models (``scores`` and ``models`` in the same order)."""
    zones, seasons = [], []
    causes, coverage, missing, hints, held, constant, behind_why = {}, {}, {}, {}, {}, {}, {}
    for sc, model in zip(scores, models):
        if not sc.starts:
            continue
        mine = _zone_verdicts(sc)
        zones += mine
        per_season = _season_verdicts(sc)
        seasons += per_season
        coverage[sc.name] = _coverage(sc, dataset)
        losing = [z.output for z in mine if not z.beats_persistence]
        lost = [v for v in per_season if not v.beats_persistence]
        absent = missing_discharge_columns(model, dataset)
        # a season lost without the input counts too: the stack4 reheat export without its Td_ columns lost
        # winter to the time-of-week mean (zones N1, lumped) while winning the year, and only "one held-out
        # week" was named (session 21)
        season_behind = [v for v in per_season if not (v.beats_persistence and v.beats_time_of_week)]
        if absent and (any(not (z.beats_persistence and z.beats_time_of_week) for z in mine) or season_behind):
            missing[sc.name] = absent
            losing += [z.output for z in mine if z.beats_persistence and not z.beats_time_of_week]
            losing += [v.output for v in season_behind if v.beats_persistence]
        if losing or lost:
            by_season = [
                c for v in lost for c in season_causes(sc, v, dataset.frame, season_model(model, v.season), dataset)
            ]
            general = likely_causes(
                model,
                sc,
                dataset,
                list(dict.fromkeys(losing + [v.output for v in lost])),
                seasons=list(dict.fromkeys(v.season for v in lost)) or None,
            )
            if by_season and general[-1].startswith("none of the cheap checks fired"):
                general = general[:-1]
            causes[sc.name] = general + by_season
        hint = "" if sc.name in missing else gain_profile_hint(model, mine)  # a missing input explains it first
        if hint:
            hints[sc.name] = [hint]
        schedule = "" if sc.name in missing else schedule_held_line(per_season)
        if schedule:
            held[sc.name] = [schedule]
        steady = "" if sc.name in missing else constant_held_line(per_season)
        if steady:
            constant[sc.name] = [steady + held_terms_note(model, per_season)]
        behind = [
            v
            for v in per_season
            if v.beats_persistence
            and np.isfinite(v.time_of_week)
            and not v.beats_time_of_week
            and v.time_of_week > LOOP_HELD_TOW_K
        ]
        why = [
            c
            for v in behind
            for c in season_causes(sc, v, dataset.frame, season_model(model, v.season), dataset, drift=False)
        ]
        if why and sc.name not in missing:
            behind_why[sc.name] = why
    return Verdict(
        zones=tuple(zones),
        causes=causes,
        coverage=coverage,
        seasons=tuple(seasons),
        missing=missing,
        hints=hints,
        loop_held=held,
        held_constant=constant,
        behind_causes=behind_why,
    )


def loop_held_lines(seasons) -> list[str]:
    """:func:`schedule_held_line` and :func:`constant_held_line` of one model's :class:`SeasonVerdict` list, the
    ones that apply (``[]`` when neither does)."""
    return [line for line in (schedule_held_line(seasons), constant_held_line(seasons)) if line]


def schedule_held_line(seasons) -> str:
    """Why a model loses to the time-of-week mean in zone-seasons that a control loop holds on their schedule.

    ``seasons``: one model's :class:`SeasonVerdict` list. A zone-season counts when the model beats persistence
    there but not the time-of-week mean, whose RMS is at most :data:`LOOP_HELD_TOW_K`: the zone repeats its
    schedule to the sensor's resolution, so the schedule is the forecast, while what the loop compensates
    (occupancy, a meeting, a loop that modulates within the model step) is not in the data. Measured on the
    emulator's seven-week winter exports (``benchmarks/short_winter_s8.md``): its own plant with the true parameters
    and internal gains, fed the 15-minute export, loses to the time-of-week mean in 26 such zones, and tracks them
    within 0.03-0.04 K from the 1-minute export. ``""`` when there is no such zone-season.
    """
    held = [
        v
        for v in seasons
        if v.beats_persistence
        and np.isfinite(v.time_of_week)
        and not v.beats_time_of_week
        and v.time_of_week <= LOOP_HELD_TOW_K
    ]
    if not held:
        return ""
    cells, worst = _held_cells(held, "time_of_week")
    head = (
        f"{cells}: there a control loop holds the zone on its schedule (time-of-week mean within "
        f"{LOOP_HELD_TOW_K:g} K, a zone sensor's resolution), so the schedule is the forecast and what the loop "
        "compensates (occupancy, meetings, modulation within the model step) is not in the data; the model "
    )
    if worst <= LOOP_HELD_TOW_K:
        return head + (
            f"is behind by at most {worst:.3f} K, less than the sensor resolves: a limit of the data, not of the "
            "fit (for control in a comfort band of a kelvin or more it does not matter)"
        )
    # behind by more than the resolution: the held schedule explains the baseline's score, not all of the loss
    return head + (
        f"is behind by up to {worst:.3f} K, more than the sensor resolves: the held schedule does not explain "
        "all of the loss"
    )


def _held_cells(held, baseline: str) -> tuple[str, float]:
    """``"C in winter 0.062 K against 0.054 K, ..."`` of the zone-seasons ``held`` against their ``baseline``
    attribute, and the largest amount [K] by which the model is behind it."""
    cells = ", ".join(f"{v.output} in {v.season} {v.rms:.3f} K against {getattr(v, baseline):.3f} K" for v in held)
    return cells, max(v.rms - getattr(v, baseline) for v in held)


def constant_held_line(seasons) -> str:
    """How little a loss to persistence means in zone-seasons held at one temperature.

    ``seasons``: one model's :class:`SeasonVerdict` list. A zone-season counts when the model loses to a persistence
    whose RMS is at most :data:`LOOP_HELD_TOW_K` (EnergyPlus's ideal thermostat holds the 90.1 large hotel's kitchen
    within 0.01 K, so a model 0.036 K off reads "305 % worse"); the ``!!`` line stays first, this says how much the
    percentage means. ``""`` when there is no such zone-season.
    """
    held = [v for v in seasons if not v.beats_persistence and v.persistence <= LOOP_HELD_TOW_K]
    if not held:
        return ""
    cells, worst = _held_cells(held, "persistence")
    return (
        f"{cells} (persistence): the zone is held at one temperature (persistence within {LOOP_HELD_TOW_K:g} K, "
        "a zone sensor's resolution: an ideal thermostat, a server room), so holding the last value is the "
        f"forecast; the model is off by at most {worst:.3f} K more, and the percentage is large only because "
        "the baseline's error is tiny"
    )


def held_terms_note(model, seasons) -> str:
    """``"; the model holds ... (held_setpoint)"`` for the zones of :func:`constant_held_line` whose model carries a
    ``held_setpoint`` term (its band, learned from the training weeks), else ``""``."""
    zones = {v.output for v in seasons if not v.beats_persistence and v.persistence <= LOOP_HELD_TOW_K}
    terms = [t for t in getattr(model, "terms", ()) if t.cause == "held_setpoint" and t.zone in zones]
    if not terms:
        return ""
    parts = []
    for t in terms:
        edges = ", ".join(f"{k.replace('_', ' ')} {v:g} °C" for k, v in t.coefficients().items() if k != "u_on")
        parts.append(f"{t.zone} at {edges}")
    return (
        "; the model holds " + "; ".join(parts) + " (held_setpoint: the band its training measurements pile up at "
        "and do not cross), what is left is its drift inside the band"
    )


def gain_profile_hint(model, zones) -> str:
    """What to try when a physics model fitted with the paper's per-time-of-week gain profile beats
    persistence but not the time-of-week mean in some of ``zones`` (:class:`ZoneVerdict`); ``""`` otherwise.

    Step 2's profile then averages only the few training weeks of each season per time-of-week slot, and
    one unusual day (a holiday, the first day of a term) weighs a third of its slot. Pooling the workdays
    where the training weeks show no weekday pattern (``gain_days = "shrunk"``) won every zone of five of
    the six emulated BMS exports (``"week"``: two of six) and gave the lowest RMS on both EnergyPlus
    buildings, but lost one zone-season cell of the 16-week reheat data that ``"week"`` won (README,
    "Your own BMS export"). Since session 8 the default is ``"auto"`` (the profile chosen by cross-validation), so
    the hint reaches a model fitted with ``gain_days="week"`` on purpose. A model fitted with another
    ``gain_days``, ``"auto"`` included (the profile chosen by cross-validation on the training weeks), gets none.
    """
    if getattr(model, "kind", None) != "physics":
        return ""
    if ((getattr(model, "meta", None) or {}).get("fit_options") or {}).get("gain_days", "week") != "week":
        return ""
    behind = [z.output for z in zones if z.beats_persistence and not z.beats_time_of_week]
    if not behind:
        return ""
    return (
        f"it loses to the time-of-week mean in {', '.join(behind)} with step 2's per-time-of-week gain profile "
        "(a few training weeks per slot); refit the gains pooled over workdays where the data allow: "
        '`hvacfmu fit --model physics --gain-days shrunk`, or `[physics].gain_days = "shrunk"` in the building '
        'file (in Python: hvacfmu.models.physics.refit_gains(model, dataset, "shrunk")), and compare'
    )


def _zone_verdicts(sc) -> list:
    nmbe, cv = g14_metrics(sc.hourly)
    r, p = np.nanmean(sc.rms, axis=0), np.nanmean(sc.baselines["persistence"], axis=0)
    t = _tow_mean(sc.baselines["time-of-week mean"], len(sc.outputs))
    hours = np.broadcast_to(sc.hourly["n"], (len(sc.outputs),)) if sc.hourly else np.zeros(len(sc.outputs), int)
    return [
        ZoneVerdict(sc.name, o, float(r[j]), float(p[j]), float(t[j]), float(nmbe[j]), float(cv[j]), int(hours[j]))
        for j, o in enumerate(sc.outputs)
    ]


def _tow_mean(tow, ny) -> np.ndarray:
    with np.errstate(all="ignore"):
        return np.nanmean(tow, axis=0) if np.isfinite(tow).any() else np.full(ny, np.nan)


def _season_verdicts(sc) -> list:
    """Per output and season with scored windows (only when the windows cover more than one season)."""
    seasons = np.asarray(sc.seasons, dtype=object)
    names = list(dict.fromkeys(sc.seasons))
    if len(names) < 2:
        return []
    out = []
    for s in names:
        sel = seasons == s
        r, p = np.nanmean(sc.rms[sel], axis=0), np.nanmean(sc.baselines["persistence"][sel], axis=0)
        t = _tow_mean(sc.baselines["time-of-week mean"][sel], len(sc.outputs))
        n_weeks = len({w for w, ok in zip(sc.weeks, sel) if ok})
        out += [
            SeasonVerdict(sc.name, o, s, float(r[j]), float(p[j]), float(t[j]), int(sel.sum()), n_weeks)
            for j, o in enumerate(sc.outputs)
        ]
    return out


def _coverage(sc, dataset) -> dict:
    """Scored windows per season, skipped windows by reason (overall and per season), test seasons
    without a scored window, and the coverage rules applied."""
    windows = sc.n_windows()
    skipped = {k: int(v) for k, v in sc.skipped.items() if v}
    tested = dict.fromkeys(w.season for w in dataset.test_weeks())
    filled = getattr(sc, "filled_inputs", None)
    return {
        "windows": windows,
        "total": sum(windows.values()) + sum(skipped.values()),
        "skipped": skipped,
        "by_season": sc.by_season(tuple(dataset.building.season_names)),
        "unscored_seasons": [s for s in tested if s not in windows],
        "rules": dict(getattr(sc, "rules", {}) or {}),
        "filled_step_share": float(np.mean(filled)) if filled is not None and len(filled) else 0.0,
    }


# =============================================================================
# likely causes
# =============================================================================
#: words of loading warnings that can explain a losing model (clock offsets, unit mix-ups); not the bare
#: "unit", which also matches the air-handling units of the T_supply weighting note
_LOADING_CAUSES = ("clock", "offset", "its unit", "the unit", "look like", "timezone", "time zone")


def likely_causes(model, score, dataset, losing, seasons=None) -> list[str]:
    """Causes the data can test for a model worse than persistence (or, without an input the building
    needs, worse than the time-of-week mean) in the outputs ``losing``; a missing input comes first.

    A model with one coefficient set per season: the checks of each set of ``seasons`` (default: every season),
    each line naming its season."""
    if getattr(model, "seasonal", False):
        out = []
        for s in seasons or model.seasons:
            lines = likely_causes(season_model(model, s), score, dataset, losing)
            out += [f"{s}'s coefficient set: {line}" for line in lines if not line.startswith("none of the cheap")]
        return list(dict.fromkeys(out)) or likely_causes(season_model(model, model.seasons[0]), score, dataset, [])[-1:]
    out = _missing_discharge(model, dataset)  # first: without it the other checks read a model of the wrong heat
    out += _unused_columns(model, score, dataset, losing)
    out += _sparse_columns(model, score, dataset)
    out += _airflow_gain(model, dataset)
    out += _short_memory(model)
    out += _twin_memory(model, losing)
    out += _bandwidth_edge(model)
    out += [
        f"loading warned: {w}"
        for w in getattr(dataset, "warnings", []) or []
        if any(k in str(w).lower() for k in _LOADING_CAUSES)
    ]
    if not out:
        out.append(
            "none of the cheap checks fired (unused columns, sparse columns, airflow gain, LOESS "
            "bandwidth, clock/units); run `hvacfmu diagnose` for the structural causes"
        )
    return out


#: share of a losing season's RMS that a mean error (bias) must reach to be named as drift [-]
DRIFT_BIAS_SHARE = 0.5
#: growth of the mean |error| from the first to the last quarter of the horizon named as drift [-]
DRIFT_GROWTH = 1.2


def season_causes(score, sv, frame=None, model=None, dataset=None, drift: bool = True) -> list[str]:
    """Causes the data can test for a model worse than persistence in one zone and season (:class:`SeasonVerdict`).

    - **drift**: the measured temperature holds (persistence is good) while the prediction walks away:
      the season's mean error is at least :data:`DRIFT_BIAS_SHARE` of its RMS and the mean |error|
      grows at least :data:`DRIFT_GROWTH`-fold from the first to the last quarter of the horizon;
    - **a day-to-day disturbance no column carries**: the windows' mean errors fall on both sides by at least
      :data:`DAY_TO_DAY_K`, spread by at least :data:`DAY_TO_DAY_SHARE` of the RMS, and follow none of the
      weather columns of ``frame`` (the dataset's; ``T_out``, ``ghi``) by :data:`DAY_TO_DAY_WEATHER_R` or more
      (see :func:`day_to_day_line`); with a ``wind`` column, a disturbance that follows the windows' mean
      ``wind · (T_out − T_zone)`` by that much (more than any weather column, on the side a leak errs) is named as
      wind-driven infiltration (session 18: the EnergyPlus apartments' winter, r +0.57 to +0.73 for the zones and
      lumped models, where the line said "no column carries" it);
    - **one test week**: the season is judged on the windows of a single held-out week;
    - **holiday** (with ``model`` and ``dataset``): the windows cover a weekday public holiday (of the country
      of the building's time zone) that the model's calendar does not hold, so it predicts a working day there
      (:mod:`hvacfmu.data.holidays`), or another weekday the data show ran like a Sunday
      (``dataset.holidays.sunday_like``: a closure no public calendar lists).

    ``drift=False`` leaves the drift out (a zone-season lost to the time-of-week mean only: the zone does not hold).
    """
    res = score.residuals
    if res is None or res.empty or sv.output not in res.columns:
        return []
    W = len(score.starts)
    N = len(res) // W
    sel = np.asarray(score.seasons, dtype=object) == sv.season
    e = res[sv.output].to_numpy(float).reshape(W, N)[sel]
    out = []
    with np.errstate(all="ignore"):
        bias = float(np.nanmean(e))
        q = max(1, N // 4)
        first, last = float(np.nanmean(np.abs(e[:, :q]))), float(np.nanmean(np.abs(e[:, -q:])))
    if drift and abs(bias) >= DRIFT_BIAS_SHARE * sv.rms and last >= DRIFT_GROWTH * first:
        side = "warmer" if bias > 0 else "colder"
        out.append(
            f"{sv.output} in {sv.season}: the prediction drifts while the zone holds its temperature "
            f"(persistence {sv.persistence:.2f} K): the measured temperature is {abs(bias):.2f} K {side} than "
            f"predicted on average (of {sv.rms:.2f} K RMS) and the mean error grows from {first:.2f} K in the first "
            f"to {last:.2f} K in the last quarter of the day: a slow heat store the model lacks (thermal mass, "
            "the ground slab, neighbouring zones) or a season level its internal-gain profile misses; "
            + (
                "the model already carries a thermal_mass term in this zone, so the physics model tests the rest"
                if sv.output in _cause_zones(model, "thermal_mass")
                else "the physics model, or `hvacfmu diagnose` (thermal_mass), tests it"
            )
        )
    day = day_to_day_line(sv, e, [t for t, ok in zip(score.starts, sel) if ok], N, frame, _wind_terms(model))
    if day:
        out.append(day)
    if sv.n_weeks == 1:
        out.append(
            f"{sv.output} in {sv.season}: judged on {sv.n_windows} windows of one held-out week; a colder or "
            "warmer week than the training weeks weighs fully (more test weeks: prepare(..., train_fraction=))"
        )
    if model is not None and dataset is not None:
        out += _holiday_cause(score, sv, model, dataset)
    return out


def _holiday_cause(score, sv, model, dataset) -> list[str]:
    """The season's scored windows cover weekday public holidays the model predicts as workdays."""
    import datetime as dt

    from ..calendars import country_of_timezone, public_holidays

    # the dataset's calendar has the declared country, else the time zone's; a list of dates alone has none
    country = dataset.holidays.country or country_of_timezone(dataset.building.timezone)
    starts = [t for t, s in zip(score.starts, score.seasons) if s == sv.season]
    if not starts:
        return []
    res = score.residuals  # W windows of N steps each, in window order
    n = len(res) // len(score.starts) if res is not None and len(res) else 0
    span = (res.index[n - 1] - res.index[0]) if n > 1 else None
    span = span if span is not None and span.total_seconds() > 0 else dt.timedelta(days=1)
    first, last = min(starts).date(), (max(starts) + span).date()
    listed = set(getattr(model, "holidays", ()) or ())
    # a calendar the building file declared, or the data decided, leaves a public holiday out on purpose (the
    # training weeks worked on it, or on every weekday observed in place of a weekend holiday): not a missed one
    calendar = getattr(dataset, "holidays", None)
    decided = getattr(calendar, "source", "none") in ("public", "declared")
    kept = set(getattr(calendar, "dates", ()) or ())
    missed = (
        {
            d: n
            for d, n in public_holidays(country, None, first, last).items()
            if d.weekday() < 5 and d.isoformat() not in listed and (not decided or d.isoformat() in kept)
        }
        if country
        else {}
    )

    def in_windows(day) -> bool:
        return any(t.date() <= day <= (t + span).date() for t in starts)

    covered = [d for d in missed if in_windows(d)]
    out = []
    if covered:
        days = ", ".join(f"{d} {missed[d]}" for d in sorted(covered))
        out.append(
            f"{sv.output} in {sv.season}: the held-out windows cover {days}, a public holiday of {country} the model "
            "predicts as a working day (its calendar does not list it: see check's Holidays line); if the building "
            f'closes on it, declare [holidays] country = "{country}" in the building file and refit'
        )
    # any other weekday the data show ran like a Sunday (a closure no public calendar lists)
    sunday = {dt.date.fromisoformat(d): g for d, g in dataset.holidays.sunday_like.items() if d not in listed}
    other = [(d, g) for d, g in sunday.items() if d not in missed and in_windows(d)]
    if other:
        days = ", ".join(f"{d} ({d.strftime('%a')}, gamma {g:.2f})" for d, g in other)
        out.append(
            f"{sv.output} in {sv.season}: the held-out windows cover {days}, a weekday that ran like a Sunday "
            "(gamma: 0 = the neighbouring workdays' operation, 1 = the Sundays'), which the model predicts as a "
            "working day; if the building was closed, list it in the building file's [holidays] dates and refit"
        )
    return out


#: mean error of a window [K] on each side that counts as a day-to-day change of sign (a zone sensor's accuracy,
#: +-0.2..0.5 K)
DAY_TO_DAY_K = 0.2
#: spread (standard deviation) of the windows' mean errors, as a share of the season's RMS, for a day-to-day cause
DAY_TO_DAY_SHARE = 0.5
#: |correlation| of the windows' mean errors with a measured weather column's window means that makes it a
#: weather the model reads wrongly rather than a disturbance no column carries
DAY_TO_DAY_WEATHER_R = 0.5
#: fewest windows to judge the day-to-day spread on
DAY_TO_DAY_MIN_WINDOWS = 3


def _cause_zones(model, cause: str) -> set:
    """Zones of ``model``'s extension terms of ``cause`` (none for a base model or no model)."""
    return {z for t in getattr(model, "terms", ()) if getattr(t, "cause", "") == cause for z in t.zones()}


def _wind_terms(model) -> set | None:
    """Zones of ``model``'s ``wind_infiltration`` terms (None without a model)."""
    return None if model is None else _cause_zones(model, "wind_infiltration")


def _window_means(col, starts, horizon) -> np.ndarray:
    """The mean of the series ``col`` over each window (``horizon`` steps from each of ``starts``)."""
    return np.array(
        [np.nanmean(col.iloc[col.index.searchsorted(t) : col.index.searchsorted(t) + horizon]) for t in starts]
    )


def _wind_follow(frame, output: str, starts, horizon, m) -> tuple | None:
    """``(label, r)``: the correlation of the windows' mean errors ``m`` with the windows' mean wind-driven exchange
    ``wind · (T_out − T_<output>)`` (the zone's measured temperature; the wind speed alone for an output without
    its own column, a lumped floor), or None when the data have no wind column or too few windows."""
    if frame is None or "wind" not in frame.columns or "T_out" not in frame.columns:
        return None
    zone = f"T_{output}"
    if zone in frame.columns:
        label, col = "wind·(T_out − T_zone)", frame["wind"] * (frame["T_out"] - frame[zone])
    else:
        label, col = "wind", frame["wind"]
    w = _window_means(col, starts, horizon)
    good = np.isfinite(w)
    if good.sum() < DAY_TO_DAY_MIN_WINDOWS or np.std(w[good]) == 0:
        return None
    return label, float(np.corrcoef(w[good], m[good])[0, 1])


def day_to_day_line(sv, e, starts, horizon, frame=None, wind_zones=None) -> str:
    """The line for a zone-season whose windows' mean errors ``e`` (windows x steps, measured minus predicted)
    change sign from day to day ('' when they do not): a heat flow no column carries when they follow no weather
    column of ``frame``, the model's response to that weather when they follow one by :data:`DAY_TO_DAY_WEATHER_R`
    or more (the EnergyPlus warehouse's fine storage in a Las Vegas summer, held at 26.7-27 °C by a unit that
    cycles: -0.54 to +0.60 K a day, r = -0.53 with the day's mean T_out, colder than predicted on the hottest days;
    the verdict named only the LOESS bandwidth).

    A missing heat store or a season level the internal-gain profile misses errs on the same side on most days;
    a heat flow that changes from day to day and that no column carries (wind-driven infiltration, opened windows,
    an unmetered heater) does not: the EnergyPlus mid-rise apartments' flats (infiltration proportional to the wind
    speed times the indoor-outdoor difference, sd 110-185 W a flat in winter) err from -1.05 to +0.45 K a day in
    winter (zones model), r = +0.78 with the day's infiltration heat away from its part linear in T_out - T_zone,
    -0.12 with the day's mean T_out and +0.21 with its ghi.
    """
    with np.errstate(all="ignore"):
        means = np.nanmean(e, axis=1)
    ok = np.isfinite(means)
    if ok.sum() < DAY_TO_DAY_MIN_WINDOWS:
        return ""
    m = means[ok]
    spread = float(np.std(m))
    if not (m.min() <= -DAY_TO_DAY_K and m.max() >= DAY_TO_DAY_K and spread >= DAY_TO_DAY_SHARE * sv.rms):
        return ""
    follows = []
    if frame is not None:
        starts = [t for t, good in zip(starts, ok) if good]
        for c in ("T_out", "ghi"):
            if c not in frame.columns:
                continue
            w = _window_means(frame[c], starts, horizon)
            good = np.isfinite(w)
            if good.sum() < DAY_TO_DAY_MIN_WINDOWS or np.std(w[good]) == 0:
                continue
            follows.append((c, float(np.corrcoef(w[good], m[good])[0, 1])))
    weather = [(c, r) for c, r in follows if abs(r) >= DAY_TO_DAY_WEATHER_R]
    wind = _wind_follow(frame, sv.output, starts, horizon, m) if frame is not None else None
    # a leak brings more of the outdoors on windy days: the zone colder than predicted where wind·(T_out − T) is most
    # negative (r > 0), warmer than predicted on calm days; the wind speed alone, the other way round (r < 0)
    if wind is not None:
        label, r_w = wind
        right_side = r_w > 0 if label != "wind" else r_w < 0
        if right_side and abs(r_w) >= DAY_TO_DAY_WEATHER_R and all(abs(r_w) > abs(r) for _, r in weather):
            return _wind_line(sv, m, spread, label, r_w, follows, wind_zones)
    if weather:
        c, r = max(weather, key=lambda cr: abs(cr[1]))
        what = {"T_out": ("warmer", "outdoor temperature"), "ghi": ("sunnier", "sun")}[c]
        side = "colder" if r < 0 else "warmer"
        reacts = "too much" if r < 0 else "too little"
        return (
            f"{sv.output} in {sv.season}: the error's mean over a window changes sign from day to day ({m.min():+.2f} "
            f"to {m.max():+.2f} K, sd {spread:.2f} K over {len(m)} windows, of {sv.rms:.2f} K RMS) and follows {c} (r "
            f"with the window's mean {r:+.2f}): on {what[0]} days the zone is {side} than predicted, so the model reacts "
            f"{reacts} to the {what[1]} in this season (a conductance or gain fitted on training weeks of other "
            "weather, or a heat flow that moves with it: ventilation, infiltration, a unit that cycles); "
            "persistence wins where a thermostat holds the zone against it; the physics model, or training weeks of "
            "this weather, test it"
        )
    seen = (
        " and follows no weather column (r with the window's mean "
        + ", ".join(f"{c} {r:+.2f}" for c, r in follows)
        + ")"
        if follows
        else ""
    )
    return (
        f"{sv.output} in {sv.season}: the error's mean over a window changes sign from day to day ({m.min():+.2f} to "
        f"{m.max():+.2f} K, sd {spread:.2f} K over {len(m)} windows, of {sv.rms:.2f} K RMS){seen}: a heat flow that "
        "changes from day to day and that no column carries (wind-driven infiltration, opened windows or doors, an "
        "unmetered heater, occupancy) rather than a missing heat store or season level, which err on the same side "
        "most days; no model fitted on these columns can predict it, and persistence wins where a thermostat holds "
        "the zone against it "
        + (
            "(the data's wind column is there: `hvacfmu diagnose` tests wind-driven infiltration with it, "
            "the wind_infiltration cause)"
            if frame is not None and "wind" in frame.columns
            else "(a wind speed column, if the site has one, lets `hvacfmu diagnose` test wind-driven infiltration)"
        )
    )


def _wind_line(sv, m, spread, label, r_w, follows, wind_zones) -> str:
    """The day-to-day line of a zone-season whose windows' mean errors follow the wind-driven exchange."""
    others = ", ".join(f"{c} {r:+.2f}" for c, r in follows)
    if wind_zones is not None and sv.output in wind_zones:
        fix = (
            "the model's wind_infiltration term in this zone is too weak for this season (it is fitted on the "
            "training year, where a unit that runs hides the leak)"
        )
    else:
        fix = (
            "the model has no wind-driven infiltration here: `hvacfmu diagnose` tests it (the wind_infiltration cause)"
        )
    return (
        f"{sv.output} in {sv.season}: the error's mean over a window changes sign from day to day ({m.min():+.2f} to "
        f"{m.max():+.2f} K, sd {spread:.2f} K over {len(m)} windows, of {sv.rms:.2f} K RMS) and follows the "
        f"window's mean {label} (r {r_w:+.2f}" + (f"; {others}" if others else "") + "): on windy days the zone "
        "loses more heat to (or gains more from) outdoors than predicted: outdoor air leaking in with the wind; "
        + fix
        + "; persistence wins where a thermostat holds the zone against it"
    )


def _used_columns(model) -> set:
    used = set(getattr(model, "disturbances", ()))
    used |= {f"T_{z}" for z in getattr(model, "outputs", ())}
    used |= {f"T_{z}" for z in getattr(model, "measured_zones", ())}
    base = getattr(model, "base", model)
    used |= {str(c) for c in (getattr(base, "inlets", None) or ()) if c}  # delivered heat / physics inlets
    used |= {str(c) for c in getattr(base, "inputs", ())}
    if any(str(c).startswith("I_") for c in used):
        used.add("ghi")  # facade irradiance is computed from it
    return used | {"excitation"}


def _unused_columns(model, score, dataset, losing) -> list[str]:
    """Measured columns the model does not use whose values correlate with a losing zone's residuals."""
    res = score.residuals
    if res is None or res.empty:
        return []
    frame = dataset.frame.reindex(res.index)
    used = _used_columns(model)
    found = []
    for c in frame.columns:
        if c in used or c.startswith("m_") or c.startswith("T_") and c[2:] in dataset.building.zone_names:
            continue
        x = frame[c].to_numpy(float)
        hits = {z: _best_correlation(x, res[z].to_numpy(float)) for z in losing}
        hits = {z: r for z, r in hits.items() if np.isfinite(r) and abs(r) >= CORRELATION_MIN}
        # nothing explained, or the same values under another name (or mixed from them), which the model reads
        if not hits or _duplicate_of(x, frame, used) is not None or _flow_mix_of(x, frame, used):
            continue
        rs = sorted(hits.values())  # one line per column, naming every zone it explains
        r_txt = f"r = {rs[0]:+.2f}" if len(rs) == 1 else f"r = {rs[0]:+.2f} .. {rs[-1]:+.2f}"
        found.append(
            f"unused measured column {c!r} correlates with the residuals of {', '.join(hits)} "
            f"({r_txt}): the model does not see it{_column_hint(c)}"
        )
    return found


#: a column within this of a used column on every row both measure is the same signal [its unit]
DUPLICATE_TOL = 0.01


#: share of a column's finite rows on which air must flow for :func:`_flow_mix_of` to compare it [-]
FLOW_MIX_MIN_SHARE = 0.1


def _flow_mix_of(x, frame, used) -> bool:
    """True when ``x`` is, wherever air flows, the airflow-weighted mean of the discharge temperatures ``Td_<box>``
    the model reads (weights ``m_<box>``): the mean supply temperature of packaged units, each unit the air of its one
    box (the 90.1 warehouse's ``T_supply``, within 0.0007 K). Where no air flows it is an idle node value that carries
    no heat."""
    pairs = [c for c in sorted(used) if c.startswith("Td_") and c in frame.columns and f"m_{c[3:]}" in frame.columns]
    if not pairs:
        return False
    m = frame[[f"m_{c[3:]}" for c in pairs]].to_numpy(float)
    td = frame[pairs].to_numpy(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        total = np.nansum(m, axis=1)
        mix = np.nansum(np.where(m > 0, m * td, 0.0), axis=1) / total
    rows = np.isfinite(x) & np.isfinite(mix) & (total > 0) & np.all(np.isfinite(m), axis=1)
    return bool(
        rows.sum() >= FLOW_MIX_MIN_SHARE * max(np.isfinite(x).sum(), 1)
        and rows.sum() > 0
        and np.max(np.abs(x[rows] - mix[rows])) <= DUPLICATE_TOL
    )


def _duplicate_of(x, frame, used) -> str | None:
    """A column the model uses that holds the same values as ``x`` (a packaged unit's supply temperature
    is its one box's discharge air), or None."""
    for c in sorted(used):
        if c not in frame.columns:
            continue
        y = frame[c].to_numpy(float)
        both = np.isfinite(x) & np.isfinite(y)
        if both.sum() >= 0.9 * np.isfinite(x).sum() > 0 and np.max(np.abs(x[both] - y[both])) <= DUPLICATE_TOL:
            return c
    return None


def missing_discharge_columns(model, dataset) -> list[str]:
    """``Td_<vav>`` of the boxes whose reheat is measured (``rh_<vav>``) but whose discharge air is not
    (empty when the model uses a ``Td_`` column or no box reports reheat)."""
    if any(str(c).startswith("Td_") for c in _used_columns(model)):
        return []
    columns = set(dataset.frame.columns)
    return [f"Td_{v}" for v in dataset.building.vav_names if f"rh_{v}" in columns and f"Td_{v}" not in columns]


def _names(cols) -> str:
    """The first four column names and how many more."""
    cols = list(cols)
    return ", ".join(cols[:4]) + (f" and {len(cols) - 4} more" if len(cols) > 4 else "")


def _missing_discharge(model, dataset) -> list[str]:
    """Boxes whose reheat is measured (``rh_<vav>``) but whose discharge air temperature is not."""
    cols = missing_discharge_columns(model, dataset)
    if not cols:
        return []
    names = _names(cols)
    return [
        f"missing input: the boxes reheat (rh_ columns) but the data hold no discharge air temperature "
        f"({names}): the heat a box delivers is m·cp·(Td − T_zone), and without Td more air looks like "
        f"more cooling while it heats; export the Td_<vav> columns and refit (the delivered-heat form)"
    ]


def _best_correlation(x, r) -> float:
    """Largest |correlation| of ``x`` with the residual ``r`` or its step-to-step change."""
    best = float("nan")
    for a, b in ((x, r), (x[1:], np.diff(r))):
        ok = np.isfinite(a) & np.isfinite(b)
        if ok.sum() < 50 or np.std(a[ok]) == 0 or np.std(b[ok]) == 0:
            continue
        c = float(np.corrcoef(a[ok], b[ok])[0, 1])
        if not np.isfinite(best) or abs(c) > abs(best):
            best = c
    return best


def _column_hint(c: str) -> str:
    if c.startswith("Td_"):
        return (
            "; discharge air temperature: the heat a box delivers is m·cp·(Td − T_zone), which a model "
            "seeing only airflow and one supply temperature takes for cooling when the box reheats"
        )
    if c.startswith("rh_"):
        return "; reheat command/valve: heat the model cannot see"
    if c == "wind":
        return (
            "; wind speed: outdoor air leaking in with the wind carries wind·(T_out − T_zone); `hvacfmu diagnose` "
            "tests it as the wind_infiltration cause"
        )
    return ""


def _sparse_columns(model, score, dataset) -> list[str]:
    """Columns the model uses with few finite values over the test weeks."""
    frame = dataset.frame
    rows = np.zeros(len(frame), bool)
    for w in dataset.test_weeks():
        rows[frame.index.searchsorted(w.start) : frame.index.searchsorted(w.end)] = True
    cols = [c for c in frame.columns if c in _used_columns(model) or c.startswith("m_")]
    out = []
    for c in cols:
        share = float(np.isfinite(frame[c].to_numpy(float)[rows]).mean()) if rows.any() else 1.0
        if share < SPARSE_SHARE:
            out.append(
                f"sparse column {c!r}: {100 * share:.0f} % of the test-week steps have a value "
                f"({sum(score.skipped.values())} windows skipped)"
            )
    return out


def _airflow_gain(model, dataset) -> list[str]:
    """Airflow gains of a linear model too small to matter: not identifiable from closed-loop data."""
    base = getattr(model, "base", model)
    if getattr(base, "heat", "airflow") == "delivered":
        # the delivered-heat form has B = 0 by construction: its identifiability was judged at fit time
        plaus = (getattr(base, "meta", None) or {}).get("plausibility") or {}
        if plaus.get("identifiable", True):
            return []
        weak = {z: e for z, e in (plaus.get("drive_effect_k") or {}).items() if e is not None and e < MIN_EFFECT_K}
        return [
            "delivered heat not identifiable (flagged at fit time): over its observed range it moves "
            + ", ".join(f"{z} by {e:.2g} K" for z, e in weak.items())
            + "; the fit learned the thermostat loop, not the building (add forced-response weeks, or use the "
            "physics model)"
        ]
    B = getattr(base, "B", None)
    if B is None:
        return []
    B = np.atleast_2d(np.asarray(B, float))
    try:
        u, _ = base.signals(dataset.frame)
    except Exception:  # noqa: BLE001 - a model whose signals cannot be built gets no airflow check
        return []
    sd = np.nanstd(np.asarray(u, float), axis=0)
    effect = np.abs(B).max(axis=0) * sd if B.shape[1] == sd.size else np.abs(B).max() * sd
    if not np.all(effect < AIRFLOW_EFFECT_MIN):
        return []
    exc = dataset.frame["excitation"].to_numpy(float) if "excitation" in dataset.frame else np.zeros(1)
    closed = "closed-loop data without excitation experiments" if not np.nansum(exc) else "these data"
    return [
        f"airflow gain not identifiable: |B| up to {np.abs(B).max():.2g} K/step per kg/s moves the zones by "
        f"at most {effect.max():.2g} K per step for the airflow's variation; from {closed} the fit learned "
        "the thermostat loop, not the building (add forced-response weeks, or use the physics model)"
    ]


def _short_memory(model) -> list[str]:
    """A fitted model whose every mode decays within :data:`SHORT_MEMORY_STEPS` model steps (``meta["plausibility"]``):
    its 24-hour prediction is the weather response plus the gain profile, whatever the zone's temperature at the start.

    The EnergyPlus mid-rise apartments (``benchmarks/apartments_s18.md``): the zones model's one-step fit has
    ``a`` = 0.0001, the open-loop refinement lifts it to time constants of 4-8 min; it loses 20 of 32 flat-seasons
    to persistence, and the verdict named only the day-to-day weather."""
    meta = getattr(model, "meta", None) or {}
    tc = (meta.get("plausibility") or {}).get("time_constants_h") if isinstance(meta, dict) else None
    if not tc:
        return []
    try:
        slowest = max(float(t) for t in tc)
    except (TypeError, ValueError):
        return []
    step_h = float(getattr(model, "step", 0) or 0) / 3600.0
    if not np.isfinite(slowest) or step_h <= 0 or slowest >= SHORT_MEMORY_STEPS * step_h:
        return []
    ol = meta.get("open_loop") or {}
    refined = ""
    if isinstance(ol, dict) and ol.get("used") and ol.get("rms_before") is not None:
        refined = (
            f"; the open-loop refinement ran (training windows' RMS {float(ol['rms_before']):.2f} -> "
            f"{float(ol['rms_after']):.2f} K) and left it there"
        )
    mem = meta.get("memory") or {}
    if isinstance(mem, dict) and mem.get("checked") and mem.get("kept") == "fit":
        cv = mem.get("week_cv") or {}
        scores = ", ".join(
            f"{k} {float(v['rms']):.2f} K" for k, v in cv.items() if isinstance(v, dict) and v.get("rms") is not None
        )
        refined += (
            f"; the fit's memory check kept it: blocked week cross-validation on the training weeks ({scores}) found "
            "no refit with memory that predicts a left-out week better"
        )
    modes = f"all {len(tc)} modes" if len(tc) > 1 else "its only mode"
    return [
        f"the model's slowest time constant is {60 * slowest:.0f} min ({modes}), shorter than its "
        f"{60 * step_h:.0f}-min step{refined}: a 24-hour prediction forgets the zone's temperature at its start within the first hour and "
        "becomes the response to the weather and the time-of-week gain profile, so it cannot follow a zone that "
        "floats away from its usual level, which persistence keeps; closed-loop data where the fit learned the "
        "thermostat loop, not the building. The physics model, or `hvacfmu diagnose` (its own one-step base in the "
        "airflow form), test a slower building"
    ]


def _twin_memory(model, losing) -> list[str]:
    """A state matrix whose zone memory sits on a neighbour, or with negative eigenvalues
    (:func:`~hvacfmu.models.plausibility.memory_warnings`), for the losing zones it names (every one when the
    losing outputs are not zones).

    The EnergyPlus apartments' diagnosed model (``benchmarks/twins_s18.md``): its mirror-twin flats S1/S2 had
    ``a_S1,S1 = 0``, ``a_S1,S2 = 0.698`` and eigenvalues -0.56 / -0.67; they lost to persistence in winter and no
    line said the model's matrix was not a building's."""
    from ..models.plausibility import memory_warnings

    A = getattr(getattr(model, "base", model), "A", None)
    names = getattr(getattr(model, "base", model), "outputs", None)
    if A is None or names is None or getattr(model, "kind", None) == "lumped":
        return []
    try:
        lines = memory_warnings(A, names)
    except (ValueError, np.linalg.LinAlgError):
        return []
    lost = [str(z) for z in (losing or [])]
    named = [w for w in lines if any(z in w for z in lost)] if any(z in names for z in lost) else lines
    return [f"the fitted state matrix is not an RC network's: {w}" for w in named]


def _bandwidth_edge(model) -> list[str]:
    """LOESS bandwidths chosen on the edge of the cross-validation grid (read from ``model.meta``)."""
    meta = getattr(model, "meta", None) or getattr(getattr(model, "base", None), "meta", None) or {}
    sm = meta.get("smoothing") if isinstance(meta, dict) else None
    if not isinstance(sm, dict) or not sm.get("cv_grid_h") or not isinstance(sm.get("bandwidth_h"), dict):
        return []
    grid = [float(g) for g in sm["cv_grid_h"]]
    lo, hi = min(grid), max(grid)
    at_lo = sorted(k for k, v in sm["bandwidth_h"].items() if float(v) <= lo)
    at_hi = sorted(k for k, v in sm["bandwidth_h"].items() if float(v) >= hi)
    out = []
    for edge, names, what in ((lo, at_lo, "lower"), (hi, at_hi, "upper")):
        if names:
            out.append(
                f"LOESS bandwidth on the {what} edge of its grid ({edge:g} h) for {len(names)} of "
                f"{len(sm['bandwidth_h'])} series ({', '.join(names[:6])}{', ...' if len(names) > 6 else ''}): "
                "the cross-validation optimum may lie outside the grid; refit with a wider "
                "`bandwidths=` grid"
            )
    return out


def _num(x: Any) -> float | None:
    x = float(x)
    return x if np.isfinite(x) else None


__all__ = [
    "G14_CVRMSE_MAX",
    "G14_NMBE_MAX",
    "SeasonVerdict",
    "Verdict",
    "ZoneVerdict",
    "g14_metrics",
    "likely_causes",
    "make_verdict",
    "season_causes",
    "day_to_day_line",
]
