"""Exception hierarchy of hvacfmu.

Every error subclasses :class:`HvacfmuError` and a builtin, so callers can catch
either (python-control / qpsolvers style).
"""


class HvacfmuError(Exception):
    """Base class of all hvacfmu errors."""


class BuildingError(HvacfmuError, ValueError):
    """A building file is malformed or inconsistent. Message lists every problem."""


class DataError(HvacfmuError, ValueError):
    """Measured data cannot be used. Message lists every problem found."""


class ModelError(HvacfmuError, ValueError):
    """A model (file or object) is malformed, inconsistent or of an unknown version."""


class FitError(HvacfmuError, RuntimeError):
    """Identification could not produce a usable model."""


class FMUError(HvacfmuError, RuntimeError):
    """Building, loading or running an FMU failed."""


class SolverError(HvacfmuError, RuntimeError):
    """An optimisation problem could not be solved."""


class HvacfmuWarning(UserWarning):
    """Warnings about data or fits that are usable but degraded."""


def problems_message(title, problems):
    """Format a list of problems as one readable message."""
    lines = [f"{title} ({len(problems)} problem{'s' if len(problems) != 1 else ''}):"]
    lines += [f"  - {p}" for p in problems]
    return "\n".join(lines)
