"""The EnergyPlus export's optional ``wind`` column (``Site Wind Speed``): added only when asked, in its own cache."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("pyenergyplus")

from hvacfmu.energyplus import cached_export
from hvacfmu.energyplus.generate import cache_key

PROTOTYPE = "ASHRAE901_OfficeSmall_STD2019_Denver"


def test_wind_is_a_cache_key_option_only_when_on():
    plain = cache_key(PROTOTYPE, days=8, start="03-06")
    assert cache_key(PROTOTYPE, days=8, start="03-06", wind=False) == plain
    assert cache_key(PROTOTYPE, days=8, start="03-06", wind=True) != plain


def test_wind_column_is_the_site_wind_and_changes_no_other_column():
    """The same 8 days as tests/test_energyplus.py's export (cached there), with the wind: every other column equal."""
    plain = pd.read_parquet(cached_export(PROTOTYPE, days=8, start="03-06").measurements)
    windy = pd.read_parquet(cached_export(PROTOTYPE, days=8, start="03-06", wind=True).measurements)
    assert sorted(windy.columns) == sorted([*plain.columns, "wind"])
    pd.testing.assert_frame_equal(windy[plain.columns], plain)
    w = windy["wind"].to_numpy()
    assert np.isfinite(w).all() and w.min() >= 0.0 and w.max() < 60.0
    assert w.std() > 0.5  # [m/s] a weather file's wind, not a constant


def test_wind_probe_is_the_site_wind_speed_and_comes_last():
    from hvacfmu.energyplus.generate import export_probes

    plain = export_probes([], {}, ["Z"])
    probes = export_probes([], {}, ["Z"], wind=True)
    assert probes[:-1] == plain
    assert (probes[-1].column, probes[-1].variable, probes[-1].key) == ("wind", "Site Wind Speed", "Environment")
