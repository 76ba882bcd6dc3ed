"""Shared fixtures: small hand-written buildings and models, session-scoped expensive data."""

from __future__ import annotations

import numpy as np
import pytest

from hvacfmu.building import building_from_dict

SMALL_BUILDING = {
    "name": "two rooms",
    "latitude": 37.875,
    "longitude": -122.259,
    "timezone": "America/Los_Angeles",
    "zones": [
        {
            "name": "A",
            "area": 100.0,
            "volume": 300.0,
            "adjacent": ["B"],
            "facades": [{"orientation": "S", "window_area": 10.0, "wall_area": 20.0}],
        },
        {
            "name": "B",
            "area": 50.0,
            "volume": 150.0,
            "adjacent": ["A"],
            "facades": [{"orientation": "N", "window_area": 5.0, "wall_area": 10.0}],
        },
    ],
    "vavs": [
        {"name": "V1", "zone": "A", "m_min": 0.05, "m_max": 0.6},
        {"name": "V2", "zone": "A", "m_min": 0.05, "m_max": 0.6},
        {"name": "V3", "zone": "B", "m_min": 0.03, "m_max": 0.4},
    ],
}


@pytest.fixture
def small_building_dict():
    import copy

    return copy.deepcopy(SMALL_BUILDING)


@pytest.fixture
def small_building():
    return building_from_dict(SMALL_BUILDING)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def default_dataset():
    """The emulator's default 51-week dataset, prepared (generated once into $HVACFMU_CACHE)."""
    import warnings

    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.errors import HvacfmuWarning

    paths = cached_dataset()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(paths.measurements, paths.building)


@pytest.fixture(scope="session")
def default_paths():
    """Files of the emulator's default dataset (51 weeks, seed 0), generated once into $HVACFMU_CACHE."""
    from hvacfmu.emulator import cached_dataset

    return cached_dataset(weeks=51, seed=0)


@pytest.fixture(scope="session")
def short_paths():
    """Files of a short emulator dataset (8 weeks, seed 0), generated once into $HVACFMU_CACHE."""
    from hvacfmu.emulator import cached_dataset

    return cached_dataset(weeks=8, seed=0)
