"""One entry point for identification: ``fit(dataset, kind) -> ZoneModel`` through the model-kind registry."""

from __future__ import annotations

from .models.registry import get_kind


def fit(dataset, kind: str, **options):
    """Identify a model of ``kind`` on ``dataset``'s training weeks.

    Parameters
    ----------
    dataset : hvacfmu.data.Dataset
    kind : str
        A registered kind that is fitted from data (:func:`hvacfmu.models.registry.fittable_kinds`:
        ``"lumped"``, ``"zones"``, ``"physics"``, and any kind a plugin registers).
    **options
        Passed to the kind's fit function (e.g. ``progress=False``).

    Returns
    -------
    ZoneModel

    Raises
    ------
    ModelError
        For an unknown kind (listing the choices) or a kind not fitted from data.
    """
    return get_kind(kind).fit_function()(dataset, **options)


__all__ = ["fit"]
