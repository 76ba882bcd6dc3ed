"""A model FMU whose states the measurements do not all set (a physics model's walls) is warmed up by default.

Fourth EnergyPlus round: `cosim` of the physics FMU of 8 outpatient rooms (166 states, 8 measured) started its walls
flat: replaying a March day gave 164 K*h outside [20, 22] degC against 75 after a week's warm-up (69.6 measured), so an
MPC run on it looked twice as bad as the building. Model A's FMUs (states = zone temperatures) still start at once.
"""

from __future__ import annotations

import importlib
from types import SimpleNamespace

import pandas as pd

cosim = importlib.import_module("harness.cosim")  # the package exports a function of the same name


def _warmup(monkeypatch, interface, warmup=None):
    seen = {}

    def rows(dataset, t_start, seconds, earliest, *args):
        seen["seconds"] = seconds
        return None, None, None

    monkeypatch.setattr(cosim, "_warmup_rows", rows)
    frame = pd.DataFrame(index=pd.date_range("2025-03-03", periods=4, freq="15min", tz="UTC"))
    run = SimpleNamespace(frame=frame, dataset=None, inputs={}, controls={}, outputs={}, V={}, building=None)
    cosim._locate_in_time(run, SimpleNamespace(interface=interface), None, warmup)
    return seen["seconds"]


def _interface(kind, n_states, n_zones):
    return {
        "kind": kind,
        "n_states": n_states,
        "variables": [{"role": "y0", "name": f"T_Z{i}_start"} for i in range(n_zones)],
    }


def test_physics_fmu_is_warmed_up_a_week_by_default(monkeypatch):
    assert _warmup(monkeypatch, _interface("physics", 166, 8)) == cosim.PLANT_WARMUP
    assert _warmup(monkeypatch, _interface("physics", 166, 8), warmup=3600.0) == 3600.0  # --warmup wins


def test_model_a_fmu_starts_at_once(monkeypatch):
    assert _warmup(monkeypatch, _interface("zones", 8, 8)) == 0.0
    assert _warmup(monkeypatch, _interface("lumped", 1, 1)) == 0.0
    assert _warmup(monkeypatch, None) == 0.0  # a foreign FMU
