"""A minimal reader and editor of EnergyPlus input files (IDF text).

An IDF is a sequence of objects ``Class, field1, field2, ...;`` with ``!``
comments. :func:`read_idf` keeps every object in file order with its fields as
strings; :meth:`Idf.text` writes the file back (comments dropped). Only what
:mod:`hvacfmu.energyplus` needs is interpreted elsewhere; this module knows no
object semantics except the class name being the first field.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from ..errors import BuildingError


@dataclasses.dataclass
class IdfObject:
    """One IDF object: ``cls`` (as written), ``fields`` (strings, without the class name)."""

    cls: str
    fields: list

    def get(self, i: int, default: str = "") -> str:
        """Field ``i`` (0-based, after the class name), stripped; ``default`` if absent or blank."""
        if i < len(self.fields) and self.fields[i].strip():
            return self.fields[i].strip()
        return default

    def number(self, i: int, default: float | None = None) -> float | None:
        """Field ``i`` as a float; ``default`` if blank, ``autosize`` or ``autocalculate``."""
        s = self.get(i)
        if not s or s.lower() in ("autosize", "autocalculate"):
            return default
        return float(s)

    @property
    def name(self) -> str:
        return self.get(0)


@dataclasses.dataclass
class Idf:
    """The objects of an IDF file, in order. ``source``: the file it was read from."""

    objects: list
    source: str = ""

    def all(self, cls: str) -> list:
        """Every object of class ``cls`` (case-insensitive)."""
        c = cls.lower()
        return [o for o in self.objects if o.cls.lower() == c]

    def one(self, cls: str) -> IdfObject | None:
        objs = self.all(cls)
        return objs[0] if objs else None

    def by_name(self, cls: str) -> dict:
        """``{name.lower(): object}`` of class ``cls``."""
        return {o.name.lower(): o for o in self.all(cls)}

    def remove(self, cls: str) -> None:
        c = cls.lower()
        self.objects = [o for o in self.objects if o.cls.lower() != c]

    def add(self, cls: str, *fields) -> None:
        self.objects.append(IdfObject(cls, [str(f) for f in fields]))

    def text(self) -> str:
        lines = []
        for o in self.objects:
            lines.append(",".join([o.cls, *o.fields]) + ";")
        return "\n".join(lines) + "\n"


def parse_idf(text: str, source: str = "") -> Idf:
    """Parse IDF ``text`` into an :class:`Idf`.

    Raises
    ------
    BuildingError
        When the text ends inside an object (a missing ``;``).
    """
    clean = "\n".join(line.split("!", 1)[0] for line in text.splitlines())
    objects = []
    chunks = clean.split(";")
    for chunk in chunks[:-1]:
        fields = [f.strip() for f in chunk.split(",")]
        if not fields[0] and len(fields) == 1:
            continue
        objects.append(IdfObject(fields[0], fields[1:]))
    if chunks[-1].strip():
        raise BuildingError(
            f"IDF file {source or '(text)'}: ends inside an object ({chunks[-1].strip()[:60]!r}...); a ';' is missing"
        )
    return Idf(objects, source)


def read_idf(path) -> Idf:
    """Read an IDF file (see :func:`parse_idf`)."""
    path = Path(path)
    if not path.exists():
        raise BuildingError(f"IDF file {path} does not exist")
    return parse_idf(path.read_text(encoding="latin-1"), source=str(path))
