"""Model A identification: LOESS, cross-validation, Bayesian constrained LS, internal gains, fits.

Parameter recovery uses data simulated from a known Model A with process and
measurement noise, written to a Parquet file and read back through
:func:`hvacfmu.data.prepare`, so the whole path (loading, weeks, split) is exercised.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from hvacfmu.building import building_from_dict
from hvacfmu.errors import BuildingError, FitError, HvacfmuWarning
from hvacfmu.models import load_model
from hvacfmu.models.datadriven import (
    bayes_cls,
    cv_bandwidth,
    estimate_gains,
    excitation_prior_b,
    fit_lumped,
    fit_zones,
    loess_smooth,
    tricube,
)
from hvacfmu.models.linear import LinearZoneModel
from hvacfmu.timeutil import time_of_week

STEP = 900.0
TZ = "America/Los_Angeles"

# ----------------------------------------------------------------------------- synthetic building and truth
ZONES6 = ("NW", "W", "S", "E", "NE", "C")
ADJ6 = {"NW": ["W", "NE", "C"], "W": ["NW", "S", "C"], "S": ["W", "E", "C"], "E": ["S", "NE", "C"],
        "NE": ["NW", "E", "C"], "C": ["NW", "W", "S", "E", "NE"]}
FAC6 = {"NW": ["N", "W"], "W": ["W"], "S": ["S"], "E": ["E"], "NE": ["N", "E"], "C": []}
VOL6 = {"NW": 900.0, "W": 700.0, "S": 1100.0, "E": 800.0, "NE": 600.0, "C": 1500.0}


def six_zone_building_dict():
    zones = [
        {"name": z, "area": VOL6[z] / 3.0, "volume": VOL6[z], "adjacent": ADJ6[z],
         "facades": [{"orientation": o, "window_area": 30.0, "wall_area": 40.0} for o in FAC6[z]]}
        for z in ZONES6
    ]
    vavs = []
    for z in ZONES6:
        for k in range(2):
            vavs.append({"name": f"V_{z}_{k}", "zone": z, "m_min": 0.05, "m_max": 0.6})
    return {"name": "synthetic six zones", "latitude": 37.875, "longitude": -122.259, "timezone": TZ,
            "zones": zones, "vavs": vavs}


def true_zone_model(building):
    """A known six-zone Model A with physically plausible, stable coefficients."""
    zn = building.zone_names
    nz = len(zn)
    pos = {z: i for i, z in enumerate(zn)}
    A = np.zeros((nz, nz))
    for i, z in enumerate(zn):
        for o in ADJ6[z]:
            A[i, pos[o]] = 0.02
        A[i, i] = 0.90 - 0.02 * len(ADJ6[z])
    vols = np.array([building.zone(z).volume for z in zn])
    B = np.diag(-0.30 * vols.mean() / vols)  # smaller zones cool faster [K per step per kg/s]
    orient = ("N", "E", "S", "W")
    dist = ("T_out", "T_supply") + tuple(f"I_{o}" for o in orient)
    C = np.zeros((nz, len(dist)))
    for i, z in enumerate(zn):
        C[i, 0] = 0.015 if FAC6[z] else 0.004
        C[i, 1] = 0.03
        for o in FAC6[z]:
            C[i, 2 + orient.index(o)] = 4e-4
    return LinearZoneModel(
        kind="zones", step=STEP, outputs=zn, measured_zones=zn, output_weights=np.eye(nz),
        vavs=building.vav_names, input_map=building.zone_vav_matrix(), disturbances=dist,
        A=A, B=B, C=C, gains={s: true_gain_profile(s, nz) for s in ("fall", "winter", "spring")},
    )


def true_lumped_model(building):
    w = building.area_weights()
    dist = ("T_out", "T_supply", "I_N", "I_E", "I_S", "I_W")
    return LinearZoneModel(
        kind="lumped", step=STEP, outputs=("floor",), measured_zones=building.zone_names,
        output_weights=w[None, :], vavs=building.vav_names, input_map=np.ones((1, len(building.vavs))),
        disturbances=dist, A=np.array([[0.88]]), B=np.array([[-0.05]]),
        C=np.array([[0.02, 0.04, 1e-4, 2e-4, 3e-4, 2e-4]]),
        gains={s: true_gain_profile(s, 1) for s in ("fall", "winter", "spring")},
    )


def true_gain_profile(season, nq):
    """Smooth weekday occupancy bumps [K per step]; weekend lower; season-dependent level."""
    level = {"fall": 1.0, "winter": 0.5, "spring": 0.8}[season]
    h = np.arange(672) * 0.25 % 24.0
    day = np.arange(672) // 96
    bump = np.exp(-0.5 * ((h - 14.0) / 3.0) ** 2)
    weekday = np.where(day < 5, 1.0, 0.3)
    prof = np.empty((672, nq))
    for j in range(nq):
        prof[:, j] = 1.2 + 0.05 * j + 0.25 * level * (1 + 0.2 * j) * weekday * bump
    return prof


def simulate_frame(model, building, weeks=14, start="2025-11-03", seed=0, noise=(0.01, 0.02)):
    """Simulate ``model`` with random exogenous airflows and weather; canonical measurement columns.

    Airflows are piecewise constant at random levels (held 1-6 h), with
    Saturday excitation experiments switching all boxes between their limits
    every 2 h. Process noise sd ``noise[0]`` [K], measurement noise sd ``noise[1]`` [K].
    """
    rng = np.random.default_rng(seed)
    idx = pd.date_range(pd.Timestamp(start, tz=TZ), periods=weeks * 672, freq="15min")
    n = len(idx)
    hours = np.arange(n) * 0.25
    nvav = len(building.vavs)
    m = np.empty((n, nvav))
    for j in range(nvav):
        k = 0
        while k < n:
            hold = int(rng.integers(4, 25))
            m[k:k + hold, j] = rng.uniform(0.1, 0.55)
            k += hold
    sat = idx.dayofweek == 5
    exc = np.zeros(n)
    exc[sat] = 1.0
    phase = ((hours // 2) % 2).astype(bool)
    m[sat & phase] = 0.6
    m[sat & ~phase] = 0.05
    T_out = 12 + 5 * np.sin(2 * np.pi * (hours - 9) / 24) + np.cumsum(rng.normal(0, 0.05, n))
    T_out = T_out - np.convolve(T_out - 12, np.ones(2000) / 2000, mode="same")
    T_sup = 14 + np.repeat(rng.normal(0, 1.0, n // 8 + 1), 8)[:n]
    sun = np.clip(np.sin(2 * np.pi * (hours - 6) / 24), 0, None)
    cloud = np.repeat(rng.uniform(0.3, 1.0, n // 96 + 1), 96)[:n]
    I = {o: 300 * sun * cloud * f for o, f in zip("NESW", (0.3, 0.8, 1.0, 0.7))}
    I["E"] *= hours % 24 < 12
    I["W"] *= hours % 24 >= 12
    frame = pd.DataFrame({f"m_{b}": m[:, j] for j, b in enumerate(building.vav_names)}, index=idx)
    frame["T_supply"] = T_sup
    frame["T_out"] = T_out
    for o in "NESW":
        frame[f"I_{o}"] = I[o]
    frame["excitation"] = exc
    u, v = model.signals(frame)
    season = np.array([building.season_of(t) for t in idx.normalize()[::96]], dtype=object).repeat(96)[:n]
    q = np.empty((n, model.n_states))
    for s in set(season):
        sel = season == s
        q[sel] = model.gains_at(idx[sel], s)
    nx = model.n_states
    X = np.empty((n, nx))
    x = np.full(nx, 21.0)
    for k in range(n):
        X[k] = x
        x = model.step_state(x, u[k], v[k], q[k]) + rng.normal(0, noise[0], nx)
    if model.kind == "lumped":
        # spread the floor temperature over zones with zero-mean area-weighted offsets
        w = model.output_weights[0]
        off = rng.normal(0, 0.3, len(w))
        off -= off @ w
        T = X[:, :1] + off[None, :]
    else:
        T = X
    T = T + rng.normal(0, noise[1], T.shape)
    for j, z in enumerate(building.zone_names):
        frame[f"T_{z}"] = T[:, j]
    frame.index.name = "time"
    return frame


def write_dataset(tmp_path, frame, building_dict, name="data"):
    """Write the frame as Parquet and prepare it through hvacfmu.data."""
    from hvacfmu.data import prepare

    path = tmp_path / f"{name}.parquet"
    frame.to_parquet(path)
    bpath = tmp_path / f"{name}_building.toml"
    building_from_dict(building_dict).save(bpath)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(path, bpath, step=STEP, seed=0)


@pytest.fixture(scope="module")
def six_building():
    return building_from_dict(six_zone_building_dict())


@pytest.fixture(scope="module")
def zone_truth(six_building):
    return true_zone_model(six_building)


@pytest.fixture(scope="module")
def zone_dataset(tmp_path_factory, six_building, zone_truth):
    frame = simulate_frame(zone_truth, six_building, seed=1)
    return write_dataset(tmp_path_factory.mktemp("zones"), frame, six_zone_building_dict())


@pytest.fixture(scope="module")
def lumped_truth(six_building):
    return true_lumped_model(six_building)


@pytest.fixture(scope="module")
def lumped_dataset(tmp_path_factory, six_building, lumped_truth):
    frame = simulate_frame(lumped_truth, six_building, seed=2)
    return write_dataset(tmp_path_factory.mktemp("lumped"), frame, six_zone_building_dict())


@pytest.fixture(scope="module")
def zone_fit(zone_dataset):
    with warnings.catch_warnings():
        warnings.simplefilter("error", HvacfmuWarning)
        return fit_zones(zone_dataset)


@pytest.fixture(scope="module")
def lumped_fit(lumped_dataset):
    with warnings.catch_warnings():
        warnings.simplefilter("error", HvacfmuWarning)
        return fit_lumped(lumped_dataset)
