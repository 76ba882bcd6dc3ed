"""The coverage rules of the evaluation's 24-hour windows: :mod:`hvacfmu.data.windows` under its public name.

The rules live in the data layer so that a model's own cross-validation can apply them too.
"""

from ..data.windows import (
    FILL_INPUTS_H,
    MIN_OUTPUT_SHARE,
    START_SHIFT_MAX_H,
    FilledFrame,
    WindowPlan,
    fill_inputs,
    plan_windows,
    skip_reasons,
    window_starts,
)

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
