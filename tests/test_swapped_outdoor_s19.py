"""Outdoor and supply air exported under each other's names (session 19).

`check` read a T_out column holding supply air as "a weather feed on another clock" and advised shifting it by
hours, which would have fitted a model with the supply air as weather. The supply column that carries the outdoor
air's daily cycle on the clock ghi confirms names the swap instead; a genuinely shifted feed keeps its advice.
"""

from __future__ import annotations

import numpy as np
from test_properties import base_frame
from test_refuse_audit import _check, _one


def test_outdoor_and_supply_air_swapped_are_named_as_a_swap(tmp_path):
    f = base_frame(days=8)
    f[["T_out", "T_supply_AHU1"]] = f[["T_supply_AHU1", "T_out"]].to_numpy()
    report = _check(f, tmp_path)
    msg = _one(report.warnings, "T_out: its daily cycle")
    assert "column T_supply_AHU1 has the outdoor air's daily cycle on time" in msg
    assert "T_supply_AHU1 and T_out look swapped" in msg and "shift the T_out column" not in msg
    assert report.exit_code == 3


def test_a_shifted_weather_feed_beside_a_supply_that_follows_it_keeps_the_shift_advice(tmp_path):
    """An economiser's mixed air follows the outdoor air on time but swings less: not a swap."""
    f = base_frame(days=8)
    f["T_supply_AHU1"] = 13.0 + 0.3 * (f["T_out"].to_numpy() - f["T_out"].mean())
    f["T_out"] = np.roll(f["T_out"].to_numpy(), 7 * 4)  # a weather feed in UTC joined to local times
    msg = _one(_check(f, tmp_path).warnings, "T_out: its daily cycle")
    assert "shift the T_out column to the data's clock" in msg and "swapped" not in msg
