"""hvacfmu: thermal models of HVAC zones from measured data, FMI 2.0 FMUs and MPC."""

from .errors import (  # noqa: F401
    BuildingError,
    DataError,
    FitError,
    FMUError,
    HvacfmuError,
    HvacfmuWarning,
    ModelError,
    SolverError,
)

__version__ = "0.1.0"
