"""The ``ell5`` layout: an L-shaped five-zone floor no rule was tuned on (session 17), and the defects the
pipeline showed on it."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from numpy.testing import assert_allclose


def test_ell5_geometry_as_designed():
    """Five unequal zones on an L: an interior C, two zones with three facades (one on the re-entrant corner's
    notch each), N and E touching at the inner corner only, boxes 1-4 and two air handlers."""
    from hvacfmu.building import validate_building
    from hvacfmu.emulator import emulated_building
    from hvacfmu.emulator.layouts import ahu_groups

    b = emulated_building("ell5")
    assert validate_building(b) == []
    assert b.zone_names == ("N", "W", "C", "S", "E")
    areas = {z.name: z.area for z in b.zones}
    assert_allclose([areas[z] for z in b.zone_names], [480.0, 192.0, 256.0, 128.0, 960.0], rtol=0, atol=1e-9)
    facades = {z.name: sorted(f.orientation for f in z.facades) for z in b.zones}
    # N's east facade and E's north facade face the notch: on main's outline rule (edges on the bounding
    # rectangle) they were interior walls to nowhere, N had two facades and E two
    assert facades == {"N": ["E", "N", "W"], "W": ["S", "W"], "C": [], "S": ["S"], "E": ["E", "N", "S"]}
    pairs = {frozenset(p) for p in b.adjacency_pairs()}
    expected = [("N", "W"), ("N", "C"), ("W", "C"), ("W", "S"), ("C", "S"), ("C", "E"), ("S", "E")]
    assert pairs == {frozenset(p) for p in expected}
    assert "E" not in b.zone("N").adjacent  # the inner corner is a point
    ratios = {
        (z.name, f.orientation): f.window_area / (f.window_area + f.wall_area) for z in b.zones for f in z.facades
    }
    assert_allclose(ratios[("S", "S")], 0.65, rtol=0, atol=1e-9)
    assert_allclose(ratios[("N", "E")], 0.55, rtol=0, atol=1e-9)
    assert [len(b.vavs_of(z)) for z in b.zone_names] == [3, 2, 2, 1, 4]
    assert ahu_groups("ell5") == {"N": "AHU1", "W": "AHU1", "C": "AHU1", "S": "AHU2", "E": "AHU2"}


def test_open_edge_rule_keeps_the_tiled_layouts():
    """On the four layouts whose zones tile their rectangle, the edges no other zone covers are exactly the
    edges on the rectangle: the ``outline="zones"`` rule would give them the same facades."""
    from hvacfmu.emulator.building import _facades_of, _open_edges
    from hvacfmu.emulator.layouts import LAYOUTS

    for name, lay in LAYOUTS.items():
        if lay.outline != "extent":
            continue
        for z, rect in lay.rects.items():
            others = [r for k, r in lay.rects.items() if k != z]
            assert _open_edges(rect, others) == _facades_of(rect, lay.extent), (name, z)


def test_layout_choices_everywhere():
    """The CLI's ``--layout`` choices and ``check_options`` know every layout of :data:`LAYOUTS`."""
    from hvacfmu.cli.commands import build_parser
    from hvacfmu.emulator.layouts import LAYOUTS, check_options

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    gen = sub.choices["generate"]
    layout = next(a for a in gen._actions if a.dest == "layout")
    assert tuple(layout.choices) == tuple(LAYOUTS)
    for name in LAYOUTS:
        assert name in layout.help
        assert check_options(layout=name) == []


@pytest.mark.slow
def test_ell5_generates_with_its_meeting_room(tmp_path):
    """``generate --layout ell5`` writes a real-BMS-like week (two air handlers, Td columns) that ``check``
    accepts; the truth records the meeting room S with its own meeting gain and says so in words."""
    from hvacfmu.data.check import check

    out = tmp_path / "e"
    cmd = [sys.executable, "-m", "hvacfmu", "-q", "generate", str(out), "--layout", "ell5", "--weeks", "1"]
    cmd += ["--seed", "1", "--hvac", "reheat", "--units", "us", "--clock", "naive-local"]
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    rep = check(out / "measurements.parquet", out / "building.toml", step=900.0)
    assert rep.ok, rep.problems
    truth = json.loads((out / "truth.json").read_text())
    occ = truth["baseline"]["occupancy"]
    assert occ["meeting_zone"] == "S" and occ["meeting_gain"] == 3500.0 and occ["meeting_probability"] == 0.5
    assert "meetings in S" in json.dumps(truth)
    toml = (out / "building.toml").read_text()
    assert "AHU1" in toml and "AHU2" in toml


def test_cosim_oscillation_names_the_building_when_the_data_cycle():
    """A replayed run whose zone reverses step after step as the measured zone does (ell5's meeting room S:
    one fast box on 128 m2) is the building's own loop; main's summary blamed "the controller cycles with the
    plant" and gave MPC advice. A replay that reverses more than the data points at the model instead."""
    from types import SimpleNamespace

    from harness.cosim import CosimResult

    s = {
        "fmu": "zones.fmu", "controller": "replay", "start": "a", "end": "b", "steps_requested": 40, "step": 900.0,
        "steps_completed": 40, "covered": True, "energy_proxy": 1.0, "total_airflow_kg": 1.0, "mean_airflow": 1.0,
        "comfort_violation_Kh": 0.0, "band": [20.0, 22.0], "step_time_median": 0.0, "step_time_max": 0.0,
        "controller_time_median": 0.0, "fmu_time_median": 0.0, "oscillation": {"T_S": 9},
        "measured_oscillation": {"T_S": 18},
    }  # fmt: skip
    text = CosimResult.format_summary(SimpleNamespace(summary=s))
    assert "the measured zone temperatures reverse as often (T_S 18)" in text
    assert "the controller cycles with the plant" not in text
    text = CosimResult.format_summary(SimpleNamespace(summary={**s, "measured_oscillation": {}}))
    assert "the replayed airflows do not respond to the run" in text and "(T_S 0)" in text
    assert "the controller cycles with the plant" not in text
    mpc = CosimResult.format_summary(SimpleNamespace(summary={**s, "controller": "mpc", "measured_oscillation": {}}))
    assert "the controller cycles with the plant" in mpc  # a controller in the loop keeps main's advice


def test_cosim_heating_line_says_when_nothing_is_commanded():
    """A model FMU replayed on a cold winter week read the data's Td_<vav> and printed "0.0 kWh of reheat
    commanded": a zero that reads as "no heating" (ell5 cold seed 1, November). The line now says the FMU takes no
    reheat command; the figure stays 0.0 in the summary for the scripts that sum it."""
    from types import SimpleNamespace

    from harness.cosim import CosimResult

    s = {
        "fmu": "zones.fmu", "controller": "replay", "start": "a", "end": "b", "steps_requested": 40, "step": 900.0,
        "steps_completed": 40, "covered": True, "energy_proxy": 1.0, "total_airflow_kg": 1.0, "mean_airflow": 1.0,
        "comfort_violation_Kh": 0.0, "band": [20.0, 22.0], "step_time_median": 0.0, "step_time_max": 0.0,
        "controller_time_median": 0.0, "fmu_time_median": 0.0, "heating_kWh": 0.0, "heating_commanded": False,
    }  # fmt: skip
    text = CosimResult.format_summary(SimpleNamespace(summary=s))
    assert "none commanded: the FMU has no Td_<vav> command input" in text
    assert "0.0 kWh of reheat" not in text
    plant = CosimResult.format_summary(SimpleNamespace(summary={**s, "heating_kWh": 12.5, "heating_commanded": True}))
    assert "12.5 kWh of reheat commanded through Td_<vav>" in plant


def test_rule_controller_refuses_mpc_options_with_a_message():
    """``cosim --controller rule --horizon 12`` (a user comparing rule and MPC on the same command line) ended in a
    TypeError traceback on main; it is now an HvacfmuError naming the option and the rule's own options."""
    from harness.cosim import make_controller
    from hvacfmu.errors import HvacfmuError

    with pytest.raises(HvacfmuError, match=r"controller 'rule' takes no option horizon \(--horizon is the MPC's\)"):
        make_controller("rule", options={"horizon": 12})
    with pytest.raises(HvacfmuError, match=r"controller 'replay' takes no option kp; its options .*: none"):
        make_controller("replay", options={"kp": 0.5})
    assert make_controller("rule", options={"kp": 0.8}).kp == 0.8


@pytest.mark.slow
def test_thin_box_in_a_minute_file_names_the_bridge(tmp_path):
    """A 1-minute export whose box answers every ~12 min (``--fault sparse_box`` at ``--export-step 60``) has no
    15-min step with half of the file's samples: ``check`` refused the whole building with "no model step of 900 s
    has enough samples" and no fix, and ``fit`` then blamed every zone ("only 0 usable transitions"). The refusal
    now names the fix that works, ``--interpolate-gaps``; with it the data pass."""
    from hvacfmu.data.check import check

    out = tmp_path / "m"  # found on ell5; quad4 here so that the test runs on main's layouts too
    cmd = [sys.executable, "-m", "hvacfmu", "-q", "generate", str(out), "--layout", "quad4", "--weeks", "2"]
    cmd += ["--seed", "4", "--hvac", "vav", "--export-step", "60", "--fault", "sparse_box", "--start", "2026-03-02"]
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    rep = check(out / "measurements.parquet", out / "building.toml", step=900.0)
    assert not rep.ok
    thin = [p for p in rep.problems if "m_VAV_" in p]
    assert thin and all("--interpolate-gaps MINUTES" in p for p in thin), rep.problems
    bridged = check(out / "measurements.parquet", out / "building.toml", step=900.0, interpolate_limit=30)
    assert bridged.ok, bridged.problems


@pytest.mark.slow
def test_physics_refusal_names_the_column_that_breaks_every_weekend(tmp_path):
    """Model B identifies on whole weekend days; one box with a short gap every day left none, and the refusal said
    only "no usable weekend segment" (ell5's 1-minute export with a thin box: 35 of 35 days broken by m_VAV_E_3).
    It now names the columns and how many days each breaks, and the fixes."""
    import pandas as pd

    out = tmp_path / "q"
    cmd = [sys.executable, "-m", "hvacfmu", "-q", "generate", str(out), "--layout", "quad4", "--weeks", "3"]
    cmd += ["--seed", "2", "--format", "csv"]
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    path = out / "measurements.csv"
    df = pd.read_csv(path)
    hour = pd.to_datetime(df["time"], utc=True).dt.hour
    df.loc[hour == 12, "m_VAV_SW_1"] = float("nan")  # an hour's gap every day in one box
    df.to_csv(path, index=False)
    fit = [sys.executable, "-m", "hvacfmu", "-q", "fit", str(path), "-b", str(out / "building.toml")]
    fit += ["--model", "physics", "-o", str(tmp_path / "p.json")]
    run = subprocess.run(fit, capture_output=True, text=True)
    assert run.returncode != 0
    assert "no usable weekend segment" in run.stderr
    assert "m_VAV_SW_1 (" in run.stderr and "--interpolate-gaps MINUTES" in run.stderr, run.stderr[-600:]
