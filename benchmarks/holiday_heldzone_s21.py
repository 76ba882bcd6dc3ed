"""Probe (session 21, issue 15): a holiday's scale gate without the zones a heater holds.

Fresh battery case a10 (``fresh_s21.md``): the holiday's fitted scale is 0 in the zone whose injected reheat holds
its temperature (the heater takes the lost gains), and that 0 pulls the gate's amplitude-weighted mean to 0.318 <
0.33. This probe reruns cases with ``selection._term_evidence`` wrapped: for a holiday candidate, a zone fitted at the
bound 0 that has an accepted ``reheat`` or ``held_setpoint`` term is left out of ``scale_mean`` (the other zones'
weights kept; only when the rest hold at least half the amplitude weight, as ``_holiday_scale_with`` does). Nothing
in the library changes. Prints each case's findings against main's record (``findings`` of the results file).

    python3 benchmarks/holiday_heldzone_s21.py RESULTS.jsonl [CHECKED.jsonl] --only 10,12
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def _patch():
    import hvacfmu.diagnosis.selection as sel
    from hvacfmu.models.causes.held_setpoint import HeldSetpoint
    from hvacfmu.models.causes.reheat import Reheat

    orig = sel._term_evidence
    moved = []

    def wrapped(c, sig, W, terms, t, coefs, options):
        orig(c, sig, W, terms, t, coefs, options)
        if getattr(t, "variant", None) != "holiday" or "scale_by_zone" not in c.evidence:
            return
        held = {x.zone for x in terms if isinstance(x, (Reheat, HeldSetpoint))}
        g = np.array([c.evidence["scale_by_zone"][z] for z in sig.zones])
        w = np.array([c.evidence["scale_weight_by_zone"][z] for z in sig.zones])
        out = np.array([z in held and gz <= 0.0 for z, gz in zip(sig.zones, g)])
        out |= np.array([z in c.evidence.get("scale_zones_at_bound", []) for z in sig.zones])
        if out.any() and w[~out].sum() >= 0.5 * w.sum():
            new = float((w[~out] @ g[~out]) / w[~out].sum())
            if abs(new - c.evidence["scale_mean"]) > 1e-12:
                moved.append((sorted(set(sig.zones) - set(np.array(sig.zones)[~out])), c.evidence["scale_mean"], new))
                c.evidence["scale_mean"] = new

    sel._term_evidence = wrapped
    return moved


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results")
    ap.add_argument("checked", nargs="?")
    ap.add_argument("--only", default=None)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.diagnosis.truth import compare_with_truth
    from hvacfmu.emulator import cached_dataset

    moved = _patch()
    keep = {int(x) for x in args.only.split(",")} if args.only else None
    for line in open(args.results):
        r = json.loads(line)
        case = r["case"]
        if keep and case["id"] not in keep:
            continue
        moved.clear()
        p = cached_dataset(weeks=r["weeks"], seed=case["seed"], effects=case["effects"], layout=case["layout"])
        rep = diagnose(prepare(p.measurements, p.building, step=case["step"]), progress=False)
        cmp = compare_with_truth(rep, json.loads(p.truth.read_text()))
        now = sorted(json.dumps([f["cause"], f["location"]], sort_keys=True) for f in rep.to_dict()["findings"])
        was = sorted(json.dumps([f["cause"], f["location"]], sort_keys=True) for f in r["findings"])
        print(
            f"case {case['id']:3d} {case['layout']} {case['effects']}: found {[e['name'] for e in cmp['found']]} "
            f"missed {[e['name'] for e in cmp['missed']]} false {[f['cause'] for f in cmp['unsupported']]}; "
            f"findings {'SAME' if now == was else 'CHANGED: -' + str(sorted(set(was) - set(now))) + ' +' + str(sorted(set(now) - set(was)))}; "
            f"scale moved {[(z, round(a, 3), round(b, 3)) for z, a, b in moved]}",
            flush=True,
        )


if __name__ == "__main__":
    main()
