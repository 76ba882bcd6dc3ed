"""The ``reheat`` cause's box-off regime: heat that runs while the zone's box is shut (session 13, issue 15).

The minimum-airflow regime ``1[u ≤ 1.05 u_min] · 1[T_out < θ]`` also holds in occupied hours when
the box sits at its minimum; on the EnergyPlus bed two off-hours heaters were missed in that form and found
with the box-off variants (``u ≤ 5 %`` of the minimum; benchmarks/diagnosis_energyplus_oracle_s13.md).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from test_diagnosis import ROW, TZ, row_model, simulate_zones

from hvacfmu.building import building_from_dict
from hvacfmu.data.dataset import Dataset
from hvacfmu.diagnosis import diagnose
from hvacfmu.diagnosis.report import _short_evidence
from hvacfmu.models.causes.reheat import BOX_OFF_FRACTION, Reheat
from hvacfmu.models.extended import ExtendedModel

#: the heater: 0.05 K/step into zone B while its box is shut and T_out < 6 °C
HEATER = Reheat(zone="B", coef=0.05, u_min=0.05 * BOX_OFF_FRACTION, T_threshold=6.0)


def boxes_off_at_night(model, weeks=8, seed=0, noise=0.02) -> Dataset:
    """Winter data whose boxes shut outside 07:00–19:00 on weekdays (airflow 0) and sit at their minimum
    (0.05 kg/s) in most cold occupied hours; temperatures simulated from ``model`` with process noise [K]."""
    rng = np.random.default_rng(seed)
    building = building_from_dict(ROW)
    idx = pd.date_range("2025-11-03", periods=weeks * 672, freq="15min", tz=TZ, name="time")
    n = len(idx)
    hour = np.asarray(idx.hour) + np.asarray(idx.minute) / 60.0
    days = np.arange(n) / 96.0
    T_out = 6 + 5 * np.sin(2 * np.pi * (hour - 9) / 24) + 4 * np.sin(2 * np.pi * days / 11.0) + rng.normal(0, 0.3, n)
    T_supply = 14 + 0.5 * np.sin(2 * np.pi * days / 3.1) + rng.normal(0, 0.1, n)
    u = rng.uniform(0.06, 0.5, (n // 4 + 1, 3)).repeat(4, axis=0)[:n]
    occupied = (np.asarray(idx.day_of_week) < 5) & (hour >= 7) & (hour < 19)
    at_min = occupied & (T_out < 8) & (rng.random(n // 4 + 1) < 0.8).repeat(4)[:n]
    u[at_min] = 0.05
    u[~occupied] = 0.0
    frame = pd.DataFrame({"T_out": T_out, "T_supply": T_supply}, index=idx)
    for j, v in enumerate(("V1", "V2", "V3")):
        frame[f"m_{v}"] = u[:, j]
    frame["ghi"] = np.maximum(0, np.sin(np.pi * (hour - 7.5) / 9)) * 500
    simulate_zones(model, frame, building, seed, rng, noise)
    return Dataset.from_frame(frame, building, step=900.0, seed=seed)


def test_heat_while_the_box_is_off_is_found_in_the_box_off_regime():
    base = row_model()
    ds = boxes_off_at_night(ExtendedModel(base=base, terms=(HEATER,)))
    rep = diagnose(ds, model=base, progress=False)
    hits = [f for f in rep.findings if f["cause"] == "reheat"]
    assert [f["location"] for f in hits] == [{"zone": "B"}], rep.summary()
    f = hits[0]
    assert f["evidence"]["u_min"] == pytest.approx(0.05 * BOX_OFF_FRACTION), f["evidence"]
    assert "box off" in _short_evidence(f), _short_evidence(f)
    est = f["parameters"]["coef"]
    assert abs(est["value"] - HEATER.coef) <= max(4 * (est["std"] or 0.0), 0.2 * HEATER.coef), est


def test_clean_twin_without_the_heater_finds_no_reheat():
    base = row_model()
    rep = diagnose(boxes_off_at_night(base), model=base, progress=False)
    assert not [f for f in rep.findings if f["cause"] == "reheat"], rep.summary()
