"""Which buildings a fleet run covers: a folder of building folders or a manifest file.

A fleet source is one of

- a folder with ``fleet.json`` (written by ``hvacfmu generate-fleet``),
- a manifest file (``.json``: a list of objects, or ``{"buildings": [...]}``;
  ``.csv``: columns ``name, measurements, building``), each entry naming the
  measurement file and the building file (paths relative to the manifest),
- a folder whose sub-folders each hold one building file (``*.toml``) and one
  measurement file (``*.parquet`` or ``*.csv``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

import pandas as pd

from ..errors import DataError


@dataclasses.dataclass(frozen=True)
class BuildingSpec:
    """One building of a fleet: its name and files."""

    name: str
    measurements: Path
    building: Path
    truth: Path | None = None

    def content_key(self) -> str:
        """SHA-256 of the measurement and building files' bytes (the cache key of their results)."""
        h = hashlib.sha256()
        for p in (self.measurements, self.building):
            h.update(p.name.encode())
            with open(p, "rb") as f:
                for chunk in iter(lambda: f.read(1 << 20), b""):
                    h.update(chunk)
        return h.hexdigest()


def read_fleet(source) -> list[BuildingSpec]:
    """The buildings of ``source`` (folder or manifest file), checked to exist.

    Raises
    ------
    DataError
        Naming the source, entry and missing file; when nothing is found.
    """
    source = Path(source)
    if not source.exists():
        raise DataError(f"fleet source {source} does not exist; give a folder of building folders or a manifest")
    if source.is_dir():
        if (source / "fleet.json").exists():
            specs = _from_manifest(source / "fleet.json")
        else:
            specs = _from_folders(source)
    else:
        specs = _from_manifest(source)
    if not specs:
        raise DataError(
            f"fleet source {source}: no building found (a sub-folder needs one *.toml building file "
            "and one *.parquet or *.csv measurement file)"
        )
    names = [s.name for s in specs]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise DataError(f"fleet source {source}: building names {dup} appear more than once; names must be unique")
    return specs


def _from_manifest(path: Path) -> list[BuildingSpec]:
    base = path.parent
    if path.suffix.lower() == ".csv":
        rows = pd.read_csv(path, dtype=str).to_dict("records")
    elif path.suffix.lower() == ".json":
        try:
            d = json.loads(path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise DataError(f"fleet manifest {path} is not valid JSON: {exc}") from None
        rows = d.get("buildings", []) if isinstance(d, dict) else d
    else:
        raise DataError(f"fleet manifest {path}: unknown format {path.suffix!r}; use .json or .csv")
    if not isinstance(rows, list):
        raise DataError(f"fleet manifest {path}: expected a list of buildings")
    specs, problems = [], []
    for i, r in enumerate(rows):
        if not isinstance(r, dict) or not all(isinstance(r.get(k), str) for k in ("measurements", "building")):
            problems.append(f"entry {i}: needs string fields 'measurements' and 'building'")
            continue
        files = {k: (base / r[k]) for k in ("measurements", "building")}
        missing = [f"{k} {p}" for k, p in files.items() if not p.exists()]
        if missing:
            problems.append(f"entry {i} ({r.get('name', '?')}): missing {', '.join(missing)}")
            continue
        truth = base / r["truth"] if isinstance(r.get("truth"), str) else None
        name = str(r.get("name") or files["measurements"].parent.name)
        specs.append(
            BuildingSpec(
                name, files["measurements"], files["building"], truth if truth is not None and truth.exists() else None
            )
        )
    if problems:
        raise DataError(f"fleet manifest {path}:\n  - " + "\n  - ".join(problems))
    return specs


def _from_folders(root: Path) -> list[BuildingSpec]:
    specs = []
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        tomls = sorted(folder.glob("*.toml"))
        data = sorted(folder.glob("*.parquet")) + sorted(folder.glob("*.csv"))
        if len(tomls) == 1 and len(data) == 1:
            truth = folder / "truth.json"
            specs.append(BuildingSpec(folder.name, data[0], tomls[0], truth if truth.exists() else None))
        elif tomls or data:
            raise DataError(
                f"fleet folder {folder}: expected exactly one *.toml building file and one "
                f"measurement file, found {[p.name for p in tomls + data]}"
            )
    return specs
