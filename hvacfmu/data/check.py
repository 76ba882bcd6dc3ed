"""``hvacfmu check``: validate a dataset and summarise what a user needs before fitting."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import BuildingError, DataError
from ..progress import Progress
from .clock import ClockCheck, clock_check, outdoor_phase_warning
from .dataset import _BRIDGE, Dataset, _prepare, option_problems, sparse_columns, sparse_message
from .loading import WIND_MAX, LoadReport, _load, as_building
from .plausibility import SPIKE_FACTOR, SPIKE_SHARE_MAX, STUCK_DAYS
from .resample import MIN_COVERAGE

#: Weeks with fewer steps than this holding every zone temperature are flagged.
WEEK_COVERAGE_WARNING = 0.8
#: Excitation periods listed by date in the report (the rest are counted).
N_PERIODS_LISTED = 12

#: Exit codes of ``hvacfmu check``: usable (notes at most), not usable, usable but a warning needs action.
EXIT_OK, EXIT_NOT_USABLE, EXIT_ATTENTION = 0, 1, 3

#: Fragments of loading warnings that change what a user must do (label shown on the final line).
_ATTENTION = {
    "unknown column(s) ignored": "unknown columns ignored",
    "a stuck sensor?": "stuck sensor",
    "discharge air below its unit's supply air": "discharge air vs its unit",
    "discharge air above T_supply_max": "discharge air vs its unit",
    "is not W/m²": "irradiance level",
    "an irradiance sensor reads 0 after sunset": "irradiance offset",
    "against the sun that ghi puts on time": "outdoor air shifted",
    "is it a setpoint exported as the zone temperature": "setpoint as zone temperature",
    "a dead flow sensor, a setpoint exported as the flow": "constant airflow",
    "the data look like a fraction 0..1": "reheat unit",
    "does not follow its own reheat": "discharge air vs its reheat",
    "the supply air of another air handler": "boxes vs air handlers",
    "it behaves like indoor air": "outdoor air looks indoor",
    "it behaves like return or room air": "supply air looks like room air",
    "the flag looks inverted": "excitation inverted",
    "mapped to the wrong zone?": "box in another zone",
    "look swapped: the temperature changes": "zone columns swapped",
    "look rotated: the temperature changes": "zone columns rotated",
    "look swapped: box ": "discharge columns swapped",
    "a frozen outdoor sensor?": "frozen outdoor air",
    "a held sensor? the value repeats": "held zone sensor",
    "colder than any weather station below 2000 m": "outdoor air unit",
}


def _tail(ds) -> str:
    """The data after the last whole week, which no stage uses (``""`` when less than a step).

    A week is 7 whole local days; across the autumn clock change they hold 169 h, so data of ``n x 168`` h that
    cross it (an emulator run of ``--weeks n``) end an hour short of their last week and lose it.
    """
    if not ds.weeks or not len(ds.frame):
        return ""
    last = ds.weeks[-1].end
    end = ds.frame.index[-1] + pd.Timedelta(seconds=ds.step)
    tail = (end - last).total_seconds()
    if tail < ds.step:
        return ""
    nxt = (last.tz_localize(None) + pd.Timedelta(days=7)).tz_localize(
        last.tz, nonexistent="shift_forward", ambiguous=False
    )
    short = (nxt - end).total_seconds()
    why = ""
    if 0 < short < 86400.0:
        long_weeks = [w for w in ds.weeks if (w.end - w.start).total_seconds() > 7 * 86400.0]
        why = f" ({_duration(short)} short of one" + (
            f": the week of {long_weeks[0].start.date()} holds the autumn clock change's extra hour)"
            if long_weeks
            else ")"
        )
    return f"; the last {_duration(tail)} of data, from {last.isoformat()}, are not a whole week and are not used{why}"


def _duration(seconds: float) -> str:
    seconds = round(seconds)
    d, rest = divmod(seconds, 86400)
    h, rest = divmod(rest, 3600)
    m = rest // 60
    if d:
        return f"{d} d {h} h"
    if h:
        return f"{h} h {m:02d} min"
    if m:
        return f"{m} min"
    return f"{seconds} s"


def _names(names, limit=8) -> str:
    if len(names) <= limit:
        return ", ".join(names)
    return f"{', '.join(names[:limit])} and {len(names) - limit} more"


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` index pairs of the runs of True in a boolean array (stop exclusive)."""
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        return []
    d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


@dataclasses.dataclass
class ColumnGaps:
    """Coverage of one column on the model step."""

    column: str
    coverage: float  # fraction of steps with a value
    n_gaps: int
    longest: float  # [s]
    longest_start: pd.Timestamp | None


@dataclasses.dataclass
class CheckReport:
    """Result of :func:`check`.

    Attributes
    ----------
    ok : bool
        True if the data can be used for fitting.
    problems : list of str
        Everything that makes the data unusable (empty if ``ok``).
    warnings : list of str
    path : str
    dataset : Dataset or None
        The prepared dataset when loading succeeded.
    load_report : LoadReport or None
    gaps : list of ColumnGaps
    excitation_periods : list of (Timestamp, Timestamp)
        Start and end (exclusive) of each run of excitation steps.
    clock : ClockCheck or None
        The data's daily cycle against the declared clock (:func:`~hvacfmu.data.clock.clock_check`).
    attention : list of str
        The warnings (also in ``warnings``) that change what a user must do before fitting: a clock
        that looks offset, columns ignored as unknown, a stuck sensor, discharge air that
        contradicts its air handler. With any of them the report does not read as a clean bill.
    """

    ok: bool
    problems: list
    warnings: list
    path: str
    building: str | None = None
    dataset: Dataset | None = None
    load_report: LoadReport | None = None
    gaps: list = dataclasses.field(default_factory=list)
    excitation_periods: list = dataclasses.field(default_factory=list)
    clock: ClockCheck | None = None
    attention: list = dataclasses.field(default_factory=list)

    @property
    def exit_code(self) -> int:
        """What ``hvacfmu check`` returns: :data:`EXIT_OK` (0, usable; notes at most),
        :data:`EXIT_NOT_USABLE` (1) or :data:`EXIT_ATTENTION` (3, usable but a warning needs action)."""
        if not self.ok:
            return EXIT_NOT_USABLE
        return EXIT_ATTENTION if self.attention else EXIT_OK

    def __str__(self) -> str:
        return self.format()

    def _plausibility_lines(self) -> list:
        """What the physical checks covered and what they masked, with counts."""
        lr, b = self.load_report, self.dataset.building
        n_m = sum(1 for c in lr.columns if c.startswith("m_"))
        n_t = sum(1 for c in lr.columns if c.startswith(("T_", "Td_")))
        lines = [
            f"Plausibility: {n_m} airflow column(s) against their box's m_min..m_max (spikes above "
            f"{SPIKE_FACTOR:g} x m_max masked up to {100 * SPIKE_SHARE_MAX:g} %), {n_t} temperature column(s) "
            f"against their unit and -50..80 °C, T_out against the climate at latitude {b.latitude:g}°, "
            f"stuck temperature sensors ({STUCK_DAYS:g} days)"
            + (
                f", wind speed against 0..{WIND_MAX:g} m/s ({lr.units['wind']} in the file)"
                if "wind" in lr.units
                else ""
            )
        ]
        if not lr.masked:
            lines.append("  nothing masked")
        for (col, why), count in lr.masked.items():
            lines.append(f"  {count} sample(s) of {col} masked ({why})")
        return lines

    def format(self) -> str:
        """The human-readable report printed by ``hvacfmu check``."""
        lines = [f"Measurements: {self.path}"]
        ds, lr = self.dataset, self.load_report
        if self.building:
            lines.append(f"Building: {self.building}")
        if lr is not None and lr.start is not None:
            span = (lr.end - lr.start).total_seconds()
            lines.append(
                f"Span: {lr.start.isoformat()} .. {lr.end.isoformat()} ({span / 86400:.1f} days, {lr.rows} rows)"
            )
            native = f"{lr.native_step:g} s (median spacing)" if lr.native_step else "unknown"
            if lr.native_step:
                expected = span / lr.native_step + 1
                native += f", {100 * min(lr.rows / expected, 1.0):.2f} % of the rows expected at that spacing"
            clock = "with UTC offsets" if lr.has_offsets else "naive"
            if not lr.has_offsets and self.dataset is not None:
                clock += f", read in {self.dataset.building.clock_timezone}"
            lines.append(f"Native resolution: {native}; times {clock}")
            coarse = {c: s for c, s in lr.column_steps.items() if s and lr.native_step and s > 1.5 * lr.native_step}
            if coarse:
                lines.append("  coarser columns: " + ", ".join(f"{c} {s:g} s" for c, s in coarse.items()))
        if ds is not None:
            lines.append(f"Model step: {ds.step:g} s -> {len(ds.frame)} steps")
            if ds.has_solar:
                given = lr is not None and all(f"I_{o}" in lr.columns for o in "NESW")
                how = "given" if given else "computed from ghi with pvlib (Erbs, isotropic sky, albedo 0.2)"
                lines.append(f"Solar: facade irradiance I_N, I_E, I_S, I_W {how}")
            else:
                lines.append("Solar: none (no ghi and no facade columns)")
            lines += self._plausibility_lines()
            lines.append("Coverage on the model step (steps with a value, gaps, longest gap):")
            groups: dict = {}
            for g in self.gaps:  # columns with identical coverage share one line
                groups.setdefault((round(g.coverage, 6), g.n_gaps, g.longest, g.longest_start), []).append(g.column)
            for (coverage, n_gaps, longest_s, longest_start), names in groups.items():
                longest = ""
                if n_gaps:
                    longest = f", longest {_duration(longest_s)} from {longest_start.isoformat()}"
                lines.append(f"  {100 * coverage:6.2f} %  {n_gaps:4d} gap(s){longest}: {_names(names)}")
            if self.clock is not None:
                offset = "" if self.clock.offset is None else f" (offset {self.clock.offset:+.1f} h)"
                lines.append(f"Clock: {self.clock.detail}{offset}")
            lines.append(
                f"Weeks: {len(ds.weeks)}" + (f" from {ds.weeks[0].start.date()}" if ds.weeks else "") + _tail(ds)
            )
            for season in ds.building.season_names:
                weeks = [w for w in ds.weeks if w.season == season]
                if not weeks:
                    continue
                test = [w for w in weeks if not w.train]
                test_txt = ", ".join(f"#{w.number} ({w.start.date()})" for w in test) or "none"
                lines.append(
                    f"  {season:<8} {len(weeks):3d} weeks: {len(weeks) - len(test)} train, {len(test)} test: {test_txt}"
                )
            lines.append(f"Holidays: {ds.holidays.summary()}")
            total = sum((e - s).total_seconds() for s, e in self.excitation_periods)
            lines.append(f"Excitation periods: {len(self.excitation_periods)} ({_duration(total)} in total)")
            for s, e in self.excitation_periods[:N_PERIODS_LISTED]:
                lines.append(f"  {s:%Y-%m-%d %a %H:%M} .. {e:%H:%M} ({_duration((e - s).total_seconds())})")
            if len(self.excitation_periods) > N_PERIODS_LISTED:
                lines.append(f"  ... and {len(self.excitation_periods) - N_PERIODS_LISTED} more")
        if self.warnings:
            act = (
                f", {len(self.attention)} need{'s' if len(self.attention) == 1 else ''} action (!)"
                if self.attention
                else ""
            )
            lines.append(f"Warnings ({len(self.warnings)}{act}):")
            lines += [f"  {'!' if w in self.attention else '-'} {w}" for w in self.warnings]
        lines.append(self.verdict_line())
        return "\n".join(lines)

    def verdict_line(self) -> str:
        """The final line: never a clean bill while a warning needs action (see :attr:`exit_code`)."""
        if self.problems:
            n = len(self.problems)
            return f"NOT USABLE: {n} problem{'s' if n != 1 else ''}:\n" + "\n".join(f"  - {p}" for p in self.problems)
        if self.attention:
            n = len(self.attention)
            what = "; ".join(_attention_label(w) for w in self.attention)
            return (
                f"OK WITH {n} WARNING{'S' if n != 1 else ''} THAT NEED{'S' if n == 1 else ''} ACTION (see above: "
                f"{what}): the data can be read, but fix {'it' if n == 1 else 'them'} before fitting or the models "
                f"learn the mistake (exit code {EXIT_ATTENTION})"
            )
        if self.warnings:
            n = len(self.warnings)
            return f"OK with {n} note{'s' if n != 1 else ''} (see above): the data can be used for fitting"
        return "OK: the data can be used for fitting"


def check(
    path,
    building,
    step: float = 900.0,
    seed: int = 0,
    train_fraction: float = 0.9,
    interpolate_limit: float | None = None,
    min_coverage: float = MIN_COVERAGE,
    timezone: str | None = None,
    progress: bool = False,
) -> CheckReport:
    """Load and validate a dataset; never raises for bad data or a bad building file.

    Parameters are those of :func:`hvacfmu.data.prepare` (``timezone``, ``progress`` included).

    Returns
    -------
    CheckReport
        ``ok`` is False, with every problem listed, when the options, the
        building file or the data cannot be used: any load problem (see
        :func:`load_measurements`), no complete week, a required column
        without a single value on the model step, or any measured column with
        a value in fewer than :data:`~hvacfmu.data.dataset.MIN_COLUMN_COVERAGE`
        (50 %) of the model steps. Plausibility findings that were masked
        (airflow spikes, stuck sensors) and a clock that looks offset
        (:func:`~hvacfmu.data.clock.clock_check`) are warnings; those that change what
        a user must do (clock offset, unknown columns ignored, stuck sensor, discharge air
        against its unit) are also in ``attention`` and make the final line read
        ``OK WITH n WARNINGS THAT NEED ACTION`` and ``exit_code`` 3 (0: usable, 1: not usable).
    """
    path = Path(path)
    bad_options = option_problems(step, train_fraction, interpolate_limit, min_coverage)
    if bad_options:
        return CheckReport(ok=False, problems=bad_options, warnings=[], path=str(path))
    try:
        building = as_building(building, timezone)
    except BuildingError as exc:
        return CheckReport(ok=False, problems=[str(exc)], warnings=[], path=str(path))
    about = (
        f"{building.name} ({len(building.zones)} zones, {len(building.vavs)} VAV boxes, time zone {building.timezone})"
    )
    with Progress(total=1, desc=f"reading {path.name}", unit="file", enabled=progress) as bar:
        frame, report, problems = _load(path, building)
        bar.update()
    if problems:
        return CheckReport(
            ok=False,
            problems=problems,
            warnings=list(report.warnings),
            path=str(path),
            building=about,
            load_report=report,
        )
    try:
        dataset = _prepare(
            path,
            building,
            step,
            seed,
            train_fraction,
            interpolate_limit,
            min_coverage,
            loaded=(frame, report),
            progress=progress,
        )
    except (DataError, ValueError) as exc:
        return CheckReport(
            ok=False,
            problems=[str(exc)],
            warnings=list(report.warnings),
            path=str(path),
            building=about,
            load_report=report,
        )
    gaps, problems, sparse = _coverage(dataset, building, path.name, min_coverage, interpolate_limit)
    step_s = dataset.step
    if not dataset.weeks:
        span = (dataset.frame.index[-1] - dataset.frame.index[0]).total_seconds() + step_s if len(dataset.frame) else 0
        problems.append(
            f"{path.name}: the data span {_duration(span)} and hold no complete week (7 days from a local midnight); "
            "fitting needs at least one"
        )
    periods, notes, clock, attention = _findings(dataset, building, path.name, report, sparse)
    return CheckReport(
        ok=not problems,
        problems=problems,
        warnings=notes,
        path=str(path),
        building=about,
        dataset=dataset,
        load_report=report,
        gaps=gaps,
        excitation_periods=periods,
        clock=clock,
        attention=attention,
    )


def _findings(dataset, building, name: str, report, sparse) -> tuple:
    """Excitation periods, notes (warnings), the clock check and the warnings that need action."""
    step_s = dataset.step
    exc = dataset.frame["excitation"].to_numpy() == 1
    periods = [
        (dataset.frame.index[a], dataset.frame.index[b - 1] + pd.Timedelta(seconds=step_s)) for a, b in runs(exc)
    ]
    notes = [w for w in dataset.warnings if w not in sparse] + _week_notes(dataset)
    if not periods:
        notes.append("no excitation periods found: airflow coefficients must come from normal operation alone")
    clock = clock_check(dataset.frame, building, step_s, has_offsets=report.has_offsets)
    attention = [w for w in notes if any(k in w for k in _ATTENTION)]
    if clock.warning:
        notes.insert(0, f"{name}: clock: {clock.warning}")
        attention.insert(0, notes[0])
    shifted = outdoor_phase_warning(dataset.frame, building, step_s, clock)
    if shifted:
        notes.insert(0, f"{name}: {shifted}")
        attention.insert(0, notes[0])
    return periods, notes, clock, attention


def _attention_label(warning: str) -> str:
    """A short name of a warning that needs action, for the final line."""
    if ": clock: " in warning:
        return "clock offset"
    return next((label for k, label in _ATTENTION.items() if k in warning), "warning")


def _coverage(dataset, building, label, min_coverage, interpolated=None):
    """Gaps per column, the coverage problems, and the sparse-column messages (also in the dataset's warnings)."""
    problems = []
    required = [c for c, req in building.expected_columns().items() if req]
    gaps = []
    missing_all: dict = {}
    step_s = dataset.step
    for col in dataset.frame.columns:
        missing = ~np.isfinite(dataset.frame[col].to_numpy())
        r = runs(missing)
        longest_run = max(r, key=lambda ab: ab[1] - ab[0]) if r else None
        gaps.append(
            ColumnGaps(
                column=col,
                coverage=float(1.0 - missing.mean()) if len(missing) else 0.0,
                n_gaps=len(r),
                longest=(longest_run[1] - longest_run[0]) * step_s if longest_run else 0.0,
                longest_start=dataset.frame.index[longest_run[0]] if longest_run else None,
            )
        )
        missing_all[col] = bool(len(missing) and missing.all())
        if col in required and missing_all[col]:
            problems.append(
                f"{label}: column {building.column_for(col)!r}: no model step of {step_s:g} s has enough samples "
                f"(at least {100 * min_coverage:g} % of the step){_masked_note(dataset, col)}; if the sensor logs "
                f"thinly all along (samples sparser than the file's rows): {_BRIDGE}"
            )
    sparse = {
        sparse_message(building.column_for(c), c, cov, interpolated=interpolated): c
        for c, cov in sparse_columns(dataset.frame).items()
    }
    for msg, col in sparse.items():
        if not (col in required and missing_all.get(col)):
            problems.append(f"{label}: {msg}{_masked_note(dataset, col)}")
    return gaps, problems, sparse


def _week_notes(dataset) -> list:
    """Weeks with fewer than :data:`WEEK_COVERAGE_WARNING` of their steps holding every zone temperature."""
    notes = []
    b = dataset.building
    zone_cols = [f"T_{z}" for z in b.zone_names if f"T_{z}" in dataset.frame.columns]
    all_zones = np.isfinite(dataset.frame[zone_cols].to_numpy()).all(axis=1)
    for w in dataset.weeks:
        a, e = dataset.frame.index.searchsorted(w.start), dataset.frame.index.searchsorted(w.end)
        share = float(all_zones[a:e].mean()) if e > a else 0.0
        if share < WEEK_COVERAGE_WARNING:
            notes.append(
                f"week #{w.number} ({w.start.date()}, {w.season}, {'train' if w.train else 'test'}): only "
                f"{100 * share:.0f} % of its steps have every zone temperature"
            )
    return notes


def _masked_note(dataset, col) -> str:
    """'' or a note that plausibility checks masked samples of ``col`` (why a column may look empty)."""
    masked = dataset.load_report.masked if dataset.load_report is not None else {}
    parts = [f"{n} sample(s) masked as {why}" for (c, why), n in masked.items() if c == col]
    return f" ({', '.join(parts)}: see the warnings)" if parts else ""
