"""The battery's detectability oracle (benchmarks/battery_oracle.py; README "Battery and speed", oracle)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


def _module(name):
    if str(BENCH) not in sys.path:
        sys.path.insert(0, str(BENCH))  # bench_diagnosis_battery imports battery_oracle by name
    spec = importlib.util.spec_from_file_location(name, BENCH / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _g(gain, t):
    return {"gain_percent": gain, "se_percent": 1.0, "t": t, "n_weeks": 13}


def _coupling(alone, pair):
    return {
        "name": "zone_coupling",
        "location": {"zones": ["A", "B"]},
        "alone": {"A": _g(*alone), "B": _g(0.5, 0.3)},
        "pair_true_k": {**_g(*pair), "k": [0.1, 0.1]},
        "pair_fitted": _g(0.0, 0.0),
    }


def test_detectable_uses_the_rules_floors_and_both_coupling_definitions():
    bo = _module("battery_oracle")
    # a coupling: (a) either zone alone, (b) the pair at its true conductance; floor 3 %, t >= 2
    r = _coupling((10.0, 5.0), (-0.5, -0.2))
    assert bo.detectable(r, "a") and not bo.detectable(r, "b")
    assert not bo.detectable(_coupling((2.5, 9.0), (2.5, 9.0)), "a")  # under the coupling floor of 3 %
    assert bo.detectable(_coupling((0.0, 0.0), (3.5, 2.1)), "b")
    # other causes: 1 % and t >= 2, the same for (a) and (b); no oracle form -> None
    assert bo.detectable({"name": "thermal_mass", "gain": _g(1.0, 0.4)}) is False
    assert bo.detectable({"name": "reheat", "gain": _g(1.2, 2.0)}, "b") is True
    assert bo.detectable({"name": "internal_gain_schedule", "gain": None}) is None


def test_oracle_columns_count_detectable_effects_and_compare_with_the_clean_level():
    bat = _module("bench_diagnosis_battery")
    case = {
        "id": 1,
        "layout": "row4",
        "step": 900.0,
        "seed": 0,
        "effects": ["zone_coupling:zones=A+B", "reheat:zone=A"],
    }
    clean_case = {"id": 0, "layout": "row4", "step": 900.0, "seed": 0, "effects": []}
    results = [
        {"case": case, "found": ["reheat"], "missed": [{"name": "zone_coupling"}], "unsupported": []},
        {"case": clean_case, "found": [], "missed": [], "unsupported": []},
    ]
    clean_reheat = {"name": "reheat", "location": {"zone": "B"}, "gain": _g(5.0, 3.0)}
    oracle = {
        1: {"case": case, "effects": [_coupling((10.0, 5.0), (-0.5, -0.2)), {"name": "reheat", "gain": _g(4.0, 3.0)}]},
        0: {"case": clean_case, "effects": [], "clean": [_coupling((12.0, 6.0), (-30.0, -5.0)), clean_reheat]},
    }
    conf, _ = bat.confusion(results)
    tot = bat._oracle_counts(conf, results, oracle)
    assert conf["zone_coupling"]["oracle a"] == 1 and conf["zone_coupling"]["oracle b"] == 0
    assert conf["reheat"]["oracle a"] == 1 and conf["reheat"]["oracle b"] == 1
    # neither effect gains more than the most-gaining uninjected candidate of its cause (12 %, 5 %)
    assert conf["zone_coupling"]["above clean"] == 0 and conf["reheat"]["above clean"] == 0
    assert (tot["oracle a"], tot["oracle a found"], tot["oracle b"], tot["oracle b found"]) == (2, 1, 1, 1)


@pytest.mark.slow
def test_oracle_row4_coupling_is_visible_zone_by_zone_but_not_as_the_pair_at_its_true_conductance():
    """Battery case 25 (row4, R1+R4, 928 W/K), the diagnosis' known miss (README "couplings").

    Measured on this machine: each zone alone with its partner measured +21.2 % (t 8.6) / +29.3 %
    (t 8.5); the pair simulated together at the true conductance 0.173/step −0.5 % (t −0.2).
    """
    bo = _module("battery_oracle")
    case = _module("bench_diagnosis_battery").make_cases(48, 2026)[25]
    rec = bo.oracle_case(case, 16)
    (e,) = rec["effects"]
    assert e["name"] == "zone_coupling" and sorted(e["location"]["zones"]) == ["R1", "R4"]
    assert all(g["gain_percent"] > 10 and g["t"] > 4 for g in e["alone"].values())
    assert abs(e["pair_true_k"]["gain_percent"]) < 3 and e["pair_true_k"]["t"] < 2
    assert e["pair_true_k"]["k"] == pytest.approx([0.173, 0.173], abs=0.002)
    assert bo.detectable(e, "a") and not bo.detectable(e, "b")


def test_stronger_scales_each_cause_s_magnitude_and_keeps_the_location():
    """The detectability gate's step (``--detectable``): magnitude × 1.5, location and other keys unchanged."""
    bo = _module("battery_oracle")
    assert bo.stronger("zone_coupling:zones=R1+R4,ua=928") == "zone_coupling:zones=R1+R4,ua=1392"
    assert bo.stronger("solar_gain:zone=R4,facade=N,shgc=0.20") == "solar_gain:zone=R4,facade=N,shgc=0.3"
    assert bo.stronger("solar_gain:zone=R4,facade=N,shgc=0.6") == "solar_gain:zone=R4,facade=N,shgc=0.8"  # cap
    # thermal mass: capacitance and conductance together, so the time constant stays 59 h
    s = bo.stronger("thermal_mass:zone=S,capacitance=2.35e+08,ua=1103")
    assert s == "thermal_mass:zone=S,capacitance=3.52e+08,ua=1654"
    assert bo.stronger("reheat:zone=SE,power=3190,below=14.8") == "reheat:zone=SE,power=4785,below=14.8"
    # a holiday keeps a smaller share of the gains; a delay grows by 15 minutes up to 90
    h = bo.stronger("internal_gain_schedule:kind=holiday,weeks=1+7,factor=0.3")
    assert h == "internal_gain_schedule:kind=holiday,weeks=1+7,factor=0.2"
    assert bo.stronger("actuation_delay:zone=C,minutes=30") == "actuation_delay:zone=C,minutes=45"
    assert bo.stronger("actuation_delay:zone=C,minutes=90") == "actuation_delay:zone=C,minutes=90"


def test_gate_scores_a_coupling_as_the_pair_fitted_and_other_causes_as_the_true_term():
    bo = _module("battery_oracle")
    r = _coupling((30.0, 9.0), (5.0, 4.0))  # alone and at the true conductance both pass ...
    assert not bo.gate_passes(r)  # ... but the gate asks the pair fitted together (0 %)
    r["pair_fitted"] = _g(3.8, 3.4)
    assert bo.gate_passes(r)
    r["pair_fitted"] = _g(2.9, 9.0)  # under the coupling floor of 3 %
    assert not bo.gate_passes(r)
    assert bo.gate_passes({"name": "solar_gain", "gain": _g(5.2, 2.3)})
    assert not bo.gate_passes({"name": "solar_gain", "gain": _g(3.6, 1.9)})


def test_gate_recall_leaves_out_only_the_effects_still_failing(capsys):
    bat = _module("bench_diagnosis_battery")
    c1 = {"id": 1, "effects": ["solar_gain:zone=A", "zone_coupling:zones=A+B"]}
    c2 = {"id": 2, "effects": ["reheat:zone=A"]}
    c3 = {"id": 3, "effects": ["thermal_mass:zone=B"]}
    results = [
        {"case": c1, "found": ["solar_gain"], "missed": [{"name": "zone_coupling"}]},
        {"case": c2, "found": [], "missed": [{"name": "reheat"}]},
        {"case": c3, "found": ["thermal_mass"], "missed": []},
    ]

    def rec(case, fails, stronger=False):
        gate = [{"name": e.split(":")[0], "passes": e.split(":")[0] not in fails} for e in case["effects"]]
        checked = {**case, "effects": [e + ",x=1" for e in case["effects"]]} if stronger else case
        return {"case": case, "checked": checked, "tries": [{"gate": gate}]}

    gated = {1: {**rec(c1, {"zone_coupling"}, True), "redraws": 3}, 2: rec(c2, set()), 3: rec(c3, set(), True)}
    bat.print_gate(results, gated)
    out = capsys.readouterr().out
    assert "made stronger: [1, 3]" in out and "still not detectable: {1: ['zone_coupling']}" in out
    assert "drawn anew (same cause, 3 times at most): {1: 3}" in out
    # the failing coupling is left out; the missed reheat passes the gate and counts
    assert "over the effects that pass the gate: 2/3 = 67 %" in out


def test_redraw_keeps_the_cause_and_is_seeded():
    bo = _module("battery_oracle")
    case = _module("bench_diagnosis_battery").make_cases(48, 2026)[25]  # row4, one coupling
    one, again, two = bo._redrawn(case, 1), bo._redrawn(case, 1), bo._redrawn(case, 2)
    assert one == again and one != two
    for c in (one, two):
        (e,) = c["effects"]
        assert e.startswith("zone_coupling:zones=") and c["layout"] == "row4" and c["id"] == 25


@pytest.mark.slow
def test_gate_makes_the_north_solar_of_case_42_stronger_until_its_true_term_is_detectable():
    """Battery case 42 (row4 R4 north window): the checked record (benchmarks/battery_checked_cases.jsonl)
    made it 1.5x stronger three times; the oracle recomputed here must fail the gate at shgc 0.45 and pass
    at 0.675 (measured: +3.6 % t 1.9, +5.2 % t 2.3)."""
    import json

    bo = _module("battery_oracle")
    recs = [json.loads(line) for line in (BENCH / "battery_checked_cases.jsonl").read_text().splitlines()]
    (rec,) = [r for r in recs if r["case"]["id"] == 42]
    assert rec["detectable"] and rec["checked"]["effects"] == ["solar_gain:zone=R4,facade=N,shgc=0.675"]
    for spec, passes in (("solar_gain:zone=R4,facade=N,shgc=0.45", False), (rec["checked"]["effects"][0], True)):
        (e,) = bo.oracle_case({**rec["case"], "effects": [spec]}, 16)["effects"]
        assert bo.gate_passes(e) is passes, (spec, e["gain"])
