"""Views on the demo's stage results shared by the demo stages and its report (no imports of either)."""

from __future__ import annotations

#: report labels of the model kinds the demo fits
LABELS = {"lumped": "Model A (lumped)", "zones": "Model A (six zones)", "physics": "Model B (physics)"}


def stage_models(r: dict) -> dict:
    """Model kind -> ``{"model", "path", "seconds"}`` of every model the demo's model stages fitted."""
    models = {}
    for key in ("model_a", "model_b"):
        for kind, d in (r.get(key) or {}).items():
            models[kind] = d
    return models


def label(kind: str) -> str:
    """The report label of a model kind (the kind itself when it has none)."""
    return LABELS.get(kind, kind)
