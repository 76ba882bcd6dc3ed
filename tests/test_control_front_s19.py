"""Comfort-against-energy fronts of two controllers compared at equal energy (issue 18 point 5, session 19).

``benchmarks/control_front_s19.py`` runs each controller at several comfort weights and compares the fronts: a
run against the other controller's Pareto front interpolated at the run's energy (and at its K·h). These tests
pin the arithmetic on hand-made fronts (no MPC run; the week-long runs are the benchmark's).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from control_front_s19 import at_equal, front_gap, interp, interp_energy, pareto  # noqa: E402


def run(w, kh, su2, reheat=0.0):
    return {"weight": w, "comfort_violation_Kh": kh, "energy_proxy": su2, "heating_kWh": reheat}


def test_pareto_drops_runs_beaten_in_energy_and_comfort():
    # the default weight spends more and holds no fewer K·h than weight 50: off the front (session 17's base, Q34)
    runs = [run(1e4, 0.46, 400.6), run(50, 0.45, 397.8), run(10, 0.60, 380.0), run(30, 0.45, 399.0)]
    assert [r["weight"] for r in pareto(runs)] == [10, 50]
    # on the reheat axis the order is the reheat's
    runs = [run(1e4, 1.0, 400, 10.0), run(10, 2.0, 380, 12.0)]
    assert [r["weight"] for r in pareto(runs, "heating_kWh")] == [1e4]


def test_interpolation_is_linear_between_front_points_and_none_outside():
    front = pareto([run(1e4, 1.0, 400.0), run(30, 2.0, 380.0), run(3, 5.0, 300.0)])
    assert interp(front, 390.0) == pytest.approx(1.5)
    assert interp(front, 340.0) == pytest.approx(3.5)
    assert interp(front, 400.0) == pytest.approx(1.0)
    assert interp(front, 401.0) is None and interp(front, 299.0) is None
    assert interp_energy(front, 1.5) == pytest.approx(390.0)
    assert interp_energy(front, 3.5) == pytest.approx(340.0)
    assert interp_energy(front, 0.5) is None and interp_energy(front, 6.0) is None


def test_runs_against_the_other_front_at_equal_energy():
    base = [run(1e4, 1.0, 400.0, 20.0), run(30, 2.0, 380.0, 18.0), run(3, 5.0, 300.0, 10.0)]
    # a run at the base's default energy is no gain; one at 390 with 1.2 K·h beats the base front (1.5 there)
    ext = [run(1e4, 0.5, 420.0, 22.0), run(30, 1.2, 390.0, 20.0)]
    got = {c["run"]["weight"]: c for c in at_equal(ext, base)}
    assert got[1e4]["saved_Kh"] is None  # 420 is beyond the base's front: no extrapolation
    assert got[1e4]["saved_energy"] is None  # and 0.5 K·h below anything the base reaches
    assert got[30]["saved_Kh"] == pytest.approx(0.3)
    assert got[30]["saved_energy"] == pytest.approx(396.0 - 390.0)  # the base needs 396 for 1.2 K·h
    assert got[30]["other_axis"] == pytest.approx(20.0 - 19.0)  # and spends 1 kWh more reheat there
    # vice versa: the base's default run against the extended front (420 ↔ 390 covers 400)
    (b0,) = [c for c in at_equal(base, ext) if c["run"]["weight"] == 1e4]
    ext_at_400 = 1.2 + (400.0 - 390.0) / 30.0 * (0.5 - 1.2)
    assert b0["saved_Kh"] == pytest.approx(ext_at_400 - 1.0)


def test_front_gap_over_the_common_range():
    base = [run(1e4, 1.0, 400.0), run(3, 5.0, 300.0)]
    better = [run(1e4, 0.0, 400.0), run(3, 4.0, 300.0)]  # one K·h fewer everywhere
    g = front_gap(base, better)
    assert (g["lo"], g["hi"]) == (300.0, 400.0)
    assert g["mean"] == pytest.approx(1.0) and g["min"] == pytest.approx(1.0) and g["max"] == pytest.approx(1.0)
    crossing = [run(1e4, 2.0, 400.0), run(3, 4.0, 300.0)]  # better at low energy, worse at high
    g = front_gap(base, crossing)
    assert g["at_lo"] == pytest.approx(1.0) and g["at_hi"] == pytest.approx(-1.0) and g["mean"] == pytest.approx(0.0)
    assert front_gap(base, [run(1e4, 0.0, 500.0)]) is None  # no common energy
    # session 19's quad4 summer fronts: the grid's last energy must not round past the common range's end
    g = front_gap([run(30, 0.47, 391.7), run(10, 0.54, 375.4)], [run(30, 0.13, 405.2), run(10, 0.27, 374.2)])
    assert g["hi"] == 391.7 and g["at_hi"] > 0.0
