"""The EnergyPlus bed with the rival rule only (``diagnosis_energyplus_s13.md``): ``unused_input.read_as``
switched off, so a copy of a column the model reads (one air handler's ``T_supply_<ahu>``) is screened as
on main. Arguments as ``bench_diagnosis_energyplus.py`` (e.g. ``--results FILE``)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import bench_diagnosis_energyplus as bench  # noqa: E402

import hvacfmu.models.causes.unused_input as unused_input  # noqa: E402

if __name__ == "__main__":
    unused_input.read_as = lambda sig, x, rows: None
    bench.main()
