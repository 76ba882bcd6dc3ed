"""The scripts in ``examples/`` run end to end on a short emulated dataset (as a user runs them)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(script, folder, out):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run(
        [sys.executable, str(ROOT / "examples" / script), "--data", str(folder), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
    )


@pytest.mark.slow
def test_fit_and_evaluate_example(short_paths, tmp_path):
    run = _run("fit_and_evaluate.py", Path(short_paths.measurements).parent, tmp_path)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    assert run.stdout.count("beats persistence in 6/6 zones") == 2  # fitted and reloaded: same verdict
    assert (tmp_path / "zones.json").exists() and list((tmp_path / "figures").glob("week_*.png"))


@pytest.mark.slow
def test_diagnose_export_cosim_example(short_paths, tmp_path):
    run = _run("diagnose_export_cosim.py", Path(short_paths.measurements).parent, tmp_path)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    assert "completed       672 / 672 steps" in run.stdout
    assert (tmp_path / "extended.fmu").exists() and (tmp_path / "cosim_rule.csv").exists()
