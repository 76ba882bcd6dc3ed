"""Model A with one coefficient set per season (issue 13 p.8, benchmarks/seasons_s21.md).

The memory check's per-season choice (``memory_select="season"``) was measured in session 20 and could not ship:
the model, its file, the FMUs and the MPC held one ``A``/``B``/``C``. :class:`SeasonalZoneModel` holds one set per
season; every consumer that fixes a season runs ``for_season(season)``; a use that does not choose one is refused.
On main none of this exists (the module's import fails: every test here fails there).
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from hvacfmu.errors import FitError, FMUError, HvacfmuWarning, ModelError
from hvacfmu.models import load_model, memory, model_from_dict
from hvacfmu.models.linear import LinearZoneModel, SeasonalZoneModel
from hvacfmu.timeutil import n_time_of_week
from tests.test_memory_s19 import data  # noqa: F401  (the module-scoped dataset fixture)

EXACT = 1e-9  # [K] FMU against the Python model (both run the same double-precision recursion)


def _set(seed: int, a: float, b: float, nz: int = 2, seasons=("winter", "summer")) -> LinearZoneModel:
    """A two-zone, three-box airflow-form Model A; ``a`` its zones' own memory, ``b`` their airflow gain."""
    rng = np.random.default_rng(seed)
    return LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=("A", "B"),
        measured_zones=("A", "B"),
        output_weights=np.eye(nz),
        vavs=("V1", "V2", "V3"),
        input_map=np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
        disturbances=("T_out", "T_supply"),
        A=np.array([[a, 0.02], [0.03, a - 0.02]]),
        B=-np.diag([b, 1.2 * b]),
        C=np.array([[0.05, 0.03], [0.06, 0.04]]) * (1.0 - a) / 0.1,
        gains={s: rng.uniform(0.5, 1.5, (n_time_of_week(900.0), nz)) * (1.0 - a) for s in seasons},
        meta={"note": f"set {seed}"},
    )


def two_season() -> SeasonalZoneModel:
    """Winter: a slow, floating building; summer: a fast one, held by its boxes (sets that differ)."""
    return SeasonalZoneModel(sets={"winter": _set(0, 0.95, 0.5), "summer": _set(1, 0.60, 2.0)}, meta={"fit": "test"})


def _signals(n: int, seed: int = 3):
    rng = np.random.default_rng(seed)
    m = rng.uniform(0.02, 0.4, (n, 3))
    v = np.column_stack([rng.uniform(0, 30, n), rng.uniform(12, 15, n)])
    return m, v


# ----------------------------------------------------------------------------- the model
def test_for_season_is_an_ordinary_model_of_that_seasons_set():
    sm = two_season()
    assert sm.seasonal and sm.seasons == ("winter", "summer") and sm.kind == "zones"
    assert sm.inputs == ("m_A", "m_B") and sm.outputs == ("A", "B") and sm.n_states == 2
    w, s = sm.for_season("winter"), sm.for_season("summer")
    assert type(w) is LinearZoneModel and not w.seasonal
    assert_allclose(w.A, _set(0, 0.95, 0.5).A, rtol=0, atol=0)
    assert_allclose(s.B, _set(1, 0.60, 2.0).B, rtol=0, atol=0)
    assert list(w.gains) == ["winter"] and list(s.gains) == ["summer"]  # a set runs only in its own season
    assert_allclose(sm.gains["summer"], _set(1, 0.60, 2.0).gains["summer"], rtol=0, atol=0)
    assert w.meta["season_set"] == "winter" and w.meta["fit"] == "test"
    with pytest.raises(ModelError, match="no coefficient set for season 'fall'"):
        sm.for_season("fall")
    with pytest.raises(ModelError, match="no internal-gain profile for season 'summer'"):
        w.gains_at(pd.date_range("2025-01-06", periods=4, freq="15min", tz="UTC"), "summer")
    # a model of one set is its own season's model
    one = _set(0, 0.9, 1.0)
    assert one.for_season("summer") is one and not one.seasonal


@pytest.mark.parametrize(
    "use",
    [
        lambda m: m.A,
        lambda m: m.B,
        lambda m: m.C,
        lambda m: m.beta,
        lambda m: m.equations(),
        lambda m: m.step_state(np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2)),
        lambda m: m.simulate(np.zeros(2), np.zeros((3, 2)), np.zeros((3, 2)), np.zeros((3, 2))),
    ],
)
def test_a_use_without_a_season_is_refused(use):
    """Never one season's set silently all year: whatever reads coefficients or steps without a season fails."""
    with pytest.raises(ModelError, match="one coefficient set per season .*needs the season chosen first"):
        use(two_season())


def test_sets_must_share_their_structure():
    other = LinearZoneModel(
        **{
            **{k: getattr(_set(1, 0.6, 2.0), k) for k in ("kind", "step", "measured_zones", "vavs", "input_map")},
            "outputs": ("A", "B"),
            "output_weights": np.eye(2),
            "disturbances": ("T_out", "T_supply"),
            "A": np.eye(2) * 0.5,
            "B": -np.eye(2),
            "C": np.zeros((2, 2)),
            "gains": {"summer": np.zeros((672, 2))},
            "holidays": ("2025-12-25",),
        }
    )
    with pytest.raises(ModelError, match="differs from the others' structure in \\['holidays'\\]"):
        SeasonalZoneModel(sets={"winter": _set(0, 0.95, 0.5), "summer": other})


# ----------------------------------------------------------------------------- the model file
def test_file_round_trip_seal_and_old_files(tmp_path):
    sm = two_season()
    path = sm.save(tmp_path / "seasonal.json")
    d = json.loads(path.read_text())
    assert d["format_version"] == 2 and "A" not in d and set(d["seasonal"]) == {"winter", "summer"}
    back = load_model(path)
    assert isinstance(back, SeasonalZoneModel)
    for s in sm.seasons:
        for k in ("A", "B", "C"):
            assert_allclose(getattr(back.for_season(s), k), getattr(sm.for_season(s), k), rtol=0, atol=0)
        assert_allclose(back.gains[s], sm.gains[s], rtol=0, atol=0)
    assert back.meta["coefficients_sha256"]
    # the seal covers every season's numbers: an edited summer coefficient warns at load
    d["seasonal"]["summer"]["A"][0][0] = 0.61
    path.write_text(json.dumps(d))
    with pytest.warns(HvacfmuWarning, match="changed after hvacfmu wrote the file"):
        load_model(path)
    # a file of one set is written and read as before (format 1, no seasonal block)
    one = _set(0, 0.9, 1.0)
    d1 = json.loads(one.save(tmp_path / "one.json").read_text())
    assert d1["format_version"] == 1 and "seasonal" not in d1 and "A" in d1
    assert type(load_model(tmp_path / "one.json")) is LinearZoneModel
    # version 2 needs the block; a block needs version 2; the block's seasons are the gain profiles'
    with pytest.raises(ModelError, match="newer than this hvacfmu understands"):
        model_from_dict({**d1, "format_version": 2})
    good = sm.to_dict()
    with pytest.raises(ModelError, match="needs format_version 2"):
        model_from_dict({**good, "format_version": 1})
    with pytest.raises(ModelError, match="must be the gain profiles'"):
        model_from_dict({**good, "gains": {"winter": good["gains"]["winter"]}})


def test_load_checks_run_on_every_season_set(small_building):
    """An unstable summer set (edited file) is refused naming the season; the box-drive check too."""
    from hvacfmu.models.loadcheck import box_drive_problems

    d = two_season().to_dict()
    d["seasonal"]["summer"]["A"] = [[1.2, 0.0], [0.0, 0.5]]
    with pytest.raises(ModelError, match="season summer: .*spectral radius"):
        model_from_dict(d)
    b = small_building
    big = SeasonalZoneModel(sets={"winter": _set(0, 0.95, 0.5), "summer": _set(1, 0.6, 40.0)})
    problems = box_drive_problems(big, b)
    assert problems and all(p.startswith("season summer: ") for p in problems)
    assert box_drive_problems(two_season(), b) == []


# ----------------------------------------------------------------------------- the fit's rule
def test_season_sets_keeps_each_seasons_best_candidate():
    a, b = (
        _set(0, 0.95, 0.5, seasons=("winter", "summer", "fall")),
        _set(1, 0.6, 2.0, seasons=("winter", "summer", "fall")),
    )
    model, pick = memory.season_sets({"fit": a, "slow": b}, {"winter": "slow", "summer": "fit"}, "slow")
    assert pick == {"winter": "slow", "summer": "fit", "fall": "slow"}  # fall not scored: the year's pick
    assert model.seasonal and model.seasons == ("winter", "summer", "fall")
    assert_allclose(model.for_season("winter").A, b.A, rtol=0, atol=0)
    assert_allclose(model.for_season("summer").A, a.A, rtol=0, atol=0)
    assert_allclose(model.gains["summer"], a.gains["summer"], rtol=0, atol=0)  # the candidate's own profile
    same, pick = memory.season_sets({"fit": a, "slow": b}, {"winter": "fit", "summer": "fit"}, "fit")
    assert same is a and set(pick.values()) == {"fit"}  # one candidate everywhere: an ordinary model
    assert "season" in memory.SELECT_RULES


def test_the_fit_option_checks_every_set_and_evaluates_per_season():
    """check_fitted runs on every set (a refusal names the season), evaluation runs each window's season's set."""
    from hvacfmu.models.plausibility import check_fitted

    sm = two_season()
    checked = check_fitted(sm, None, warn=lambda m: None)
    assert set(checked.meta["plausibility"]["seasons"]) == {"winter", "summer"}
    assert checked.for_season("summer").meta["plausibility"]["spectral_radius"] < 1
    bad = SeasonalZoneModel(sets={"winter": _set(0, 0.95, 0.5), "summer": _set(1, 1.05, 2.0)})
    with pytest.raises(FitError, match="season summer's coefficient set"):
        check_fitted(bad, None, warn=lambda m: None)


@pytest.mark.slow
def test_memory_select_season_in_fit_zones(data, tmp_path):  # noqa: F811
    """The option runs inside the fit: each season's set is the candidate meta names for it (a forced forgetful
    fit on the 6-week fixture of test_memory_s19), and the model survives its file. The fixture's weeks are all
    fall, so the fit keeps one set (an ordinary model); a model of several sets is composed by
    :func:`memory.season_sets` (tested above) and measured on the EnergyPlus apartments (seasons_s21.md)."""
    from hvacfmu.models.datadriven import fit_zones
    from tests.test_memory_s19 import FORGETFUL

    _, ds = data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        model = fit_zones(ds, memory_select="season", **FORGETFUL)
    info = model.meta["memory"]
    pick = info["selection"]["season_sets"]
    assert info["selection"]["rule"] == "season" and set(pick) == set(model.gains)
    for s, name in pick.items():
        run = model.for_season(s)
        assert_allclose(np.diag(run.A), info["candidates"][name]["A_diag"], rtol=0, atol=0)
    assert bool(getattr(model, "seasonal", False)) == (len(set(pick.values())) > 1)
    back = load_model(model.save(tmp_path / "m.json"))
    for s in pick:
        assert_allclose(back.for_season(s).A, model.for_season(s).A, rtol=0, atol=0)


# ----------------------------------------------------------------------------- FMUs
def _python(model, season, idx, m, v, y0):
    from hvacfmu.models.state import state_from_outputs

    run = model.for_season(season)
    u = m @ run.input_map.T
    q = run.gains_at(idx, season)
    _, Y = run.simulate(state_from_outputs(run, y0, u[0], v[0], q[0]), u, v, q)
    return Y


@pytest.mark.slow
@pytest.mark.parametrize("native", [False, True])
def test_both_fmus_run_the_set_of_their_season_parameter(tmp_path, native):
    """The pythonfmu FMU and the native C FMU of a two-season model, run through FMPy for each season: equal to
    the Python simulation of that season's set within 1e-9 K; the two seasons' outputs differ by kelvins."""
    from hvacfmu.fmu import export_fmu, export_native_fmu
    from tests.test_fmu import Slave, run_fmu

    sm = two_season()
    path = (
        export_native_fmu(sm, tmp_path / "S.fmu", model_name="seasonal")
        if native
        else export_fmu(sm.save(tmp_path / "s.json"), tmp_path / "S.fmu")
    )
    from fmpy import read_model_description

    season_var = {v.name: v for v in read_model_description(str(path)).modelVariables}["season"]
    assert "1 = winter, 2 = summer" in season_var.description and "coefficient set" in season_var.description
    n = 192
    idx = pd.date_range("2025-01-06", periods=n, freq="15min", tz="UTC")  # a Monday 00:00: time of week 0
    m, v = _signals(n)
    y0 = np.array([21.0, 22.0])
    names_in = ["m_V1", "m_V2", "m_V3", "T_out", "T_supply"]
    U = np.hstack([m, v])
    out = {}
    for s in sm.seasons:
        slave = Slave(path, f"s_{s}_{native}")
        try:
            slave.init(
                {"T_A_start": 21.0, "T_B_start": 22.0, "season": sm.seasons.index(s) + 1, "start_time_of_week": 0.0},
                inputs=(names_in, U[0]),
            )
            out[s] = run_fmu(slave, names_in, U, ["T_A", "T_B"])
        finally:
            slave.close()
        assert_allclose(out[s], _python(sm, s, idx, m, v, y0), rtol=0, atol=EXACT)
    assert np.abs(out["winter"] - out["summer"]).max() > 1.0


def test_native_header_holds_one_matrix_set_per_season():
    from hvacfmu.fmu_native import export_native_fmu, seasonal_equations

    sm = two_season()
    eqs = seasonal_equations(sm)
    assert_allclose(eqs[1].A, sm.for_season("summer").A, rtol=0, atol=0)
    with pytest.raises(FMUError, match="must end in .fmu"):
        export_native_fmu(sm, "x.zip")


# ----------------------------------------------------------------------------- MPC
def test_mpc_adapter_plans_with_the_runs_season_set(small_building):
    """`cosim --controller mpc`: the controller's predictor is the run's season's set; no season, no run."""
    import dataclasses

    from harness.mpc import cosim_controller
    from tests.test_cosim_horizon_s15 import _context

    sm = SeasonalZoneModel(
        sets={
            "fall": _set(0, 0.95, 0.5, seasons=("fall",)),
            "winter": _set(1, 0.60, 2.0, seasons=("winter",)),
        }
    )
    for season in ("fall", "winter"):
        ctrl = cosim_controller(sm, small_building, horizon=4)
        ctx = dataclasses.replace(_context(sm, small_building, 8), season=season)
        ctrl.reset(ctx)
        assert_allclose(ctrl.model.A, sm.for_season(season).A, rtol=0, atol=0)
        assert_allclose(np.asarray(ctrl.mpc.pred.A), sm.for_season(season).A, rtol=0, atol=1e-12)
        u = ctrl(0, None, np.array([21.0, 21.0]), {})
        assert np.all(np.isfinite(u))
    ctrl = cosim_controller(sm, small_building, horizon=4)
    with pytest.raises(ModelError, match="names no season"):
        ctrl.reset(dataclasses.replace(_context(sm, small_building, 8), season=None))
    with pytest.raises(ModelError, match="no coefficient set for season 'summer'"):
        ctrl.reset(dataclasses.replace(_context(sm, small_building, 8), season="summer"))
    from harness.mpc.predict import make_predictor

    with pytest.raises(ModelError, match="needs the season chosen first"):
        make_predictor(sm)


def test_diagnosis_refuses_a_seasonal_base():
    from hvacfmu.diagnosis.design import base_linear

    with pytest.raises(FitError, match="one coefficient set per season"):
        base_linear(two_season())


# ----------------------------------------------------------------------------- evaluation, diagnosis
@pytest.fixture(scope="module")
def two_season_data(short_paths, tmp_path_factory):
    """The 8-week emulator dataset with its fall cut in two seasons (fall: 4 weeks, "late": 4), a test week each."""
    from pathlib import Path

    from hvacfmu.data import prepare

    text = Path(short_paths.building).read_text()
    old = '{ name = "fall", start = "09-01", end = "12-15" }'
    assert old in text
    text = text.replace(
        old, '{ name = "fall", start = "09-01", end = "09-28" }, { name = "late", start = "09-29", end = "12-15" }'
    )
    d = tmp_path_factory.mktemp("late")
    (d / "building.toml").write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(short_paths.measurements, d / "building.toml")


@pytest.mark.slow
def test_evaluation_runs_each_window_with_its_seasons_set(two_season_data):
    """Every held-out window of the seasonal model scores exactly as its season's set alone; the verdict runs."""
    from hvacfmu.evaluation import evaluate
    from tests.test_fmu import zones_model

    ds = two_season_data
    assert {w.season for w in ds.test_weeks()} == {"fall", "late"}
    m0, m5 = zones_model(ds.building, 0), zones_model(ds.building, 5)
    sm = SeasonalZoneModel(sets={"fall": m0, "late": m5})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        res = evaluate([sm, m0, m5], ds, names=["seasonal", "fall_set", "late_set"])
    sc = {s.name: s for s in res.scores}
    seasons = np.array(sc["seasonal"].seasons)
    assert set(seasons) == {"fall", "late"} and sc["seasonal"].starts == sc["fall_set"].starts
    for s, ref in (("fall", "fall_set"), ("late", "late_set")):
        assert_allclose(sc["seasonal"].rms[seasons == s], sc[ref].rms[seasons == s], rtol=0, atol=1e-12)
    other = {"fall": "late_set", "late": "fall_set"}
    for s, ref in other.items():  # the sets differ: running the other season's set would show
        assert np.abs(sc["seasonal"].rms[seasons == s] - sc[ref].rms[seasons == s]).max() > 0.05
    assert res.verdict is not None and any(z.model == "seasonal" for z in res.verdict.zones)


def test_diagnose_fits_its_base_with_one_set(monkeypatch):
    """The diagnosis refits and extends one A over the year: its own base fit asks for memory_select='mean'."""
    import hvacfmu.fitting
    from hvacfmu.diagnosis import pipeline

    seen = {}

    class Stop(Exception):
        pass

    def fake_fit(dataset, kind, **kw):
        seen.update(kw, kind=kind)
        raise Stop

    monkeypatch.setattr(hvacfmu.fitting, "fit", fake_fit)
    from types import SimpleNamespace

    dataset = SimpleNamespace(building=SimpleNamespace(zone_names=("a", "b")))  # the message counts its zones
    with pytest.raises(Stop):
        pipeline._base_model(dataset, None, lambda *a: None, [])
    assert seen["kind"] == "zones" and seen["memory_select"] == "mean"
    from hvacfmu.models.datadriven import DEFAULTS

    assert DEFAULTS["memory_select"] == "season"  # the fit's default (session 21)
