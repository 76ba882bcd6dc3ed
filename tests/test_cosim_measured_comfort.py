"""cosim's comfort line gives the measured zone temperatures' figure over the same steps and band.

Fourth EnergyPlus round: on the full-service restaurant in Fresno (held at 24 degC all summer, the kitchen at 26 degC)
`cosim` said "297.85 K*h outside [20, 22] degC" for the rule controller and 294.67 for the MPC, with nothing to tell the
default band from a controller failing; the measured building was 301 K*h outside the same band.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from harness.cosim import CosimResult, _measured_violation


def _run(t_a, t_b, band=(20.0, 22.0)):
    index = pd.date_range("2025-07-01", periods=len(t_a), freq="15min", tz="UTC")
    frame = pd.DataFrame({"T_A": t_a, "T_B": t_b}, index=index)
    building = SimpleNamespace(zone_names=("A", "B"), area_weights=lambda: np.array([0.75, 0.25]))
    return SimpleNamespace(
        out_names=("T_A", "T_B"),
        outputs={"T_A": ("A",), "T_B": ("B",)},
        frame=frame,
        band=band,
        step=900.0,
        building=building,
    )


def _summary(measured, steps=8, outputs=2):
    return {
        "fmu": "m.fmu", "controller": "rule", "start": "s", "end": "e", "steps_requested": steps, "step": 900.0,
        "steps_completed": steps, "covered": True, "energy_proxy": 1.0, "total_airflow_kg": 1.0,
        "mean_airflow": 1.0, "comfort_violation_Kh": 5.0, "band": [20.0, 22.0], "step_time_median": 0.0,
        "step_time_max": 0.0, "controller_time_median": 0.0, "fmu_time_median": 0.0,
        "measured_comfort_violation_Kh": measured, "outputs": outputs,
    }  # fmt: skip


def test_measured_violation_over_the_steps_taken():
    run = _run(np.full(9, 24.0), np.full(9, 21.0))  # A 2 K above the band, B inside
    assert _measured_violation(run, 8) == pytest.approx(8 * 2.0 * 0.25)
    assert _measured_violation(run, 4) == pytest.approx(4 * 2.0 * 0.25)
    # a lumped model's floor output: the area-weighted mean of its zones (0.75 x 24 + 0.25 x 21 = 23.25: 1.25 K above)
    run.out_names, run.outputs = ("T_floor",), {"T_floor": ("A", "B")}
    assert _measured_violation(run, 8) == pytest.approx(8 * 1.25 * 0.25)
    run.outputs = {"T_floor": ("A", "C")}  # a zone without a measured column: no figure
    assert _measured_violation(run, 8) is None


def test_comfort_line_names_the_measured_figure_and_the_band_option():
    far = CosimResult(table=pd.DataFrame(), summary=_summary(4.0)).format_summary()
    line = next(x for x in far.splitlines() if "comfort" in x)
    assert "(the measured zone temperatures: 4.00 K*h; the building runs outside this band itself" in line
    assert "--band" in line
    near = CosimResult(table=pd.DataFrame(), summary=_summary(0.3)).format_summary()
    line = next(x for x in near.splitlines() if "comfort" in x)
    assert line.endswith("(the measured zone temperatures: 0.30 K*h)")
    none = CosimResult(table=pd.DataFrame(), summary=_summary(None)).format_summary()
    assert next(x for x in none.splitlines() if "comfort" in x).endswith("degC")


def test_mpc_statistics_that_change_the_reading_are_said_in_words():
    st = {"steps": 192, "failures": 0, "not_converged": 47, "projected_steps": 164, "projected_max": 20.24}
    text = CosimResult(table=pd.DataFrame(), summary=dict(_summary(None), controller_stats=st)).format_summary()
    assert "164 of 192 steps planned airflows beyond the boxes' [m_min, m_max] (up to 20.2 kg/s)" in text
    assert "the band may be out of the boxes' reach there" in text
    assert "47 of 192 steps did not converge; the best iterate was applied" in text and "found no plan" not in text
    rule = CosimResult(
        table=pd.DataFrame(), summary=dict(_summary(None), controller_stats={"kp": 0.5})
    ).format_summary()
    assert "limits " not in rule and "convergence" not in rule
