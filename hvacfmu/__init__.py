"""hvacfmu: thermal models of HVAC zones from measured data, FMI 2.0 FMUs and MPC.

The Python API, in the order of the work (``import hvacfmu as hf``)::

    building = hf.load_building("building.toml")
    report = hf.check("data.csv", building)             # coverage, gaps, seasons, split
    data = hf.prepare("data.csv", building)              # Dataset on the model step
    model = hf.fit(data, "zones")                        # a kind from hf.model_kinds()
    result = hf.evaluate(model, data)                    # .verdict, .table(), .to_pandas(), .plot(dir)
    diagnosis = hf.diagnose(data)                        # .format(), .model (the extended model)
    hf.export_fmu(model, "zones.fmu")                    # a model object or a model file
    import harness; harness.cosim("zones.fmu", data, "rule")   # co-simulation (FMPy)

Also ``hf.load_measurements(path, building) -> (frame, report)``, ``hf.generate(outdir, weeks=8)``
(an emulated dataset), ``hf.generate_fleet(n, outdir)`` (n varied emulated buildings and ``fleet.json``), ``hf.load_model(path)``. Names are imported on first use (PEP 562), so
``import hvacfmu`` stays fast; the exception classes are imported eagerly.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .errors import (
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

#: public name -> (module, attribute), imported on first access
_LAZY = {
    "load_building": ("hvacfmu.building", "load_building"),
    "load_measurements": ("hvacfmu.data", "load_measurements"),
    "prepare": ("hvacfmu.data", "prepare"),
    "check": ("hvacfmu.data", "check"),
    "generate": ("hvacfmu.emulator", "generate"),
    "generate_fleet": ("hvacfmu.emulator", "generate_fleet"),
    "fit": ("hvacfmu.fitting", "fit"),
    "load_model": ("hvacfmu.models", "load_model"),
    "diagnose": ("hvacfmu.diagnosis", "diagnose"),
    "fleet": ("hvacfmu.fleet", "fleet"),
    "model_kinds": ("hvacfmu.models.registry", "kind_names"),
    "Dataset": ("hvacfmu.data", "Dataset"),
    "EvaluationResult": ("hvacfmu.evaluation", "EvaluationResult"),
}

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    from .building import load_building
    from .data import Dataset, check, load_measurements, prepare
    from .diagnosis import diagnose
    from .emulator import generate, generate_fleet
    from .evaluation import EvaluationResult
    from .fitting import fit
    from .models import load_model
    from .models.registry import kind_names as model_kinds


def __getattr__(name: str) -> Any:
    try:
        module, attr = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'hvacfmu' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


def _as_model(model: Any) -> Any:
    """A ZoneModel from a model object or a model file path."""
    from .models import load_model as _load
    from .models.base import ZoneModel

    return model if isinstance(model, ZoneModel) else _load(model)


def evaluate(
    model: Any,
    data: Any,
    horizon: int = 96,
    names: Any = None,
    fill_inputs_h: float = 2.0,
    min_output_share: float = 0.75,
) -> EvaluationResult:
    """Score models by 24-hour open-loop prediction RMS on the held-out weeks, verdict first.

    Parameters
    ----------
    model : ZoneModel, path, or a sequence of them
        Model objects or saved model files (JSON).
    data : hvacfmu.data.Dataset
        Prepared data (:func:`prepare`); its test weeks are scored.
    horizon : int
        Prediction horizon [steps] (96 = 24 h at 15 minutes).
    names : sequence of str, optional
        Labels of the models.
    fill_inputs_h : float [h]
        Longest input gap filled by interpolation in time for the simulation (zone
        temperatures are never filled; see :mod:`hvacfmu.evaluation.windows`).
    min_output_share : float [-]
        A window is scored only when every output is measured in this share of its steps.

    Returns
    -------
    hvacfmu.evaluation.EvaluationResult
        ``.verdict`` (per zone against persistence and the time-of-week mean, ASHRAE
        Guideline 14 NMBE / CV(RMSE)), ``.table()``, ``.to_pandas()``, ``.plot(folder)``,
        ``.format()``, ``.save_json(path)``.
    """
    from .evaluation import evaluate as _evaluate

    models = [_as_model(m) for m in model] if isinstance(model, (list, tuple)) else _as_model(model)
    return _evaluate(
        models, data, horizon=horizon, names=names, fill_inputs_h=fill_inputs_h, min_output_share=min_output_share
    )


def export_fmu(model: Any, path: Any, *, timezone: str | None = None) -> Any:
    """Export a model as an FMI 2.0 co-simulation FMU.

    Parameters
    ----------
    model : ZoneModel or path
        A model object (saved into the FMU's resources) or a saved model file (JSON).
    path : path
        The ``.fmu`` file to write.
    timezone : str, optional
        IANA time zone of the building, for models with calendar terms.

    Returns
    -------
    pathlib.Path
        The written FMU.
    """
    import tempfile
    from pathlib import Path

    from .fmu import export_fmu as _export
    from .models.base import ZoneModel

    if not isinstance(model, ZoneModel):
        return _export(Path(model), path, timezone=timezone)
    with tempfile.TemporaryDirectory(prefix="hvacfmu-export-") as tmp:
        model_path = model.save(Path(tmp) / f"{model.kind}.json")
        return _export(model_path, path, timezone=timezone)


__all__ = [
    "BuildingError",
    "DataError",
    "Dataset",
    "EvaluationResult",
    "FMUError",
    "FitError",
    "HvacfmuError",
    "HvacfmuWarning",
    "ModelError",
    "SolverError",
    "__version__",
    "check",
    "diagnose",
    "evaluate",
    "export_fmu",
    "fit",
    "fleet",
    "generate",
    "generate_fleet",
    "load_building",
    "load_measurements",
    "load_model",
    "model_kinds",
    "prepare",
]
