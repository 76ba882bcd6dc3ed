"""What a slave reads from its FMU's ``resources/``: the stored variable layout and a cache of loaded models.

``resources/interface.json`` (:data:`INTERFACE_FILE`) is the variable layout written
at export; a slave registers its variables from it even when the model file is
unusable, and refuses to run when the two disagree (:func:`read_layout`).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

INTERFACE_FILE = "interface.json"

#: (kind, digest of the resource files) -> what a slave's ``_setup`` built from them; models and plants are
#: immutable, so instances of one FMU share them instead of loading (and, for physics, discretising) them again
SETUP_CACHE: dict = {}
SETUP_CACHE_SIZE = 8


def cached_setup(kind: str, resources, names, build):
    """``build()`` for the resource files ``names``, reused while their bytes are unchanged (errors not cached)."""
    digest = hashlib.sha256()
    for name in names:
        path = Path(resources or ".") / name
        digest.update(name.encode() + b"\0" + (path.read_bytes() if path.is_file() else b"<missing>") + b"\0")
    key = (kind, digest.hexdigest())
    if key not in SETUP_CACHE:
        value = build()
        while len(SETUP_CACHE) >= SETUP_CACHE_SIZE:
            SETUP_CACHE.pop(next(iter(SETUP_CACHE)))
        SETUP_CACHE[key] = value
    return SETUP_CACHE[key]


def normalise(obj):
    """JSON round trip (tuples -> lists, numpy scalars -> floats) for comparing layouts."""
    return json.loads(json.dumps(obj, default=float))


#: layout keys that document a variable and do not change what the FMU computes
DOCUMENTATION_KEYS = ("description", "unit")


def _structure(layout):
    """``layout`` without its documentation (:data:`DOCUMENTATION_KEYS`, also the layout's own description)."""
    out = normalise(layout)
    if isinstance(out, dict):
        out.pop("description", None)
        out["variables"] = [
            {k: v for k, v in e.items() if k not in DOCUMENTATION_KEYS} if isinstance(e, dict) else e
            for e in out.get("variables") or []
        ]
    return out


def _stored(resources) -> dict:
    return json.loads((Path(resources or ".") / INTERFACE_FILE).read_text(encoding="utf-8"))


def stored_timezone(resources) -> str | None:
    """The ``timezone`` written at export into ``interface.json`` (None when absent or unreadable)."""
    try:
        return _stored(resources).get("timezone")
    except Exception:  # noqa: BLE001 - read_layout reports an unreadable file
        return None


def stored_season_dates(resources) -> list | None:
    """The building's seasons by date written at export into ``interface.json`` (None when absent or unreadable)."""
    try:
        return _stored(resources).get("season_dates")
    except Exception:  # noqa: BLE001 - read_layout reports an unreadable file
        return None


def stored_boxes(resources) -> dict | None:
    """The box limits written at export into ``interface.json`` ({} when absent, None when unreadable)."""
    try:
        return _stored(resources).get("boxes", {})
    except Exception:  # noqa: BLE001 - read_layout reports an unreadable file
        return None


def read_layout(resources, model_layout, resource_name):
    """The FMU's variable layout: ``interface.json`` when present, checked against the model's.

    Returns ``(layout, problem)``; ``problem`` is None when the model matches.
    """
    path = Path(resources or ".") / INTERFACE_FILE
    stored = None
    if path.is_file():
        try:
            stored = json.loads(path.read_text(encoding="utf-8"))
        except Exception as exc:  # noqa: BLE001
            return (model_layout, f"{path} is unreadable: {exc}")
    if model_layout is None:
        return (stored, None)
    if stored is not None and normalise(stored) != normalise(model_layout):
        if _structure(stored) == _structure(model_layout):
            # only the documentation differs (descriptions, units, the layout's own description): an FMU
            # exported by another hvacfmu version, whose wording changed since; the FMU's own variables stand
            return (stored, None)
        return (
            stored,
            f"resources/{resource_name} does not match the FMU's variables ({INTERFACE_FILE}); "
            "was the file replaced? Export the FMU again",
        )
    return (model_layout, None)
