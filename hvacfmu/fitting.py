"""One entry point for identification: ``fit(dataset, kind) -> ZoneModel``."""

from __future__ import annotations

from .errors import ModelError

FIT_FUNCTIONS = {
    "lumped": ("hvacfmu.models.datadriven", "fit_lumped"),
    "zones": ("hvacfmu.models.datadriven", "fit_zones"),
    "physics": ("hvacfmu.models.physics", "fit_physics"),
}


def fit(dataset, kind: str, **options):
    """Identify a model of ``kind`` ("lumped", "zones", "physics") on ``dataset``'s training weeks.

    Parameters
    ----------
    dataset : hvacfmu.data.Dataset
    kind : str
    **options
        Passed to the kind's fit function (e.g. ``progress=False``).
    """
    import importlib

    if kind not in FIT_FUNCTIONS:
        raise ModelError(f"unknown model kind {kind!r}; choose one of {sorted(FIT_FUNCTIONS)}")
    module, name = FIT_FUNCTIONS[kind]
    return getattr(importlib.import_module(module), name)(dataset, **options)
