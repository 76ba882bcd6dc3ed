"""Measured data in: loading, validation, unit conversion, resampling, solar, weeks.

Public API (see DEVELOPING.md, section ``hvacfmu.data``):

- :func:`load_measurements` ``(path, building) -> (DataFrame, LoadReport)``:
  native resolution, tz-aware local index, canonical SI columns; raises
  :class:`~hvacfmu.errors.DataError` listing every problem.
- :func:`prepare` ``(path, building, step=900, seed=0, train_fraction=0.9,
  interpolate_limit=None) -> Dataset``.
- :class:`Dataset`, :class:`Week`.
- :func:`check` ``(path, building, ...) -> CheckReport``.
"""

from .check import CheckReport, check
from .dataset import Dataset, Week, file_sha256, make_weeks, prepare
from .loading import LoadReport, load_measurements
from .resample import interpolate_gaps, resample
from .solar import facade_irradiance
from .units import AIR_DENSITY, from_si, normalize_unit, to_si

__all__ = [
    "AIR_DENSITY",
    "CheckReport",
    "Dataset",
    "LoadReport",
    "Week",
    "check",
    "facade_irradiance",
    "file_sha256",
    "from_si",
    "interpolate_gaps",
    "load_measurements",
    "make_weeks",
    "normalize_unit",
    "prepare",
    "resample",
    "to_si",
]
