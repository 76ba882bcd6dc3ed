"""Option ``coupling_alone_unshared`` (session 16): a coupling between zones that share no facade and no air
handler scored zone by zone, each zone alone and beyond the mean of every other zone (placebo).

``benchmarks/coupling_s16.md``: on ``quad4`` the diagonal pairs share no facade orientation; their injected
couplings gain +7.5 … +21 % per zone with the partner measured but lose when the pair is simulated together, so
the pair rule misses them. The option was off by default in session 16: on ``core9`` it raised false couplings
(clean battery cases 1 and 6: N+W, N+E). Session 17 added an instrument check and turned it on
(``tests/test_coupling_s17.py``).
"""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.slow

QUAD4_COUPLING = {"weeks": 16, "seed": 34, "effects": ["zone_coupling:zones=NW+SE,ua=1051"], "layout": "quad4"}


def _dataset(spec):
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(**spec)
    return prepare(paths.measurements, paths.building, step=900.0)


@pytest.fixture(scope="module")
def quad4():
    return _dataset(QUAD4_COUPLING)


def _couplings(rep):
    return [f for f in rep.to_dict()["findings"] if f["cause"] == "zone_coupling"]


def test_shared_drivers_name_a_common_facade(quad4):
    from hvacfmu.diagnosis.design import make_signals
    from hvacfmu.fitting import fit
    from hvacfmu.models.causes.zone_coupling import shared_drivers

    sig = make_signals(quad4, fit(quad4, "zones", progress=False, use_solar=False, heat="airflow", open_loop=False))
    z = sig.zones.index
    assert shared_drivers(sig, z("NW"), z("NE")) == ["facade N"]
    assert shared_drivers(sig, z("SE"), z("SW")) == ["facade S"]
    # one T_supply column for every box: which unit serves which zone is not measured, so it is not shared
    assert shared_drivers(sig, z("NW"), z("SE")) == []
    assert shared_drivers(sig, z("NE"), z("SW")) == []


def test_a_diagonal_coupling_is_found_zone_by_zone_and_missed_by_the_pair_rule(quad4):
    """Also session 17's ``test_default_finds_a_quad4_diagonal_coupling`` (``quad4`` battery 2026 case 13, the same
    data): the option is the default since session 17, so this one diagnosis is the default's, and the found pair
    must pass the instrument check (merged here in session 19: one 16-week diagnosis fewer)."""
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS

    assert DEFAULT_OPTIONS["coupling_alone_unshared"] is True  # the explicit option below is the default
    rep = diagnose(quad4, progress=False, coupling_alone_unshared=True)
    found = _couplings(rep)
    assert [sorted(f["location"]["zones"]) for f in found] == [["NW", "SE"]]
    ev = found[0]["evidence"]
    assert ev["shared_drivers"] == [] and ev["scored_alone"]
    # session 17's instrument check passes (measured: pooled 0.11 per step, t 3.2)
    assert ev["instrument"]["iv_coef"] > 0 and ev["instrument"]["iv_t"] >= 2.0
    for tests in (ev["cv_by_zone"], ev["cv_beyond_others_mean"]):
        assert set(tests) == {"NW", "SE"}
        assert all(r["gain_percent"] >= 3.0 and r["t"] >= 2.0 for r in tests.values())
    # the pair rule (the pair simulated together; the default before session 17) misses it on the same data
    assert _couplings(diagnose(quad4, progress=False, coupling_alone_unshared=False)) == []
