"""A temperature column written in tenths of a degree F was told it "looks like K" (session 19).

A BMS that trends integer tenths (704 for 70.4 °F) gave a median of 704, and the hint said kelvin, which no air
is at 704 K. The hint now names the scales a median fits: K only from 220 to 340, tenths of a degree C or F
where a tenth of the median is a room or outdoor temperature in that unit.
"""

from __future__ import annotations

import copy

import pytest
from test_properties import BUILDING, base_frame, write

from hvacfmu.building import building_from_dict
from hvacfmu.data import check


def _problem(frame, tmp_path, column, units):
    d = copy.deepcopy(BUILDING)
    d["units"] = units
    report = check(write(frame, tmp_path / "m.csv", "offset"), building_from_dict(d))
    (msg,) = [p for p in report.problems if f"column {column!r}" in p]
    return msg


@pytest.mark.parametrize(
    ("scale", "offset", "units", "expected"),
    [
        (18.0, 320.0, {"T_*": "degF"}, "look like tenths of a degree F (divide by 10)"),  # 70.4 °F as 704
        (10.0, 0.0, {"T_*": "degF"}, "look like tenths of a degree C (divide by 10)"),  # 21.5 °C as 215
        (1.0, 273.15, {"T_*": "degF"}, "look like K"),  # kelvin (or tenths of °C): still K first
    ],
)
def test_a_large_zone_temperature_names_the_scale_it_fits(tmp_path, scale, offset, units, expected):
    f = base_frame(days=8)
    f["T_A"] = (f["T_A"] * scale + offset).round()
    msg = _problem(f, tmp_path, "T_A", units)
    assert "declared degF but the median is" in msg and expected in msg
