"""The evaluation protocol every model is judged by: 24-hour open-loop RMS on held-out weeks.

On each held-out test week, an open-loop prediction of ``horizon`` steps (96 =
24 h at 15 minutes) starts at every local midnight from
``model.initial_state(frame, k0)``, driven by the measured inputs ``u``,
disturbances ``v`` and the season's internal-gain profile. Each window gets the
RMS error of eq. (RMS) of the paper,

    RMS = ( 1/N sum_{k=1..N} (y_measured(k) - y_predicted(k))^2 )^(1/2),

per output; RMS values are averaged by output and season (the paper's Table I).
Windows with any missing value (measured outputs over the window, inputs or
disturbances over the horizon, or a non-finite initial state) are skipped and
counted.

Two baselines are scored on exactly the same windows and outputs:

- ``persistence``: the output at the window's start held for 24 h;
- ``time-of-week mean``: the mean measured output of the season's training
  weeks at the same time of week.

Only the :class:`~hvacfmu.models.base.ZoneModel` interface is used
(``measured_outputs``, ``signals``, ``gains_at``, ``initial_state``,
``simulate``), so every model kind plugs in unchanged.

References
----------
D. Zhou, Q. Hu, C. J. Tomlin, "Model comparison of a data-driven and a physical
model for simulating HVAC systems", eq. (RMS), Table I and section V-A.
"""

from __future__ import annotations

import dataclasses
import json
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from .errors import DataError, HvacfmuWarning, problems_message
from .timeutil import n_time_of_week, time_of_week

#: Names of the baselines, in table order.
BASELINES = ("persistence", "time-of-week mean")


# =============================================================================
# layer 1: arrays
# =============================================================================
def window_rms(measured, predicted):
    """RMS error per window and output, eq. (RMS).

    Parameters
    ----------
    measured, predicted : arrays (W, N, ny) [°C]
        Values at steps k = 1..N of each window.

    Returns
    -------
    array (W, ny) [K]
    """
    e = np.asarray(measured, float) - np.asarray(predicted, float)
    return np.sqrt(np.mean(e * e, axis=-2))


def time_of_week_profile(y, slots, n_slots):
    """Mean of ``y`` (n, ny) per time-of-week slot; empty slots interpolated around the week.

    Returns
    -------
    profile : array (n_slots, ny)
    coverage : float
        Fraction of slots with data before filling (0 means the profile is all NaN).
    """
    from .models.datadriven import estimate_gains

    return estimate_gains(y, slots, n_slots)


# =============================================================================
# results
# =============================================================================
@dataclasses.dataclass
class ModelScore:
    """Scores of one model on the test windows.

    Attributes
    ----------
    name, kind : str
    outputs : tuple of str
        Output names (zones, or ``("floor",)``).
    starts : list of pandas.Timestamp
        Start (local midnight) of each evaluated window.
    seasons : list of str
        Season of each window (its test week's season).
    weeks : list of int
        Week number of each window.
    rms : array (W, ny) [K]
        Model RMS per window and output.
    baselines : dict name -> array (W, ny) [K]
        Baseline RMS on the same windows (NaN where a baseline is undefined).
    skipped : dict reason -> int
        Windows not evaluated, by reason.
    """

    name: str
    kind: str
    outputs: tuple
    starts: list
    seasons: list
    weeks: list
    rms: np.ndarray
    baselines: dict
    skipped: dict

    def table(self, which: str = "model", season_order=None) -> pd.DataFrame:
        """Table I: rows seasons (+ ``all``), columns outputs + ``mean`` [K].

        ``which`` is ``"model"`` or a baseline name.
        """
        R = self.rms if which == "model" else self.baselines[which]
        seasons = np.asarray(self.seasons, dtype=object)
        order = [s for s in (season_order or []) if s in set(self.seasons)]
        order += [s for s in dict.fromkeys(self.seasons) if s not in order]
        rows = {}
        for s in order:
            rows[s] = np.nanmean(R[seasons == s], axis=0) if np.any(seasons == s) else np.full(len(self.outputs), np.nan)
        if len(self.seasons):
            rows["all"] = np.nanmean(R, axis=0)
        df = pd.DataFrame.from_dict(rows, orient="index", columns=list(self.outputs))
        df["mean"] = df[list(self.outputs)].mean(axis=1)
        df.index.name = "season"
        return df

    def n_windows(self) -> dict:
        """Evaluated windows per season."""
        return {s: int(self.seasons.count(s)) for s in dict.fromkeys(self.seasons)}


@dataclasses.dataclass
class EvaluationResult:
    """Outcome of :func:`evaluate`.

    Attributes
    ----------
    scores : list of ModelScore
    horizon : int
        Prediction horizon [steps].
    step : float [s]
    season_order : tuple of str
        The building's season order (for tables).
    notes : list of str
        Everything a reader should know (seasons without test weeks, skips).
    data_sha256 : str or None
    models : list
        The evaluated models (not serialised), for :meth:`plot`.
    """

    scores: list
    horizon: int
    step: float
    season_order: tuple
    notes: list
    data_sha256: str | None = None
    models: list = dataclasses.field(default_factory=list, repr=False)

    def score(self, name: str) -> ModelScore:
        for s in self.scores:
            if s.name == name:
                return s
        raise KeyError(f"no model named {name!r}; have {[s.name for s in self.scores]}")

    def table(self, name: str | None = None, which: str = "model") -> pd.DataFrame:
        """Table I of model ``name`` (default: the first) or of one of its baselines."""
        sc = self.scores[0] if name is None else self.score(name)
        return sc.table(which, self.season_order)

    # --- text ----------------------------------------------------------
    def format_table(self, digits: int = 3) -> str:
        """The paper's Table I for each model and both baselines, as text."""
        out = [f"24-hour open-loop prediction RMS [K] on held-out weeks "
               f"(horizon {self.horizon} steps of {self.step:g} s)"]
        shown = []
        for sc in self.scores:
            n = sc.n_windows()
            skipped = ", ".join(f"{v} {k}" for k, v in sc.skipped.items() if v) or "none"
            out.append("")
            out.append(f"== {sc.name} ({sc.kind}): {sum(n.values())} windows "
                       f"({', '.join(f'{s} {k}' for s, k in n.items())}); skipped: {skipped}")
            out.append(_format_df(sc.table("model", self.season_order), digits))
            key = (sc.outputs, tuple(sc.starts))
            if key in shown:
                out.append("(baselines as above: same outputs and windows)")
                continue
            shown.append(key)
            for b in BASELINES:
                out.append(f"-- baseline: {b}")
                out.append(_format_df(sc.table(b, self.season_order), digits))
        if self.notes:
            out.append("")
            out += [f"note: {n}" for n in self.notes]
        return "\n".join(out)

    def __str__(self):
        return self.format_table()

    # --- data ----------------------------------------------------------
    def to_dict(self) -> dict:
        """JSON-ready mapping: tables, baselines, window counts, per-window RMS, notes."""

        def tab(df):
            return {s: {c: _num(v) for c, v in row.items()} for s, row in df.iterrows()}

        models = []
        for sc in self.scores:
            models.append(
                {
                    "name": sc.name,
                    "kind": sc.kind,
                    "outputs": list(sc.outputs),
                    "table": tab(sc.table("model", self.season_order)),
                    "baselines": {b: tab(sc.table(b, self.season_order)) for b in BASELINES},
                    "n_windows": sc.n_windows(),
                    "skipped": dict(sc.skipped),
                    "windows": [
                        {
                            "start": t.isoformat(),
                            "season": s,
                            "week": int(w),
                            "rms": [_num(x) for x in sc.rms[i]],
                            **{b: [_num(x) for x in sc.baselines[b][i]] for b in BASELINES},
                        }
                        for i, (t, s, w) in enumerate(zip(sc.starts, sc.seasons, sc.weeks))
                    ],
                }
            )
        return {
            "horizon": int(self.horizon),
            "step": float(self.step),
            "unit": "K",
            "data_sha256": self.data_sha256,
            "models": models,
            "notes": list(self.notes),
        }

    def save_json(self, path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_dict(), indent=1, allow_nan=False), encoding="utf-8")
        return path

    def to_pandas(self) -> pd.DataFrame:
        """Long table, one row per (model, window, output): RMS of the model and the baselines [K]."""
        recs = []
        for sc in self.scores:
            for i, (t, s, w) in enumerate(zip(sc.starts, sc.seasons, sc.weeks)):
                for j, o in enumerate(sc.outputs):
                    rec = {"model": sc.name, "kind": sc.kind, "season": s, "week": w, "start": t,
                           "output": o, "rms": sc.rms[i, j]}
                    rec.update({b: sc.baselines[b][i, j] for b in BASELINES})
                    recs.append(rec)
        cols = ["model", "kind", "season", "week", "start", "output", "rms", *BASELINES]
        return pd.DataFrame.from_records(recs, columns=cols)

    # --- figures -------------------------------------------------------
    def plot(self, folder, dataset=None, week=None) -> list:
        """Write figures (PNG, matplotlib Agg) into ``folder``; returns the paths.

        - ``rms_<model>.png``: RMS by season and output, model vs baselines;
        - ``week_<n>.png``: 7-day open-loop trajectories of every model on a
          test week (``week``: a :class:`~hvacfmu.data.Week` or week number;
          default: the first spring test week, else the first test week),
          when ``dataset`` is given.
        """
        from . import plots

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        files = []
        for sc in self.scores:
            files.append(plots.plot_rms_table(sc, folder / f"rms_{_slug(sc.name)}.png", self.season_order))
        if dataset is not None and self.models:
            wk = _choose_week(dataset, week)
            if wk is not None:
                trajs = [week_trajectory(m, dataset, wk, name=sc.name) for m, sc in zip(self.models, self.scores)]
                files.append(plots.plot_week_trajectories(trajs, folder / f"week_{wk.number}.png"))
        return files


@dataclasses.dataclass
class Trajectory:
    """An open-loop trajectory over a week, for plots (``week_trajectory``).

    Attributes
    ----------
    name : str
    outputs : tuple of str
    index : DatetimeIndex
    measured, predicted : arrays (n, ny) [°C]
    season : str
    week : int
    filled : int
        Input/disturbance values that were missing and held at their last value.
    """

    name: str
    outputs: tuple
    index: pd.DatetimeIndex
    measured: np.ndarray
    predicted: np.ndarray
    season: str
    week: int
    filled: int = 0

    def rms(self) -> np.ndarray:
        """RMS error over the whole trajectory per output [K] (NaN-aware)."""
        e = self.measured[1:] - self.predicted[1:]
        return np.sqrt(np.nanmean(e * e, axis=0))

    def to_pandas(self) -> pd.DataFrame:
        cols = {f"measured_{o}": self.measured[:, j] for j, o in enumerate(self.outputs)}
        cols.update({f"predicted_{o}": self.predicted[:, j] for j, o in enumerate(self.outputs)})
        return pd.DataFrame(cols, index=self.index)


# =============================================================================
# layer 2: the protocol
# =============================================================================
def evaluate(model_or_models, dataset, horizon: int = 96, names=None) -> EvaluationResult:
    """Score models by 24-hour open-loop prediction RMS on the held-out test weeks.

    Parameters
    ----------
    model_or_models : ZoneModel or sequence of ZoneModel
    dataset : hvacfmu.data.Dataset
        Its test weeks are evaluated; its training weeks feed the
        time-of-week-mean baseline.
    horizon : int
        Prediction horizon N [steps] (96 = 24 h at 15 minutes).
    names : sequence of str, optional
        Labels of the models (default: ``meta["name"]`` or the kind, made unique).

    Returns
    -------
    EvaluationResult

    Raises
    ------
    DataError
        If no window of any model could be evaluated (every reason listed).

    Warns
    -----
    HvacfmuWarning
        For seasons without a test week and models that cannot predict a season.
    """
    from .models.base import ZoneModel

    models = list(model_or_models) if isinstance(model_or_models, (list, tuple)) else [model_or_models]
    if not models:
        raise ValueError("no model to evaluate")
    for m in models:
        if not isinstance(m, ZoneModel):
            raise TypeError(f"expected ZoneModel instances, got {type(m).__name__}")
    horizon = int(horizon)
    if horizon < 1:
        raise ValueError(f"horizon must be at least one step, got {horizon}")
    step = float(dataset.step)
    for m in models:
        if abs(float(m.step) - step) > 1e-9:
            raise DataError(f"model step {m.step} s differs from the dataset step {step} s; prepare the data with --step {m.step:g}")
    names = _model_names(models, names)
    frame = dataset.frame
    b = dataset.building
    notes = []
    test_weeks = dataset.test_weeks()
    seasons_with_data = [s for s in b.season_names if any(w.season == s for w in dataset.weeks)]
    for s in seasons_with_data:
        if not any(w.season == s for w in test_weeks):
            notes.append(f"season {s} has no test week (too few weeks); it is not evaluated")
    for n in notes:
        warnings.warn(n, HvacfmuWarning, stacklevel=2)
    if not test_weeks:
        raise DataError("the dataset has no test week: nothing to evaluate (need at least two weeks in a season)")
    starts = _window_starts(frame.index, test_weeks)
    scores = []
    failures = []
    for model, name in zip(models, names):
        sc, more = _score_model(model, name, dataset, starts, horizon)
        notes += more
        scores.append(sc)
        if not sc.starts:
            failures.append(f"{name}: " + (", ".join(f"{v} {k}" for k, v in sc.skipped.items() if v) or "no windows"))
    if len(failures) == len(scores):
        raise DataError(problems_message("No test window could be evaluated", failures))
    return EvaluationResult(
        scores=scores,
        horizon=horizon,
        step=step,
        season_order=tuple(b.season_names),
        notes=notes,
        data_sha256=getattr(dataset, "sha256", None),
        models=models,
    )


def _window_starts(index, weeks):
    """(week, local midnight) pairs: every midnight of every test week."""
    out = []
    for w in weeks:
        tz = w.start.tz
        day0 = w.start.tz_localize(None)
        for d in range(7):
            t = (day0 + pd.Timedelta(days=d)).tz_localize(tz, nonexistent="shift_forward", ambiguous=False)
            if t < w.end:
                out.append((w, t))
    return out


def _score_model(model, name, dataset, starts, horizon):
    frame = dataset.frame
    idx = frame.index
    n = len(frame)
    N = horizon
    Y = np.asarray(model.measured_outputs(frame), float)
    u, v = (np.asarray(a, float) for a in model.signals(frame))
    ny = Y.shape[1]
    okY = np.all(np.isfinite(Y), axis=1)
    okUV = np.all(np.isfinite(u), axis=1) & np.all(np.isfinite(v), axis=1)
    # windows with all data: prefix sums of bad rows
    badY = np.r_[0, np.cumsum(~okY)]
    badUV = np.r_[0, np.cumsum(~okUV)]
    skipped = {"missing data": 0, "window past the end of the data": 0, "no internal-gain profile for season": 0,
               "no row at midnight": 0}
    notes = []
    keep = []  # (week, t, k0)
    no_profile = set()
    for w, t in starts:
        k0 = idx.get_indexer([t])[0]
        if k0 < 0:
            skipped["no row at midnight"] += 1
            continue
        if k0 + N >= n:
            skipped["window past the end of the data"] += 1
            continue
        if badY[k0 + N + 1] - badY[k0] or badUV[k0 + N] - badUV[k0]:
            skipped["missing data"] += 1
            continue
        if w.season not in getattr(model, "gains", {}):
            skipped["no internal-gain profile for season"] += 1
            no_profile.add(w.season)
            continue
        keep.append((w, t, k0))
    for s in sorted(no_profile):
        msg = f"{name}: no internal-gain profile for season {s} (no training data in it); its test windows are skipped"
        notes.append(msg)
        warnings.warn(msg, HvacfmuWarning, stacklevel=3)
    x0 = []
    final = []
    for w, t, k0 in keep:
        x = np.asarray(model.initial_state(frame, k0), float)
        if not np.all(np.isfinite(x)):
            skipped["missing data"] += 1
            continue
        x0.append(x)
        final.append((w, t, k0))
    W = len(final)
    rms = np.empty((W, ny))
    base = {b: np.full((W, ny), np.nan) for b in BASELINES}
    if W:
        k0s = np.array([k for _, _, k in final])
        rng = k0s[:, None] + np.arange(N)[None, :]  # (W, N) rows k0..k0+N-1
        q = np.stack([np.asarray(model.gains_at(idx[r], w.season), float) for (w, _, _), r in zip(final, rng)])
        _, Yp = model.simulate(np.stack(x0), u[rng], v[rng], q)
        meas = Y[rng + 1]  # (W, N, ny) at k = 1..N
        rms = window_rms(meas, Yp[:, 1:, :])
        rms[~np.isfinite(rms)] = np.inf  # a diverging model must show, not vanish from the means
        base["persistence"] = window_rms(meas, np.broadcast_to(Y[k0s][:, None, :], meas.shape))
        base["time-of-week mean"] = _tow_baseline(dataset, Y, final, rng, notes, name)
    total_skipped = sum(skipped.values())
    if total_skipped:
        notes.append(f"{name}: {total_skipped} of {len(starts)} windows skipped ("
                     + ", ".join(f"{v} {k}" for k, v in skipped.items() if v) + ")")
    sc = ModelScore(
        name=name,
        kind=str(getattr(model, "kind", type(model).__name__)),
        outputs=tuple(model.outputs),
        starts=[t for _, t, _ in final],
        seasons=[w.season for w, _, _ in final],
        weeks=[w.number for w, _, _ in final],
        rms=rms,
        baselines=base,
        skipped=skipped,
    )
    return sc, notes


def _tow_baseline(dataset, Y, final, rng, notes, name):
    """RMS of the seasonal time-of-week mean of the training weeks, on the given windows."""
    idx = dataset.frame.index
    step = float(dataset.step)
    n_slots = n_time_of_week(step)
    slots = time_of_week(idx, step)
    week_of_row = np.full(len(idx), -1)
    train_season = np.full(len(idx), None, dtype=object)
    for w in dataset.weeks:
        a, e = idx.searchsorted(w.start), idx.searchsorted(w.end)
        week_of_row[a:e] = w.number
        if w.train:
            train_season[a:e] = w.season
    profiles = {}
    out = np.full((len(final), Y.shape[1]), np.nan)
    for i, ((w, _, _), r) in enumerate(zip(final, rng)):
        s = w.season
        if s not in profiles:
            sel = train_season == s
            prof, cov = time_of_week_profile(Y[sel], slots[sel], n_slots) if sel.any() else (None, 0.0)
            if cov == 0.0:
                prof = None
                notes.append(f"{name}: season {s} has no training data, so no time-of-week-mean baseline")
            profiles[s] = prof
        prof = profiles[s]
        if prof is not None:
            out[i] = window_rms(Y[r + 1][None], prof[slots[r + 1]][None])[0]
    return out


def week_trajectory(model, dataset, week, name=None) -> Trajectory:
    """Open-loop simulation over a whole week (7 days), as in the paper's Fig. 5.

    Starts from ``model.initial_state(frame, k0)`` at the week's first row
    (or the first row with a finite initial state) and runs open loop to the
    week's end with the measured inputs and disturbances and the season's
    internal-gain profile. Missing inputs/disturbances are held at their last
    value (counted in ``Trajectory.filled``).

    Parameters
    ----------
    model : ZoneModel
    dataset : hvacfmu.data.Dataset
    week : hvacfmu.data.Week or int
        The week or its number.
    name : str, optional

    Returns
    -------
    Trajectory
    """
    if isinstance(week, (int, np.integer)):
        match = [w for w in dataset.weeks if w.number == int(week)]
        if not match:
            raise DataError(f"no week number {week}; the dataset has weeks 0..{len(dataset.weeks) - 1}")
        week = match[0]
    frame = dataset.frame
    idx = frame.index
    a, e = idx.searchsorted(week.start), idx.searchsorted(week.end)
    if e - a < 2:
        raise DataError(f"week {week.number} ({week.start.date()}) has no data rows")
    Y = np.asarray(model.measured_outputs(frame), float)
    k0 = None
    for k in range(a, e - 1):
        x0 = np.asarray(model.initial_state(frame, k), float)
        if np.all(np.isfinite(x0)):
            k0 = k
            break
    if k0 is None:
        raise DataError(f"week {week.number}: no row with a complete initial state")
    u, v = (pd.DataFrame(np.asarray(z, float)) for z in model.signals(frame))
    part_u, part_v = u.iloc[k0:e - 1], v.iloc[k0:e - 1]
    filled = int(part_u.isna().to_numpy().sum() + part_v.isna().to_numpy().sum())
    part_u, part_v = part_u.ffill().bfill().to_numpy(), part_v.ffill().bfill().to_numpy()
    q = np.asarray(model.gains_at(idx[k0:e - 1], week.season), float)
    _, Yp = model.simulate(x0, part_u, part_v, q)
    return Trajectory(
        name=name or str(getattr(model, "kind", "model")),
        outputs=tuple(model.outputs),
        index=idx[k0:e],
        measured=Y[k0:e],
        predicted=np.asarray(Yp),
        season=week.season,
        week=week.number,
        filled=filled,
    )


# =============================================================================
# helpers
# =============================================================================
def _choose_week(dataset, week):
    if week is not None:
        if isinstance(week, (int, np.integer)):
            found = next((w for w in dataset.weeks if w.number == int(week)), None)
            if found is None:
                numbers = [w.number for w in dataset.weeks]
                raise DataError(f"no week {int(week)} in the dataset; weeks are numbered "
                                f"{min(numbers)}..{max(numbers)}" if numbers else "the dataset has no week")
            return found
        return week
    tests = dataset.test_weeks()
    spring = [w for w in tests if w.season == "spring"]
    return (spring or list(tests) or [None])[0]


def _model_names(models, names):
    if names is not None:
        names = [str(n) for n in names]
        if len(names) != len(models) or len(set(names)) != len(names):
            raise ValueError("names must be unique, one per model")
        return names
    out = []
    for m in models:
        base = str((getattr(m, "meta", None) or {}).get("name") or getattr(m, "kind", type(m).__name__))
        nm, i = base, 2
        while nm in out:
            nm, i = f"{base}-{i}", i + 1
        out.append(nm)
    return out


def _num(x):
    x = float(x)
    return x if np.isfinite(x) else None


def _slug(s):
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in s)


def _format_df(df: pd.DataFrame, digits: int) -> str:
    cols = [str(c) for c in df.columns]
    width = max(7, digits + 4, *(len(c) for c in cols))
    sw = max(6, *(len(str(i)) for i in df.index)) if len(df) else 6
    lines = ["season".ljust(sw) + "".join(c.rjust(width + 1) for c in cols)]
    for s, row in df.iterrows():
        lines.append(str(s).ljust(sw) + "".join(
            (f"{v:.{digits}f}" if np.isfinite(v) else "n/a").rjust(width + 1) for v in row.to_numpy(float)))
    return "\n".join(lines)


__all__ = [
    "BASELINES",
    "EvaluationResult",
    "ModelScore",
    "Trajectory",
    "evaluate",
    "time_of_week_profile",
    "week_trajectory",
    "window_rms",
]
