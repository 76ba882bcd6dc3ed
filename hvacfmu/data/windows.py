"""Which 24-hour test windows are scored, and on which steps: the coverage rules of the protocol.

(In the data layer so that the evaluation and a model's own cross-validation, e.g. the physics model's
``gain_days = "auto"``, apply the same rules; :mod:`hvacfmu.evaluation.windows` is its public name.)

Real BMS exports have outages (a logger down for minutes to hours, rows dropped). Skipping
every window with one missing value leaves a verdict that rests on a few days of one season,
so a window is scored under these stated rules:

1. **Inputs** (airflows, discharge and supply temperatures, weather, irradiance: every column
   except the zone temperatures) are filled for the simulation by linear interpolation in time
   across gaps of at most ``fill_inputs_h`` hours (:data:`FILL_INPUTS_H`, default 2 h). A filled
   input can only make the model worse (the baselines use no inputs), so filling is
   conservative; it is bounded because a long gap's guess is no longer a measurement. A window
   whose inputs still miss a value after filling is skipped ("input gap longer than ... h").
2. **Initial state**: the zone temperatures must be measured at the window's start, local
   midnight; where one is missing the window starts at the first step within
   :data:`START_SHIFT_MAX_H` (1 h) where all are, and keeps its horizon. Otherwise it is
   skipped ("outputs not measured in the first hour").
3. **Outputs are never filled**: errors are computed only on the steps whose measured output
   exists, and the window is skipped when an output is measured in fewer than
   ``min_output_share`` (:data:`MIN_OUTPUT_SHARE`, 75 %) of its steps.
4. Persistence and the time-of-week mean are scored on exactly the same steps (the same mask)
   as the model.

Zone temperatures are filled neither for the simulation nor for the scores, also when a model
reads a neighbour's temperature as a disturbance.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from ..errors import DataError
from .resample import interpolate_gaps

#: Longest gap of an input filled by linear interpolation in time for the simulation [h]
FILL_INPUTS_H = 2.0
#: A window is scored only when every output is measured in at least this share of its steps [-]
MIN_OUTPUT_SHARE = 0.75
#: Latest start of a window whose zone temperatures are not all measured at midnight [h]
START_SHIFT_MAX_H = 1.0


def skip_reasons(fill_inputs_h: float, min_output_share: float) -> tuple:
    """The reasons a window is skipped, in the order they are checked."""
    return (
        "no row at midnight",
        f"outputs not measured in the first {START_SHIFT_MAX_H:g} h",
        "window past the end of the data",
        f"an output measured in under {100 * min_output_share:g} % of the steps",
        f"input gap longer than {fill_inputs_h:g} h" if fill_inputs_h > 0 else "input gap (inputs not filled)",
        "no internal-gain profile for season",
        "no finite initial state",
    )


@dataclasses.dataclass(frozen=True)
class FilledFrame:
    """A dataset frame with its input columns gap-filled for simulation.

    Attributes
    ----------
    frame : DataFrame
        The dataset's frame; every column except the zone temperatures interpolated in time
        across gaps of at most ``limit_h`` hours.
    filled : DataFrame of bool
        True where a value was missing and is now filled.
    limit_h : float [h]
    min_output_share : float [-]
    """

    frame: pd.DataFrame
    filled: pd.DataFrame
    limit_h: float
    min_output_share: float = MIN_OUTPUT_SHARE

    def rules(self) -> dict:
        """The coverage rules applied, for results and reports."""
        return {
            "fill_inputs_h": self.limit_h,
            "min_output_share": self.min_output_share,
            "start_shift_max_h": START_SHIFT_MAX_H,
            "filled_input_values": int(self.filled.to_numpy().sum()),
        }


def fill_inputs(
    frame: pd.DataFrame, zone_names, step: float, limit_h: float, min_output_share: float = MIN_OUTPUT_SHARE
) -> FilledFrame:
    """Fill the input columns of ``frame`` for simulation (zone temperatures untouched).

    Parameters
    ----------
    frame : DataFrame
        A dataset frame on the model step (regular, tz-aware index).
    zone_names : sequence of str
        Zones whose ``T_<zone>`` columns are outputs and stay as measured.
    step : float [s]
        Model step.
    limit_h : float [h]
        Longest gap to fill (0: nothing is filled).
    min_output_share : float [-]
        Carried along for the window rules (:func:`plan_windows`).

    Returns
    -------
    FilledFrame
    """
    if not np.isfinite(limit_h) or limit_h < 0:
        raise DataError(f"fill_inputs_h (--fill-inputs) must be a number of hours >= 0, got {limit_h!r}")
    if not 0 < min_output_share <= 1:
        raise DataError(f"min_output_share must be in (0, 1] (--min-output-share: 0..100 %), got {min_output_share!r}")
    outputs = {f"T_{z}" for z in zone_names}
    cols = [c for c in frame.columns if c not in outputs]
    missing = frame[cols].isna()
    if limit_h == 0 or not missing.to_numpy().any():
        none = pd.DataFrame(False, index=frame.index, columns=frame.columns)
        return FilledFrame(frame, none, float(limit_h), float(min_output_share))
    filled_inputs = interpolate_gaps(frame[cols], limit_h * 60.0, native_step=step)
    filled_inputs = filled_inputs.reindex(frame.index)  # the frame is regular: no row is added
    out = frame.copy()
    out[cols] = filled_inputs[cols].to_numpy()
    mask = pd.DataFrame(False, index=frame.index, columns=frame.columns)
    mask[cols] = missing.to_numpy() & np.isfinite(out[cols].to_numpy(dtype=float))
    return FilledFrame(out, mask, float(limit_h), float(min_output_share))


def window_starts(weeks) -> list:
    """(week, local midnight) pairs: every local midnight of every week of ``weeks`` (DST-safe)."""
    out = []
    for w in weeks:
        tz = w.start.tz
        day0 = w.start.tz_localize(None)
        for d in range(7):
            t = (day0 + pd.Timedelta(days=d)).tz_localize(tz, nonexistent="shift_forward", ambiguous=False)
            if t < w.end:
                out.append((w, t))
    return out


@dataclasses.dataclass
class WindowPlan:
    """The windows of one model that are scored, and the skipped ones with their reason.

    Attributes
    ----------
    kept : list of (Week, int)
        Week and start row ``k`` of each scored window (``k`` is midnight, or the first step
        within :data:`START_SHIFT_MAX_H` with every output measured).
    skipped : list of (Week, pandas.Timestamp, str)
        Week, midnight and reason of each skipped window.
    """

    kept: list
    skipped: list

    def counts(self, reasons) -> dict:
        """Skipped windows per reason (every reason listed, 0 included)."""
        out = dict.fromkeys(reasons, 0)
        for _, _, why in self.skipped:
            out[why] = out.get(why, 0) + 1
        return out


def plan_windows(starts, index, Y, u, v, horizon, gains, fill_inputs_h, min_output_share, step) -> WindowPlan:
    """Apply the coverage rules to every (week, midnight) in ``starts``.

    Parameters
    ----------
    starts : list of (Week, pandas.Timestamp)
    index : DatetimeIndex
        The dataset frame's index.
    Y : array (n, ny) [°C]
        Measured outputs (NaN where missing, never filled).
    u, v : arrays (n, .)
        The model's inputs and disturbances from the gap-filled frame.
    horizon : int
        Steps N of a window.
    gains : mapping season -> profile
        The model's internal-gain profiles (a season without one is skipped).
    fill_inputs_h, min_output_share : float
        The rules' parameters (for the reasons' wording).
    step : float [s]
    """
    reasons = skip_reasons(fill_inputs_h, min_output_share)
    n, N = len(index), int(horizon)
    shift_max = int(round(START_SHIFT_MAX_H * 3600.0 / step))
    y_ok = np.isfinite(Y)
    row_ok = y_ok.all(axis=1)
    obs = np.r_[np.zeros((1, Y.shape[1]), np.int64), np.cumsum(y_ok, axis=0)]  # prefix counts per output
    bad_in = ~(np.all(np.isfinite(u), axis=1) & np.all(np.isfinite(v), axis=1))
    bad_in = np.r_[0, np.cumsum(bad_in)]
    kept, skipped = [], []
    for w, t in starts:
        k0 = index.get_indexer([t])[0]
        if k0 < 0:
            skipped.append((w, t, reasons[0]))
            continue
        ok = np.flatnonzero(row_ok[k0 : k0 + shift_max + 1])
        if not len(ok):
            skipped.append((w, t, reasons[1]))
            continue
        k = k0 + int(ok[0])
        if k + N >= n:
            skipped.append((w, t, reasons[2]))
        elif np.any(obs[k + N + 1] - obs[k + 1] < min_output_share * N):
            skipped.append((w, t, reasons[3]))
        elif bad_in[k + N] - bad_in[k]:
            skipped.append((w, t, reasons[4]))
        elif w.season not in gains:
            skipped.append((w, t, reasons[5]))
        else:
            kept.append((w, k))
    return WindowPlan(kept, skipped)


__all__ = [
    "FILL_INPUTS_H",
    "MIN_OUTPUT_SHARE",
    "START_SHIFT_MAX_H",
    "FilledFrame",
    "WindowPlan",
    "fill_inputs",
    "plan_windows",
    "skip_reasons",
    "window_starts",
]
