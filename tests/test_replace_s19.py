"""``coupling_instrument_neighbours="replace"`` and the facade weather check (session 19, issue 15).

With ``"replace"`` the neighbour-held instrument (:func:`coupling_instrument_beyond_neighbours`) gates a coupling
scored zone by zone instead of session 17's plain instrument. Until session 19 it also skipped the instrument
with the facades' weather held (``coupling_shared_weather``), which is a different question: with the facade
options on, README battery 2026 clean case 0 (``row4``) then reported a false R1+R4 coupling
(``benchmarks/replace_s19.md``: plain instrument t 2.8, weather-controlled t 1.4, neighbour-held t 2.8).
"""

from __future__ import annotations

from types import SimpleNamespace

from hvacfmu.models.causes import ZoneCoupling


def _iv(t: float, coef: float, zones=("R1", "R4")) -> dict:
    return {
        "iv_coef": coef,
        "iv_t": t,
        **{f"iv_coef_{z}": coef for z in zones},
        **{f"iv_first_F_{z}": 30.0 for z in zones},
    }


def _candidate(weather: bool, plain_t: float) -> SimpleNamespace:
    """A coupling R1+R4 scored zone by zone with the instrument figures measured on ``row4`` clean case 0."""
    ev = {
        "scored_alone": True,
        "symmetry_ratio": 1.0,
        "instrument": _iv(plain_t, 0.067),
        "instrument_neighbours": _iv(2.76, 0.041),
    }
    if weather:
        ev["instrument_weather"] = {**_iv(1.45, 0.025), "controls": ["I_N", "I_S", "T_out low-passed 3 h"]}
    return SimpleNamespace(
        cause="zone_coupling",
        test={"delta_bic": 39.0},
        evidence=ev,
        term=ZoneCoupling(zone_a="R1", zone_b="R4", coef_ab=0.01, coef_ba=0.01),
        status="not tested",
        reason="",
    )


def _gate(c, **options) -> SimpleNamespace:
    from hvacfmu.diagnosis import selection as S

    S._gate(c, {**S.DEFAULT_OPTIONS, **options})
    return c


def test_replace_keeps_the_facade_weather_check():
    """Fails before session 19: ``"replace"`` returned early and accepted the pair the weather controls reject."""
    c = _gate(_candidate(weather=True, plain_t=2.83), coupling_instrument_neighbours="replace")
    assert c.status == "no evidence"
    assert "beyond the weather of their facades" in c.reason
    # the same reason when the plain instrument fails too: under "replace" it is not the condition
    c = _gate(_candidate(weather=True, plain_t=0.9), coupling_instrument_neighbours="replace")
    assert c.status == "no evidence" and "beyond the weather of their facades" in c.reason


def test_replace_drops_only_the_plain_instrument():
    """Without the weather check, ``"replace"`` passes a pair the plain instrument fails and the held one passes;
    with both instruments required (``True``) the plain one rejects it."""
    c = _gate(_candidate(weather=False, plain_t=0.9), coupling_instrument_neighbours="replace")
    assert c.status == "not tested"
    c = _gate(_candidate(weather=False, plain_t=0.9), coupling_instrument_neighbours=True)
    assert c.status == "no evidence" and "not shown to be an exchange" in c.reason


def test_replace_names_the_held_instrument_when_both_fail():
    """Under ``"replace"`` a pair failing both instruments is not said to pass "through the zones between them"
    (that reason holds when the plain instrument passes). Fails before session 19."""
    c = _candidate(weather=False, plain_t=0.9)
    c.evidence["instrument_neighbours"] = _iv(1.1, 0.03)
    c = _gate(c, coupling_instrument_neighbours="replace")
    assert c.status == "no evidence"
    assert "through the zones between them" not in c.reason
    assert "with each zone's neighbours held" in c.reason and "t = 1.1 < 2" in c.reason
    # both required: the plain instrument passing, the held one failing, keeps session 18's reason
    c = _candidate(weather=False, plain_t=2.83)
    c.evidence["instrument_neighbours"] = _iv(1.1, 0.03)
    c = _gate(c, coupling_instrument_neighbours=True)
    assert c.status == "no evidence" and "through the zones between them" in c.reason


def test_a_coupled_zone_is_held_as_a_neighbour():
    """Row model A–B–C with a coupling A+C already in the model: the held instrument of the pair A+B holds C in
    A's equation too (a coupling carries heat as a wall does); before session 19 A's equation held no zone, so a
    move of B reaching A through C was credited to A+B (checked battery case 43: a false N+E through the injected
    N+SE, ``benchmarks/replace_s19.md``). Fails before session 19 (no ``held_<zone>`` evidence, C not held)."""
    from test_diagnosis import row_model, simulate_dataset

    from hvacfmu.diagnosis import selection as S
    from hvacfmu.diagnosis.design import make_signals
    from hvacfmu.models.causes.signals import Within

    sig = make_signals(simulate_dataset(row_model(), weeks=8, seed=1), row_model())
    W = Within(sig.group, sig.rows("train"))
    pair = ZoneCoupling(zone_a="A", zone_b="B", coef_ab=0.0, coef_ba=0.0)
    ac = ZoneCoupling(zone_a="A", zone_b="C", coef_ab=0.01, coef_ba=0.01)
    held = S.coupling_instrument_beyond_neighbours(sig, W, [ac], pair, 24)
    assert held["held_A"] == ["C"] and held["held_B"] == ["C"]
    plain = S.coupling_instrument_beyond_neighbours(sig, W, [], pair, 24)
    assert plain["held_A"] == [] and plain["held_B"] == ["C"]
    assert held["iv_t"] != plain["iv_t"]  # C's move is now taken out of A's equation
