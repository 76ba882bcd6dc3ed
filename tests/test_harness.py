"""Co-simulation harness: exactness through run_cosim, summary figures, early stops, controllers, CLI."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from test_fmu import EXACT, zones_model

from harness.controllers import ControlContext, Controller, ReplayController, RuleController
from harness.cosim import CosimResult, make_controller, run_cosim
from hvacfmu.errors import FMUError, HvacfmuError, HvacfmuWarning
from hvacfmu.fmu import export_fmu, export_plant_fmu
from hvacfmu.fmu_slave import state_from_outputs


@pytest.fixture(scope="module")
def data(short_paths):
    from hvacfmu.data import prepare

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(short_paths.measurements, short_paths.building)


@pytest.fixture(scope="module")
def zones(tmp_path_factory, data):
    d = tmp_path_factory.mktemp("harness")
    model = zones_model(data.building)
    mp = model.save(d / "zones.json")
    return model, mp, export_fmu(mp, d / "Zones.fmu")


class Scripted:
    """Replays measured airflows but returns ``bad`` at step ``at``."""

    name = "scripted"

    def __init__(self, at, bad):
        self.at, self.bad = at, bad

    def reset(self, context):
        self.inner = ReplayController()
        self.inner.reset(context)

    def __call__(self, k, t, y, v):
        m = np.array(self.inner(k, t, y, v), dtype=float)
        if k == self.at:
            m[-1] = self.bad
        return m


def test_replay_run_equals_python_model(zones, data):
    model, _, path = zones
    week = data.test_weeks()[0]
    r = run_cosim(path, data, ReplayController(), week=week.number, model=model)
    assert isinstance(r, CosimResult) and r.covered
    tab = r.table
    assert len(tab) == 673 and tab.index[0] == week.start and tab.index[-1] == week.end
    rows = tab.iloc[:-1]
    u, v = model.signals(rows)
    q = model.gains_at(rows.index, week.season)
    y0 = tab[[f"T_{z}" for z in model.outputs]].iloc[0].to_numpy()
    measured = data.week_frame(week)[[f"T_{z}" for z in model.outputs]].interpolate(limit_direction="both")
    assert_allclose(y0, measured.iloc[0].to_numpy(), rtol=0, atol=1e-12)  # started from measurement
    _, Y = model.simulate(state_from_outputs(model, y0, u[0], v[0], q[0]), u, v, q)
    assert_allclose(tab[[f"T_{z}" for z in model.outputs]].to_numpy(), Y, rtol=0, atol=EXACT)
    # the replayed airflows are the measured ones where measured, clipped to the box limits (and counted)
    meas = data.week_frame(week)[[f"m_{b}" for b in data.building.vav_names]].to_numpy()
    ok = np.isfinite(meas)
    boxes = {b.name: b for b in data.building.vavs}
    lo = np.array([boxes[b].m_min for b in data.building.vav_names])
    hi = np.array([boxes[b].m_max for b in data.building.vav_names])
    clipped = np.clip(meas, lo, hi)
    assert_allclose(rows[[f"m_{b}" for b in data.building.vav_names]].to_numpy()[ok], clipped[ok], rtol=0, atol=0)
    filled = pd.DataFrame(meas).ffill().fillna(pd.Series(lo)).to_numpy()  # gaps: last value, m_min first
    n_out = int(np.sum(np.abs(np.clip(filled, lo, hi) - filled) > 1e-9))
    assert r.summary["controller_stats"]["clipped_box_steps"] == n_out


def test_summary_figures(zones, data, tmp_path):
    model, _, path = zones
    r = run_cosim(path, data, RuleController(), week=1, model=model, band=(20.5, 21.5))
    tab, s = r.table, r.summary
    M = tab[[f"m_{b}" for b in data.building.vav_names]].iloc[:-1].to_numpy()
    T = tab[[f"T_{z}" for z in model.outputs]].iloc[1:].to_numpy()
    assert_allclose(s["energy_proxy"], np.sum(M**2), rtol=1e-12, atol=0)
    assert_allclose(s["total_airflow_kg"], np.sum(M) * 900.0, rtol=1e-12, atol=0)
    viol = np.where(T < 20.5, 20.5 - T, 0) + np.where(T > 21.5, T - 21.5, 0)
    assert_allclose(s["comfort_violation_Kh"], viol.sum() * 0.25, rtol=1e-12, atol=0)
    assert s["steps_completed"] == s["steps_requested"] == 672
    assert 0 < s["step_time_median"] <= s["step_time_max"]
    out = r.save(tmp_path / "res.parquet")
    back = pd.read_parquet(out)
    assert_allclose(back.to_numpy(), tab.to_numpy(), rtol=0, atol=0)
    assert json.loads(out.with_suffix(".json").read_text())["covered"] is True
    assert "comfort" in r.format_summary()


@pytest.mark.parametrize("bad, message", [(-0.2, "invalid input value"), (float("nan"), "need 21 finite airflows")])
def test_early_stop_is_an_error_with_partial_result(zones, data, bad, message):
    model, _, path = zones
    with pytest.raises(FMUError, match="stopped early: 10 of 672 steps") as info:
        run_cosim(path, data, Scripted(10, bad), week=1, model=model)
    res = info.value.result
    assert res.summary["steps_completed"] == 10 and not res.covered
    assert message in res.summary["stopped_because"]
    week = {w.number: w for w in data.weeks}[1]
    when = str(week.start + pd.Timedelta(minutes=150))
    assert when in res.summary["stopped_because"]  # the time of the failed step is named
    if bad < 0:
        # pythonfmu FMUs answer a refused step with fmi2Fatal (they cannot answer fmi2Error; discard is a silent stop)
        assert "fmi2DoStep at t=" in str(info.value) and "returned fatal" in str(info.value)
    assert len(res.table) == 11
    partial = run_cosim(path, data, Scripted(10, bad), week=1, model=model, allow_partial=True)
    assert not partial.covered


def test_rule_controller_pi_logic(data):
    frame = data.week_frame(data.weeks[0])
    b = data.building
    ctx = ControlContext(
        frame=frame,
        building=b,
        vavs=b.vav_names,
        outputs=tuple(f"T_{z}" for z in b.zone_names),
        output_zones=tuple((z,) for z in b.zone_names),
        step=900.0,
    )
    c = RuleController(kp=0.5, ti=3600.0)
    c.reset(ctx)
    m_min, m_max = ctx.box_limits()
    hot, cold = np.full(len(b.zone_names), 25.0), np.full(len(b.zone_names), 17.0)
    assert_allclose(c(0, frame.index[0], hot, {"T_supply": 13.0}), m_max, rtol=0, atol=1e-12)  # saturated cooling
    c.reset(ctx)
    assert_allclose(c(0, frame.index[0], cold, {"T_supply": 13.0}), m_min, rtol=0, atol=1e-12)  # no cooling needed
    c.reset(ctx)
    warm_supply = c(0, frame.index[0], cold, {"T_supply": 30.0})  # heating: cold zone gets warm air
    assert np.all(warm_supply > m_min)
    c.reset(ctx)
    y = np.full(len(b.zone_names), 21.5)
    first = c(0, frame.index[0], y, {"T_supply": 13.0})
    later = [c(k, frame.index[k], y, {"T_supply": 13.0}) for k in range(1, 4)][-1]
    assert np.all(later > first)  # the integral acts
    assert isinstance(c, Controller) and isinstance(ReplayController(), Controller)


def test_rule_controller_on_plant_fmu(tmp_path, short_paths, data):
    """The plant FMU with the PI controller: runs a day, airflows within limits, zones held near the band."""
    plant = export_plant_fmu(short_paths.truth, tmp_path / "Plant.fmu")
    week = data.weeks[1]
    r = run_cosim(plant, data, RuleController(), start=week.start, stop=week.start + pd.Timedelta(days=1))
    assert r.covered and len(r.table) == 97
    M = r.table[[f"m_{b}" for b in data.building.vav_names]].iloc[:-1].to_numpy()
    m_min = np.array([v.m_min for v in data.building.vavs])
    m_max = np.array([v.m_max for v in data.building.vavs])
    assert np.all(M >= m_min - 1e-12) and np.all(M <= m_max + 1e-12)
    T = r.table[[f"T_{z}" for z in data.building.zone_names]].to_numpy()
    assert np.all((T > 15.0) & (T < 28.0))


def test_make_controller_errors():
    assert make_controller("replay").name == "replay"
    assert make_controller("rule", options={"kp": 0.8}).kp == 0.8
    with pytest.raises(HvacfmuError, match="needs the controller's model"):
        make_controller("mpc")
    with pytest.raises(HvacfmuError, match="unknown controller"):
        make_controller("pid")


def test_foreign_mapping(zones, data, tmp_path):
    """A mapping file connects an FMU by explicit names; unmapped or wrong names are listed."""
    model, _, path = zones
    mapping = {
        "inputs": {f"m_{b}": f"m_{b}" for b in data.building.vav_names} | {d: d for d in model.disturbances},
        "outputs": {f"T_{z}": z for z in model.outputs},
    }
    r = run_cosim(path, data, ReplayController(), week=1, mapping=mapping)
    assert r.covered
    with pytest.raises(FMUError, match="is not an output of the FMU"):
        run_cosim(path, data, ReplayController(), week=1, mapping={"inputs": {}, "outputs": {"T_nowhere": "NW"}})


def test_cosim_command_line(zones, short_paths, tmp_path):
    _, mp, path = zones
    out = tmp_path / "res.csv"
    cmd = [
        sys.executable,
        "-m",
        "hvacfmu.cli",
        "-q",
        "cosim",
        "--fmu",
        str(path),
        "--data",
        str(short_paths.measurements),
        "--building",
        str(short_paths.building),
        "--controller",
        "rule",
        "--model",
        str(mp),
        "--week",
        "2",
        "--out",
        str(out),
        "--plot",
        str(tmp_path / "run.png"),
    ]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "run.png").stat().st_size > 10_000
    assert "672 / 672 steps" in run.stdout and "comfort" in run.stdout
    tab = pd.read_csv(out)
    assert len(tab) == 673 and json.loads(out.with_suffix(".json").read_text())["controller"] == "rule"


@pytest.mark.slow  # over 15 s: keeps the not-slow tier under 3 min
def test_cli_reports_plant_stopping_early(tmp_path, short_paths):
    """A plant FMU whose emulated span ends inside the requested span: exit 1, loud message, partial table."""
    from hvacfmu.emulator import cached_dataset

    short = cached_dataset(weeks=3, seed=0)
    plant = export_plant_fmu(short.truth, tmp_path / "Plant3w.fmu")
    out = tmp_path / "partial.csv"
    cmd = [
        sys.executable,
        "-m",
        "hvacfmu.cli",
        "-q",
        "cosim",
        "--plant",
        str(plant),
        "--data",
        str(short_paths.measurements),
        "--building",
        str(short_paths.building),
        "--controller",
        "rule",
        "--start",
        "2025-09-21T12:00",
        "--stop",
        "2025-09-22T12:00",
        "--out",
        str(out),
    ]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 1
    assert "STOPPED EARLY" in run.stdout and "beyond the emulated span" in run.stderr
    tab = pd.read_csv(out)
    assert len(tab) == 49  # 12 h of steps, then the refusal
    assert json.loads(out.with_suffix(".json").read_text())["covered"] is False


@pytest.fixture(scope="module")
def native_zones(tmp_path_factory, data):
    from hvacfmu.fmu_native import export_native_fmu

    model = zones_model(data.building)
    return model, export_native_fmu(model, tmp_path_factory.mktemp("native") / "ZonesNative.fmu")


def test_native_fmu_refusing_a_step_stops_the_run_and_names_time_and_status(native_zones, data, tmp_path):
    """A non-Python FMU refuses an out-of-range airflow: FMUError with time, call and status; CLI exit 1."""
    model, path = native_zones
    with pytest.raises(FMUError) as info:
        run_cosim(path, data, Scripted(30, 99.0), week=1, model=model)
    msg = str(info.value)
    assert "stopped early: 30 of 672 steps" in msg and "fmi2DoStep at t=" in msg and "returned error" in msg
    assert "invalid input value(s)" in msg and "=99" in msg
    full = run_cosim(path, data, ReplayController(), week=1, model=model)  # the same FMU runs a whole week
    assert full.covered and len(full.table) == 673


def test_native_fmu_run_starts_from_the_measured_state_season_and_time_of_week(native_zones, zones, data):
    """``cosim`` on a native FMU sets its start temperatures, season and time of week as on the pythonfmu FMU.

    The native FMU had no ``resources/interface.json``: the harness set no start value and the run started at
    21 °C in the first season at Monday 00:00 without a word (fleet sweep s10, b000: 116.7 against 172.2 K·h
    outside the band for the same model and week). Now both FMUs give the same trajectory."""
    model, path = native_zones
    week = data.test_weeks()[0]
    start = week.start + pd.Timedelta(days=2, hours=6)  # a Wednesday morning: the time of week matters
    span = dict(start=start, stop=start + pd.Timedelta(hours=12), model=model)
    native = run_cosim(path, data, ReplayController(), **span)
    python = run_cosim(zones[2], data, ReplayController(), **span)
    sv = native.summary["start_values"]
    assert sv == python.summary["start_values"] and sv["start_time_of_week"] == (2 * 24 + 6) * 3600.0
    assert {f"T_{z}_start" for z in model.outputs} <= set(sv)
    cols = [f"T_{z}" for z in model.outputs]
    assert_allclose(native.table[cols].to_numpy(), python.table[cols].to_numpy(), rtol=0, atol=1e-9)


def test_checked_simulate_raises_instead_of_truncating(native_zones, zones, tmp_path):
    """An FMU that refuses a step: simulate_fmu_checked raises, naming the time and the value.

    The native FMU answers fmi2Error, so FMPy itself raises; an FMU that answers fmi2Discard (the pythonfmu
    FMU here) makes fmpy.simulate_fmu return a short result silently, which simulate_fmu_checked turns into
    an error.
    """
    from fmpy import simulate_fmu

    from harness.cosim import simulate_fmu_checked

    n = 20
    sig = np.zeros(n, dtype=[("time", float), ("T_out", float)])
    sig["time"] = np.arange(n) * 900.0
    sig["T_out"] = np.where(np.arange(n) < 5, 10.0, 95.0)  # out of range from step 5
    path = native_zones[1]
    with pytest.raises(Exception, match="status 3"):
        simulate_fmu(str(path), stop_time=(n - 1) * 900.0, output_interval=900.0, input=sig)
    with pytest.raises(FMUError, match=r"failed: .*error.*at t=4500 s: invalid input value\(s\): T_out=95"):
        simulate_fmu_checked(path, stop_time=(n - 1) * 900.0, output_interval=900.0, input=sig)
    ok = simulate_fmu_checked(path, stop_time=(n - 1) * 900.0, output_interval=900.0)
    assert len(ok) == n
    other = zones[2]
    try:
        res = simulate_fmu(str(other), stop_time=(n - 1) * 900.0, output_interval=900.0, input=sig)
    except Exception:  # noqa: BLE001 - an FMU answering fmi2Error: FMPy is loud already
        res = None
    if res is not None:  # fmi2Discard: FMPy's silent truncation, which the checked call refuses
        assert res["time"][-1] < (n - 1) * 900.0
        with pytest.raises(FMUError, match=r"stopped early at t=4500 s of 17100 s"):
            simulate_fmu_checked(other, stop_time=(n - 1) * 900.0, output_interval=900.0, input=sig)


def test_data_without_solar_keeps_facade_inputs_at_their_start(zones, data):
    """A model FMU with facade irradiance inputs on data without solar columns: warning, inputs at 0 W/m2."""
    from hvacfmu.data.dataset import Dataset

    model, _, path = zones
    frame = data.frame.drop(columns=[c for c in data.frame.columns if c.startswith("I_") or c == "ghi"])
    dark = Dataset.from_frame(frame, data.building)
    assert not any(c.startswith("I_") for c in dark.frame.columns)
    with pytest.warns(HvacfmuWarning, match=r"no column for the FMU input\(s\) \['I_N', 'I_E', 'I_S', 'I_W'\]"):
        r = run_cosim(path, dark, ReplayController(), week=1, model=model)
    assert r.covered and r.summary["defaulted_inputs"] == ["I_N", "I_E", "I_S", "I_W"]


def test_summary_names_outputs_that_cycle_with_the_plant():
    """A controller that alternates full heat and full cooling every step (fleet sweep s10: MPC on a model whose
    first-step heat gain is 14x below its one-step fit, zone E swinging 3 K a step) completed its run with only
    the comfort figure to show for it. The summary counts, per output, the steps that reverse a move of more
    than ``OSCILLATION_K`` and the printed summary names them; a smooth run has none."""
    from types import SimpleNamespace

    from harness.cosim import OSCILLATION_K, oscillation_counts

    k = np.arange(40)
    smooth = 21.0 + 0.8 * np.sin(2 * np.pi * k / 96)  # a day's swing
    cycling = 21.0 + 1.5 * (-1.0) ** k  # ±1.5 K every step
    small = 21.0 + 0.2 * (-1.0) ** k  # sensor-sized alternation
    Y = np.column_stack([smooth, cycling, small])
    assert OSCILLATION_K == 0.5
    assert oscillation_counts(Y, ["T_A", "T_E", "T_C"]) == {"T_E": 38}
    assert oscillation_counts(Y[:2], ["T_A", "T_E", "T_C"]) == {}
    s = {
        "fmu": "Plant.fmu", "controller": "mpc", "start": "a", "end": "b", "steps_requested": 40, "step": 900.0,
        "steps_completed": 40, "covered": True, "energy_proxy": 1.0, "total_airflow_kg": 1.0, "mean_airflow": 1.0,
        "comfort_violation_Kh": 0.0, "band": [20.0, 22.0], "step_time_median": 0.0, "step_time_max": 0.0,
        "controller_time_median": 0.0, "fmu_time_median": 0.0, "oscillation": {"T_E": 38},
    }  # fmt: skip
    text = CosimResult.format_summary(SimpleNamespace(summary=s))
    assert "oscillation     T_E 38 of 39 steps reverse a move of more than 0.5 K: the controller cycles" in text
    text = CosimResult.format_summary(SimpleNamespace(summary={**s, "oscillation": {"T_E": 2}}))
    assert text.endswith("T_E 2 of 39 steps reverse a move of more than 0.5 K")  # a few: counted, not judged
    assert "oscillation" not in CosimResult.format_summary(SimpleNamespace(summary={**s, "oscillation": {}}))


def test_a_model_fmu_reading_the_reheat_heat_qrh_runs_on_the_data_it_is_derived_from(data, tmp_path):
    """The FMU of a diagnosis's extended/control model of a reheat building has an input ``Qrh_<zone>`` [kW] (the
    zone's reheat through its discharge air, derived from ``m``, ``Td_<vav>`` and the supply air). ``cosim`` refused
    it on every FMU ("FMU input 'Qrh_W' is neither a box airflow m_<vav> nor a data column", round 2 of fleet sweep
    s10). Now the run derives it from the data with the FMU's own model (pythonfmu) or ``--model`` (native FMU,
    else the refusal names the remedy); the table carries the values fed."""
    import dataclasses

    from harness.mpc.heating import reheat_disturbances
    from hvacfmu.fmu_native import export_native_fmu
    from hvacfmu.models.causes.reheat import Reheat
    from hvacfmu.models.extended import ExtendedModel

    base = zones_model(data.building)
    z = base.outputs[0]
    model = ExtendedModel(base, (Reheat(zone=z, coef=0.05, variant="discharge"),))
    vavs = data.building.vav_names
    frame = data.frame.assign(**{f"Td_{v}": data.frame["T_supply"] + 5.0 for v in vavs})
    ds = dataclasses.replace(data, frame=frame)
    start = ds.test_weeks()[0].start + pd.Timedelta(hours=8)
    span = dict(start=start, stop=start + pd.Timedelta(hours=3))
    native = export_native_fmu(model, tmp_path / "Ext.fmu")
    with pytest.raises(HvacfmuError, match=rf"'Qrh_{z}' is neither .* pass that model with --model"):
        run_cosim(native, ds, ReplayController(), **span)
    run = run_cosim(native, ds, ReplayController(), model=model, **span)
    q = reheat_disturbances(model, frame)[f"Qrh_{z}"]
    fed = run.table[f"Qrh_{z}"].to_numpy()[:-1]
    assert np.all(fed > 0.0)
    assert_allclose(fed, pd.Series(q, index=frame.index).loc[run.table.index[:-1]].to_numpy(), rtol=1e-12)


def test_the_reheat_heat_input_of_an_fmu_has_a_unit_and_says_how_to_compute_it():
    """``fmpy info`` on the FMU of a diagnosis's control model of a reheat building showed ``Qrh_W`` with no unit
    and its own name as the description: a user feeding the FMU could not know it is a heat [kW] computed from the
    discharge air (round 2 of fleet sweep s10). Now kW (a unit definition with factor 1000) and the formula."""
    from xml.etree.ElementTree import tostring

    from hvacfmu.fmu_description import unit_definitions
    from hvacfmu.fmu_slave.names import signal_entry

    e = signal_entry("Qrh_W")
    assert e["unit"] == "kW" and "Td_<vav>" in e["description"] and "[kW]" in e["description"]
    assert 'factor="1000"' in tostring(unit_definitions([e])).decode()
    assert signal_entry("rh_VAV_1")["description"].startswith("Reheat signal of VAV box VAV_1")


def test_summary_says_which_outputs_are_below_or_above_the_band(zones, data):
    """``cosim --controller mpc`` with a lumped model on a nine-zone plant (round 2 of fleet sweep s10) printed
    "comfort 306.38 K*h" and nothing on where: the one decision kept the four corner zones 56-61 K*h above the
    band and the core 52 K*h below. The summary now splits the figure per output, below and above, and prints the
    worst; the parts add up to the total."""
    model, _, path = zones
    start = data.test_weeks()[0].start + pd.Timedelta(hours=8)
    band = (21.0, 21.2)
    run = run_cosim(path, data, ReplayController(), start=start, stop=start + pd.Timedelta(hours=6), band=band)
    s = run.summary
    by = s["comfort_by_output"]
    assert set(by) == {f"T_{z}" for z in model.outputs}
    assert sum(b + a for b, a in by.values()) == pytest.approx(s["comfort_violation_Kh"], rel=1e-12)
    worst = max(by, key=lambda k: sum(by[k]))
    assert sum(by[worst]) > 0.05 and "    by output     " + worst in run.format_summary()


def test_mpc_with_a_lumped_model_on_a_multi_zone_fmu_says_it_holds_the_mean_only(zones, data):
    """A lumped model's MPC on a six-zone FMU keeps the floor mean in the band, not each zone (round 2 of fleet sweep
    s10: 306 and 178 K*h in two days against 3.3 and 1.1 with the zones model), and said nothing before the run."""
    from harness.cosim import make_controller
    from hvacfmu.models.datadriven import fit_lumped

    _, _, path = zones
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        lumped = fit_lumped(data)
    start = data.test_weeks()[0].start + pd.Timedelta(hours=8)
    ctrl = make_controller("mpc", lumped, data.building, {"horizon": 3})
    with pytest.warns(HvacfmuWarning, match=r"the MPC keeps that mean in the band, not each zone") as rec:
        run = run_cosim(path, data, ctrl, model=lumped, start=start, stop=start + pd.Timedelta(hours=1))
    msg = next(str(w.message) for w in rec if "keeps that mean" in str(w.message))
    assert f"weighted mean of {len(data.building.zone_names)} plant outputs" in msg and "fit --model zones" in msg
    assert run.covered
    # the zones model on the same FMU reads one output each: no such warning
    zmodel = zones[0]
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        run_cosim(
            path,
            data,
            make_controller("mpc", zmodel, data.building, {"horizon": 3}),
            model=zmodel,
            start=start,
            stop=start + pd.Timedelta(hours=1),
        )
    assert not [w for w in rec if "keeps that mean" in str(w.message)]
