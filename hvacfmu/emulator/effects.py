"""Optional effects injected into the emulated building (names = diagnosis cause ids).

Every effect has moderate, realistic defaults for an office floor. Parameters
not given (e.g. the zone) are drawn from the dataset seed and recorded in
``truth.json``.

============================ ==================================================================
effect                       parameters (default)
============================ ==================================================================
``solar_gain``               ``zone`` (random perimeter zone), ``facade`` (random non-north
                             facade of that zone), ``shgc`` extra solar heat gain coefficient
                             of those windows delivered straight to the zone air (0.2; e.g.
                             blinds never closed), or ``scale`` (total gain = scale x baseline)
``zone_coupling``            ``zones`` = ``A+B``, two zones *not* declared adjacent (random
                             pair), ``ua`` [W/K] undeclared conductance, e.g. an open door or
                             a shared return duct (400)
``actuation_delay``          ``zone`` (random), ``minutes`` delay between the logged airflow
                             of the zone's boxes and the air actually delivered (30; a
                             multiple of the 5-minute control interval)
``internal_gain_schedule``   ``kind`` = ``holiday`` (default) or ``dst``; ``weeks`` = ``3+9``
                             holiday week numbers from the first midnight (default two
                             random semester weeks), ``factor`` of weekday gains in holiday
                             weeks (0.2). ``dst``: gains follow standard time all year, i.e.
                             one hour late on the local clock while daylight saving is on
``reheat``                   ``zone`` (random perimeter zone), ``power`` [W] extra reheat
                             (3000) whenever all the zone's boxes are at minimum airflow and
                             ``below`` [°C] outdoor temperature is not reached (13)
``thermal_mass``             ``zone`` (random), ``capacitance`` [J/K] of an extra slow mass,
                             e.g. a storage room full of paper or a concrete core wall (2e8),
                             coupled to the zone air by ``ua`` [W/K] (1000); time constant ~2.3 days
``wind_infiltration``        ``zone`` (random perimeter zone), ``ua`` [W/K per m/s] of outdoor air
                             leaking in with the wind (40: at 5 m/s 200 W/K, about 0.6 air changes
                             an hour in a 1000 m³ zone): ``ua · wind · (T_out − T_zone)`` into the
                             zone air, the wind held per control interval (its 5-minute mean); the
                             wind is the dataset's own series (``weather.synthetic_wind``), written
                             as the ``wind`` column only with ``generate(wind=...)``
``off_hours_heater``         ``zone`` (random perimeter zone), ``power`` [W] of a heater left on in
                             the zone (2000), heating whenever the zone's boxes are shut (zero
                             airflow) and the outdoor temperature is below ``below`` [°C] (5): an
                             occupant's space heater or a frost-protection loop; needs
                             ``generate(schedule="night-off")`` (boxes are never shut otherwise).
                             Diagnosis cause ``reheat`` at the zone (its box-off variant)
``sensor_offset``            ``zone`` (random), ``delta`` [K] added to the zone's *measured* temperature
                             (2.0) from ``day`` (random, in the middle half of the dataset; days
                             from the first midnight) at ``hour`` (10.0, local) on: a sensor
                             re-calibrated or replaced, a BMS point re-mapped. The plant and its
                             controllers are unchanged (they act on the true room temperature); only
                             the exported column reads ``+delta``. Requested only (not drawn by fleets)
============================ ==================================================================
"""

from __future__ import annotations

import zlib

import numpy as np
import pandas as pd

from ..errors import HvacfmuError, problems_message

EFFECT_NAMES = (
    "solar_gain",
    "zone_coupling",
    "actuation_delay",
    "internal_gain_schedule",
    "reheat",
    "thermal_mass",
    "wind_infiltration",
)
#: Effects that need a non-default ``generate(schedule=...)`` (kept out of :data:`EFFECT_NAMES`, which every
#: dataset accepts and ``generate-fleet`` draws from, so fleets and seeds are unchanged).
SCHEDULE_EFFECTS = ("off_hours_heater",)
#: Effects on the measurements only (kept out of :data:`EFFECT_NAMES` too: fleets and battery draws are unchanged).
MEASUREMENT_EFFECTS = ("sensor_offset",)
ALL_EFFECT_NAMES = EFFECT_NAMES + SCHEDULE_EFFECTS + MEASUREMENT_EFFECTS

#: Diagnosis cause id of every effect whose name is not itself a cause id.
EFFECT_CAUSES = {"off_hours_heater": "reheat"}

EFFECT_DEFAULTS = {
    "solar_gain": {"shgc": 0.2},
    "zone_coupling": {"ua": 400.0},
    "actuation_delay": {"minutes": 30.0},
    "internal_gain_schedule": {"kind": "holiday", "factor": 0.2},
    "reheat": {"power": 3000.0, "below": 13.0},
    "thermal_mass": {"capacitance": 2.0e8, "ua": 1000.0},
    "wind_infiltration": {"ua": 40.0},
    "off_hours_heater": {"power": 2000.0, "below": 5.0},
    "sensor_offset": {"delta": 2.0, "hour": 10.0},
}
EFFECT_KEYS = {
    "solar_gain": {"zone", "facade", "shgc", "scale"},
    "zone_coupling": {"zones", "ua"},
    "actuation_delay": {"zone", "minutes"},
    "internal_gain_schedule": {"kind", "weeks", "factor", "hours"},
    "reheat": {"zone", "power", "below"},
    "thermal_mass": {"zone", "capacitance", "ua"},
    "wind_infiltration": {"zone", "ua"},
    "off_hours_heater": {"zone", "power", "below"},
    "sensor_offset": {"zone", "delta", "day", "hour"},
}


class EmulatorError(HvacfmuError, ValueError):
    """An emulator argument (effect, weeks, format) is invalid. Message lists every problem."""


def _value(key, text):
    if key == "zones":
        return [z for z in text.split("+") if z]
    if key == "weeks":
        try:
            return [int(w) for w in text.split("+") if w]
        except ValueError:
            return text
    try:
        return float(text)
    except ValueError:
        return text


def parse_effect(spec) -> dict:
    """Parse ``"name:key=value,..."`` into ``{"name": name, key: value, ...}``.

    Numbers become floats, ``zones=A+B`` a list of zone names, ``weeks=3+9`` a
    list of week numbers. A dict is checked and returned as a copy.

    Raises
    ------
    EmulatorError
        Unknown effect or parameter, or a malformed ``key=value``; every problem listed.
    """
    if isinstance(spec, dict):
        d = dict(spec)
        for key in ("zones", "weeks"):
            if isinstance(d.get(key), str):
                d[key] = _value(key, d[key])
    else:
        text = str(spec).strip()
        name, _, rest = text.partition(":")
        d = {"name": name.strip()}
        problems = []
        for item in filter(None, (s.strip() for s in rest.split(","))):
            key, eq, val = item.partition("=")
            if not eq or not key.strip() or not val.strip():
                problems.append(f"{item!r} is not key=value")
                continue
            d[key.strip()] = _value(key.strip(), val.strip())
        if problems:
            raise EmulatorError(problems_message(f"Invalid effect {text!r}", problems))
    problems = []
    name = d.get("name")
    if name not in ALL_EFFECT_NAMES:
        problems.append(f"unknown effect {name!r}; known effects: {', '.join(ALL_EFFECT_NAMES)}")
    else:
        for key in d:
            if key != "name" and key not in EFFECT_KEYS[name]:
                problems.append(f"{name}: unknown parameter {key!r} (known: {', '.join(sorted(EFFECT_KEYS[name]))})")
    if problems:
        raise EmulatorError(problems_message(f"Invalid effect {d}", problems))
    return d


def _rng(seed, i, name):
    return np.random.default_rng(np.random.SeedSequence([int(seed), 1000 + i, zlib.crc32(name.encode())]))


def resolve_effects(effects, seed: int, building: dict, weeks: int, control_interval: float = 300.0) -> list[dict]:
    """Fill in defaults and random choices of every effect, and validate them.

    Parameters
    ----------
    effects : sequence of str or dict
    seed : int
    building : dict
        Building mapping (zones with facades and adjacency, windows).
    weeks : int
        Length of the dataset [weeks] (holiday weeks are drawn inside it).
    control_interval : float [s]

    Returns
    -------
    list of dict
        One fully specified dict per effect (JSON-serialisable).
    """
    ctx = _layout_context(building, weeks, control_interval)
    out, problems = [], []
    for i, spec in enumerate(effects):
        try:
            e = parse_effect(spec)
        except EmulatorError as exc:
            problems.append(str(exc))
            continue
        name = e["name"]
        rng = _rng(seed, i, name)
        r = {"name": name, **EFFECT_DEFAULTS[name]}
        r.update({k: v for k, v in e.items() if k != "name"})
        for k, v in list(r.items()):
            if isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool):
                r[k] = float(v)
            elif k == "weeks" and isinstance(v, (list, tuple)):
                r[k] = [int(x) for x in v]
            elif k == "zones" and isinstance(v, (list, tuple)):
                r[k] = [str(x) for x in v]
        _RESOLVERS[name](e, r, rng, ctx, f"effect {i + 1} ({name})", problems)
        out.append(r)
    if sum(r["name"] == "off_hours_heater" for r in out) > 1:
        problems.append("off_hours_heater given more than once (the emulator models one heater)")
    delayed = [r["zone"] for r in out if r["name"] == "actuation_delay"]
    for z in {z for z in delayed if delayed.count(z) > 1}:
        problems.append(f"actuation_delay given twice for zone {z}")
    if problems:
        raise EmulatorError(problems_message("Invalid emulator effects", problems))
    return out


def _layout_context(building: dict, weeks: int, control_interval: float) -> dict:
    """What the resolvers need of the building: zones, facades, perimeter zones, (non-)adjacent pairs."""
    zones = [z["name"] for z in building["zones"]]
    facades = {z["name"]: [f["orientation"] for f in z.get("facades", [])] for z in building["zones"]}
    adjacent = set()
    for z in building["zones"]:
        for a in z.get("adjacent", []):
            adjacent.add(frozenset((z["name"], a)))
    return {
        "building": building,
        "weeks": weeks,
        "control_interval": control_interval,
        "zones": zones,
        "facades": facades,
        "perimeter": [z for z in zones if facades[z]],
        "adjacent": adjacent,
        "non_adjacent": [
            (a, b) for i, a in enumerate(zones) for b in zones[i + 1 :] if frozenset((a, b)) not in adjacent
        ],
    }


def _check_zone(z, allowed, where: str, problems: list) -> bool:
    if z not in allowed:
        problems.append(f"{where}: zone {z!r} is not one of {', '.join(allowed)}")
        return False
    return True


def _resolve_solar_gain(e, r, rng, ctx, where, problems) -> None:
    if "zone" not in e:
        r["zone"] = str(rng.choice(ctx["perimeter"]))
    if _check_zone(r["zone"], ctx["perimeter"], where, problems):
        options = ctx["facades"][r["zone"]]
        if "facade" not in e:
            sunny = [f for f in options if f != "N"] or options
            r["facade"] = str(rng.choice(sunny))
        elif r["facade"] not in options:
            problems.append(f"{where}: zone {r['zone']} has no {r['facade']!r} facade (it has {', '.join(options)})")
    if "scale" in e:
        base = [w["shgc"] for w in ctx["building"].get("windows", []) if w["zone"] == r.get("zone")]
        r["shgc"] = (float(e["scale"]) - 1.0) * (base[0] if base else 0.0)
    if not isinstance(r["shgc"], float) or not 0.0 < r["shgc"] <= 1.0:
        problems.append(f"{where}: shgc must be in (0, 1], got {r['shgc']!r}")


def _resolve_zone_coupling(e, r, rng, ctx, where, problems) -> None:
    non_adjacent = ctx["non_adjacent"]
    if "zones" not in e:
        pair = non_adjacent[int(rng.integers(len(non_adjacent)))]
        r["zones"] = list(pair)
    pair = r["zones"]
    if not isinstance(pair, list) or len(pair) != 2 or pair[0] == pair[1]:
        problems.append(f"{where}: zones must be two different zones like 'NW+S', got {pair!r}")
    elif all(_check_zone(z, ctx["zones"], where, problems) for z in pair) and frozenset(pair) in ctx["adjacent"]:
        problems.append(
            f"{where}: zones {pair[0]} and {pair[1]} are declared adjacent; the coupling must be undeclared "
            f"(non-adjacent pairs: {', '.join('+'.join(p) for p in non_adjacent)})"
        )
    if not isinstance(r["ua"], float) or not r["ua"] > 0:
        problems.append(f"{where}: ua must be > 0 W/K, got {r['ua']!r}")


def _resolve_actuation_delay(e, r, rng, ctx, where, problems) -> None:
    if "zone" not in e:
        r["zone"] = str(rng.choice(ctx["zones"]))
    _check_zone(r["zone"], ctx["zones"], where, problems)
    step = ctx["control_interval"] / 60.0
    m = r["minutes"]
    if not isinstance(m, float) or m <= 0 or abs(m / step - round(m / step)) > 1e-9:
        problems.append(f"{where}: minutes must be a positive multiple of {step:g}, got {m!r}")


def _resolve_internal_gain_schedule(e, r, rng, ctx, where, problems) -> None:
    weeks = ctx["weeks"]
    if r["kind"] not in ("holiday", "dst"):
        problems.append(f"{where}: kind must be 'holiday' or 'dst', got {r['kind']!r}")
    elif r["kind"] == "holiday":
        if "weeks" not in e:
            candidates = np.arange(1, weeks) if weeks > 1 else np.arange(weeks)
            k = min(2, len(candidates))
            r["weeks"] = sorted(int(w) for w in rng.choice(candidates, size=k, replace=False))
        w = r["weeks"]
        if not isinstance(w, list) or not w or any(not 0 <= x < weeks for x in w):
            problems.append(f"{where}: weeks must be week numbers in 0..{weeks - 1} like '3+9', got {w!r}")
        if not isinstance(r["factor"], float) or not 0.0 <= r["factor"] < 1.0:
            problems.append(f"{where}: factor must be in [0, 1), got {r['factor']!r}")
    else:
        r.pop("factor", None)
        r.setdefault("hours", 1.0)
        if r["hours"] != 1.0:
            problems.append(f"{where}: only a one-hour daylight-saving shift is modelled (hours=1)")


def _resolve_reheat(e, r, rng, ctx, where, problems) -> None:
    if "zone" not in e:
        r["zone"] = str(rng.choice(ctx["perimeter"]))
    _check_zone(r["zone"], ctx["zones"], where, problems)
    if not isinstance(r["power"], float) or not r["power"] > 0:
        problems.append(f"{where}: power must be > 0 W, got {r['power']!r}")
    if not isinstance(r["below"], float):
        problems.append(f"{where}: below must be a temperature in °C, got {r['below']!r}")


def _resolve_thermal_mass(e, r, rng, ctx, where, problems) -> None:
    if "zone" not in e:
        r["zone"] = str(rng.choice(ctx["zones"]))
    _check_zone(r["zone"], ctx["zones"], where, problems)
    for key, unit in (("capacitance", "J/K"), ("ua", "W/K")):
        if not isinstance(r[key], float) or not r[key] > 0:
            problems.append(f"{where}: {key} must be > 0 {unit}, got {r[key]!r}")


def _resolve_wind_infiltration(e, r, rng, ctx, where, problems) -> None:
    if "zone" not in e:
        r["zone"] = str(rng.choice(ctx["perimeter"]))
    _check_zone(r["zone"], ctx["zones"], where, problems)
    if not isinstance(r["ua"], float) or not r["ua"] > 0:
        problems.append(f"{where}: ua must be > 0 W/K per m/s, got {r['ua']!r}")


def _resolve_sensor_offset(e, r, rng, ctx, where, problems) -> None:
    if "zone" not in e:
        r["zone"] = str(rng.choice(ctx["zones"]))
    _check_zone(r["zone"], ctx["zones"], where, problems)
    days = 7 * int(ctx["weeks"])
    if "day" not in e:
        r["day"] = float(rng.integers(days // 4, max(days // 4 + 1, (3 * days) // 4)))
    d, h = r["day"], r["hour"]
    if not isinstance(d, float) or d != int(d) or not 0 < d < days:
        problems.append(f"{where}: day must be a whole day number in 1..{days - 1}, got {d!r}")
    if not isinstance(h, float) or not 0.0 <= h < 24.0:
        problems.append(f"{where}: hour must be in [0, 24), got {h!r}")
    if not isinstance(r["delta"], float) or r["delta"] == 0.0 or abs(r["delta"]) > 20.0:
        problems.append(f"{where}: delta must be a non-zero offset within ±20 K, got {r['delta']!r}")


def sensor_offset_time(start, timezone: str, effect: dict) -> pd.Timestamp:
    """The local instant a ``sensor_offset`` effect starts: ``day`` days after the first midnight at ``hour``."""
    t0 = pd.Timestamp(start)
    t0 = t0.tz_localize(timezone) if t0.tzinfo is None else t0.tz_convert(timezone)
    day = (t0.normalize() + pd.Timedelta(days=int(effect["day"]))).tz_localize(None)
    return (day + pd.Timedelta(hours=float(effect["hour"]))).tz_localize(timezone, nonexistent="shift_forward")


_RESOLVERS = {
    "solar_gain": _resolve_solar_gain,
    "zone_coupling": _resolve_zone_coupling,
    "actuation_delay": _resolve_actuation_delay,
    "internal_gain_schedule": _resolve_internal_gain_schedule,
    "reheat": _resolve_reheat,
    "thermal_mass": _resolve_thermal_mass,
    "wind_infiltration": _resolve_wind_infiltration,
    "off_hours_heater": _resolve_reheat,  # the same parameters: zone, power [W], below [°C]
    "sensor_offset": _resolve_sensor_offset,
}


def effect_label(effect: dict) -> str:
    """Short text form ``name:key=value,...`` of a resolved effect (round-trips through parse_effect)."""
    parts = []
    for k, v in effect.items():
        if k == "name":
            continue
        if isinstance(v, list):
            v = "+".join(str(x) for x in v)
        parts.append(f"{k}={v}")
    return effect["name"] + (":" + ",".join(parts) if parts else "")
