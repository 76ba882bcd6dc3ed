"""The modal form of the native FMU (hvacfmu.fmu_native_modal): decomposition, grouping, verification, fallback."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.linalg import expm

from hvacfmu.fmu_native_modal import MODAL_ABOVE, modal_form, physical_step, real_eigen, symmetrizing_scale, verify
from hvacfmu.models.equations import ModelEquations, Switch


def rc_matrix(n, seed=0):
    """A discrete RC-network matrix expm(-diag(1/c) L h): symmetrisable by sqrt(c)."""
    rng = np.random.default_rng(seed)
    G = np.triu(rng.uniform(0, 5, (n, n)) * (rng.uniform(size=(n, n)) < 0.2), 1)
    G = G + G.T
    L = np.diag(G.sum(1) + rng.uniform(0.1, 1, n)) - G
    c = rng.uniform(1e3, 1e6, n)
    return expm(-(L / c[:, None]) * 900.0), c


def equations(A, seed=1, switches=()):
    """Bilinear equations around A: 3 inputs, 2 disturbances, 2 gains, outputs x[0], x[1]."""
    rng = np.random.default_rng(seed)
    n = A.shape[0]
    cols = [rng.uniform(0, 1e-3, n), rng.uniform(0, 1e-3, n)]  # box b's zone has its own column
    Bxu = tuple(np.outer(-cols[i % 2] * (1 + (i == 2)), np.eye(n)[i % 2]) for i in range(3))
    Bvu = tuple(np.outer(cols[i % 2] * (1 + (i == 2)), np.eye(2)[1]) for i in range(3))
    return ModelEquations(
        step=900.0,
        A=A,
        Bu=np.zeros((n, 3)),
        Bv=rng.uniform(0, 0.01, (n, 2)),
        Bq=rng.uniform(0, 0.01, (n, 2)),
        C=np.eye(n)[:2],
        inputs=("m_a", "m_b", "m_c"),
        disturbances=("T_out", "T_supply"),
        outputs=("a", "b"),
        gains={"winter": rng.uniform(0, 1, (672, 2))},
        Bxu=Bxu,
        Bvu=Bvu,
        switches=switches,
    )


def test_symmetrizing_scale_finds_the_capacities_of_an_rc_network():
    A, c = rc_matrix(60)
    d = symmetrizing_scale(A)
    assert d is not None
    r = d / np.sqrt(c)
    assert_allclose(r, r[0], rtol=1e-12)
    assert symmetrizing_scale(A + np.triu(np.full_like(A, 1e-3), 1)) is None  # not symmetrisable any more


def test_real_eigen_reconstructs_and_refuses_complex_or_defective():
    A, _ = rc_matrix(60)
    lam, V, W = real_eigen(A)
    assert_allclose((V * lam) @ W, A, rtol=0, atol=1e-13)
    assert_allclose(V @ W, np.eye(60), rtol=0, atol=1e-12)
    rot = np.array([[np.cos(0.1), -np.sin(0.1)], [np.sin(0.1), np.cos(0.1)]]) * 0.9
    assert real_eigen(rot) is None  # complex pair
    assert real_eigen(np.array([[0.9, 1.0], [0.0, 0.9]])) is None  # Jordan block


def test_modal_form_groups_bilinear_columns_and_verifies():
    A, _ = rc_matrix(40)
    sw = Switch(gain=np.linspace(0, 1, 40), input_index=0, input_below=0.2, disturbance_index=0, disturbance_below=10.0)
    eq = equations(A, switches=(sw,))
    form = modal_form(eq, [0, 1])
    assert form is not None
    # boxes a and c feed x[0]'s column (c twice), b its own; the v columns are the negatives: 2 groups
    assert form.n_rep == 2
    assert sorted(set(form.bt_alpha.tolist())) == [-2.0, -1.0, 1.0, 2.0]
    assert list(form.S_state) == [0, 1]
    assert verify(eq, form)
    # a form one part in 1e8 off is caught by the verification
    bad = dataclasses.replace(form, P=form.P * (1 + 1e-8))
    assert not verify(eq, bad)


def test_small_or_oscillating_models_keep_the_physical_form():
    A, _ = rc_matrix(MODAL_ABOVE)
    assert modal_form(equations(A), [0, 1]) is None  # small: the dense product is cheap
    n = 40
    A = np.zeros((n, n))
    A[0:2, 0:2] = [[0.8, -0.3], [0.3, 0.8]]  # a complex pair
    A[2:, 2:] = np.diag(np.linspace(0.1, 0.9, n - 2))
    assert modal_form(equations(A), [0, 1]) is None


def test_physical_step_is_the_equation():
    A, _ = rc_matrix(30)
    eq = equations(A)
    x, u, v, q = np.full(30, 20.0), np.array([0.1, 0.2, 0.3]), np.array([5.0, 14.0]), np.array([0.5, 0.7])
    expect = A @ x + eq.Bv @ v + eq.Bq @ q + sum(u[i] * (eq.Bxu[i] @ x + eq.Bvu[i] @ v) for i in range(3))
    assert_allclose(physical_step(eq, x, u, v, q), expect, rtol=1e-15)


@pytest.fixture(scope="module")
def physics_eq():
    from test_fmu import physics_model

    from hvacfmu.emulator import sdh_building

    return physics_model(sdh_building(nominal=True)).equations()


def test_physics_model_runs_in_modal_form(physics_eq):
    """Model B (269 states, 21 boxes in 6 zones): one column per zone, 6 physical states per step."""
    form = modal_form(physics_eq, list(range(6)))
    assert form is not None
    assert form.n_rep == 6
    assert list(form.S_state) == list(range(6))
    assert form.P.shape[1] <= 24  # T_out, 4 facades, 6 gains, 6 zone columns (T_supply only through the boxes)


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs the system C compiler gcc")
def test_forced_modal_c_runtime_with_map_bilinear_term_and_switch(tmp_path, monkeypatch):
    """The C runtime's modal branch on a small extended model (forced: MODAL_ABOVE = 0) with a box map,
    a bilinear supply-air term, a thermal-mass state and a reheat switch: two weeks in FMPy equal the
    Python model to 1e-9 K."""
    import pandas as pd
    from test_fmu_native import header, signals, simulate_year, zones_model

    import hvacfmu.fmu_native_modal as modal
    from hvacfmu.emulator import sdh_building
    from hvacfmu.fmu_native import export_native_fmu
    from hvacfmu.models.extended import ExtendedModel, Reheat, SolarGain, SupplyAirBilinear, ThermalMass

    base = zones_model(sdh_building(nominal=True))
    A = np.asarray(base.A)
    base = dataclasses.replace(base, A=0.5 * (A + A.T))  # symmetric: real eigenvalues (the test model's are complex)
    z = base.outputs
    model = ExtendedModel(
        base=base,
        terms=(
            ThermalMass(zone=z[1], alpha=0.02, beta=0.05),
            SupplyAirBilinear(zone=z[2], coef=0.02),
            SolarGain(zone=z[4], facade="W", coef=4e-4),
            Reheat(zone=z[5], coef=0.05, u_min=1.2, T_threshold=14.0),  # zone C: 5 boxes, summed airflow
        ),
    )
    eq = model.equations()
    assert eq.switches and eq.bilinear
    monkeypatch.setattr(modal, "MODAL_ABOVE", 0)
    path = export_native_fmu(model, tmp_path / "modal.fmu")
    assert "#define HV_MODAL 1" in header(path)
    Y, Yref = simulate_year(model, path, 2 * 672)
    assert_allclose(Y, Yref[: len(Y)], rtol=0, atol=1e-9)  # [K]
    assert np.ptp(Yref) > 1.0
    idx, cols, _, _ = signals(model, 2 * 672)
    u, v = model.signals(pd.DataFrame(cols, index=idx))
    assert 0.1 < eq.switches[0].active(u, v).mean() < 0.9  # the reheat switch turns on and off
