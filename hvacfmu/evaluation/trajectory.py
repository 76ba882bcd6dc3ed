"""Open-loop trajectories over a whole test week (the paper's Fig. 5) and the choice of that week."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from ..errors import DataError
from ..models.base import season_model


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
    part_u, part_v = u.iloc[k0 : e - 1], v.iloc[k0 : e - 1]
    filled = int(part_u.isna().to_numpy().sum() + part_v.isna().to_numpy().sum())
    part_u, part_v = part_u.ffill().bfill().to_numpy(), part_v.ffill().bfill().to_numpy()
    run = season_model(model, week.season)  # a model with one coefficient set per season runs the week's
    q = np.asarray(run.gains_at(idx[k0 : e - 1], week.season), float)
    _, Yp = run.simulate(x0, part_u, part_v, q)
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


def choose_week(dataset, week):
    """The week to draw: ``week`` (a Week or its number), else the first spring test week, else the first."""
    if week is not None:
        if isinstance(week, (int, np.integer)):
            found = next((w for w in dataset.weeks if w.number == int(week)), None)
            if found is None:
                numbers = [w.number for w in dataset.weeks]
                raise DataError(
                    f"no week {int(week)} in the dataset; weeks are numbered {min(numbers)}..{max(numbers)}"
                    if numbers
                    else "the dataset has no week"
                )
            return found
        return week
    tests = dataset.test_weeks()
    spring = [w for w in tests if w.season == "spring"]
    return (spring or list(tests) or [None])[0]
