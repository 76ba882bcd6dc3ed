"""Time helpers shared by data, models and FMUs: time of week and weeks."""

from __future__ import annotations

import numpy as np
import pandas as pd

SECONDS_PER_WEEK = 7 * 86400


def n_time_of_week(step: float) -> int:
    """Number of time-of-week slots for a model step ``step`` [s] (672 for 900 s)."""
    n = SECONDS_PER_WEEK / step
    if abs(n - round(n)) > 1e-9:
        raise ValueError(f"model step {step} s does not divide a week")
    return int(round(n))


def local_seconds(index: pd.DatetimeIndex) -> np.ndarray:
    """Seconds since 1970-01-01 00:00 on the local wall clock of each timestamp (int64, floored to whole seconds).

    One conversion to the wall clock for every calendar field read from it (``seconds_of_week``, the local date):
    each pandas field (``day_of_week``, ``hour`` ...) of a tz-aware index converts it again.
    """
    index = pd.DatetimeIndex(index)
    wall = index.tz_localize(None) if index.tz is not None else index
    return np.asarray(wall.values).astype("datetime64[s]").astype(np.int64)


def week_seconds(local: np.ndarray) -> np.ndarray:
    """Seconds since Monday 00:00 of wall-clock seconds ``local`` (:func:`local_seconds`)."""
    local = np.asarray(local, dtype=np.int64)
    # 1970-01-01 was a Thursday (day 3 of a week that starts on Monday)
    return ((local // 86400 + 3) % 7) * 86400 + local % 86400


def seconds_of_week(index: pd.DatetimeIndex) -> np.ndarray:
    """Seconds since Monday 00:00 local time of each timestamp (local wall clock)."""
    return week_seconds(local_seconds(index))


def time_of_week(index: pd.DatetimeIndex, step: float) -> np.ndarray:
    """Slot number 0 .. n_time_of_week(step)-1 of each timestamp (Monday 00:00 is 0)."""
    return (seconds_of_week(index) // int(step)).astype(np.int64)
