"""The holiday scale gate leaves out a zone its own control holds (session 21, ``benchmarks/fresh_s21.md``, a10).

A heater (``reheat``) or a held set point takes a holiday's lost gains in that zone, so its temperature shows no
holiday and its fitted scale sits at the bound 0; kept in, it pulled row4 case a10's mean to 0.318 < 0.33.
"""

import numpy as np

from hvacfmu.diagnosis.selection import _holiday_scale_with, _zones_held_by_control
from hvacfmu.models.causes.reheat import Reheat
from hvacfmu.models.causes.solar_gain import SolarGain

ZONES = ("R1", "R2", "R3", "R4")
G = np.array([0.30, 0.0, 0.66, 0.37])  # a10's fitted scales, R2 held by its reheat
W = np.array([0.018, 0.014, 0.012, 0.018])
AGAINST = {z: (g, 1.0, 0.11) for z, g in zip(ZONES, (0.35, 0.003, 0.6, 0.4))}  # R2 reads neither way


def _gate(held):
    ev = {"scale_mean": float(W @ G / W.sum())}
    _holiday_scale_with(ev, G, W, ZONES, AGAINST, held=held)
    return ev


def test_a_held_zone_at_zero_is_left_out():
    before = _gate(frozenset())
    assert before["scale_mean"] < 0.33 and "scale_zones_held" not in before
    after = _gate({"R2"})
    assert after["scale_zones_held"] == ["R2"] and "R2" in after["scale_zones_at_bound"]
    assert after["scale_mean"] > 0.33
    assert np.isclose(after["scale_mean"], float(W[[0, 2, 3]] @ G[[0, 2, 3]] / W[[0, 2, 3]].sum()))


def test_a_held_zone_with_a_holiday_stays_in():
    g = G.copy()
    g[1] = 0.5  # R2 shows the holiday after all: its evidence counts
    ev = {"scale_mean": float(W @ g / W.sum())}
    _holiday_scale_with(ev, g, W, ZONES, AGAINST, held={"R2"})
    assert "scale_zones_held" not in ev and ev["scale_mean"] == float(W @ g / W.sum())


def test_held_zones_are_those_with_reheat_or_held_setpoint_terms():
    terms = [Reheat(zone="R2"), SolarGain(zone="R1", facade="S")]
    assert _zones_held_by_control(terms) == {"R2"}
