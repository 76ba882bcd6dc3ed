"""The ``quad4`` layout: a 2 x 2 floor of corner offices no diagnosis rule was tuned on (session 15)."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


def test_quad4_geometry_as_designed():
    """Four unequal corner offices, two facades each, walls between adjacent pairs only, own boxes and units."""
    from hvacfmu.building import validate_building
    from hvacfmu.emulator import emulated_building
    from hvacfmu.emulator.layouts import ahu_groups

    b = emulated_building("quad4")
    assert validate_building(b) == []
    assert b.zone_names == ("NW", "NE", "SE", "SW")
    areas = {z.name: z.area for z in b.zones}
    assert_allclose([areas[z] for z in ("NW", "NE", "SE", "SW")], [320.0, 256.0, 192.0, 240.0], rtol=0, atol=1e-9)
    facades = {z.name: sorted(f.orientation for f in z.facades) for z in b.zones}
    assert facades == {"NW": ["N", "W"], "NE": ["E", "N"], "SE": ["E", "S"], "SW": ["S", "W"]}
    pairs = {frozenset(p) for p in b.adjacency_pairs()}
    assert pairs == {frozenset(p) for p in (("NW", "NE"), ("NE", "SE"), ("SE", "SW"), ("SW", "NW"))}
    assert "SE" not in b.zone("NW").adjacent and "SW" not in b.zone("NE").adjacent  # diagonals touch at a point
    ratios = {
        (z.name, f.orientation): f.window_area / (f.window_area + f.wall_area) for z in b.zones for f in z.facades
    }
    assert_allclose(ratios[("SE", "S")], 0.60, rtol=0, atol=1e-9)
    assert_allclose(ratios[("NE", "N")], 0.25, rtol=0, atol=1e-9)
    assert len({round(r, 3) for r in ratios.values()}) >= 6  # the facades differ
    assert [len(b.vavs_of(z)) for z in b.zone_names] == [3, 2, 2, 2]
    assert ahu_groups("quad4") == {"NW": "AHU1", "NE": "AHU1", "SE": "AHU2", "SW": "AHU2"}


def test_quad4_generates_and_checks(tmp_path):
    """``generate --layout quad4`` writes a week that ``check`` accepts at the 15-min step; its truth names
    the layout's zones."""
    import json

    from hvacfmu.data.check import check

    out = tmp_path / "q"
    cmd = [sys.executable, "-m", "hvacfmu", "-q", "generate", str(out), "--layout", "quad4", "--weeks", "1"]
    cmd += ["--seed", "1", "--effect", "solar_gain:zone=SE,facade=S"]
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    rep = check(out / "measurements.parquet", out / "building.toml", step=900.0)
    assert rep.ok, rep.problems
    assert rep.exit_code == 0
    truth = json.loads((out / "truth.json").read_text())
    assert "SE" in json.dumps(truth["effects"])


def test_fleet_does_not_draw_quad4():
    """The fleet keeps the layouts it drew before quad4 existed (a fleet seed keeps its buildings)."""
    from hvacfmu.emulator.fleet import fleet_parameters

    layouts = {p["layout"] for p in fleet_parameters(60, seed=3)}
    assert layouts == {"sdh", "row4", "core9"}


def test_battery_on_quad4_covers_every_cause_twice():
    """``make_cases(..., layouts=["quad4"])``: 4 clean cases, every cause at least twice, couplings on the
    diagonal (the only non-adjacent pairs); the default battery is still drawn on row4 / core9 / sdh."""
    if str(BENCH) not in sys.path:
        sys.path.insert(0, str(BENCH))
    spec = importlib.util.spec_from_file_location("bench_diagnosis_battery", BENCH / "bench_diagnosis_battery.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    cases = mod.make_cases(20, 2026, ["quad4"], n_clean=4, n_pair=4, step=900.0)
    assert {c["layout"] for c in cases} == {"quad4"} and {c["step"] for c in cases} == {900.0}
    assert sum(not c["effects"] for c in cases) == 4
    causes = [e.split(":")[0] for c in cases for e in c["effects"]]
    for cause in mod.CAUSES:
        assert causes.count(cause) >= 2, cause
    for c in cases:
        for e in c["effects"]:
            if e.startswith("zone_coupling:"):
                pair = set(e.split("zones=")[1].split(",")[0].split("+"))
                assert pair in ({"NW", "SE"}, {"NE", "SW"}), e
    assert {c["layout"] for c in mod.make_cases(48, 2026)} == {"row4", "core9", "sdh"}


@pytest.mark.parametrize(
    "climate, start, hvac",
    [("hot", "2026-07-06", "vav"), ("cold", "2026-01-12", "reheat"), ("mild", "2025-10-06", "vav")],
)
def test_quad4_simulates_plausibly_with_every_effect(climate, start, hvac):
    """One week with every effect (locations drawn): plausible temperatures, boxes cooling above minimum but not
    saturated in the hot climate, the coupling on a diagonal, and the plant replays the closed loop exactly."""
    from hvacfmu.emulator import Plant, make_truth, simulate
    from hvacfmu.emulator.effects import EFFECT_NAMES

    truth = make_truth(1, 3, list(EFFECT_NAMES), start=start, layout="quad4", climate=climate, hvac=hvac)
    sim = simulate(truth)
    T = sim["T_zone"]
    assert T.shape[1] == 4 and np.all(np.isfinite(T))
    assert 15.0 < np.percentile(T, 1) and np.percentile(T, 99) < 29.0  # [°C]
    (pair,) = [set(e["zones"]) for e in truth["effects"] if e["name"] == "zone_coupling"]
    assert pair in ({"NW", "SE"}, {"NE", "SW"})
    if climate == "hot":
        vavs = truth["baseline"]["building"]["vavs"]
        m_min = np.array([v["m_min"] for v in vavs])
        m_max = np.array([v["m_max"] for v in vavs])
        idx = sim["index"]
        afternoon = np.asarray((idx.day_of_week < 5) & (idx.hour >= 10) & (idx.hour < 18))
        cooling = np.mean((sim["m_vav"][afternoon] - m_min) / (m_max - m_min))
        assert 0.1 < cooling < 0.9, cooling
    if climate == "cold":
        assert sim["reheat"].sum() > 0
        plant = Plant.from_truth(truth)
        assert plant.zones == ("NW", "NE", "SE", "SW")
        x, out = sim["x0"], []
        for k in range(720):
            x, Tz = plant.advance(
                x,
                60.0 * k,
                60.0,
                sim["m_vav"][k],
                sim["T_out"][k],
                sim["T_supply"][k],
                sim["I"][k],
                reheat=sim["reheat_command"][k],
            )
            out.append(Tz)
        assert_allclose(np.array(out)[:-1], T[1:720], rtol=0, atol=1e-9)  # [K]
