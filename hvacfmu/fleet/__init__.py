"""Fit, evaluate, diagnose and export many buildings on Dask (``hvacfmu fleet``).

>>> import hvacfmu as hf
>>> result = hf.fleet("campus/", stages="check,fit,evaluate", out="campus-results")  # doctest: +SKIP
>>> result.table.groupby("verdict").size()  # doctest: +SKIP
"""

from .manifest import BuildingSpec, read_fleet
from .run import FleetResult, fleet, fleet_table
from .task import STAGES, run_building

__all__ = ["STAGES", "BuildingSpec", "FleetResult", "fleet", "fleet_table", "read_fleet", "run_building"]
