"""Zone models: the common interface, Model A (linear), Model B (physics), extensions.

Use :func:`load_model` to read any saved model; it dispatches on the file's
``kind`` through the model-kind registry (:mod:`hvacfmu.models.registry`) and never
executes code from the file.
"""

from __future__ import annotations

import json
from pathlib import Path

from ..errors import ModelError
from .base import FORMAT_VERSION, ZoneModel
from .registry import ModelKind, get_kind, kind_names, kinds, register_kind


def model_class(kind: str):
    """The class implementing model ``kind`` (from the registry; unknown kind -> :class:`ModelError`)."""
    return get_kind(kind).load_class()


def model_from_dict(d: dict) -> ZoneModel:
    """Rebuild a model from its JSON mapping: schema validated by the kind, then plausibility.

    Raises
    ------
    ModelError
        For a wrong schema (naming the key) or a model that cannot be a building
        (:mod:`hvacfmu.models.loadcheck`: unstable, wrong signs, absurd gains ...).
    """
    from .loadcheck import require_plausible

    if not isinstance(d, dict) or "kind" not in d:
        raise ModelError("model file has no 'kind'; is this an hvacfmu model?")
    try:
        model = model_class(d["kind"]).from_dict(d)
    except (TypeError, ValueError, KeyError, IndexError, AttributeError) as exc:
        if isinstance(exc, ModelError):
            raise
        raise ModelError(
            f"malformed {d.get('kind')!r} model file ({type(exc).__name__}: {exc}); refit the model with hvacfmu fit"
        ) from None
    return require_plausible(model)


def load_model(path) -> ZoneModel:
    """Read a saved model (JSON). Raises :class:`ModelError` on any problem."""
    path = Path(path)
    if not path.exists():
        raise ModelError(f"model file {path} does not exist")
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ModelError(f"model file {path} is not valid JSON: {exc}") from None
    try:
        model = model_from_dict(d)
    except ModelError as exc:
        raise ModelError(f"{path}: {exc}") from None
    _warn_if_edited(d, path)
    return model


def _warn_if_edited(d: dict, path: Path) -> None:
    """Warn when the numbers of model file ``path`` differ from those :meth:`ZoneModel.save` sealed."""
    import warnings

    from ..errors import HvacfmuWarning
    from .base import coefficients_sha256

    meta = d.get("meta") if isinstance(d.get("meta"), dict) else {}
    sealed = meta.get("coefficients_sha256")
    if not isinstance(sealed, str):
        return  # written before session 20, or by another tool: nothing to compare
    try:
        now = coefficients_sha256(d)
    except (TypeError, ValueError):
        return
    if now != sealed:
        warnings.warn(
            f"{path}: the model's coefficients were changed after hvacfmu wrote the file (edited by hand or by "
            "another tool): the fit's checks and scores in its meta describe another model. It passed the load "
            "checks (stability, signs, size); refit with hvacfmu fit to trust it",
            HvacfmuWarning,
            stacklevel=2,
        )


__all__ = [
    "FORMAT_VERSION",
    "ModelKind",
    "ZoneModel",
    "get_kind",
    "kind_names",
    "kinds",
    "load_model",
    "model_class",
    "model_from_dict",
    "register_kind",
]
