"""A unit that heats in the coldest weeks only still has its held heating setpoint learned (session 17).

``held_setpoint`` learned a running unit's edge only from at least 2 % of the training rows in that mode. The
EnergyPlus mid-rise apartments' corner flats heat in 1.7-1.8 % of a year's training rows, 89-90 % of those steps ending at
their 21.1 °C setpoint: the edge was never learned and the winter model let them drift. A mode now needs
``MIN_MODE_ROWS`` rows, whatever share of the year they are (``benchmarks/apartments_s17.md``).
"""

from __future__ import annotations

import numpy as np
import pytest

from hvacfmu.models.causes import HeldSetpoint
from hvacfmu.models.causes import held_setpoint as hs

FULL = 0.2  # the unit's full airflow [kg/s]


def _winter_heating(n=30000, heat_rows=480, seed=5):
    """A year of a flat that cools most of the time (held at 24.0 °C) and heats in ``heat_rows`` steps of its
    coldest weeks (held at 21.1 °C, supply air 34 °C)."""
    rng = np.random.default_rng(seed)
    T = rng.uniform(21.5, 26.0, n)
    Ts = np.full(n, 12.5)
    u = np.zeros(n)
    cool = rng.random(n) < 0.5
    u[cool] = FULL * rng.uniform(0.05, 0.9, cool.sum())
    heat = np.zeros(n, bool)
    heat[1000 : 1000 + 3 * heat_rows : 3] = True  # within a few winter weeks
    cool &= ~heat
    u[heat] = FULL * rng.uniform(0.05, 0.9, heat.sum())
    Ts[heat] = 34.0
    T[heat] = rng.uniform(20.6, 21.0, heat.sum())  # the flat is below its heating setpoint when the unit heats
    T[1:][cool[:-1]] = 24.0
    T[1:][heat[:-1]] = 21.1
    return T, u, Ts, heat


def test_a_heating_mode_of_one_season_is_learned():
    T, u, Ts, heat = _winter_heating()
    rows = np.arange(len(T))
    assert hs.MIN_MODE_ROWS <= heat.sum() < 0.02 * len(rows)  # the corner flats: 482-499 of 27,725 rows
    term, ev = HeldSetpoint.learn("A", T, u, Ts, rows, u_min=0.0)
    assert ev["heating_ceiling"]["n"] == heat.sum()
    assert term.heating_ceiling == pytest.approx(21.1)  # main: no heating edge (under 2 % of the rows)
    assert term.cooling_floor == pytest.approx(24.0)


def test_a_mode_of_too_few_rows_is_still_not_learned():
    """Guard (passes on main too): below ``MIN_MODE_ROWS`` rows in a mode there is no edge on that side."""
    T, u, Ts, heat = _winter_heating(heat_rows=hs.MIN_MODE_ROWS - 20)
    term, ev = HeldSetpoint.learn("A", T, u, Ts, np.arange(len(T)), u_min=0.0)
    assert ev["heating_ceiling"] == {"n": int(heat.sum())}
    assert term.heating_ceiling is None and term.cooling_floor == pytest.approx(24.0)
