"""Fast access to a slave's value list by value reference (used on every FMI call)."""

from __future__ import annotations

import operator


def tuple_getter(indices):
    """A fast function ``values -> tuple(values[i] for i in indices)``."""
    indices = list(indices)
    if not indices:
        return lambda values: ()
    get = operator.itemgetter(*indices)
    if len(indices) == 1:
        return lambda values: (get(values),)
    return get


def contiguous(vrs) -> bool:
    """True when the value references ``vrs`` are consecutive (a slice of the value list)."""
    return bool(vrs) and list(vrs) == list(range(vrs[0], vrs[0] + len(vrs)))
