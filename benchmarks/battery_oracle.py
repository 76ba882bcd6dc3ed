"""Detectability oracle for the diagnosis battery (issue 15 p.4): is an injected effect visible at all?

For every effect the emulator injected (``truth.json``: cause, location, magnitude), the held-out gain
of adding the **true** regressor to a per-zone least-squares model of the affected zone(s), by the
diagnosis' own blocked cross-validation (10 blocks of whole training weeks, 24-h open-loop windows
from midnight, week-clustered paired t; :mod:`hvacfmu.diagnosis.crossval`):

- reference structure: the diagnosis' base model (six-zone Model A, ``v = [T_out, T_supply]``) plus
  the solar path of every window the emulator's baseline has (``truth.baseline.structure.causes``),
  refitted by the diagnosis' one-step least squares; for an injected solar gain its own path is
  left out of the reference (the true regressor is that path);
- **(a)** the true term added, its coefficient fitted, scored on the affected zone(s) with every
  other zone measured (a coupling: each zone alone, its partner measured — the issue's wording;
  a holiday: all zones, on its active days as the diagnosis scores it);
- **(b)** a coupling only: the pair simulated together, the conductance fixed at its **true**
  value per step ``ua · step / C_z`` with ``C_z`` the zone's fast capacitance the emulator knows
  (air node ``2 ρ c_p V`` + furniture ``16 kJ/(K m²) · area``), the rest refitted around it; and
  the pair together with the conductance fitted (what the diagnosis' rule scores).

On clean cases the same numbers for every **uninjected** candidate of each cause (couplings: every
non-adjacent pair, at a fixed 1200 W/K for (b); thermal mass: every zone at 50 h; delay: every zone
at 30/45/60 min; reheat: every zone at 13 °C; holiday: every single training week) give the largest
gain a cause shows where it is absent: an oracle that cannot separate is no oracle.

Used by ``bench_diagnosis_battery.py --oracle``; one case costs 10-60 s of CPU (15 min) on cached data.
"""

from __future__ import annotations

import dataclasses
import json
import time

import numpy as np

DETECT_T = 2.0  # week-clustered paired t
DETECT_GAIN = {"zone_coupling": 3.0}  # [%] the rule's floors (README "Diagnosis"); others 1 %
DEFAULT_GAIN = 1.0
K_FACTORS = (0.25, 0.5)  # (b) also at these fractions of the true conductance (C_z is uncertain)
CLEAN_UA = 1200.0  # [W/K] conductance forced on an uninjected pair for (b)
CLEAN_TAU_H = 50.0  # [h] time constant of the uninjected thermal-mass candidates
AIR_MULT, FURNITURE = 2.0, 16000.0  # emulator DEFAULT_EXTRAS / baseline physics internal_mass
RHO_CP = 1.2 * 1005.0  # [J/(m3 K)]


def _fixed_coupling(za, zb, ka, kb):
    """A coupling with per-zone coefficients fixed at ``ka``/``kb`` [1/step] (the refit may not move them)."""
    from hvacfmu.models.extended import ZoneCoupling

    @dataclasses.dataclass(frozen=True)
    class FixedCoupling(ZoneCoupling):
        def features(self, sig, U_eff):
            a, b = sig.zones.index(self.zone_a), sig.zones.index(self.zone_b)
            d = sig.Y[:, b] - sig.Y[:, a]
            return [(a, "ka", d, ka, ka + 1e-12), (b, "kb", -d, kb, kb + 1e-12)]

        def with_fit(self, sig, coefs, stds):
            return dataclasses.replace(self, coef_ab=ka, coef_ba=kb)

    return FixedCoupling(zone_a=za, zone_b=zb)


def fast_capacitance(truth: dict, zone: str) -> float:
    """Air node + furniture of ``zone`` [J/K] (the emulator's fast cluster behind one measured temperature)."""
    z = next(z for z in truth["baseline"]["building"]["zones"] if z["name"] == zone)
    mass = float(truth["baseline"]["building"].get("physics", {}).get("internal_mass", FURNITURE))
    return AIR_MULT * RHO_CP * float(z["volume"]) + mass * float(z["area"])


def _test(plan, before, after) -> dict:
    from hvacfmu.diagnosis.crossval import paired_test

    r = paired_test(plan, before, after)
    return {k: r.get(k) for k in ("gain_percent", "se_percent", "t", "n_weeks")}


class Oracle:
    """The reference structure of one dataset and the cross-validated gain of any term on it."""

    def __init__(self, ds, truth):
        from hvacfmu.diagnosis.crossval import make_plan
        from hvacfmu.diagnosis.design import make_signals
        from hvacfmu.diagnosis.selection import horizon_steps
        from hvacfmu.fitting import fit
        from hvacfmu.models.extended import SolarGain

        base = fit(ds, "zones", progress=False, use_solar=False, heat="airflow", open_loop=False)
        self.sig = make_signals(ds, base)
        self.truth = truth
        self.step = float(ds.step)
        self.plan = make_plan(self.sig, 10, horizon_steps(ds.step))
        causes = truth["baseline"]["structure"].get("causes", {})
        self.solar = (
            [SolarGain(zone=e["zone"], facade=e["facade"]) for e in causes.get("solar_gain", [])]
            if self.sig.has_solar
            else []
        )
        self._scores: dict = {}

    def reference(self, without=None) -> list:
        return [t for t in self.solar if without is None or (t.zone, t.facade) != without]

    def _before(self, ref, key):
        from hvacfmu.diagnosis.crossval import fold_fits, fold_scores

        k = (tuple((t.zone, t.facade) for t in ref), key)
        if k not in self._scores:
            self._scores[k] = fold_scores(self.sig, self.plan, fold_fits(self.sig, self.plan, ref, key), key)
        return self._scores[k]

    def gain(self, term, zones_idx, ref=None) -> dict:
        """Cross-validated gain of ``ref + [term]`` over ``ref`` on ``zones_idx`` (others measured)."""
        from hvacfmu.diagnosis.crossval import fold_fits, fold_scores

        ref = self.reference() if ref is None else ref
        key = tuple(sorted(zones_idx))
        after = fold_scores(self.sig, self.plan, fold_fits(self.sig, self.plan, ref + [term], key), key)
        return _test(self.plan, self._before(ref, key), after)

    def holiday_gain(self, term) -> dict:
        """A holiday scored as the diagnosis scores it (active days; day by day within one block)."""
        from hvacfmu.diagnosis.selection import cross_validate
        from hvacfmu.models.causes.base import Candidate

        c = Candidate(term.cause, term.location(), [term], 0, evidence={})
        c.term = term
        cross_validate(self.sig, self.plan, self.reference(), c, {})
        out = {k: c.cv.get(k) for k in ("gain_percent", "se_percent", "t")}
        out["unit"] = c.cv.get("unit", "week")
        return out

    def coupling(self, za, zb, ua, scaled=True) -> dict:
        """(a) each zone alone, fitted; (b) the pair together at the true conductance (and at
        :data:`K_FACTORS` of it when ``scaled``), and fitted."""
        from hvacfmu.models.extended import ZoneCoupling

        sig = self.sig
        a, b = sig.zones.index(za), sig.zones.index(zb)
        t = ZoneCoupling(zone_a=za, zone_b=zb)
        ka = ua * self.step / fast_capacitance(self.truth, za)
        kb = ua * self.step / fast_capacitance(self.truth, zb)
        return {
            "alone": {za: self.gain(t, (a,)), zb: self.gain(t, (b,))},
            "pair_true_k": {**self.gain(_fixed_coupling(za, zb, ka, kb), (a, b)), "k": [ka, kb]},
            "pair_fitted": self.gain(t, (a, b)),
            "pair_scaled_k": {
                f"{f:g}": self.gain(_fixed_coupling(za, zb, f * ka, f * kb), (a, b)) for f in K_FACTORS if scaled
            },
        }


def _holiday_term(sig, truth, weeks):
    from hvacfmu.diagnosis.truth import _holiday_dates
    from hvacfmu.models.extended import InternalGainSchedule

    dates = sorted(_holiday_dates(truth, {"weeks": list(weeks)}))
    return InternalGainSchedule(
        variant="holiday", zone_names=tuple(sig.zones), coef=(1.0,) * sig.nz, dates=tuple(dates)
    )


def true_term(o: Oracle, e: dict):
    """The true term of effect ``e`` and the zones to score it on (None when the oracle has no form for it)."""
    from hvacfmu.models.extended import ActuationDelay, Reheat, SolarGain, ThermalMass

    sig = o.sig
    name = e["name"]
    if name == "solar_gain":
        return SolarGain(zone=e["zone"], facade=e["facade"]), [sig.zones.index(e["zone"])]
    if name == "thermal_mass":
        alpha = min(o.step * float(e["ua"]) / float(e["capacitance"]), 1.0)
        return ThermalMass(zone=e["zone"], alpha=alpha), [sig.zones.index(e["zone"])]
    if name == "actuation_delay":
        d = max(1, int(round(float(e["minutes"]) * 60.0 / o.step)))
        return ActuationDelay(zone=e["zone"], delay=d), [sig.zones.index(e["zone"])]
    if name == "reheat":
        zi = sig.zones.index(e["zone"])
        umin = float(sig.u_min[zi] * 1.05 + 1e-6)
        return Reheat(zone=e["zone"], u_min=umin, T_threshold=float(e["below"])), [zi]
    if name == "internal_gain_schedule" and e.get("kind", "holiday") == "holiday":
        return _holiday_term(sig, o.truth, e["weeks"]), list(range(sig.nz))
    return None, []


def effect_oracle(o: Oracle, e: dict) -> dict:
    """Oracle numbers of one injected effect (see the module docstring)."""
    out = {"name": e["name"], "location": {k: e[k] for k in ("zone", "zones", "facade", "weeks") if k in e}}
    if e["name"] == "zone_coupling":
        out.update(o.coupling(e["zones"][0], e["zones"][1], float(e["ua"])))
        return out
    term, zs = true_term(o, e)
    if term is None:
        out["gain"] = None
        return out
    if e["name"] == "internal_gain_schedule":
        out["gain"] = o.holiday_gain(term)
    elif e["name"] == "solar_gain":
        out["gain"] = o.gain(term, zs, ref=o.reference(without=(e["zone"], e["facade"])))
    else:
        out["gain"] = o.gain(term, zs)
    return out


def detectable(r: dict, which: str = "a") -> bool | None:
    """Whether an effect's oracle gain passes the rule's floor (1 %, coupling 3 %) at t ≥ 2.

    ``which``: ``"a"`` (coupling: either zone alone), ``"b"`` (coupling: the pair at the true
    conductance; other causes as ``"a"``).
    """
    floor = DETECT_GAIN.get(r["name"], DEFAULT_GAIN)

    def ok(g):
        return _passes(g, floor)

    if r["name"] == "zone_coupling":
        return ok(r["pair_true_k"]) if which == "b" else any(ok(g) for g in r["alone"].values())
    return None if r.get("gain") is None else ok(r["gain"])


def _passes(g: dict | None, floor: float) -> bool:
    """An oracle gain record at or above ``floor`` [%] with t >= :data:`DETECT_T`."""
    return bool(g and g.get("t") is not None and g["gain_percent"] >= floor and g["t"] >= DETECT_T)


def _adjacent(sig, a, b) -> bool:
    return b in sig.neighbours[a] or a in sig.neighbours[b]


def clean_candidates(o: Oracle) -> list:
    """Every uninjected candidate of every cause on a clean case, with its oracle numbers."""
    from hvacfmu.models.extended import ActuationDelay, Reheat, ThermalMass

    sig, out = o.sig, []
    for a in range(sig.nz):
        for b in range(a + 1, sig.nz):
            if not _adjacent(sig, a, b):
                r = {"name": "zone_coupling", "location": {"zones": [sig.zones[a], sig.zones[b]]}}
                r.update(o.coupling(sig.zones[a], sig.zones[b], CLEAN_UA, scaled=False))
                out.append(r)
    for zi, z in enumerate(sig.zones):
        alpha = min(o.step / (CLEAN_TAU_H * 3600.0), 1.0)
        out.append(
            {"name": "thermal_mass", "location": {"zone": z}, "gain": o.gain(ThermalMass(zone=z, alpha=alpha), [zi])}
        )
        for minutes in (30, 45, 60):
            d = max(1, int(round(minutes * 60.0 / o.step)))
            g = o.gain(ActuationDelay(zone=z, delay=d), [zi])
            out.append({"name": "actuation_delay", "location": {"zone": z, "minutes": minutes}, "gain": g})
        t = Reheat(zone=z, u_min=float(sig.u_min[zi] * 1.05 + 1e-6), T_threshold=13.0)
        out.append({"name": "reheat", "location": {"zone": z}, "gain": o.gain(t, [zi])})
    train_weeks = sorted({int(w) for w in np.unique(sig.week[sig.rows("train")])})
    for w in train_weeks:
        g = o.holiday_gain(_holiday_term(sig, o.truth, [w]))
        out.append({"name": "internal_gain_schedule", "location": {"weeks": [w]}, "gain": g})
    return out


def oracle_case(case: dict, weeks: int) -> dict:
    """Oracle record of one battery case (``bench_diagnosis_battery.make_cases``)."""
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(weeks=weeks, seed=case["seed"], effects=case["effects"], layout=case["layout"])
    ds = prepare(paths.measurements, paths.building, step=case["step"])
    truth = json.loads(paths.truth.read_text())
    c0 = time.process_time()
    o = Oracle(ds, truth)
    rec: dict = {"case": case, "weeks": weeks}
    if o.plan is None:
        rec["error"] = "fewer than 4 training weeks: no cross-validation"
        return rec
    rec["effects"] = [effect_oracle(o, e) for e in truth.get("effects", [])]
    if not case["effects"]:
        rec["clean"] = clean_candidates(o)
    rec["cpu_s"] = time.process_time() - c0
    return rec


def _g(g) -> str:
    if not g or g.get("t") is None:
        return "n/a"
    return f"{g['gain_percent']:+.1f} ± {g['se_percent']:.1f} % (t {g['t']:.1f})"


def effect_line(r: dict) -> str:
    """One printed line per injected effect."""
    if r["name"] == "zone_coupling":
        alone = ", ".join(f"{z} {_g(g)}" for z, g in r["alone"].items())
        k = r["pair_true_k"]["k"]
        return (
            f"    oracle {r['name']} {r['location']}: (a) alone {alone}; (b) pair at true k "
            f"{k[0]:.3f}/{k[1]:.3f} {_g(r['pair_true_k'])}; "
            + "".join(f"x{f} {_g(g)}; " for f, g in r.get("pair_scaled_k", {}).items())
            + f"pair fitted {_g(r['pair_fitted'])} "
            f"-> detectable a {detectable(r, 'a')}, b {detectable(r, 'b')}"
        )
    return f"    oracle {r['name']} {r['location']}: (a) {_g(r.get('gain'))} -> detectable {detectable(r)}"


def best_clean(records: list) -> dict:
    """Per cause (and for couplings per measure) the most-gaining uninjected candidate over clean records."""
    best: dict = {}

    def keep(key, g, rec, loc):
        if g and g.get("t") is not None and (key not in best or g["gain_percent"] > best[key][0]["gain_percent"]):
            best[key] = (g, rec["case"]["id"], loc)

    for rec in records:
        for r in rec.get("clean", []):
            if r["name"] == "zone_coupling":
                for z, g in r["alone"].items():
                    keep("zone_coupling (a) alone", g, rec, {**r["location"], "scored": z})
                keep("zone_coupling (b) pair at 1200 W/K", r["pair_true_k"], rec, r["location"])
                keep("zone_coupling pair fitted", r["pair_fitted"], rec, r["location"])
            else:
                keep(r["name"], r["gain"], rec, r["location"])
    return best


def clean_lines(records: list) -> list:
    out = ["most-gaining UNINJECTED candidate per cause over the clean cases (oracle's false-alarm level):"]
    for key, (g, cid, loc) in sorted(best_clean(records).items()):
        out.append(f"    {key:40s} {_g(g)}  case {cid} {loc}")
    return out


# --- detectability gate of the battery's draw (``bench_diagnosis_battery.py --detectable``) -----------------------
# The issue's own battery "checked the effect magnitudes to be detectable". Ours: an injected effect passes
# when its true term gains at least the rule's floor (1 %, coupling 3 %) at t >= 2 by the rule's blocked
# cross-validation (a coupling: the pair fitted together, as the diagnosis scores it); an effect that fails
# is made stronger by GATE_SCALE (GATE_TRIES times at most) and its case regenerated; one still failing is drawn
# anew (same cause, REDRAWS times at most). The gate never looks at what the diagnosis reports; an effect
# failing after all that is kept, flagged and counted apart.
GATE_SCALE = 1.5
GATE_TRIES = 3
SHGC_MAX = 0.8  # a window's solar heat gain coefficient above this is not glass
DELAY_MAX_MIN = 90.0
REDRAWS = 3  # an effect still failing after GATE_TRIES is drawn anew (same cause) at most this often
REDRAW_SEED = 15  # seeds the new draws: np.random.default_rng([REDRAW_SEED, case id, redraw])


def gate_passes(r: dict) -> bool:
    """Whether an oracle record of one effect passes the battery's detectability gate (see above)."""
    if r["name"] == "zone_coupling":
        return _passes(r["pair_fitted"], DETECT_GAIN["zone_coupling"])
    return bool(detectable(r, "a"))


def _fmt(x: float) -> str:
    return f"{x:.3g}" if abs(x) >= 1e5 else f"{x:.4g}"


def stronger(spec: str, factor: float = GATE_SCALE) -> str:
    """The effect ``spec`` (``"name:key=value,..."``) made ``factor`` times stronger, location unchanged.

    Solar: ``shgc`` (at most :data:`SHGC_MAX`); coupling: ``ua``; thermal mass: ``capacitance`` and ``ua``
    (same time constant, more heat exchanged); reheat: ``power``; holiday: the remaining share ``factor``
    divided; delay: 15 minutes longer (at most :data:`DELAY_MAX_MIN`).
    """
    name, _, rest = spec.partition(":")
    kv = dict(item.split("=", 1) for item in rest.split(",") if item)
    mult = {
        "solar_gain": {"shgc": factor},
        "zone_coupling": {"ua": factor},
        "thermal_mass": {"capacitance": factor, "ua": factor},
        "reheat": {"power": factor},
        "internal_gain_schedule": {"factor": 1.0 / factor},
    }.get(name, {})
    for key, f in mult.items():
        kv[key] = _fmt(float(kv[key]) * f)
    if name == "solar_gain":
        kv["shgc"] = _fmt(min(float(kv["shgc"]), SHGC_MAX))
    if name == "actuation_delay":
        kv["minutes"] = _fmt(min(float(kv["minutes"]) + 15.0, DELAY_MAX_MIN))
    return name + ":" + ",".join(f"{k}={v}" for k, v in kv.items())


def _gate_summary(e: dict) -> dict:
    g = e["pair_fitted"] if e["name"] == "zone_coupling" else e.get("gain")
    return {
        "name": e["name"],
        "passes": gate_passes(e),
        "gain_percent": (g or {}).get("gain_percent"),
        "t": (g or {}).get("t"),
    }


def _scaled_tries(cur: dict, weeks: int, first: dict | None, tries: list) -> dict:
    """Gate ``cur``, making its failing effects stronger up to :data:`GATE_TRIES` times; appends to ``tries``."""
    for k in range(GATE_TRIES + 1):
        rec = first if (k == 0 and first is not None and first.get("case") == cur) else oracle_case(cur, weeks)
        gate = [_gate_summary(e) for e in rec.get("effects", [])]
        tries.append({"effects": list(cur["effects"]), "gate": gate})
        fails = [i for i, g in enumerate(gate) if not g["passes"]]
        if not fails or k == GATE_TRIES:
            return cur
        cur = {**cur, "effects": [stronger(s) if i in fails else s for i, s in enumerate(cur["effects"])]}
    return cur


def _redrawn(case: dict, draw: int) -> dict:
    """``case`` with each effect that failed the gate drawn anew (location and magnitude; same cause)."""
    from bench_diagnosis_battery import random_effect

    from hvacfmu.emulator.layouts import get_layout

    rng = np.random.default_rng([REDRAW_SEED, int(case["id"]), draw])
    return {
        **case,
        "effects": [random_effect(rng, get_layout(case["layout"]), s.split(":")[0]) for s in case["effects"]],
    }


def checked_case(case: dict, weeks: int, first: dict | None = None) -> dict:
    """The case with every injected effect passing the gate (``first``: its oracle record if already known).

    An effect still failing after :data:`GATE_TRIES` stronger versions is drawn anew (its cause kept; location
    and magnitude from a seeded stream, the other effects of the case kept), :data:`REDRAWS` times at most.
    Returns ``{"case": the drawn case, "checked": the case to run, "tries": [{"effects", "gate"}, ...],
    "redraws": n, "detectable": all effects pass}``.
    """
    tries: list = []
    cur = _scaled_tries(dict(case), weeks, first, tries)
    redraws = 0
    while any(not g["passes"] for g in tries[-1]["gate"]) and redraws < REDRAWS:
        redraws += 1
        fails = {i for i, g in enumerate(tries[-1]["gate"]) if not g["passes"]}
        new = _redrawn(cur, redraws)
        cur = {**cur, "effects": [new["effects"][i] if i in fails else s for i, s in enumerate(cur["effects"])]}
        cur = _scaled_tries(cur, weeks, None, tries)
    ok = all(g["passes"] for g in tries[-1]["gate"])
    return {"case": case, "weeks": weeks, "checked": cur, "tries": tries, "redraws": redraws, "detectable": ok}
