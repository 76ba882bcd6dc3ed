"""The diagnosis report: text (``format``), JSON (``to_dict``/``save_json``) and figures (``plot``).

JSON schema ``hvacfmu.diagnosis/1`` (stable; documented in the README section
"Diagnosis"). Keys are only ever added within a schema version.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

SCHEMA = "hvacfmu.diagnosis/1"


def _clean(x):
    """JSON-ready copy: numpy scalars to Python, NaN/inf to None, tuples to lists."""
    if isinstance(x, dict):
        return {str(k): _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating, float)):
        x = float(x)
        return x if math.isfinite(x) else None
    if isinstance(x, np.bool_):
        return bool(x)
    if isinstance(x, np.ndarray):
        return _clean(x.tolist())
    return x


def _cv_units(cv: dict) -> str:
    """ "13 weeks" (week-clustered test) or "10 active days" (calendar terms)."""
    if cv.get("unit") == "active day":
        each = ", each left out alone" if cv.get("folds") == "one per active day" else ""
        return f"{cv['n_days']} active days{each}"
    return f"{cv['n_weeks']} weeks"


@dataclasses.dataclass
class DiagnosisReport:
    """Outcome of :func:`hvacfmu.diagnosis.diagnose`.

    Attributes
    ----------
    verdict : str
        ``"found"`` (at least one cause confirmed), ``"nothing missing"`` (no cause and
        white residuals) or ``"unexplained"`` (no catalogue cause, but structure left).
    findings : list of dict
        Confirmed causes in the order they were added (see :meth:`to_dict`).
    candidates : list of dict
        Every other candidate with its status (``not significant``, ``no held-out gain``,
        ``untestable``, ``rejected``: the joint refit with it fails the load checks ...), evidence and test.
    unexplained : list of dict
        Zones whose final residuals are not white: ``zone``, ``period_h`` of the dominant
        periodogram peak, ``peak_share``, ``cpgram_departure``, ``ljung_box_p``.
    whiteness : dict
        ``before`` / ``after``: zone -> whiteness tests of the one-step residuals.
    errors : dict
        Breakdowns of the base model's residuals (``one_step``, ``open_loop``) and of the
        extended model's (``open_loop_after``).
    heldout : dict
        Held-out 24-hour RMS [K] per zone of the base and the extended model, per season
        and overall, and the gain [%] per zone.
    model : ExtendedModel
        The extended model (the base unchanged when nothing was found).
    base_model : ZoneModel
    data : dict
    options : dict
    rounds : list of dict
    budget : dict
        The term budget: ``max_terms``, ``n_terms`` (findings), ``reached`` (the budget stopped the selection) and
        ``left``: the candidates significant against the final model that were not cross-validated for it
        (``cause``, ``location``, ``key``, ``delta_bic``; ``tried_before``: the earlier round that cross-validated
        it against the model of then and did not accept it), strongest first.
    series : dict
        Residual arrays for the figures (not serialised).
    selected_model : ExtendedModel or None
        The model of the forward selection, before the held setpoints (:mod:`hvacfmu.diagnosis.held`) were
        added (not serialised; the same as ``model`` when none was).
    """

    verdict: str
    findings: list
    candidates: list
    unexplained: list
    whiteness: dict
    errors: dict
    heldout: dict
    model: object
    base_model: object
    data: dict
    options: dict
    rounds: list
    notes: list = dataclasses.field(default_factory=list)
    budget: dict = dataclasses.field(default_factory=dict)
    series: dict = dataclasses.field(default_factory=dict, repr=False)
    selected_model: object = dataclasses.field(default=None, repr=False)

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict:
        """JSON-ready mapping following schema ``hvacfmu.diagnosis/1``."""
        return _clean(
            {
                "schema": SCHEMA,
                "verdict": self.verdict,
                "summary": self.summary(),
                "data": self.data,
                "base_model": {"kind": self.base_model.kind, "outputs": list(self.base_model.outputs)},
                "options": self.options,
                "findings": self.findings,
                "candidates": self.candidates,
                "untestable": [
                    {"cause": c["cause"], "location": c["location"], "reason": c["reason"]}
                    for c in self.candidates
                    if c["status"] == "untestable"
                ],
                "unexplained": self.unexplained,
                "whiteness": self.whiteness,
                "errors": self.errors,
                "heldout": self.heldout,
                "rounds": self.rounds,
                "budget": self.budget,
                "notes": self.notes,
                "model": {"kind": "extended", "terms": [t.to_dict() for t in self.model.terms]},
            }
        )

    def save_json(self, path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_dict(), indent=1, allow_nan=False), encoding="utf-8")
        return path

    # ------------------------------------------------------------------ text
    @property
    def causes(self) -> list:
        """Cause ids of the findings, in order."""
        return [f["cause"] for f in self.findings]

    def summary(self) -> str:
        if self.findings:
            parts = [f"{f['cause']} ({_loc(f['location'])})" for f in self.findings]
            s = "found: " + "; ".join(parts)
        elif self.unexplained:
            s = "no catalogue cause explains the remaining errors"
        else:
            s = "nothing missing: no catalogue cause is significant and the residuals are white"
        if self.unexplained:
            s += "; unexplained structure in " + ", ".join(
                f"{u['zone']} (period {u['period_h']:.1f} h)" for u in self.unexplained
            )
        if self.budget.get("reached"):
            s += (
                f"; stopped at the term budget (max_terms {self.budget['max_terms']}) with "
                f"{len(self.budget['left'])} significant candidate(s) not cross-validated"
            )
        return s

    def format(self) -> str:
        """Human-readable report."""
        L = [
            f"Diagnosis of the {self.base_model.kind} model on {self.data.get('source') or 'the dataset'}",
            f"  {self.data.get('n_train_weeks')} training / {self.data.get('n_test_weeks')} held-out weeks, "
            f"solar data: {'yes' if self.data.get('has_solar') else 'no'}",
            "",
        ]
        ho = self.heldout
        if ho.get("verdict_lines"):  # against the baselines first (issue 13 p.5), then the causes
            L += ["Held-out verdict against persistence and the time-of-week mean (base refitted, extended):"]
            L += [f"  {line}" for line in ho["verdict_lines"]] + [""]
        L += [f"Verdict: {self.verdict} — {self.summary()}", ""]
        L += self._heldout_lines()
        if self.findings:
            L.append("Findings (in order of selection):")
            for i, f in enumerate(self.findings, 1):
                L += _finding_lines(i, f)
            L.append("")
        L += self._budget_lines() + self._candidate_lines() + self._residual_lines() + self._threshold_lines()
        for n in self.notes:
            L.append(f"note: {n}")
        return "\n".join(L)

    def _heldout_lines(self) -> list:
        """Held-out RMS per zone, base refitted -> extended."""
        L: list = []
        ho = self.heldout
        if ho.get("zones"):
            L.append("Held-out 24-hour RMS [K] per zone (base structure refitted -> extended, gain):")
            for z in ho["zones"]:
                b, a, g = ho["base"]["all"].get(z), ho["extended"]["all"].get(z), ho["gain_percent"].get(z)
                if b is None or a is None:
                    continue
                L.append(f"  {z:>6}: {b:.3f} -> {a:.3f}  ({g:+.1f} %)")
            L.append(
                f"  {'mean':>6}: {ho['mean_base']:.3f} -> {ho['mean_extended']:.3f}  ({ho['gain_percent_mean']:+.1f} %)"
            )
            if "mean_original_base" in ho:
                which = (
                    "the given base model"
                    if ho.get("original_given", True)
                    else "no base model given: diagnose's own fit (the paper's one-step fit, airflow form, no solar)"
                )
                L.append(
                    f"  ({which}: mean {ho['mean_original_base']:.3f} -> refitted "
                    f"{ho['mean_base']:.3f}, {ho['refit_gain_percent_mean']:+.1f} %: a change of fitting "
                    f"method, not a cause)"
                )
            L.append("")
        return L

    def _budget_lines(self) -> list:
        """When the term budget stopped the selection: the candidates it left, significant against the final model."""
        b = self.budget
        if not b.get("reached"):
            return []
        L = [
            f"Term budget reached: the selection stopped at max_terms = {b['max_terms']} terms; "
            f"{len(b['left'])} candidate(s) significant against the final model were not cross-validated "
            f"(not tested, not absent; raise max_terms to test them):"
        ]
        for c in b["left"]:
            t = c.get("tried_before")
            g = "" if not t or t.get("cv_gain_percent") is None else f", {t['cv_gain_percent']:+.1f} %"
            before = (
                f" (cross-validated in round {t['round']} against the model of then: {t['status']}{g})" if t else ""
            )
            L.append(f"  - {c['cause']} at {_loc(c['location'])}: ΔBIC {c['delta_bic']:.1f}{before}")
        return L + [""]

    def _candidate_lines(self) -> list:
        """Candidates significant but not confirmed, and untestable ones."""
        L: list = []
        rej = [c for c in self.candidates if c["status"] in ("no cross-validated gain", "no evidence", "rejected")]
        if rej:
            L.append("Significant on training data but not confirmed (not added):")
            for c in rej:
                L.append(f"  - {c['cause']} at {_loc(c['location'])}: {c['reason']}")
            L.append("")
        unt = [c for c in self.candidates if c["status"] == "untestable"]
        if unt:
            L.append("Untestable (not absent):")
            seen = set()
            for c in unt:
                key = (c["cause"], c["reason"])
                zs = [_loc(d["location"]) for d in unt if (d["cause"], d["reason"]) == key]
                if key in seen:
                    continue
                seen.add(key)
                L.append(f"  - {c['cause']} ({'; '.join(zs)}): {c['reason']}")
            L.append("")
        if self.unexplained:
            L.append("Unexplained (residuals not white, no catalogue cause):")
            for u in self.unexplained:
                L.append(
                    f"  - zone {u['zone']}: dominant period {u['period_h']:.1f} h "
                    f"({100 * u['peak_share']:.1f} % of residual variance), cumulated periodogram departs "
                    f"{u['cpgram_departure']:.2f} (1 % bound {u['cpgram_bound']:.2f})"
                )
            L.append("")
        return L

    def _residual_lines(self) -> list:
        """Unexplained zones, largest open-loop errors and residual whiteness before -> after."""
        L: list = []
        big = self.errors.get("largest_open_loop_errors", [])
        if big:
            L.append("Where the base model errs most (24-hour open-loop, mean error [K] = measured - predicted):")
            for c in big:
                L.append(
                    f"  - {c['zone']} at {c['by']}={c['label']}: {c['mean']:+.3f} (rms {c['rms']:.3f}, n {c['n']})"
                )
            L.append("")
        L.append(
            "Residual whiteness (one-step, training weeks): zone: lag-1 ACF, Ljung-Box p, "
            "periodogram departure before -> after"
        )
        for z in self.model.outputs:
            b, a = self.whiteness["before"].get(z, {}), self.whiteness["after"].get(z, {})
            if "acf_lag1" not in b:
                continue
            L.append(
                f"  {z:>6}: {b['acf_lag1']:+.2f}, {b['ljung_box']['p_value']:.2g}, {b['cpgram_departure']:.3f}"
                f" -> {a.get('acf_lag1', float('nan')):+.2f}, "
                f"{a.get('ljung_box', {}).get('p_value', float('nan')):.2g}, "
                f"{a.get('cpgram_departure', float('nan')):.3f}"
            )
        return L

    def _threshold_lines(self) -> list:
        """The acceptance rule's thresholds."""
        L: list = []
        o = self.options
        L.append("")
        L.append(
            f"Thresholds: ΔBIC > {o['bic_margin']:g} with autocorrelation-adjusted LR, then blocked "
            f"cross-validation over {o.get('cv_folds', 10)} folds of whole training weeks: gain "
            f">= {o.get('cv_min_gain_percent', 1.0):g} % (zone_coupling {o['coupling_min_gain_percent']:g} %) "
            f"and >= {o['min_gain_abs']:g} K with week-clustered paired t >= {o.get('cv_min_t', 2.0):g}; "
            f"held-out weeks are reported, not used to accept."
        )
        return L

    def __str__(self):
        return self.format()

    # ------------------------------------------------------------------ figures
    def plot(self, folder) -> list:
        """Write the diagnostic figures (PNG) into ``folder``; returns the paths."""
        from . import plots

        return plots.plot_all(self, folder)


def _finding_lines(i: int, f: dict) -> list:
    """The lines of finding number ``i``: test, evidence, parameters, cross-validation, rivals, held-out gain."""
    L: list = []
    t = f["test"]
    L.append(f" {i}. {f['cause']} at {_loc(f['location'])}")
    if t.get("open_loop_only"):  # a limiter (held_setpoint): no one-step regressor, cross-validated open loop only
        L.append("    test: open-loop cross-validation only (a limiter leaves the one-step prediction unchanged)")
    else:
        hm = (f.get("evidence") or {}).get("holiday_merge") or {}
        of = (
            f" (its first part, {hm['parts'][0]['dates'][0]}…{hm['parts'][0]['dates'][-1]})"
            if hm.get("merged") and hm.get("parts")
            else ""
        )
        L.append(
            f"    test{of}: LR {t['lr']:.1f} (autocorrelation-adjusted {t['lr_adjusted']:.1f}), "
            f"dof {t['dof']}, ΔBIC {t['delta_bic']:.1f}"
        )
    ev = _short_evidence(f)
    if ev:
        L.append(f"    evidence: {ev}")
    if f.get("parameters"):
        L.append(f"    parameters: {_fmt_params(f['parameters'])}")
    L += _holiday_lines(f.get("evidence") or {})
    cv = f.get("cv") or {}
    if cv.get("gain_percent") is not None:
        L.append(
            f"    cross-validated gain {cv['gain_percent']:.1f} ± {cv['se_percent']:.1f} % "
            f"({_cv_units(cv)}, {cv['n_folds']} folds, paired t {cv['t']:.1f}; "
            f"affected zones open loop, others measured)"
        )
    rv = (f.get("evidence") or {}).get("rival")
    if rv:
        t = "n/a" if rv.get("cv_t") is None else f"{rv['cv_t']:.1f}"
        why = f"the data favour {rv['favoured']}"
        if rv.get("shared_columns"):  # the same measured column(s) under two causes: one gain, decided by its rule
            why = f"both read {', '.join(rv['shared_columns'])}: one gain; {rv['favoured']} is named: {rv['why']}"
        elif rv["favoured"] != f["cause"]:  # the rival's t is higher, but it failed its own acceptance
            g = rv.get("cv_gain_percent")
            why = (
                f"its paired t is higher, but it fails its own acceptance rule"
                f"{'' if g is None else f' (cross-validated gain {g:.1f} %)'}, so this finding stands"
            )
        L.append(
            f"    competing cause for this gain: {rv['cause']} at {_loc(rv['location'])} "
            f"(cross-validated paired t {t}); {why}"
        )
    for o in f.get("competitors") or []:
        # a competitor a gate turned down after its fit improved (the supermarket's DST-shift schedule: ΔBIC 5321,
        # "not significant") reads as a contradiction without the gate's reason
        why = f": {o['reason']}" if o.get("reason") and o.get("status") != "found" else ""
        head = (
            "also significant here" if o.get("status") not in ("not significant", "no evidence") else "also tested here"
        )
        L.append(f"    {head}: {o['cause']} at {_loc(o['location'])} (ΔBIC {o['delta_bic']:.1f}, {o['status']}{why})")
    h = f.get("heldout") or {}
    if h.get("zones"):
        zz = ", ".join(f"{z} {v['before']:.3f}->{v['after']:.3f}" for z, v in h["zones"].items())
        L.append(f"    held-out RMS [K]: {zz}; gain {h['gain_percent']:.1f} %")
    return L


def _holiday_lines(ev: dict) -> list:
    """A holiday's parts (found week by week, merged or kept apart) and held-out weekdays that look like it."""
    L = []
    hm = ev.get("holiday_merge")
    if hm:

        def pct(r):
            return "n/a" if r.get("gain_percent") is None else f"{r['gain_percent']:+.1f} ± {r['se_percent']:.1f} %"

        head = "merged into this one term" if hm["merged"] else f"kept as {len(hm['parts'])} terms (one holiday)"
        L.append(
            f"    one holiday on {len(hm['dates'])} weekdays, found as {len(hm['parts'])} terms: {head}; {hm['why']}"
        )
        for p in hm["parts"]:
            L.append(
                f"      part {p['dates'][0]}…{p['dates'][-1]} ({len(p['dates'])} d): when found"
                + ("" if p.get("delta_bic") is None else f" ΔBIC {p['delta_bic']:.1f},")
                + f" {pct(p['cv_when_found'])}"
                f", merged term on its days {pct(p['merged_over_none_on_its_days'])}"
            )
    look = ev.get("heldout_lookalike") or {}
    if look.get("dates"):
        weeks = "; ".join(
            f"{w['dates'][0]}…{w['dates'][-1]} ({len(w['dates'])} d, γ {w['gamma']:.2f})" for w in look["weeks"]
        )
        L.append(
            f"    also looks like a holiday (held-out weeks, final model's residuals): {weeks}; not used in fitting"
        )
    return L


def _loc(loc: dict) -> str:
    parts = []
    for k, v in loc.items():
        if k == "dates":
            v = f"{len(v)} days" if len(v) > 3 else ",".join(v)
        elif isinstance(v, list):
            v = "+".join(str(x) for x in v)
        parts.append(f"{k}={v}")
    return ", ".join(parts)


def _fmt_params(p: dict) -> str:
    out = []
    for k, v in p.items():
        if isinstance(v, dict) and "value" in v:
            s = f"{k}={v['value']:.4g}" + (f"±{v['std']:.2g}" if v.get("std") is not None else "")
            out.append(s)
        elif isinstance(v, dict):
            out.append(
                f"{k}=" + ", ".join(f"{z}:{w['value']:.3g}±{w['std']:.2g}" for z, w in v.items() if abs(w["value"]) > 0)
            )
    return "; ".join(out)


def _short_evidence(f: dict) -> str:
    ev = f.get("evidence", {})
    c = f["cause"]
    if c == "solar_gain":
        s, cl = ev.get("resid_sunny", {}), ev.get("resid_cloudy", {})
        ph = (
            ""
            if ev.get("resid_peak_hour") is None or ev.get("facade_peak_hour") is None
            else f"; residual peaks at {ev['resid_peak_hour']:.1f} h, facade irradiance at {ev['facade_peak_hour']:.1f} h"
        )
        return (
            f"corr(residual, I) {ev.get('corr', float('nan')):+.2f}; mean one-step residual sunny "
            f"{(s.get('mean') or 0):+.4f} K vs cloudy {(cl.get('mean') or 0):+.4f} K" + ph
        )
    if c == "sensor_offset":
        return sensor_offset_evidence(f["location"], ev)
    if c == "unused_input":
        return (
            f"column {ev.get('column')} (coverage {100 * (ev.get('coverage') or 0):.0f} %): corr(residual, column) "
            f"{ev.get('corr', float('nan')):+.2f}"
        )
    if c == "supply_air_bilinear":
        return f"corr(residual, u·(T_supply−T)) {ev.get('corr', float('nan')):+.2f}"
    if c == "wind_infiltration":
        return (
            f"corr(residual, wind·(T_out−T)) {ev.get('corr', float('nan')):+.2f}, beyond T_out−T alone (partial) "
            f"{ev.get('partial_corr_beyond_dT', float('nan')):+.2f}; mean wind {ev.get('wind_mean_m_s', float('nan')):.1f} m/s"
        )
    if c == "zone_coupling":
        return f"corr(residual, ΔT of the pair) {ev.get('corr_a', float('nan')):+.2f} / {ev.get('corr_b', float('nan')):+.2f}"
    if c == "thermal_mass":
        return (
            f"time constant {ev.get('time_constant_h', float('nan')):.1f} h (alpha {ev.get('alpha', float('nan')):g})"
        )
    if c == "actuation_delay":
        xc = ev.get("xcorr_resid_airflow_by_lag", {})
        fu = ev.get("xcorr_resid_future_airflow_by_lag", {})
        h = ev.get("history") or {}
        given = (
            f"; ΔBIC {h['delta_bic']:.1f} given the zone's own temperatures of the last {h.get('history_h', 1):g} h"
            if h.get("delta_bic") is not None
            else ""
        )
        return (
            "corr(residual, airflow lagged): "
            + ", ".join(f"{k}:{v:+.2f}" for k, v in xc.items() if v is not None)
            + "; future airflow: "
            + ", ".join(f"{k}:{v:+.2f}" for k, v in fu.items() if v is not None)
            + given
        )
    if c == "reheat" and "corr_reheat_heat" in ev:
        return (
            f"corr(residual, Σ m·cp·(Td − T_supply)) {ev['corr_reheat_heat']:+.2f}; coils heating in "
            f"{100 * ev.get('share_of_rows_heating', 0):.0f} % of training rows"
        )
    if c == "reheat":
        th = ev.get("T_threshold", float("nan"))
        if ev.get("u_box_off") is not None and ev.get("u_min", 0) <= ev["u_box_off"] * (1 + 1e-9):
            return f"box off (airflow ≤ {ev['u_box_off']:.4f} kg/s, {100 * ev.get('box_off_fraction', 0.05):g} % of its minimum) and T_out < {th:g} °C"
        return f"T_out threshold {th:g} °C at minimum airflow {ev.get('u_min', 0):.3f} kg/s"
    if c == "internal_gain_schedule":
        if "days" in ev:
            return f"{len(f['location'].get('dates', []))} weekdays with weekend-like gains ({ev.get('rule')})"
        if "lag_h" in ev:
            # a shift retested after a rival was accepted: the screen numbers of the round it passed
            sc = ev.get("screen_passed") or ev
            when = (
                " in the round its screen passed; retested after a rival was accepted" if "screen_passed" in ev else ""
            )
            eve = sc.get("evening")
            evening = (
                f", evening ramp-down {60 * eve['legal_lag_h']:+.0f} min (R² {eve['r2_at_legal_lag']:.2f})"
                if eve
                else ""
            )
            stp = sc.get("step_given_weather") or {}
            if stp.get("t") is not None:
                evening += (
                    f", morning jump {stp['jump']:+.2f}, {stp['jump_given_weather']:+.2f} with the day's weather held "
                    f"(t {stp['t']:.1f})"
                )
            return (
                f"weekday morning gains {60 * sc['lag_h']:+.0f} min later under daylight saving "
                f"(R² {sc.get('r2_at_lag', 0):.2f}, scale {sc.get('scale_at_lag', 0):.2f}{evening}{when}); "
                f"daylight-saving rows {100 * ev.get('dst_fraction_of_training_rows', 0):.0f} % of training"
            )
        return f"daylight-saving rows {100 * ev.get('dst_fraction_of_training_rows', 0):.0f} % of training"
    if c == "held_setpoint":
        return held_evidence(ev)
    return ""


def sensor_offset_evidence(loc: dict, ev: dict) -> str:
    """The sensor-offset finding in words: zone, offset, date, what to check, and the numbers behind it."""
    when = str(loc.get("start", "?")).replace("T", " ")[:16]
    if loc.get("after"):  # between training days: the change lies in the held-out week or gap before ``start``
        when = f"between {str(loc['after']).replace('T', ' ')[:16]} and {when} (days without training data)"
    d = ev.get("offset_K")
    off = "?" if d is None else f"{d:+.2f}"
    if loc.get("end"):  # a change and its return: the sensor put back (or the set point moved for a while)
        until = str(loc["end"]).replace("T", " ")[:16]
        if loc.get("end_after"):
            until = f"between {str(loc['end_after']).replace('T', ' ')[:16]} and {until} (days without training data)"
        r = ev.get("return_K")
        back = "then back" + ("" if r is None else f" ({r:+.2f} K from before)")
        text = (
            f"zone {loc.get('zone')} reads {off} K from {when} until {until}, {back} (a sensor re-calibrated "
            "and put back, or a set point moved for that time): check the sensor's history; "
        )
        text += (
            f"its level against the other zones differs between those dates (t {ev.get('split_t', float('nan')):.1f})"
        )
        p = ev.get("persist_halves_K")
        if p:
            text += f", kept {p[0]:+.2f} / {p[1]:+.2f} K over the halves between them"
        jb = (ev.get("at_return") or {}).get("jump_residual_K")
        if ev.get("jump_residual_K") is not None:
            text += f"; one-step residuals at the jumps {ev['jump_residual_K']:+.2f}" + (
                f" / {jb:+.2f} K" if jb is not None else " K"
            )
        return text
    further = bool(ev.get("accepted_changes"))  # a further change of a zone with one already named
    text = (
        f"zone {loc.get('zone')} reads {off} K {'more ' if further else ''}from {when} on ("
        + ("a further change after the one named before: " if further else "")
        + "a re-calibrated/replaced sensor, or a changed setpoint offset): check the sensor's history; "
    )
    text += f"its level against the other zones splits there (t {ev.get('split_t', float('nan')):.1f})"
    p = ev.get("persist_halves_K")
    if p:
        text += f", kept {p[0]:+.2f} / {p[1]:+.2f} K over the halves after"
    if ev.get("jump_residual_K") is not None:
        text += f"; one-step residual at the jump {ev['jump_residual_K']:+.2f} K"
    if ev.get("airflow_local_before") is not None:
        text += (
            f"; the zone's airflow {ev['airflow_local_before']:.3f} -> {ev['airflow_local_after']:.3f} kg/s over the "
            "days around it (a set point moved by the offset would change it; weather changes it too)"
        )
    return text


def held_evidence(ev: dict) -> str:
    """The held edges of a ``held_setpoint`` candidate's evidence: where the training measurements pile up and how
    rarely they cross (``"cooling_floor 24 °C: 84 % of 16355 cooling rows at it, 0.02 % below"``)."""
    parts = []
    for name, side, what, word in (
        ("always", "lower", "rows", "below"),
        ("always", "upper", "rows", "above"),
        ("cooling_floor", "lower", "cooling rows", "below"),
        ("heating_ceiling", "upper", "heating rows", "above"),
    ):
        e = ev.get(name) or {}
        if e.get(side) is None:
            continue
        label = side if name == "always" else name
        parts.append(
            f"{label} {e[side]:g} °C: {100 * e[f'{side}_pile']:.0f} % of {e['n']} {what} at it, "
            f"{100 * e[f'{side}_beyond']:.2f} % {word}"
        )
    return "; ".join(parts)
