"""Model A's open-loop refinement (hvacfmu.models.openloop): the linear gain form, the exact Jacobian, couplings.

Data are simulated by known six-zone models (delivered-heat and airflow forms, from
test_delivered_heat / test_datadriven) and read back through hvacfmu.data.prepare.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from hvacfmu.building import building_from_dict
from hvacfmu.errors import FitError, HvacfmuWarning
from hvacfmu.models import datadriven, openloop
from hvacfmu.models.datadriven import fit_zones
from tests.test_datadriven import simulate_frame, six_zone_building_dict, true_zone_model, write_dataset
from tests.test_delivered_heat import delivered_truth


@pytest.fixture(scope="module")
def building():
    return building_from_dict(six_zone_building_dict())


@pytest.fixture(scope="module", params=["delivered", pytest.param("airflow", marks=pytest.mark.slow)])
def case(request, tmp_path_factory, building):
    """(dataset, one-step fitted model) of either heat form; 6 weeks keep the module fast. The fast tier runs the
    delivered-heat form (the default for reheat data); the airflow form's copies of the tests are ``slow``."""
    truth = delivered_truth(building) if request.param == "delivered" else true_zone_model(building)
    frame = simulate_frame(truth, building, weeks=6, seed=5)
    if request.param == "airflow":
        frame = frame.drop(columns=[c for c in frame.columns if c.startswith("Td_")])
    ds = write_dataset(tmp_path_factory.mktemp(request.param), frame, six_zone_building_dict())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        model = fit_zones(ds, open_loop=False, heat=request.param)
    assert model.heat == request.param
    return ds, model


def _problem(ds, model, couplings):
    prep = datadriven._Prepared(ds, datadriven._options({"heat": model.heat}))
    starts = openloop.training_windows(prep, 96)
    assert starts.size >= 7
    return openloop._Problem(model, prep, starts, 96, couplings=couplings)


def _perturbed(pb, seed=0):
    """A parameter vector inside the bounds, away from the start (couplings given a value of their own)."""
    rng = np.random.default_rng(seed)
    th = pb.theta0 * (1.0 + 0.2 * rng.standard_normal(pb.n_par))
    th[2 * pb.nx + int(pb.cmask.sum()) :] = rng.uniform(0.0, 0.03, int(pb.omask.sum()))
    return np.clip(th, pb.lb, np.minimum(pb.ub - 1e-6, 10.0))


@pytest.mark.parametrize("couplings", [False, True])
def test_linear_gains_and_window_errors_equal_the_model_simulation(case, couplings):
    """The affine gain form and the fast window simulation are the model's own: gains_for and simulate agree."""
    ds, model = case
    pb = _problem(ds, model, couplings)
    th = _perturbed(pb)
    ref = pb.with_theta(th)  # gains re-estimated through model.step_state
    lin = pb.gains_of(th)
    assert set(lin) == set(ref.gains)
    for s in lin:
        np.testing.assert_allclose(lin[s], np.asarray(ref.gains[s]), atol=1e-12, rtol=0)
    q = np.zeros(pb.rng.shape + (pb.nx,))
    for s, prof in ref.gains.items():
        sel = pb.seasons[pb.rng[:, 0]] == s
        q[sel] = np.asarray(prof)[pb.slots[pb.rng[sel]] % len(prof)]
    _, Yp = ref.simulate(pb.Y[pb.rng[:, 0]], pb.u[pb.rng], pb.v[pb.rng], q)
    expected = ((pb.Y[pb.rng + 1] - Yp[:, 1:, :]) * pb.weight).ravel()
    got = pb.residuals(th)[: expected.size]
    np.testing.assert_allclose(got, expected, atol=1e-11, rtol=0)
    if couplings:
        np.testing.assert_array_equal(ref.A != 0, (ref.A != 0) & (pb.omask | np.eye(pb.nx, dtype=bool)))


@pytest.mark.parametrize("couplings", [False, True])
def test_exact_jacobian_matches_central_differences(case, couplings):
    ds, model = case
    pb = _problem(ds, model, couplings)
    th = _perturbed(pb, seed=1)
    J = pb.jacobian(th)
    assert J.shape == (pb.residuals(th).size, pb.n_par)
    Jfd = np.empty_like(J)
    for p in range(pb.n_par):
        h = 1e-6 * max(1.0, abs(th[p]))
        e = np.zeros(pb.n_par)
        e[p] = h
        Jfd[:, p] = (pb.residuals(th + e) - pb.residuals(th - e)) / (2 * h)
    scale = np.max(np.abs(Jfd), axis=0)
    assert np.all(scale > 0), "every parameter moves the errors"
    np.testing.assert_array_less(np.max(np.abs(J - Jfd), axis=0), 1e-6 * scale)


def test_couplings_are_refitted_stable_and_only_between_adjacent_zones(case, building):
    ds, model = case
    prep = datadriven._Prepared(ds, datadriven._options({"heat": model.heat}))
    plain, info0 = openloop.refine_open_loop(model, prep)
    coupled, info1 = openloop.refine_open_loop(model, prep, couplings=True, max_nfev=25)
    assert info0["used"] and info1["used"]
    assert info1["rms_after"] < info1["rms_before"]
    adjacent = openloop._adjacent_mask(model, building)
    off = ~np.eye(model.n_states, dtype=bool)
    np.testing.assert_array_equal(coupled.A[off & ~adjacent], 0.0)
    np.testing.assert_array_equal(plain.A[off], model.A[off])  # without couplings they stay the one-step values
    assert np.any(np.abs(coupled.A[adjacent] - model.A[adjacent]) > 1e-4)
    assert np.all(coupled.A >= 0.0)
    assert np.all(np.abs(coupled.A).sum(axis=1) <= 1.0 - 1e-3 + 1e-9)
    assert max(abs(np.linalg.eigvals(coupled.A))) < 1.0


def test_fit_option_and_command_line(case, tmp_path, cli, monkeypatch):
    """The command line in-process (``cli``): a usage error; the real ``fit`` subprocess is in test_delivered_heat."""
    ds, _ = case
    with pytest.raises(FitError, match="open_loop_couplings must be True or False"):
        fit_zones(ds, open_loop_couplings="yes")
    monkeypatch.chdir(tmp_path)
    bad = cli("fit", "x.csv", "-b", "b.toml", "-m", "lumped", "-o", "m.json", "--couplings")
    assert bad.returncode == 2 and "--couplings applies to the six-zone Model A" in bad.stderr
