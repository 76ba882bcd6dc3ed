"""The evaluation protocol every model is judged by, and the verdict that opens its result.

- :mod:`.protocol`: :func:`evaluate`, 24-hour open-loop RMS on held-out weeks against
  persistence and the time-of-week mean (the paper's Table I);
- :mod:`.result`: :class:`EvaluationResult` (``.table``, ``.to_pandas()``, ``.plot()``,
  ``.verdict``, ``.format()``, ``.to_dict()``) and :class:`ModelScore`;
- :mod:`.verdict`: the per-zone verdict against the baselines, ASHRAE Guideline 14 hourly
  NMBE / CV(RMSE), and the likely causes the data can test when a model loses;
- :mod:`.trajectory`: 7-day open-loop trajectories (the paper's Fig. 5);
- :mod:`.plots`: the figures of a result (matplotlib imported lazily).
"""

from __future__ import annotations

from .protocol import evaluate, time_of_week_profile, window_rms
from .result import BASELINES, EvaluationResult, ModelScore
from .trajectory import Trajectory, choose_week, week_trajectory

#: old private name of :func:`choose_week`
_choose_week = choose_week

__all__ = [
    "BASELINES",
    "EvaluationResult",
    "ModelScore",
    "Trajectory",
    "choose_week",
    "evaluate",
    "time_of_week_profile",
    "week_trajectory",
    "window_rms",
]
