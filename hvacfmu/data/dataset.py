"""Weeks, seasons, the train/test split and the :class:`Dataset` that models are fitted on."""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import numbers
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from ..building import ORIENTATIONS, Building, building_notes
from ..errors import DataError, HvacfmuWarning, problems_message
from ..progress import Progress
from .boxmap import check_box_zones, check_discharge_swaps, check_zone_swaps
from .holidays import HolidayCalendar, decide_holidays
from .loading import LoadReport, as_building, load_measurements
from .plausibility import check_discharge, check_roles, check_supply_assignment
from .resample import MIN_COVERAGE, interpolate_gaps, resample
from .solar import facade_irradiance

#: Canonical solar columns of a prepared dataset.
FACADE_COLUMNS = tuple(f"I_{o}" for o in ORIENTATIONS)


@dataclasses.dataclass(frozen=True)
class Week:
    """One 7-day block of data.

    Attributes
    ----------
    number : int
        Position in :attr:`Dataset.weeks` (0 for the first block).
    start : pandas.Timestamp
        Local midnight starting the block (inclusive).
    end : pandas.Timestamp
        Local midnight seven days later (exclusive).
    season : str
        Season of the block's midpoint.
    train : bool
        True for a training week, False for a held-out test week.
    """

    number: int
    start: pd.Timestamp
    end: pd.Timestamp
    season: str
    train: bool


def make_weeks(index: pd.DatetimeIndex, end, building: Building, seed: int = 0, train_fraction: float = 0.9):
    """Cut data into weeks, assign seasons and split into training and test weeks.

    Weeks are consecutive 7-day blocks of local calendar days starting at the
    first local midnight at or after ``index[0]``; a trailing block that ends
    after ``end`` is dropped. Each week belongs to the season of its midpoint.
    Per season, ``round((1 - train_fraction) * n)`` weeks, at least one if the
    season has two weeks or more, are drawn as test weeks with a generator
    seeded by ``(seed, season number)``, so a season's split does not depend on
    the others.

    Parameters
    ----------
    index : DatetimeIndex
        tz-aware times of the data (only the first matters).
    end : pandas.Timestamp
        End of the data (exclusive), e.g. last bin start + step.
    building : Building
    seed : int
    train_fraction : float
        Fraction of training weeks per season, in (0, 1].

    Returns
    -------
    weeks : tuple of Week
    notes : list of str
        Warnings (e.g. a season with a single week gets no test week).
    """
    if not 0 < train_fraction <= 1:
        raise ValueError(f"train_fraction must be in (0, 1], got {train_fraction}")
    if len(index) == 0:
        return (), ["no data: no weeks"]
    tz = index.tz
    first = index[0]
    day0 = first.tz_localize(None).normalize()
    if pd.Timestamp(day0).tz_localize(tz, nonexistent="shift_forward", ambiguous=False) < first:
        day0 = day0 + pd.Timedelta(days=1)
    blocks = []
    k = 0
    while True:
        days = pd.DatetimeIndex([day0 + pd.Timedelta(days=7 * k), day0 + pd.Timedelta(days=7 * (k + 1))])
        s, e = days.tz_localize(tz, nonexistent="shift_forward", ambiguous=False)
        if e > end:
            break
        blocks.append((s, e))
        k += 1
    seasons = [building.season_of(s + (e - s) / 2) for s, e in blocks]
    train = [True] * len(blocks)
    notes = []
    for i, name in enumerate(building.season_names):
        members = [j for j, sn in enumerate(seasons) if sn == name]
        n = len(members)
        if n == 0:
            continue
        if n == 1:
            notes.append(f"season {name} has only one week ({blocks[members[0]][0].date()}): no test week for it")
            continue
        n_test = max(1, int(np.floor((1.0 - train_fraction) * n + 0.5 + 1e-9)))
        n_test = min(n_test, n - 1)
        rng = np.random.default_rng([int(seed), i])
        for j in rng.choice(n, size=n_test, replace=False):
            train[members[int(j)]] = False
    weeks = tuple(Week(j, s, e, seasons[j], train[j]) for j, (s, e) in enumerate(blocks))
    return weeks, notes


@dataclasses.dataclass(frozen=True, eq=False)
class Dataset:
    """Measured data on the model step, ready for fitting and evaluation.

    Attributes
    ----------
    frame : DataFrame
        Index: tz-aware local bin starts named ``time`` (regular, ``step``
        apart). Columns: ``T_<zone>`` [°C], ``m_<vav>`` [kg/s], ``T_supply``
        [°C] (with several air handlers: their airflow-weighted mean, see
        :func:`primary_supply`), ``T_supply_<ahu>`` [°C] per declared air
        handler, ``T_out`` [°C], optional ``ghi`` [W/m²], ``I_N I_E I_S I_W``
        [W/m²] when ``has_solar``, ``excitation`` (0/1 float), and when the
        file has them per box ``Td_<vav>`` (discharge air) [°C] and
        ``rh_<vav>`` (reheat command) [0..1]. NaN where data are missing.
    building : Building
    step : float [s]
    source : str or None
        Path of the measurements file.
    sha256 : str or None
        Hash of the measurements file.
    weeks : tuple of Week
    warnings : list of str
    has_solar : bool
        True if facade irradiance is available (given or computed from ``ghi``).
    coverage : DataFrame or None
        Fraction of expected raw samples per bin and column.
    load_report : LoadReport or None
    holidays : HolidayCalendar
        The weekdays whose internal gains follow Sunday's profile in every model fitted on the data
        (:func:`hvacfmu.data.holidays.decide_holidays`: the building file's ``[holidays]``, or the
        public holidays of its country when the training weeks show the building closes on them).
    """

    frame: pd.DataFrame
    building: Building
    step: float = 900.0
    source: str | None = None
    sha256: str | None = None
    weeks: tuple = ()
    warnings: list = dataclasses.field(default_factory=list)
    has_solar: bool = False
    coverage: pd.DataFrame | None = None
    load_report: LoadReport | None = None
    holidays: HolidayCalendar = HolidayCalendar()

    # --- weeks ---------------------------------------------------------
    def week_frame(self, week: Week) -> pd.DataFrame:
        """Rows of :attr:`frame` in ``[week.start, week.end)``."""
        idx = self.frame.index
        return self.frame.iloc[idx.searchsorted(week.start, side="left") : idx.searchsorted(week.end, side="left")]

    def train_weeks(self, season: str | None = None) -> tuple:
        """Training weeks, optionally of one season."""
        return tuple(w for w in self.weeks if w.train and (season is None or w.season == season))

    def test_weeks(self, season: str | None = None) -> tuple:
        """Held-out test weeks, optionally of one season."""
        return tuple(w for w in self.weeks if not w.train and (season is None or w.season == season))

    @property
    def seasons(self) -> tuple:
        """Season names that have at least one week, in the building's order."""
        have = {w.season for w in self.weeks}
        return tuple(s for s in self.building.season_names if s in have)

    @functools.cached_property
    def season_of_row(self) -> np.ndarray:
        """Season name of each row of :attr:`frame`.

        Rows inside a week get the week's season (as the paper assigns whole
        weeks to seasons); rows outside every week get the season of their
        local calendar day.
        """
        idx = self.frame.index
        if not len(idx):
            return np.array([], dtype=object)
        key = idx.month.to_numpy() * 100 + idx.day.to_numpy()
        uniq, inverse = np.unique(key, return_inverse=True)
        names = np.array(
            [self.building.season_of(pd.Timestamp(2001 if k != 229 else 2000, k // 100, k % 100)) for k in uniq],
            dtype=object,
        )
        out = names[inverse]
        for w in self.weeks:
            out[idx.searchsorted(w.start) : idx.searchsorted(w.end)] = w.season
        return out

    @functools.cached_property
    def week_of_row(self) -> np.ndarray:
        """Week number of each row of :attr:`frame`, -1 outside every week."""
        out = np.full(len(self.frame), -1, dtype=np.int64)
        idx = self.frame.index
        for w in self.weeks:
            out[idx.searchsorted(w.start) : idx.searchsorted(w.end)] = w.number
        return out

    # --- construction --------------------------------------------------
    @classmethod
    def from_frame(
        cls,
        frame: pd.DataFrame,
        building,
        step: float = 900.0,
        seed: int = 0,
        train_fraction: float = 0.9,
        source=None,
        sha256=None,
        warnings_=None,
        coverage=None,
        load_report=None,
    ) -> Dataset:
        """A dataset from a frame already on the model step (weeks, split and facade irradiance added).

        ``frame`` must have a regular tz-aware index ``step`` apart and
        canonical SI columns; facade irradiance is computed from ``ghi`` at the
        step midpoints for facades without a column.
        """
        building = as_building(building)
        notes = list(warnings_ or [])
        _check_step_frame(frame, step)
        frame = frame.copy()
        frame.index.name = "time"
        given = [c for c in FACADE_COLUMNS if c in frame.columns]
        has_solar = len(given) == 4
        if "ghi" in frame.columns and len(given) < 4:
            mid = frame.index + pd.Timedelta(seconds=step / 2)
            computed = facade_irradiance(mid, frame["ghi"].to_numpy(), building.latitude, building.longitude)
            for c in FACADE_COLUMNS:
                if c not in frame.columns:
                    frame[c] = computed[c].to_numpy()
            has_solar = True
        elif not has_solar:
            notes.append("no 'ghi' and no facade irradiance columns: the dataset has no solar data")
            frame = frame.drop(columns=given)
        if "excitation" not in frame.columns:
            notes.append("no 'excitation' column: no forced-response experiments are flagged (all 0)")
            frame["excitation"] = 0.0
        if (
            building.ahus
            and "T_supply" not in frame.columns
            and all(c in frame.columns for c in building.supply_columns())
        ):
            frame["T_supply"] = primary_supply(frame, building)
            if len(building.ahus) > 1:
                notes.append(
                    f"T_supply is the airflow-weighted mean of {', '.join(building.supply_columns())} per step "
                    "(weights: the measured airflow of each unit's boxes, their m_max where airflow is missing); "
                    "per-box models use each box's own unit (Building.supply_column)"
                )
        order = [f"T_{z}" for z in building.zone_names] + [f"m_{v}" for v in building.vav_names]
        order += ["T_supply", *building.supply_columns(), "T_out", "ghi"]
        order += (list(FACADE_COLUMNS) if has_solar else []) + ["excitation"]
        order += [f"Td_{v}" for v in building.vav_names] + [f"rh_{v}" for v in building.vav_names] + ["wind"]
        frame = frame[[c for c in order if c in frame.columns]].astype(float)
        end = frame.index[-1] + pd.Timedelta(seconds=step) if len(frame) else None
        weeks, week_notes = make_weeks(frame.index, end, building, seed=seed, train_fraction=train_fraction)
        notes += week_notes
        if not weeks:
            notes.append("the data hold no complete week (7 days from a local midnight): nothing to fit on")
        holidays = decide_holidays(frame, building, weeks)
        notes += list(holidays.notes)
        return cls(
            frame=frame,
            building=building,
            step=float(step),
            source=None if source is None else str(source),
            sha256=sha256,
            weeks=weeks,
            warnings=notes,
            has_solar=has_solar,
            coverage=coverage,
            load_report=load_report,
            holidays=holidays,
        )


def primary_supply(frame: pd.DataFrame, building: Building) -> np.ndarray:
    """One supply temperature [°C] per row from the units' ``T_supply_<ahu>`` columns.

    The mean of the units' supply temperatures weighted by the airflow their
    boxes deliver in that row (``m_<vav>`` [kg/s]); in rows where a box's
    airflow is missing or the total is 0, weighted by the units' summed
    ``m_max`` instead. NaN where any unit's supply temperature is missing.
    """
    if len(building.ahus) == 1:
        return frame[building.ahus[0].supply_column].to_numpy(dtype=float, copy=True)
    n = len(frame)
    temps = (
        np.column_stack([frame[c].to_numpy(dtype=float) for c in building.supply_columns()]) if n else np.zeros((0, 0))
    )
    flows = np.zeros((n, len(building.ahus)))
    nominal = np.zeros(len(building.ahus))
    for j, a in enumerate(building.ahus):
        for v in building.vavs:
            if v.ahu == a.name:
                col = f"m_{v.name}"
                m = frame[col].to_numpy(dtype=float) if col in frame.columns else np.full(n, np.nan)
                flows[:, j] += m
                nominal[j] += v.m_max
    total = flows.sum(axis=1)
    use_flow = np.isfinite(total) & (total > 0)
    weights = np.where(use_flow[:, None], flows, nominal[None, :])
    with np.errstate(invalid="ignore", divide="ignore"):
        return (weights * temps).sum(axis=1) / weights.sum(axis=1)


def _check_step_frame(frame: pd.DataFrame, step: float) -> None:
    """Raise DataError unless ``frame`` has a tz-aware index regularly ``step`` seconds apart."""
    idx = frame.index
    if not isinstance(idx, pd.DatetimeIndex) or idx.tz is None:
        raise DataError("a dataset frame needs a tz-aware DatetimeIndex (local time of the building)")
    if len(idx) > 1:
        d = np.diff(idx.as_unit("ns").asi8)
        bad = np.flatnonzero(d != round(step * 1e9))
        if len(bad):
            raise DataError(
                f"a dataset frame must be regular with the model step {step:g} s; {len(bad)} spacing(s) differ, "
                f"first after {idx[bad[0]].isoformat()} ({d[bad[0]] / 1e9:g} s); resample it first "
                "(hvacfmu.data.resample)"
            )


def file_sha256(path) -> str:
    """SHA-256 hex digest of a file."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 22), b""):
            h.update(chunk)
    return h.hexdigest()


def prepare(
    path,
    building,
    step: float = 900.0,
    seed: int = 0,
    train_fraction: float = 0.9,
    interpolate_limit: float | None = None,
    min_coverage: float = MIN_COVERAGE,
    timezone: str | None = None,
    progress: bool = False,
) -> Dataset:
    """Load, validate, resample and split a measurements file.

    Parameters
    ----------
    path : str or Path
        Measurements (CSV or Parquet), see :func:`load_measurements`.
    building : Building or path
    step : float [s]
        Model step (default 900 s); must divide one hour.
    seed : int
        Seed of the train/test week split.
    train_fraction : float
        Fraction of training weeks per season (default 0.9).
    interpolate_limit : float or None [min]
        Linearly interpolate gaps up to this length before averaging
        (default None: keep every gap).
    min_coverage : float
        Minimum fraction of raw samples for a step to get a value.
    timezone : str, optional
        Zone of the data's naive timestamps (e.g. ``"UTC"``), overriding the
        building's ``data_timezone`` (default: the building's ``timezone``).
    progress : bool
        Show the stages (load, gaps, resampling, solar and weeks): a bar on a
        terminal, log lines otherwise (:mod:`hvacfmu.progress`).

    Returns
    -------
    Dataset

    Raises
    ------
    DataError
        If the file cannot be used (every problem listed).

    Warns
    -----
    HvacfmuWarning
        For each entry of :attr:`Dataset.warnings`.
    """
    building = as_building(building, timezone)
    dataset = _prepare(path, building, step, seed, train_fraction, interpolate_limit, min_coverage, progress=progress)
    for w in dataset.warnings:
        warnings.warn(w, HvacfmuWarning, stacklevel=2)
    return dataset


#: Columns with a value in fewer model steps than this share are refused by ``check`` (warned by ``prepare``).
MIN_COLUMN_COVERAGE = 0.5


def sparse_columns(frame: pd.DataFrame, threshold: float = MIN_COLUMN_COVERAGE) -> dict:
    """Measured columns holding a value in fewer than ``threshold`` of the rows -> their coverage [0..1].

    ``excitation`` and computed facade irradiance are not measured columns and are skipped.
    """
    out = {}
    for col in frame.columns:
        if col == "excitation" or col in FACADE_COLUMNS:
            continue
        cov = float(np.isfinite(frame[col].to_numpy(dtype=float)).mean()) if len(frame) else 0.0
        if cov < threshold:
            out[col] = cov
    return out


def sparse_message(
    name: str,
    canonical: str,
    coverage: float,
    threshold: float = MIN_COLUMN_COVERAGE,
    interpolated: float | None = None,
) -> str:
    """The message naming a column too sparse for the models (see :data:`MIN_COLUMN_COVERAGE`).

    ``interpolated``: the ``--interpolate-gaps`` limit [min] already applied, if any; then the message does not
    advise it again (after `--interpolate-gaps 200` on a box logging every 195 min at best, with gaps up to 38 h,
    `check` repeated the advice) but says the gaps it left are longer.
    """
    what = "a required column" if canonical.startswith(("T_", "m_")) else "an optional column"
    bridge = (
        f"--interpolate-gaps {interpolated:g} bridged the gaps up to {interpolated:g} min and left these: the sensor "
        "is silent for longer than that, and bridging longer gaps would invent its values"
        if interpolated
        else f"a sensor logging thinly all along: {_BRIDGE}"
    )
    return (
        f"column {name!r}"
        + (f" ({canonical})" if name != canonical else "")
        + f": a value in only {100 * coverage:.1f} % of the model steps, below the {100 * threshold:g} % that "
        f"fitting and evaluation need ({what}); trim the file to the span the sensor covers, fix the export"
        + ("" if what.startswith("a required") else ", or drop the column")
        + f"; {bridge}"
    )


#: The fix for a column whose samples are spread thinly over the whole span (change-of-value logging, or a
#: box that answers every ~12 min in a 1-minute file): each model step has too few of the file's samples.
_BRIDGE = "bridge its samples with --interpolate-gaps MINUTES (a little over its spacing)"


def option_problems(step, train_fraction=0.9, interpolate_limit=None, min_coverage=MIN_COVERAGE) -> list[str]:
    """Problems of the numeric options of :func:`prepare` (empty if fine), each naming the option and the fix."""
    problems = []
    ok_step = isinstance(step, numbers.Real) and np.isfinite(step) and step > 0
    if not ok_step or abs(step - round(step)) > 1e-9 or 3600 % round(step):
        problems.append(
            f"step {step!r} s: the model step must be a positive whole number of seconds dividing one hour "
            "(e.g. 300, 600, 900, 1800, 3600)"
        )
    if not (isinstance(train_fraction, numbers.Real) and 0 < train_fraction <= 1):
        problems.append(f"train_fraction {train_fraction!r}: must be in (0, 1], e.g. 0.9")
    if interpolate_limit is not None and not (
        isinstance(interpolate_limit, numbers.Real) and np.isfinite(interpolate_limit) and interpolate_limit >= 0
    ):
        problems.append(f"interpolate gaps {interpolate_limit!r} min: must be a number of minutes >= 0")
    if not (isinstance(min_coverage, numbers.Real) and 0 < min_coverage <= 1):
        problems.append(f"min_coverage {min_coverage!r}: must be in (0, 1], e.g. 0.5")
    return problems


def _prepare(path, building, step, seed, train_fraction, interpolate_limit, min_coverage, loaded=None, progress=False):
    problems = option_problems(step, train_fraction, interpolate_limit, min_coverage)
    if problems:
        raise DataError(problems_message("Cannot prepare the data with these options", problems))
    building = as_building(building)
    with Progress(total=4, desc=f"data {Path(path).name}", unit="stage", enabled=progress) as bar:
        if loaded is None:
            raw, report = load_measurements(path, building)
        else:
            raw, report = loaded
        bar.update(note="gaps")
        label = Path(path).name
        notes = list(report.warnings) + [f"{label}: {n}" for n in building_notes(building)]
        column_steps = dict(report.column_steps)
        if interpolate_limit is not None:
            before = int(np.isfinite(raw.to_numpy()).sum())
            raw = interpolate_gaps(raw, interpolate_limit, report.native_step)
            filled = int(np.isfinite(raw.to_numpy()).sum()) - before
            notes.append(
                f"interpolated {filled} missing value(s) linearly in gaps of at most {interpolate_limit:g} min"
            )
        bar.update(note="resampling")
        frame, coverage = resample(raw, step, min_coverage=min_coverage, column_steps=column_steps)
        coarse = [c for c, s in column_steps.items() if s and s > step * (1 + 1e-9)]
        if coarse:
            notes.append(
                f"column(s) {', '.join(coarse)} sampled more coarsely than the {step:g} s step: "
                "interpolated linearly to the step midpoints"
            )
        sparse = sparse_columns(frame)
        notes += [
            sparse_message(building.column_for(c), c, cov, interpolated=interpolate_limit) for c, cov in sparse.items()
        ]
        notes += check_discharge(frame, building)
        notes += [f"{label}: {n}" for n in check_roles(frame, building) + check_supply_assignment(frame, building)]
        bar.update(note="solar and weeks")
        dataset = Dataset.from_frame(
            frame,
            building,
            step=step,
            seed=seed,
            train_fraction=train_fraction,
            source=str(Path(path)),
            sha256=file_sha256(path),
            warnings_=notes,
            coverage=coverage,
            load_report=report,
        )
        # on the finished frame: facade irradiance belongs to the baseline the boxes' heat is weighed against
        dataset.warnings.extend(f"{label}: {n}" for n in check_box_zones(dataset.frame, building))
        zone_swaps = check_zone_swaps(dataset.frame, building)
        dataset.warnings.extend(f"{label}: {n}" for n in zone_swaps)
        if not zone_swaps:  # swapped zone columns make boxes prefer other boxes' discharge air too: fix them first
            dataset.warnings.extend(f"{label}: {n}" for n in check_discharge_swaps(dataset.frame, building))
        bar.update()
    return dataset


__all__ = [
    "MIN_COLUMN_COVERAGE",
    "Dataset",
    "Week",
    "file_sha256",
    "make_weeks",
    "prepare",
    "primary_supply",
    "sparse_columns",
]
