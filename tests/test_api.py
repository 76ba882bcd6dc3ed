"""The public Python API: ``import hvacfmu as hf`` is light, every advertised name resolves, and the
wrappers accept model objects or files."""

from __future__ import annotations

import subprocess
import sys

import pytest


def test_import_is_light():
    """``import hvacfmu`` loads neither numpy nor pandas nor any layer module (lazy PEP 562 names)."""
    code = (
        "import sys, hvacfmu; heavy = [m for m in ('numpy', 'pandas', 'hvacfmu.data', 'hvacfmu.models', "
        "'harness') if m in sys.modules]; print(heavy)"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "[]"


def test_every_public_name_resolves():
    import hvacfmu as hf

    for name in hf.__all__:
        assert getattr(hf, name) is not None, name
    assert set(hf.__all__) <= set(dir(hf))
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        hf.nonsense  # noqa: B018
    assert hf.model_kinds()[:3] == ["lumped", "zones", "physics"]


def test_harness_cosim_is_the_wrapper_and_the_module_still_imports():
    import harness
    from harness.cosim import run_cosim

    assert callable(harness.cosim) and harness.run_cosim is run_cosim
    assert "run_cosim" in harness.cosim.__doc__


def test_export_fmu_accepts_a_model_or_its_file(tmp_path, small_building):
    import numpy as np

    import hvacfmu as hf
    from hvacfmu.fmu import validate
    from hvacfmu.models.linear import LinearZoneModel

    b = small_building
    nz = len(b.zone_names)
    model = LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=b.zone_names,
        measured_zones=b.zone_names,
        output_weights=np.eye(nz),
        vavs=b.vav_names,
        input_map=b.zone_vav_matrix(),
        disturbances=("T_out", "T_supply"),
        A=0.9 * np.eye(nz),
        B=-0.5 * np.eye(nz),
        C=np.full((nz, 2), 0.02),
        gains={s: np.full((672, nz), 1.0) for s in b.season_names},
    )
    from_object = hf.export_fmu(model, tmp_path / "a.fmu")
    from_file = hf.export_fmu(model.save(tmp_path / "m.json"), tmp_path / "b.fmu")
    assert validate(from_object) == [] and validate(from_file) == []
    with pytest.raises(hf.ModelError, match="does not exist"):
        hf.evaluate(tmp_path / "missing.json", None)
