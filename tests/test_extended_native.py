"""Extended models (diagnosed terms) as native FMUs: the terms' matrix form (``ExtendedModel.equations``)
runs in generated C and matches the Python model (delay registers, slow mass, bilinear supply air,
coupling, solar, on/off reheat as a switch)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from numpy.testing import assert_allclose
from test_fmu_native import simulate_year, zones_model

from hvacfmu.fmu_native import export_native_fmu
from hvacfmu.models.extended import (
    ActuationDelay,
    ExtendedModel,
    Reheat,
    SolarGain,
    SupplyAirBilinear,
    ThermalMass,
    ZoneCoupling,
)

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs the system C compiler gcc")


def test_extended_model_native_fmu_matches_python(tmp_path):
    from hvacfmu.emulator import sdh_building

    base = zones_model(sdh_building(nominal=True))
    z = base.outputs
    model = ExtendedModel(
        base=base,
        terms=(
            ActuationDelay(zone=z[0], delay=2),
            ThermalMass(zone=z[1], alpha=0.02, beta=0.05),
            SupplyAirBilinear(zone=z[2], coef=0.02),
            ZoneCoupling(zone_a=z[0], zone_b=z[3], coef_ab=0.01, coef_ba=0.015),
            SolarGain(zone=z[4], facade="W", coef=4e-4),
            Reheat(zone=z[5], coef=0.05, u_min=0.25, T_threshold=14.0),
        ),
    )
    path = export_native_fmu(model, tmp_path / "extended.fmu")
    Y, Yref = simulate_year(model, path, 2 * 672)
    assert_allclose(Y, Yref[: len(Y)], rtol=0, atol=1e-9)  # [K]
    assert np.ptp(Yref) > 1.0
