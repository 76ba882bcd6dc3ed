"""A fleet of varied emulated buildings, for portfolio runs without real data (issue 19).

:func:`generate_fleet` draws, from one seed, for every building: layout,
construction, climate, HVAC mode (a third of the buildings are real-BMS-like
``reheat`` systems exported in US units with naive timestamps and logger
outages), zero to two effects at random locations, a start date (a season, when
the datasets are shorter than 40 weeks) and the building's own dataset seed.
Each building goes to its own folder; ``fleet.json`` lists them::

    {"format": "hvacfmu.fleet/1", "seed": 0, "weeks": 51, "emulator_version": "...",
     "buildings": [{"name": "b000", "folder": "b000", "measurements": "b000/measurements.parquet",
                    "building": "b000/building.toml", "truth": "b000/truth.json",
                    "parameters": {...the generate() keywords...}}, ...]}

Paths in the manifest are relative to the manifest's folder.
"""

from __future__ import annotations

import json
import sys
import time
import zlib
from pathlib import Path

import numpy as np

from .effects import EFFECT_NAMES, EmulatorError
from .generate import EMULATOR_VERSION, generate
from .layouts import CLIMATES, CONSTRUCTION_TEMPLATES

FLEET_FORMAT = "hvacfmu.fleet/1"
#: Mondays that start a season's data (used when datasets are shorter than 40 weeks).
SEASON_STARTS = ("2025-09-01", "2025-12-01", "2026-01-05", "2026-03-02", "2026-06-01")
REHEAT_SHARE = 1.0 / 3.0  # [-] share of real-BMS-like buildings
#: Effects a fleet draws from: the catalogue of emulator 1.4 (``wind_infiltration`` needs a wind column to be
#: diagnosed and is not drawn, so a seed's fleet stays what it was)
FLEET_EFFECTS = tuple(e for e in EFFECT_NAMES if e != "wind_infiltration")
#: Layouts a fleet draws from: those of emulator 1.4. Not :data:`.layouts.LAYOUTS`: a layout added there
#: (``quad4``) would change the draw ``rng.choice`` makes, hence every building of an existing fleet seed.
FLEET_LAYOUTS = ("sdh", "row4", "core9")


def fleet_parameters(n: int, seed: int = 0, weeks: int = 51) -> list[dict]:
    """The :func:`~hvacfmu.emulator.generate` keywords of every building of a fleet (drawn from ``seed``)."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), zlib.crc32(b"fleet")]))
    out = []
    for _ in range(int(n)):
        layout = str(rng.choice(list(FLEET_LAYOUTS)))
        climate = str(rng.choice(list(CLIMATES)))
        hvac = str(rng.choice(["reheat", "reheat-dual"])) if rng.random() < REHEAT_SHARE else "vav"
        n_eff = int(rng.choice([0, 1, 2], p=[0.3, 0.45, 0.25]))
        names = [str(e) for e in rng.choice(FLEET_EFFECTS, size=n_eff, replace=False)]
        if weeks < 2:
            names = [e for e in names if e != "internal_gain_schedule"]  # a holiday week needs a second week
        p = {
            "seed": int(rng.integers(0, 2**31 - 1)),
            "layout": layout,
            "construction": str(rng.choice(list(CONSTRUCTION_TEMPLATES))),
            "climate": climate,
            "hvac": hvac,
            "effects": names,
            "start": "2025-09-01" if weeks >= 40 else str(rng.choice(SEASON_STARTS)),
        }
        if hvac != "vav":
            p.update(
                units="us", clock=str(rng.choice(["naive-local", "naive-utc"])), export_step=900, faults=["outages"]
            )
        out.append(p)
    return out


def generate_fleet(n: int, outdir, seed: int = 0, weeks: int = 51, progress: bool = True) -> Path:
    """Generate ``n`` varied buildings into ``outdir`` and write ``outdir/fleet.json``.

    Parameters
    ----------
    n : int
        Number of buildings (>= 1).
    outdir : path
        Created if needed; building ``i`` goes to ``outdir/b{i:03d}``.
    seed : int
        Draws every building's parameters (see :func:`fleet_parameters`).
    weeks : int
        Length of every building's dataset [weeks].
    progress : bool
        One log line per building on stderr.

    Returns
    -------
    Path
        The manifest ``fleet.json``.
    """
    problems = []
    if not isinstance(n, (int, np.integer)) or n < 1:
        problems.append(f"n must be a positive number of buildings, got {n!r}")
    if not isinstance(weeks, (int, np.integer)) or weeks < 1:
        problems.append(f"weeks must be a positive integer, got {weeks!r}")
    if problems:
        from ..errors import problems_message

        raise EmulatorError(problems_message("Invalid fleet arguments", problems))
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    rows = []
    t0 = time.perf_counter()
    for i, p in enumerate(fleet_parameters(n, seed, weeks)):
        name = f"b{i:03d}"
        paths = generate(outdir / name, weeks=int(weeks), **p)
        rows.append(
            {
                "name": name,
                "folder": name,
                "measurements": paths.measurements.relative_to(outdir).as_posix(),
                "building": paths.building.relative_to(outdir).as_posix(),
                "truth": paths.truth.relative_to(outdir).as_posix(),
                "parameters": {"weeks": int(weeks), **p},
            }
        )
        if progress:
            print(
                f"fleet: {i + 1}/{n} {name}: {p['layout']}, {p['construction']}, {p['climate']}, {p['hvac']}, "
                f"effects {', '.join(p['effects']) or 'none'} ({time.perf_counter() - t0:.0f} s)",
                file=sys.stderr,
            )
    manifest = {
        "format": FLEET_FORMAT,
        "seed": int(seed),
        "weeks": int(weeks),
        "emulator_version": EMULATOR_VERSION,
        "buildings": rows,
    }
    path = outdir / "fleet.json"
    path.write_text(json.dumps(manifest, indent=1), encoding="utf-8")
    return path
