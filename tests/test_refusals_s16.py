"""False refusals of legitimate EnergyPlus exports found in session 16 (benchmarks/refusals_s16.md).

Seven 4-week 90.1/Ref exports were refused by ``check``/``prepare``; two causes are fixed here, each test
failed before its fix:

- a school lobby in January really falls ~15 K for an hour each morning (air handler starting on cold outdoor
  air, doors open) and climbs back over two hours: the zone-spike rule read that as an error code;
- the operating rooms' scheduled minimum flow (``OR_MinSA_Sched``: 1.0 in the day, 0.2 otherwise) was written as
  ``m_min = m_max``: the night airflow then fell under ``0.6 x m_min`` (refused as a unit error).
"""

from __future__ import annotations

import numpy as np

from hvacfmu.data.plausibility import SPIKE_SHARE_MAX, check_zone_spikes
from hvacfmu.energyplus.hvac import Box, box_limits
from hvacfmu.energyplus.idf import parse_idf

STEP_NS = 900 * 10**9


def _rows(positions, si):
    return ", ".join(f"{si[i]:g} at row {i}" for i in positions[:3])


def _lobby(days=28, seed=0):
    """Zone air of a lobby, 15-min samples: ~19 °C with a daily swing, and every morning at 07:00 a fall of
    13-17 K in one step, an hour at 1-6 °C with some wobble, then a climb back over 2 h (as the EnergyPlus 90.1
    primary/secondary school lobbies in Denver, January)."""
    rng = np.random.default_rng(seed)
    n = days * 96
    t = np.arange(n) * STEP_NS
    hour = (np.arange(n) % 96) / 4.0
    v = 19.0 + 1.0 * np.sin(2 * np.pi * (hour - 9) / 24) + rng.normal(0, 0.05, n)
    for d in range(days):
        i = d * 96 + 28  # 07:00
        low = rng.uniform(1.0, 6.0)
        v[i : i + 4] = low + rng.normal(0, 0.7, 4)
        v[i + 4 : i + 12] = low + (19.0 - low) * (1 - np.exp(-np.arange(1, 9) / 2.0))
    return v, t


def test_a_january_school_lobby_is_zone_air_not_an_error_code():
    v, t = _lobby()
    problems, warnings = [], []
    out = check_zone_spikes(v.copy(), t, np.ones(len(v), bool), "column 'T_Lobby'", _rows, problems, warnings)
    assert problems == [] and warnings == []
    assert np.isfinite(out).all()


def test_error_codes_and_dropouts_in_a_swinging_lobby_are_still_caught():
    """The smooth excursions are kept, but a code that jumps away and back (one sample or several, varying or
    not) is still masked, and too many of them are still refused."""
    v, t = _lobby(seed=1)
    ok = np.ones(len(v), bool)
    bad = v.copy()
    bad[500] = 0.0  # one sample
    bad[1200:1204] = [0.0, 0.1, 0.0, 0.2]  # a short dropout that wobbles: jumps in and out
    bad[2000:2006] = 85.0 - 50.0  # a held default
    problems, warnings = [], []
    out = check_zone_spikes(bad, t, ok, "column 'T_Lobby'", _rows, problems, warnings)
    assert problems == [] and len(warnings) == 1, (problems, warnings)
    assert np.isnan(out[[500, 1200, 1201, 1202, 1203, 2000, 2005]]).all()
    assert np.isfinite(np.delete(out, [500, 1200, 1201, 1202, 1203, *range(2000, 2006)])).all()
    many = v.copy()
    idx = np.arange(50, len(v), 40)[: int(len(v) * SPIKE_SHARE_MAX * 2)]
    many[idx] = 0.0
    problems = []
    check_zone_spikes(many, t, ok, "column 'T_Lobby'", _rows, problems, [])
    assert len(problems) == 1 and "column 'T_Lobby'" in problems[0]


_IDF = """
AirTerminal:SingleDuct:VAV:Reheat,
  OR1 VAV Box Component, ALWAYS_ON, OR1 Damper Node, OR1 Inlet Node, AUTOSIZE,
  Scheduled, , , OR_MinSA_Sched, Coil:Heating:Water, OR1 Coil, AUTOSIZE, 0.0, OR1 Outlet Node;
AirTerminal:SingleDuct:VAV:Reheat,
  Office VAV Box Component, ALWAYS_ON, Office Damper Node, Office Inlet Node, AUTOSIZE,
  Scheduled, , , Office_MDP_Sch, Coil:Heating:Water, Office Coil, AUTOSIZE, 0.0, Office Outlet Node;
Schedule:Compact,
  OR_MinSA_Sched, Fraction, Through: 12/31,
  For: Weekdays, Until: 09:00,0.2, Until: 18:00,1.0, Until: 24:00,0.2,
  For: SummerDesignDay, Until: 24:00,1.0,
  For: AllOtherDays, Until: 24:00,0.2;
Schedule:Compact,
  Office_MDP_Sch, Fraction, Through: 12/31,
  For: Weekdays, Until: 07:00,0.0, Until: 19:00,0.3, Until: 24:00,0.0,
  For: AllOtherDays, Until: 24:00,0.0;
"""


def test_a_scheduled_minimum_flow_gives_the_lowest_running_minimum():
    """m_min of a scheduled-minimum VAV terminal is the schedule's smallest positive fraction (the operating
    room's 20 % every night), not its largest (100 %, m_min = m_max); a 0 is the damper shut with its unit."""
    idf = parse_idf(_IDF, source="test.idf")
    typ = "AirTerminal:SingleDuct:VAV:Reheat"
    boxes = [
        Box("VAV_OR1", "OR1", typ, "OR1 VAV Box Component", "OR1 Inlet Node", "AHU", "n"),
        Box("VAV_Office", "Office", typ, "Office VAV Box Component", "Office Inlet Node", "AHU", "n"),
    ]
    sizing = {
        (typ.lower(), "or1 vav box component"): {"Design Size Maximum Air Flow Rate [m3/s]": 1.0},
        (typ.lower(), "office vav box component"): {"Design Size Maximum Air Flow Rate [m3/s]": 0.5},
    }
    limits = box_limits(idf, boxes, sizing, rho=1.0)
    assert limits["VAV_OR1"] == (0.2, 1.0)
    assert limits["VAV_Office"] == (0.15, 0.5)


def test_zones_energyplus_computes_identically_are_left_out_of_the_export():
    """The Ref 2004 outpatient clinic's exam halls are copies (16.723 m2, 50.97 m3, one south wall, one box each):
    EnergyPlus gives them the same air to the last digit, which check refuses as one point exported twice. The
    generator keeps the first of each set and leaves the copies out with their boxes, saying so."""
    import pandas as pd

    from hvacfmu.energyplus.generate import _leave_twins_out, twin_zones

    n = 300
    rng = np.random.default_rng(0)
    hall = np.round(20 + np.cumsum(rng.normal(0, 0.05, n)), 4)
    frame = pd.DataFrame(
        {
            "T_out": rng.normal(0, 1, n),
            "T_Hall_1": hall,
            "T_Hall_2": hall.copy(),
            "T_Hall_3": hall.copy(),
            "T_Office": np.round(hall + rng.normal(0, 0.02, n), 4),
            "T_Const_A": np.full(n, 21.0),
            "T_Const_B": np.full(n, 21.0),
        }
    )
    typ = "AirTerminal:SingleDuct:VAV:Reheat"
    boxes = [Box(f"VAV_{z}", z, typ, f"{z} box", f"{z} node", "AHU_2" if z == "Hall_3" else "AHU_1", "n") for z in
             ("Hall_1", "Hall_2", "Hall_3", "Office", "Const_A", "Const_B")]  # fmt: skip
    for b in boxes:
        frame[f"m_{b.name}"] = 0.1
        frame[f"Td_{b.name}"] = 20.0
    frame["T_supply_AHU_1"] = frame["T_supply_AHU_2"] = 13.0
    twins = twin_zones(frame, [b.zone for b in boxes])
    assert twins == {"Hall_2": "Hall_1", "Hall_3": "Hall_1"}  # constant columns are another check's business
    left_out: dict = {}
    ahus = {"AHU_1": "n1", "AHU_2": "n2"}
    out, kept, ahus, warning = _leave_twins_out(frame, boxes, ahus, twins, left_out)
    assert [b.zone for b in kept] == ["Hall_1", "Office", "Const_A", "Const_B"]
    assert list(ahus) == ["AHU_1"]
    gone = {"T_Hall_2", "T_Hall_3", "m_VAV_Hall_2", "Td_VAV_Hall_2", "m_VAV_Hall_3", "Td_VAV_Hall_3", "T_supply_AHU_2"}
    assert gone.isdisjoint(out.columns) and set(frame.columns) - set(out.columns) == gone
    assert set(left_out) == {"Hall_2", "Hall_3"} and "same air as zone Hall_1" in left_out["Hall_2"]
    assert "Hall_2 (= Hall_1)" in warning
