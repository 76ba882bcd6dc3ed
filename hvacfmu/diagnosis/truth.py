"""Compare a diagnosis with the emulator's ``truth.json`` (tests, demo report).

A finding is *supported* when the emulator really contains the cause at that
location, either in its baseline structure (``truth["baseline"]["structure"]["causes"]``,
or for older files the structure's description: window solar gains per zone and
facade, bilinear supply air, wall/slab/furniture mass, reheat coils) or as an
injected effect (``truth["effects"]``). An injected
effect is *found* when a finding names its cause and location.
"""

from __future__ import annotations

import pandas as pd

#: Injected effects whose diagnosis cause id is not their own name (the emulator's
#: ``hvacfmu.emulator.effects.EFFECT_CAUSES``; repeated here: the diagnosis reads only truth.json).
EFFECT_CAUSES = {"off_hours_heater": "reheat"}


def _effects(truth, name):
    return [e for e in truth.get("effects", []) if e.get("name") == name]


def _holiday_dates(truth, effect) -> set:
    start = pd.Timestamp(truth.get("start", "2025-09-01")).tz_localize(None).normalize()
    out = set()
    for w in effect.get("weeks", []):
        for d in range(5):
            out.add((start + pd.Timedelta(days=7 * int(w) + d)).date().isoformat())
    return out


def sensor_offset_time(truth, effect) -> pd.Timestamp:
    """The instant an injected ``sensor_offset`` starts, from truth.json's ``start`` and ``timezone``
    (:func:`hvacfmu.emulator.effects.sensor_offset_time`): ``day`` days after the first local midnight, at ``hour``."""
    from ..emulator.effects import sensor_offset_time as at

    return at(truth.get("start", "2025-09-01"), truth.get("timezone", "UTC"), {"hour": 10.0, **effect})


def effect_matches(finding: dict, effect: dict, truth: dict, step: float = 900.0) -> bool:
    """True if ``finding`` (a report finding dict) names ``effect``'s cause and location.

    ``step`` [s] is the model step of the diagnosis (a delay is matched within one step or 15 min,
    whichever is longer).
    """
    c, loc = finding["cause"], finding["location"]
    name = effect["name"]
    if c != EFFECT_CAUSES.get(name, name):
        return False
    if name == "solar_gain":
        return loc.get("zone") == effect["zone"] and loc.get("facade") == effect["facade"]
    if name == "zone_coupling":
        return set(loc.get("zones", [])) == set(effect["zones"])
    if name in ("thermal_mass", "reheat", "wind_infiltration", "off_hours_heater"):
        return loc.get("zone") == effect["zone"]
    if name == "actuation_delay":
        # within one step or 15 minutes, whichever is longer (the same tolerance in time at 5 and 15 min)
        err_s = abs(int(loc.get("delay", 0)) * float(step) - float(effect["minutes"]) * 60.0)
        return loc.get("zone") == effect["zone"] and err_s <= max(float(step), 900.0)
    if name == "sensor_offset":
        # the right zone, its change within one day of the injected one (or inside its bracket)
        if loc.get("zone") != effect["zone"] or not loc.get("start"):
            return False
        at, day = sensor_offset_time(truth, effect), pd.Timedelta(days=1)

        def near(when: str, after) -> bool:
            if after:  # bracketed between training days: the true change inside the bracket
                return pd.Timestamp(after) - day <= at <= pd.Timestamp(when) + day
            return abs(pd.Timestamp(when) - at) <= day

        # a change and its return (``end``: the sensor put back) names two injected changes of the zone
        return near(loc["start"], loc.get("after")) or bool(loc.get("end")) and near(loc["end"], loc.get("end_after"))
    if name == "internal_gain_schedule":
        kind = effect.get("kind", "holiday")
        if kind == "dst":
            return loc.get("variant") == "dst_shift"
        if loc.get("variant") != "holiday":
            return False
        true_days = _holiday_dates(truth, effect)
        days = set(loc.get("dates", []))
        return bool(days) and len(days & true_days) >= 0.5 * len(days)
    return False


def finding_supported(finding: dict, truth: dict, step: float = 900.0) -> tuple[bool, str]:
    """Whether the emulator's truth contains the finding's cause at its location, and why."""
    c, loc = finding["cause"], finding["location"]
    for e in truth.get("effects", []):
        if effect_matches(finding, e, truth, step):
            return True, f"injected effect {e['name']}"
    st = truth.get("baseline", {}).get("structure", {})
    listed = st.get("causes")
    if isinstance(listed, dict):  # emulator >= 1.2: cause ids present in the baseline, by location
        for entry in listed.get(c, []):
            keys = [k for k in ("zone", "facade", "zones") if k in entry]
            same = all((set(entry[k]) == set(loc.get(k, [])) if k == "zones" else entry[k] == loc.get(k)) for k in keys)
            if same:
                return True, f"baseline: {entry.get('source', c)}"
        unmetered = truth.get("hvac", "vav") == "vav"  # the "reheat" modes log each box's discharge air
        if (
            c == "held_setpoint"
            and unmetered
            and any(e.get("zone") == loc.get("zone") for e in listed.get("reheat", []))
        ):
            # the zone's box controller holds its heating set point with a reheat coil whose heat the data do not
            # carry (the emulator's "vav" mode logs no discharge air): a set point held by unmetered heat, which is
            # what the held-setpoint term describes (its lower edge)
            return True, "baseline: VAV controller holds the heating set point with unmetered reheat"
        return False, "not in the emulator's truth"
    if c == "solar_gain":
        if loc.get("facade") in st.get("solar_gain", {}).get(loc.get("zone"), []):
            return True, "baseline window solar gain"
    elif c == "supply_air_bilinear":
        if st.get("supply_air", {}).get("form") == "bilinear":
            return True, "baseline bilinear supply air"
    elif c == "thermal_mass":
        tm = st.get("thermal_mass", {})
        if tm.get("walls") or tm.get("slabs") or tm.get("furniture_J_per_K_m2"):
            return True, "baseline wall/slab/furniture mass"
    elif c == "reheat":
        if st.get("reheat"):
            return True, "baseline reheat coils"
    return False, "not in the emulator's truth"


def compare_with_truth(report, truth: dict) -> dict:
    """Findings vs truth.

    Parameters
    ----------
    report : DiagnosisReport or its ``to_dict()``
    truth : dict
        Parsed ``truth.json``.

    Returns
    -------
    dict with ``found`` (injected effects matched by a finding), ``missed`` (injected
    effects not found), ``unsupported`` (findings absent from the truth: false alarms)
    and ``supported`` (findings with the reason they are in the truth).
    """
    d = report if isinstance(report, dict) else report.to_dict()
    findings = d["findings"]
    step = float(d.get("data", {}).get("step", 900.0))
    found, missed = [], []
    for e in truth.get("effects", []):
        (found if any(effect_matches(f, e, truth, step) for f in findings) else missed).append(e)
    supported, unsupported = [], []
    for f in findings:
        ok, why = finding_supported(f, truth, step)
        (supported if ok else unsupported).append({"cause": f["cause"], "location": f["location"], "why": why})
    return {"found": found, "missed": missed, "supported": supported, "unsupported": unsupported}
