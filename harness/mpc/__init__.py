"""Energy-efficient MPC for Model A (linear) and Model B (bilinear), section V.B of the paper.

- :mod:`harness.mpc.problem`: the condensed SOCP / exact-penalty QP, move blocking, replay of failed problems;
- :mod:`harness.mpc.predict`: condensed predictions for both models, Kalman filter;
- :mod:`harness.mpc.controller`: the receding-horizon controller and a pure-Python closed loop;
- :mod:`harness.mpc.adapter`: the controller protocol of :mod:`harness.controllers` (``hvacfmu cosim --controller mpc``);
- :mod:`harness.mpc.synthetic`: random bilinear RC networks for tests and benchmarks.
"""

from .adapter import CosimMPC, cosim_controller, settings_from_options
from .controller import ClosedLoopResult, MPCController, Plan, closed_loop, input_limits
from .predict import BilinearPredictor, KalmanFilter, LinearPredictor, make_predictor
from .problem import CondensedProblem, MPCSettings, QPSolution, default_blocks, replay_problem, save_problem

__all__ = [
    "BilinearPredictor",
    "ClosedLoopResult",
    "CosimMPC",
    "cosim_controller",
    "settings_from_options",
    "CondensedProblem",
    "KalmanFilter",
    "LinearPredictor",
    "MPCController",
    "MPCSettings",
    "Plan",
    "QPSolution",
    "closed_loop",
    "default_blocks",
    "input_limits",
    "make_predictor",
    "replay_problem",
    "save_problem",
]
