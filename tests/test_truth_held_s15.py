"""A held set point on the emulator is baseline physics where the zone's box controller holds its heating set point
with a reheat coil the data do not log (``hvacfmu.diagnosis.truth.finding_supported``); elsewhere it is false."""

from __future__ import annotations

from hvacfmu.diagnosis.truth import compare_with_truth, finding_supported


def _truth(reheat_zones, hvac="vav"):
    return {
        "hvac": hvac,
        "zones": ["NE", "C"],
        "effects": [],
        "baseline": {
            "structure": {
                "causes": {
                    "solar_gain": [{"zone": "NE", "facade": "E"}],
                    "reheat": [{"zone": z, "source": "baseline VAV controllers in heating mode"} for z in reheat_zones],
                }
            }
        },
    }


def _held(zone):
    return {"cause": "held_setpoint", "location": {"zone": zone}}


def test_held_setpoint_is_supported_where_unmetered_reheat_holds_the_zone():
    ok, why = finding_supported(_held("NE"), _truth(["NE", "C"]))
    assert ok and "unmetered reheat" in why
    report = {"findings": [_held("NE")], "data": {"step": 900.0}}
    assert compare_with_truth(report, _truth(["NE"]))["unsupported"] == []


def test_held_setpoint_without_a_controller_holding_the_zone_is_false():
    ok, why = finding_supported(_held("NE"), _truth(["C"]))
    assert not ok and why == "not in the emulator's truth"
    # the "reheat" modes log the discharge air: the heat holding the set point is in the data
    ok, _ = finding_supported(_held("NE"), _truth(["NE", "C"], hvac="reheat"))
    assert not ok
    # other causes are not widened by the rule
    ok, _ = finding_supported({"cause": "thermal_mass", "location": {"zone": "NE"}}, _truth(["NE"]))
    assert not ok
