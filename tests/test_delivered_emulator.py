"""Delivered heat on the emulator's real-BMS-like reheat mode (issue 13 p.3-4): verdict against the baselines,
and FMU export of the delivered-heat forms (per-box airflow and discharge-temperature inputs)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

from hvacfmu.errors import HvacfmuWarning

REHEAT = {"hvac": "reheat", "start": "2025-11-03T00:00:00"}


def _prepare(weeks):
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(weeks=weeks, seed=0, **REHEAT)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(paths.measurements, paths.building)


@pytest.mark.slow
def test_reheat_data_delivered_model_beats_baselines():
    """16 weeks fall-spring, two air handlers, reheat at minimum airflow; 24-hour open-loop RMS per zone.

    Measured here: Model A with Td 0.18 K mean (fall 0.18, winter 0.14, spring 0.22), persistence 1.02 K,
    time-of-week mean 0.28 K; against time-of-week it wins all 24 zone-season cells, by 7 % (fall NE) to
    59 % (winter S). Before the delivered form was refined for 24-h prediction by default (the training weeks
    hold airflow experiments): 0.24 K, losing winter NE (0.145 against 0.136 K) and tying winter C.
    Bounds: below persistence by at least 30 % in every zone and season; below time-of-week in every zone
    and season.
    Also measured, and stated rather than asserted as a loss: the airflow form without the Td columns
    reaches 0.25 K on these data; the delivered form must not be worse than it.
    """
    from hvacfmu.data.dataset import Dataset
    from hvacfmu.evaluation import evaluate
    from hvacfmu.models.datadriven import fit_zones

    ds = _prepare(16)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        model = fit_zones(ds)
        frame = ds.frame.drop(columns=[c for c in ds.frame.columns if c.startswith("Td_")])
        blind = fit_zones(Dataset.from_frame(frame, ds.building, step=ds.step, seed=0))
    assert model.heat == "delivered" and all(c.startswith("Td_") for c in model.inlets)
    assert blind.heat == "airflow"
    res = evaluate([model, blind], ds, names=["Td", "no Td"])
    rms = res.table("Td")
    pers = res.table("Td", which="persistence").loc[rms.index, rms.columns]
    assert np.all(rms.to_numpy() < 0.7 * pers.to_numpy()), (rms, pers)
    tow = res.table("Td", which="time-of-week mean").loc[rms.index, rms.columns]
    assert np.all(rms.to_numpy() < tow.to_numpy()), (rms, tow)
    assert rms.loc["all", "mean"] <= res.table("no Td").loc["all", "mean"] + 1e-3


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["zones", "lumped", "physics"])
def test_delivered_forms_export_to_fmu(kind, tmp_path):
    """Fit on reheat data (inputs: m_<vav> per box, disturbances incl. Td_<vav>), export, FMPy == Python."""
    from hvacfmu.fitting import fit
    from hvacfmu.fmu import export_fmu, validate
    from hvacfmu.models import load_model
    from tests.test_registry import EXACT, _fmu_run, _reference, _two_days

    ds = _prepare(3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        opts = {"max_nfev": 3, "max_segments": 4} if kind == "physics" else {}
        model = fit(ds, kind, progress=False, **opts)
    assert any(d.startswith("Td_") for d in model.disturbances)
    path = model.save(tmp_path / f"{kind}.json")
    loaded = load_model(path)
    fmu = export_fmu(path, tmp_path / f"{kind}.fmu", timezone=ds.building.timezone)
    assert validate(fmu) == []
    week, frame = _two_days(ds, loaded)
    assert_allclose(
        _fmu_run(fmu, loaded, frame, week.season), _reference(loaded, frame, week.season), rtol=0, atol=EXACT
    )  # [K]


@pytest.mark.slow
def test_reheat_data_physics_with_discharge_air_beats_baselines_everywhere():
    """Model B with per-box Td inlets on the same 16 weeks (one fit, about a minute).

    Measured here: 0.16 K mean (fall 0.17, winter 0.12, spring 0.21; 0.18 K with the adiabatic slabs of
    the emulator-1.3 building file) against time-of-week 0.28 K and persistence 1.02 K, the closest cell
    fall E (+1.9 % against time-of-week); without the Td columns (airflow times the units' supply) 0.25 K.
    Step 2's other profiles on the same step-1 fit (README "Where physics loses"): ``gain_days="workdays"``
    0.150 K, ``"shrunk"`` 0.153 K, better in most cells but both lose fall E (-3.3 %, -2.2 %): that cell is one
    test week whose Wednesday and Friday levels happened to sit near their training weekdays' means.
    ``"auto"`` (the profile with the lowest blocked-CV RMS over the training weeks; the default since session 8,
    when ten new seven-week winter exports and the earlier eleven data sets gave it a lower RMS on all but one)
    chooses ``"shrunk"`` here and loses that cell as well (-2.2 %). On seeds 1 and 2 of these data every profile
    loses fall C (by 13-55 %).
    Bounds: with ``"week"`` below time-of-week and below 70 % of persistence in every zone and season; with the
    default (``"auto"``, same step 1) a lower mean RMS than ``"week"``, below 70 % of persistence in every zone and
    season and below time-of-week in every zone over all windows.
    """
    from hvacfmu.evaluation import evaluate
    from hvacfmu.models.physics import fit_physics, refit_gains

    ds = _prepare(16)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        model = fit_physics(ds, progress=False, gain_days="week")
    assert all(c.startswith("Td_") for c in model.meta["inlets"].values())
    res = evaluate([model], ds, names=["physics"])
    rms = res.table("physics")
    for base, factor in (("persistence", 0.7), ("time-of-week mean", 1.0)):
        ref = res.table("physics", which=base).loc[rms.index, rms.columns]
        assert np.all(rms.to_numpy() < factor * ref.to_numpy()), (base, rms, ref)
    auto = refit_gains(model, ds, "auto")
    res_a = evaluate([auto], ds, names=["physics"])
    rms_a = res_a.table("physics")
    assert np.nanmean(rms_a.loc["all"]) < np.nanmean(rms.loc["all"]), (rms_a, rms)
    pers = res_a.table("physics", which="persistence").loc[rms_a.index, rms_a.columns]
    assert np.all(rms_a.to_numpy() < 0.7 * pers.to_numpy()), (rms_a, pers)
    tow = res_a.table("physics", which="time-of-week mean").loc["all", rms_a.columns]
    assert np.all(rms_a.loc["all"] < tow), (rms_a.loc["all"], tow)
