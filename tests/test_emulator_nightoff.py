"""The emulator's opt-in ``night-off`` schedule and the ``off_hours_heater`` effect (session 13)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from hvacfmu.cli.commands import build_parser
from hvacfmu.diagnosis.truth import compare_with_truth
from hvacfmu.emulator import EmulatorError, Plant, generate, make_truth, simulate
from hvacfmu.emulator.controllers import occupied_mode

START = "2025-11-03"  # a Monday in a cold climate: heating nights
HEATER = "off_hours_heater:zone=W,power=2500,below=30"  # below 30 °C: on whenever the boxes are shut


@pytest.fixture(scope="module")
def sims():
    kw = {"climate": "cold", "start": START}
    return {
        "on": simulate(make_truth(1, 4, **kw)),
        "off": simulate(make_truth(1, 4, schedule="night-off", **kw)),
        "heater": simulate(make_truth(1, 4, [HEATER], schedule="night-off", **kw)),
    }


def test_default_schedule_is_always_on_and_unchanged(tmp_path):
    """No schedule argument and ``always-on`` write the same bytes; the truth names no schedule."""
    a = generate(tmp_path / "a", weeks=1, seed=5, fmt="csv")
    b = generate(tmp_path / "b", weeks=1, seed=5, fmt="csv", schedule="always-on")
    assert a.measurements.read_bytes() == b.measurements.read_bytes()
    assert a.truth.read_bytes() == b.truth.read_bytes()
    truth = json.loads(a.truth.read_text())
    assert "schedule" not in truth and "schedule" not in truth["baseline"]["controllers"]
    m = pd.read_csv(a.measurements)[[f"m_{v}" for v in truth["vavs"]]]
    assert (m.min() > 0.05).all()  # always on: the boxes never shut (m_min 0.1-0.2 kg/s; noise 0.004)


def test_always_on_boxes_never_below_minimum(sims):
    sim = sims["on"]
    m_min = sim["core"].m_min
    assert sim["system_on"].all()
    assert (sim["m_applied"] >= m_min - 1e-12).all()


def test_night_off_shuts_boxes_and_air_handler(sims):
    sim = sims["off"]
    occ = occupied_mode(sim["index"])
    on = sim["system_on"]
    off = ~on & ~sim["excitation"]
    assert off.mean() > 0.5  # nights and the weekend
    assert not (occ & ~on).any()  # running through the occupied hours
    assert (sim["m_applied"][off] == 0).all() and (sim["m_vav"][off] == 0).all()
    assert (sim["reheat"][off] == 0).all() and (sim["reheat_command"][off] == 0).all()
    assert (sim["m_applied"][occ] >= sim["core"].m_min - 1e-12).all()
    assert sim["m_applied"][occ].mean() > 0.1  # [kg/s]
    # the supply-air sensor: the reset schedule while on, the idle duct (near the rooms) after an hour off
    Ts, room = sim["T_supply"], sim["T_zone"].mean(axis=1)
    assert_allclose(Ts[on], sims["on"]["T_supply"][on], atol=1e-12)
    long_off = off & np.concatenate([np.zeros(120, bool), off[:-120]]) & np.roll(off, 120)
    assert long_off.sum() > 1000
    assert np.abs(Ts[long_off] - room[long_off]).max() < 1.0  # [K] 2 h off: within e^-2 of the room air
    assert np.abs(Ts[occ] - room[occ]).mean() > 3.0  # [K] cold supply air while running


def test_night_off_reheat_mode_per_air_handler():
    sim = simulate(make_truth(1, 1, climate="cold", start=START, hvac="reheat", layout="row4", schedule="night-off"))
    off = ~sim["system_on"] & ~sim["excitation"]
    assert sim["T_supply"].shape[1] == 2
    assert (sim["m_applied"][off] == 0).all() and (sim["reheat"][off] == 0).all()
    assert np.isfinite(sim["T_supply"]).all()


def test_heater_heats_only_while_boxes_are_shut(sims):
    off, heat = sims["off"], sims["heater"]
    w = off["core"].zones.index("W")
    shut = ~off["system_on"] & ~off["excitation"]
    dT = heat["T_zone"][:, w] - off["T_zone"][:, w]
    assert dT[shut].mean() > 0.3  # [K] 2.5 kW at night
    others = [i for i in range(len(off["core"].zones)) if i != w]
    assert dT[shut].mean() > 3 * np.abs(heat["T_zone"][:, others] - off["T_zone"][:, others])[shut].mean()


def test_plant_reproduces_night_off_with_heater(sims):
    """Plant.advance with the simulation's inputs (boxes shut at night) reproduces the heater's trajectory."""
    truth = make_truth(1, 4, [HEATER], climate="cold", start=START, schedule="night-off")
    sim, plant = sims["heater"], Plant.from_truth(truth)
    x, T = sim["x0"], []
    for k in range(1800):  # Monday until 06:00 Tuesday: a night with the heater on
        T.append(plant.zone_temperatures(x))
        x, _ = plant.advance(
            x, 60.0 * k, 60.0, sim["m_vav"][k], sim["T_out"][k], sim["T_supply"][k], sim["I"][k],
            reheat=sim["reheat_command"][k],
        )  # fmt: skip
    assert not sim["system_on"][1300:1600].any()
    assert_allclose(np.array(T), sim["T_zone"][:1800], rtol=0, atol=1e-9)  # [K]


def test_heater_recorded_in_truth_and_scored_as_reheat(tmp_path):
    paths = generate(tmp_path / "h", weeks=1, seed=2, climate="cold", start=START, schedule="night-off",
                     effects=["off_hours_heater:zone=W"])  # fmt: skip
    truth = json.loads(paths.truth.read_text())
    assert truth["schedule"] == "night-off"
    assert truth["baseline"]["controllers"]["schedule"]["mode"] == "night-off"
    assert truth["effects"] == [{"name": "off_hours_heater", "power": 2000.0, "below": 5.0, "zone": "W"}]
    report = {"findings": [{"cause": "reheat", "location": {"zone": "W"}}], "data": {"step": 900}}
    assert [e["name"] for e in compare_with_truth(report, truth)["found"]] == ["off_hours_heater"]
    report["findings"][0]["location"]["zone"] = "S"
    assert [e["name"] for e in compare_with_truth(report, truth)["missed"]] == ["off_hours_heater"]


def test_heater_needs_night_off_and_schedule_is_checked():
    with pytest.raises(EmulatorError, match="night-off"):
        make_truth(1, 0, ["off_hours_heater"])
    with pytest.raises(EmulatorError, match="schedule must be one of always-on, night-off"):
        make_truth(1, 0, schedule="nights")
    with pytest.raises(EmulatorError, match="power must be > 0"):
        make_truth(1, 0, ["off_hours_heater:power=-1"], schedule="night-off")


def test_cli_generate_schedule_flag():
    args = build_parser().parse_args(["generate", "out", "--schedule", "night-off"])
    assert args.schedule == "night-off"
    assert build_parser().parse_args(["generate", "out"]).schedule == "always-on"


def test_fleets_never_draw_the_heater():
    """generate-fleet draws from EFFECT_NAMES: the heater (it needs night-off) stays out, fleets are unchanged."""
    from hvacfmu.emulator.effects import ALL_EFFECT_NAMES, EFFECT_NAMES
    from hvacfmu.emulator.fleet import FLEET_EFFECTS

    assert "off_hours_heater" in ALL_EFFECT_NAMES
    assert "off_hours_heater" not in EFFECT_NAMES and "off_hours_heater" not in FLEET_EFFECTS


@pytest.mark.slow
def test_diagnosis_finds_the_heater_as_box_off_reheat(tmp_path):
    """8 cold weeks, row4, night-off with a 2.5-kW heater in R1 below 5 °C: the diagnosis names reheat at R1
    in its box-off form (airflow bound 5 % of the zone's minimum), and nothing outside the truth (~25 s)."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose

    paths = generate(tmp_path / "h", weeks=8, seed=0, climate="cold", start=START, layout="row4",
                     schedule="night-off", effects=["off_hours_heater:zone=R1,power=2500,below=5"])  # fmt: skip
    truth = json.loads(paths.truth.read_text())
    report = diagnose(prepare(paths.measurements, paths.building), progress=False).to_dict()
    cmp = compare_with_truth(report, truth)
    assert [e["name"] for e in cmp["found"]] == ["off_hours_heater"] and not cmp["unsupported"]
    (hit,) = [f for f in report["findings"] if f["cause"] == "reheat" and f["location"]["zone"] == "R1"]
    zone_min = sum(v["m_min"] for v in truth["baseline"]["building"]["vavs"] if v["zone"] == "R1")
    assert hit["parameters"]["u_min"]["value"] <= 0.06 * zone_min  # the box-off variant, not minimum airflow
    assert hit["parameters"]["T_threshold"]["value"] <= 8.0  # [°C] the heater's 5 °C, within a threshold step


def test_schedule_in_cache_key_and_refused_by_energyplus(capsys):
    from hvacfmu.cli import main
    from hvacfmu.emulator import cache_key

    assert cache_key(8, 0) == cache_key(8, 0, schedule="always-on")  # default: the cached files stay valid
    assert cache_key(8, 0, schedule="night-off") != cache_key(8, 0)
    assert main(["generate", "out", "--engine", "energyplus", "--schedule", "night-off"]) != 0
    assert "--schedule night-off is an emulator option" in capsys.readouterr().err
