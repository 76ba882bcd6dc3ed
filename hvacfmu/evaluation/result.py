"""Results of the evaluation protocol: scores per model, the whole result, week trajectories."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pandas as pd

from .verdict import Verdict

#: Names of the baselines, in table order.
BASELINES = ("persistence", "time-of-week mean")


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
    hourly : dict or None
        Sums over the hourly means of all windows for ASHRAE Guideline 14 (see
        :func:`hvacfmu.evaluation.protocol.hourly_statistics`).
    residuals : DataFrame or None
        Measured minus predicted [K] at every window step (rows: time; columns: outputs; NaN
        where the output was not measured).
    observed : array of bool (W, N, ny)
        The steps each window's errors count (the output was measured); the model and both
        baselines are scored on exactly these.
    filled_inputs : array (W,) [-]
        Share of each window's steps at which an input of the model was filled by interpolation.
    skipped_windows : list of (pandas.Timestamp, str, str)
        Midnight, season and reason of each skipped window.
    rules : dict
        The coverage rules applied (``fill_inputs_h``, ``min_output_share``, ...), see
        :mod:`hvacfmu.evaluation.windows`.
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
    hourly: dict | None = dataclasses.field(default=None, repr=False, compare=False)
    residuals: pd.DataFrame | None = dataclasses.field(default=None, repr=False, compare=False)
    observed: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)
    filled_inputs: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)
    skipped_windows: list = dataclasses.field(default_factory=list, repr=False)
    rules: dict = dataclasses.field(default_factory=dict, repr=False)

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
            in_s = seasons == s
            rows[s] = np.nanmean(R[in_s], axis=0) if np.any(in_s) else np.full(len(self.outputs), np.nan)
        if len(self.seasons):
            rows["all"] = np.nanmean(R, axis=0)
        df = pd.DataFrame.from_dict(rows, orient="index", columns=list(self.outputs))
        df["mean"] = df[list(self.outputs)].mean(axis=1)
        df.index.name = "season"
        return df

    def n_windows(self) -> dict:
        """Evaluated windows per season."""
        return {s: int(self.seasons.count(s)) for s in dict.fromkeys(self.seasons)}

    def by_season(self, season_order=()) -> dict:
        """Per season: ``scored`` windows and ``skipped`` windows by reason (only non-zero reasons)."""
        out: dict = {}
        order = [s for s in season_order if s in set(self.seasons) | {s for _, s, _ in self.skipped_windows}]
        for s in order + [s for s in dict.fromkeys(self.seasons) if s not in order]:
            out[s] = {"scored": 0, "skipped": {}}
        for s in self.seasons:
            out[s]["scored"] += 1
        for _, s, why in self.skipped_windows:
            d = out.setdefault(s, {"scored": 0, "skipped": {}})["skipped"]
            d[why] = d.get(why, 0) + 1
        return out

    def coverage_line(self, season_order=()) -> str:
        """``fall 5 scored, 2 skipped (2 input gap longer than 2 h); winter ...`` and the inputs filled."""
        parts = []
        for s, d in self.by_season(season_order).items():
            n_skip = sum(d["skipped"].values())
            why = f" ({', '.join(f'{v} {k}' for k, v in d['skipped'].items())})" if n_skip else ""
            parts.append(f"{s} {d['scored']} scored, {n_skip} skipped{why}")
        text = "; ".join(parts) or "no window"
        if self.filled_inputs is not None and len(self.filled_inputs) and self.filled_inputs.max() > 0:
            text += (
                f"; inputs filled by interpolation (gaps up to {self.rules.get('fill_inputs_h', 0):g} h): "
                f"{100 * float(np.mean(self.filled_inputs)):.1f} % of the steps of the scored windows"
            )
        return text


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
    verdict : Verdict or None
        Per zone against persistence and the time-of-week mean, ASHRAE Guideline 14 hourly
        NMBE / CV(RMSE), and the likely causes where a model loses to persistence.
    """

    scores: list
    horizon: int
    step: float
    season_order: tuple
    notes: list
    data_sha256: str | None = None
    models: list = dataclasses.field(default_factory=list, repr=False)
    verdict: Verdict | None = None

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
    def format(self, digits: int = 3) -> str:
        """The verdict first (losing zones and their likely causes on top), then the RMS tables."""
        head = self.verdict.format() + "\n\n" if self.verdict is not None else ""
        return head + self.format_table(digits)

    def format_table(self, digits: int = 3) -> str:
        """The paper's Table I for each model and both baselines, as text."""
        out = [
            f"24-hour open-loop prediction RMS [K] on held-out weeks (horizon {self.horizon} steps of {self.step:g} s)"
        ]
        shown = []
        for sc in self.scores:
            n = sc.n_windows()
            skipped = ", ".join(f"{v} {k}" for k, v in sc.skipped.items() if v) or "none"
            out.append("")
            out.append(
                f"== {sc.name} ({sc.kind}): {sum(n.values())} windows "
                f"({', '.join(f'{s} {k}' for s, k in n.items())}); skipped: {skipped}"
            )
            if sc.skipped_windows or (sc.filled_inputs is not None and np.any(sc.filled_inputs > 0)):
                out.append(f"   per season: {sc.coverage_line(self.season_order)}")
            out.append(_format_df(sc.table("model", self.season_order), digits))
            key = (sc.outputs, tuple(sc.starts), _mask_key(sc.observed))
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
        return self.format()

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
                    "by_season": sc.by_season(self.season_order),
                    "rules": dict(sc.rules),
                    "windows": [
                        {
                            "start": t.isoformat(),
                            "season": s,
                            "week": int(w),
                            "rms": [_num(x) for x in sc.rms[i]],
                            "observed_steps": [int(x) for x in sc.observed[i].sum(axis=0)]
                            if sc.observed is not None and len(sc.observed)
                            else None,
                            "filled_inputs": _num(sc.filled_inputs[i])
                            if sc.filled_inputs is not None and len(sc.filled_inputs)
                            else None,
                            **{b: [_num(x) for x in sc.baselines[b][i]] for b in BASELINES},
                        }
                        for i, (t, s, w) in enumerate(zip(sc.starts, sc.seasons, sc.weeks))
                    ],
                }
            )
        return {
            "verdict": self.verdict.to_dict() if self.verdict is not None else None,
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
                    rec = {
                        "model": sc.name,
                        "kind": sc.kind,
                        "season": s,
                        "week": w,
                        "start": t,
                        "output": o,
                        "rms": sc.rms[i, j],
                    }
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
        from .trajectory import choose_week, week_trajectory

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        files = []
        for sc in self.scores:
            files.append(plots.plot_rms_table(sc, folder / f"rms_{_slug(sc.name)}.png", self.season_order, BASELINES))
        if dataset is not None and self.models:
            wk = choose_week(dataset, week)
            if wk is not None:
                trajs = [week_trajectory(m, dataset, wk, name=sc.name) for m, sc in zip(self.models, self.scores)]
                files.append(plots.plot_week_trajectories(trajs, folder / f"week_{wk.number}.png"))
        return files


def _mask_key(observed):
    """A hashable summary of the observed steps (baselines are shared only on identical masks)."""
    return None if observed is None else (observed.shape, np.packbits(observed).tobytes())


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
        lines.append(
            str(s).ljust(sw)
            + "".join((f"{v:.{digits}f}" if np.isfinite(v) else "n/a").rjust(width + 1) for v in row.to_numpy(float))
        )
    return "\n".join(lines)
