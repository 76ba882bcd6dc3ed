"""Co-simulation master (FMPy) and controllers (rule-based, MPC), on hvacfmu's public API.

``harness.cosim(fmu, data, controller)`` runs an FMU with a controller in the loop over
measured data (a thin wrapper of :func:`harness.cosim.run_cosim`). The modules:
:mod:`harness.cosim` (the master), :mod:`harness.controllers` (replay, rule-based),
:mod:`harness.mpc` (model predictive control).

Note: the function :func:`cosim` takes the attribute name of the submodule ``harness.cosim``;
import from the module by name (``from harness.cosim import run_cosim``), as usual.
"""

from __future__ import annotations

from typing import Any

from . import cosim as _cosim_module  # loaded first, so the function below keeps the attribute name

run_cosim = _cosim_module.run_cosim
make_controller = _cosim_module.make_controller
CosimResult = _cosim_module.CosimResult


def cosim(
    fmu: Any, data: Any, controller: Any = "rule", *, model: Any = None, options: dict | None = None, **kwargs: Any
) -> Any:
    """Co-simulate an FMU with a controller in the loop over a span of measured data (FMPy).

    Parameters
    ----------
    fmu : path
        A co-simulation FMU (``hf.export_fmu`` of a model, or the emulator's plant FMU).
    data : hvacfmu.data.Dataset
        Prepared data; one row per communication step.
    controller : str or controller
        ``"replay"``, ``"rule"`` or ``"mpc"`` (built with ``model`` and ``options``), or an object
        following the controller protocol of :mod:`harness.controllers`.
    model : ZoneModel or path, optional
        The controller's model (needed by ``"mpc"``), also used to map measured temperatures.
    options : dict, optional
        Controller options (e.g. ``{"horizon": 12}`` for MPC; without ``horizon`` the MPC plans over 3 h in
        steps of the data, ``harness.controllers.DEFAULT_HORIZON_H``: 12 steps at 15 min, 36 at 5 min).
    **kwargs
        Passed to :func:`harness.cosim.run_cosim` (``week=``, ``start=``, ``stop=``, ``band=`` [°C],
        ``start_values=``, ``allow_partial=``, ``warmup=`` [s], ``progress=``, ``system=``: ``"schedule"``
        (default; the data's air-handler-off steps run with every box at 0) or ``"always-on"``,
        :mod:`harness.schedule`).

    Returns
    -------
    harness.cosim.CosimResult
        ``.table`` (pandas), ``.summary``, ``.format_summary()``, ``.save(path)``.
    """
    if model is not None and not hasattr(model, "step_state"):
        from hvacfmu.models import load_model

        model = load_model(model)
    if isinstance(controller, str):
        controller = make_controller(controller, model, data.building, options)
    elif options:
        raise TypeError("options apply to a controller given by name only")
    return run_cosim(fmu, data, controller, model=model, **kwargs)


__all__ = ["CosimResult", "cosim", "make_controller", "run_cosim"]
