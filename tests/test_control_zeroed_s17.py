"""A term the control model's refit drops is named, not silently left out (session 17, issue 18 p.5).

``terms_on_base`` refits the diagnosis's terms on the base's dynamics. A refit that puts every coefficient of a
term at its bound 0 removes the term from the control model: the MPC then controls without it. Session 17 measured
that on a quad4 coupling found at t 5.3 (``benchmarks/control_gain_coupling_s17.md``); it now warns, records it in
``meta["control_base"]["notes"]`` and ``meta["zeroed"]``, and names ``keep=`` as the way to keep the diagnosis's value.
Session 19 (``benchmarks/control_front_s19.md``): a zone coupling the refit zeroes keeps the diagnosis's
coefficients by default (``keep_zeroed``), said by a warning; a term that comes without coefficients stays dropped.
"""

from __future__ import annotations

import warnings

import pytest

from hvacfmu.diagnosis.control import zeroed_terms
from hvacfmu.errors import HvacfmuWarning
from hvacfmu.models.causes import SolarGain, ZoneCoupling


def test_zeroed_terms_names_only_terms_whose_every_coefficient_is_zero():
    pair, sun = ZoneCoupling(zone_a="NW", zone_b="S"), SolarGain(zone="S", facade="S")
    assert zeroed_terms([pair, sun], [{"coef_ab": 0.0, "coef_ba": 0.0}, {"coef": 0.3}]) == [pair]
    assert zeroed_terms([pair], [{"coef_ab": 0.0, "coef_ba": 1e-6}]) == []
    assert zeroed_terms([pair], [{"coef_ab": 0.0, "coef_ba": 0.0}], keep=("zone_coupling",)) == []
    assert zeroed_terms([pair], [{}]) == []  # a term without coefficients is not "set to 0"


@pytest.mark.slow
def test_control_model_warns_when_its_refit_drops_a_coupling():
    """12 emulated weeks without any coupling: the non-adjacent NW+S conductance refits to 0 on the base (measured:
    every one of the 15 pairs does), and the warning says so."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis.control import terms_on_base
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.fitting import fit

    paths = cached_dataset(weeks=12, seed=0, effects=["solar_gain:zone=S,facade=S"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        ds = prepare(paths.measurements, paths.building, seed=0)
        base = fit(ds, "zones", progress=False, use_solar=False, heat="airflow", open_loop=False)
    with pytest.warns(HvacfmuWarning, match=r"sets zone_coupling in NW, S to 0 .* keep=\('zone_coupling',\)"):
        model = terms_on_base(ds, base, [ZoneCoupling(zone_a="NW", zone_b="S"), SolarGain(zone="S", facade="S")])
    (pair, sun) = model.terms
    assert pair.coef_ab == pair.coef_ba == 0.0 and sun.coef > 0.0
    assert [z["zones"] for z in model.meta["zeroed"]] == [["NW", "S"]]
    assert any("NW, S to 0" in n for n in model.meta["control_base"]["notes"])
    assert model.meta["zeroed"][0]["kept"] is False  # it came without coefficients: nothing to keep

    # a coupling that comes with the diagnosis's coefficients keeps them where the refit zeroes it (session 19)
    found = ZoneCoupling(zone_a="NW", zone_b="S", coef_ab=0.05, coef_ba=0.04)
    with pytest.warns(HvacfmuWarning, match=r"sets zone_coupling in NW, S to 0 .* keeps the diagnosis's coefficients"):
        kept = terms_on_base(ds, base, [found, SolarGain(zone="S", facade="S")])
    (pair_k, sun_k) = kept.terms
    assert (pair_k.coef_ab, pair_k.coef_ba) == (0.05, 0.04)
    assert sun_k.coef != sun.coef  # the solar term is refitted around the kept conductance
    assert kept.meta["zeroed"][0]["kept"] is True
    # keep_zeroed=() is session 17's control model: the refit's 0, warned as before
    with pytest.warns(HvacfmuWarning, match=r"sets zone_coupling in NW, S to 0 .* keep=\('zone_coupling',\)"):
        dropped = terms_on_base(ds, base, [found, SolarGain(zone="S", facade="S")], keep_zeroed=())
    assert dropped.terms[0].coef_ab == dropped.terms[0].coef_ba == 0.0
    assert dropped.terms[1].coef == sun.coef
