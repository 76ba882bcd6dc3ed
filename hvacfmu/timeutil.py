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


def seconds_of_week(index: pd.DatetimeIndex) -> np.ndarray:
    """Seconds since Monday 00:00 local time of each timestamp (local wall clock)."""
    index = pd.DatetimeIndex(index)
    return (
        index.day_of_week.to_numpy() * 86400
        + index.hour.to_numpy() * 3600
        + index.minute.to_numpy() * 60
        + index.second.to_numpy()
    ).astype(np.int64)


def time_of_week(index: pd.DatetimeIndex, step: float) -> np.ndarray:
    """Slot number 0 .. n_time_of_week(step)-1 of each timestamp (Monday 00:00 is 0)."""
    return (seconds_of_week(index) // int(step)).astype(np.int64)
