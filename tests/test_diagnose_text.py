"""``diagnose`` names the model it compares the refitted base with: "the given base model" only when
one was given (issue 13 follow-up); without one it says the base is diagnose's own fit.

Data: six weeks simulated from the known six-zone model of ``test_datadriven`` (7 s per diagnosis here).
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
from test_datadriven import simulate_frame, six_zone_building_dict, true_zone_model, write_dataset

from hvacfmu.building import building_from_dict
from hvacfmu.diagnosis import diagnose
from hvacfmu.errors import HvacfmuWarning

REPO = Path(__file__).resolve().parents[1]
GIVEN = "(the given base model: mean "
OWN = "(no base model given: diagnose's own fit (the paper's one-step fit, airflow form, no solar): mean "


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    building = building_from_dict(six_zone_building_dict())
    frame = simulate_frame(true_zone_model(building), building, weeks=6, start="2025-10-20", seed=11)
    folder = tmp_path_factory.mktemp("diagtext")
    return write_dataset(folder, frame, six_zone_building_dict(), "six"), folder


def test_without_a_model_the_text_does_not_claim_one_was_given(data):
    ds, _ = data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        report = diagnose(ds, progress=False)
    text = report.format()
    assert report.heldout["original_given"] is False
    assert OWN in text and "given base model" not in text, text
    given = dataclasses.replace(report, heldout={**report.heldout, "original_given": True})
    assert GIVEN in given.format() and OWN not in given.format()
    assert report.to_dict()["heldout"]["original_given"] is False


@pytest.mark.slow
def test_cli_with_and_without_a_base_model(data):
    ds, folder = data
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    bld = folder / "six_building.toml"

    def run(*extra):
        cmd = [sys.executable, "-m", "hvacfmu.cli", "-q", "diagnose", ds.source, "-b", str(bld), *extra]
        r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
        assert r.returncode == 0, r.stderr[-3000:]
        return r.stdout

    fit = subprocess.run(
        [sys.executable, "-m", "hvacfmu.cli", "-q", "fit", ds.source, "-b", str(bld), "-m", "zones"]
        + ["--heat", "airflow", "-o", str(folder / "zones.json")],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert fit.returncode == 0, fit.stderr[-3000:]
    assert GIVEN in run("-m", str(folder / "zones.json"))
    own = run()
    assert OWN in own and "given base model" not in own
