"""Lifecycle of the pythonfmu FMUs: memory over many instances in one process, clean exit of many processes.

Uses the functions of ``benchmarks/bench_fmu_lifecycle.py`` (which prints the full figures).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from bench_fmu_lifecycle import build_fmus, cycles, processes  # noqa: E402


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    return build_fmus(("lumped", "zones", "physics", "plant"), tmp_path_factory.mktemp("lifecycle"))


@pytest.mark.slow
def test_many_instances_in_one_process_keep_memory_flat(fmus):
    """200 instantiate/simulate/free cycles of lumped, zones and plant, 50 of physics: < 20 MB in all.

    (Before the fix of the pythonfmu re-execution, 100 cycles grew 17-354 MB per FMU.) The physics
    model is limited to 50 cycles here (about 1 s each); the benchmark runs 200.
    """
    growth = {kind: cycles(path, 50 if kind == "physics" else 200, 8)["trimmed"] for kind, path in fmus.items()}
    assert sum(growth.values()) < 20.0, growth


@pytest.mark.slow
def test_processes_that_simulated_the_plant_exit_cleanly(fmus):
    """100 separate processes simulate the plant FMU (the one that aborted at exit) and all exit 0."""
    r = processes(fmus["plant"], 100, 2)
    assert r["ok"] == 100, r


def test_instances_share_the_loaded_model_and_the_slave_class(tmp_path):
    """A second instance does not re-run the slave script's definitions or reload the model."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    path = build_fmus(("zones",), tmp_path)["zones"]
    md = read_model_description(str(path))
    unz = extract(str(path))
    loaded = []
    for i in range(3):
        s = FMU2Slave(
            guid=md.guid, unzipDirectory=unz, modelIdentifier=md.coSimulation.modelIdentifier, instanceName=f"i{i}"
        )
        s.instantiate()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        s.doStep(0.0, 900.0)
        s.terminate()
        s.freeInstance()
        # the process may hold other FMUs of this kind from earlier tests (pytest-xdist workers): count entries
        loaded.append(set(sys.modules[md.coSimulation.modelIdentifier]._SETUP_CACHE))
    module = sys.modules[md.coSimulation.modelIdentifier]
    assert module._hvacfmu_slave_class is getattr(module, md.coSimulation.modelIdentifier)
    assert loaded[1] == loaded[0] and loaded[2] == loaded[0]  # one model loaded for three instances
