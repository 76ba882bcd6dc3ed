"""Benchmark: the control gain of the diagnosis (issue 18 point 5).

For each case (an emulator dataset of 51 weeks with one injected effect that matters for
control: extra solar gain through one facade, or an undeclared zone coupling), runs the
whole loop:

1. ``diagnose`` the dataset (its own base: the six-zone Model A without solar, as in the
   paper), and check that the injected effect is among the findings;
2. the control models: **base** = that Model A with its gain profiles re-estimated, and
   **extended** = the same Model A with the diagnosis's terms refitted on its dynamics
   (:func:`hvacfmu.diagnosis.control.terms_on_base`); with ``--joint`` also the
   diagnosis's own extended model (its one-step refit, README "Control gain of the
   diagnosis" says why it is not the one to control with);
3. ``cosim --controller mpc`` on the plant FMU of the dataset (the building with the
   effect) for a summer and a winter held-out week, horizon 12 (the demo's, ``"plant"``
   preset).

Prints per case, week and model the fan/cooling energy proxy Σu² [(kg/s)²], the commanded
reheat [kWh], the comfort violation [K·h] outside [20, 22] °C and the week time, then
extended against base: K·h saved and energy change. Diagnoses are cached in
``$HVACFMU_CACHE/bench_control_gain/`` (keyed by the dataset and the diagnosis sources).

Usage::

    python3 benchmarks/bench_control_gain.py [--cases 0:solar_gain:zone=W,facade=W ...]
        [--seasons summer winter] [--horizon 12] [--days 7] [--joint]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import tempfile
import time
from pathlib import Path

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_mpc_plant import pick_weeks  # noqa: E402

DEFAULT_CASES = (
    "0:solar_gain:zone=W,facade=W",
    "1:solar_gain:zone=S,facade=S",
    "2:solar_gain:zone=E,facade=E",
    "0:zone_coupling:zones=W+E",
    "3:solar_gain:zone=E,facade=E,shgc=0.1",
    "3:solar_gain:zone=W,facade=W,shgc=0.1",
)


def _source_hash() -> str:
    h = hashlib.sha256()
    for folder in ("hvacfmu/diagnosis", "hvacfmu/models/causes"):
        for p in sorted((ROOT / folder).glob("*.py")):
            h.update(p.read_bytes())
    return h.hexdigest()[:12]


def diagnosed(paths, ds):
    """(base Model A, diagnosis findings, diagnosis extended model), cached by dataset and diagnosis code."""
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.models import load_model

    root = Path(os.environ.get("HVACFMU_CACHE", Path.home() / ".cache" / "hvacfmu"))
    folder = root / "bench_control_gain" / f"{Path(paths.truth).parent.name}-{_source_hash()}"
    if (folder / "findings.json").is_file():
        findings = json.loads((folder / "findings.json").read_text(encoding="utf-8"))
        return load_model(folder / "base.json"), findings, load_model(folder / "extended.json")
    rep = diagnose(ds, progress=False)
    folder.mkdir(parents=True, exist_ok=True)
    rep.base_model.save(folder / "base.json")
    rep.model.save(folder / "extended.json")
    findings = [{"cause": f["cause"], "location": f.get("location")} for f in rep.findings]
    (folder / "findings.json").write_text(json.dumps(findings), encoding="utf-8")
    return rep.base_model, findings, rep.model


def injected_found(effect: dict, findings) -> str:
    """The finding that names the injected effect (cause and place), or ``"missed"``."""
    for f in findings:
        loc = f.get("location") or {}
        if f["cause"] != effect["name"]:
            continue
        if effect["name"] == "solar_gain" and (loc.get("zone"), loc.get("facade")) == (
            effect["zone"],
            effect["facade"],
        ):
            return f"solar_gain {loc['zone']}/{loc['facade']}"
        if effect["name"] == "zone_coupling" and set(loc.get("zones") or ()) == set(effect["zones"]):
            return f"zone_coupling {'+'.join(loc['zones'])}"
    return "missed"


def capacity_limited_Kh(table, building, band=(20.0, 22.0)) -> float:
    """K·h above the band while every box of the zone is at its maximum airflow (no controller can cool more)."""
    import numpy as np

    step_h = (table.index[1] - table.index[0]).total_seconds() / 3600.0
    total = 0.0
    for z in building.zone_names:
        boxes = building.vavs_of(z)
        at_max = np.all(np.column_stack([table[f"m_{v.name}"] >= 0.98 * v.m_max for v in boxes]), axis=1)
        hot = np.clip(table[f"T_{z}"].to_numpy(float) - band[1], 0.0, None)
        total += float(np.sum(hot[at_max])) * step_h
    return total


def run_week(fmu, ds, model, week, horizon, days):
    import pandas as pd

    from harness.cosim import make_controller, run_cosim

    t0 = time.perf_counter()
    ctrl = make_controller("mpc", model, ds.building, {"horizon": horizon})
    span = {"week": week.number} if days >= 7 else {"start": week.start, "stop": week.start + pd.Timedelta(days=days)}
    r = run_cosim(fmu, ds, ctrl, model=model, **span)
    s = r.summary
    st = s.get("controller_stats") or {}
    return {
        "energy": s["energy_proxy"],
        "heat": s.get("heating_kWh", 0.0),
        "viol": s["comfort_violation_Kh"],
        "viol_at_max": capacity_limited_Kh(r.table.iloc[1:], ds.building),
        "wall": time.perf_counter() - t0,
        "failures": st.get("failures", 0),
        "not_converged": st.get("not_converged", 0),
    }


def run_case(case: str, seasons, horizon: int, days: float, joint: bool) -> list:
    """Rows (effect, found, season, week, model, figures) of one ``seed:effect`` case."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis.control import terms_on_base
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.fmu import export_plant_fmu

    seed, _, spec = case.partition(":")
    paths = cached_dataset(weeks=51, seed=int(seed), effects=[spec])
    ds = prepare(paths.measurements, paths.building, seed=int(seed))
    effect = json.loads(Path(paths.truth).read_text(encoding="utf-8"))["effects"][0]
    t0 = time.perf_counter()
    base0, findings, ext_joint = diagnosed(paths, ds)
    found = injected_found(effect, findings)
    models = {"base": terms_on_base(ds, base0, ()), "extended": terms_on_base(ds, base0, ext_joint.terms)}
    if joint:
        models["joint refit"] = ext_joint
    print(
        f"case seed {seed} {spec}: diagnosis {time.perf_counter() - t0:.1f} s, {len(findings)} findings, "
        f"injected effect: {found}",
        flush=True,
    )
    fmu = export_plant_fmu(paths.truth, Path(tempfile.mkdtemp()) / "Plant.fmu")
    rows = []
    for season, week in pick_weeks(ds, seasons).items():
        for name, model in models.items():
            r = run_week(fmu, ds, model, week, horizon, days)
            rows.append({"effect": spec, "seed": int(seed), "found": found, "season": season, "model": name, **r})
            print(
                f"  {season:<6} week {week.number:2d} {name:<11} Σu² {r['energy']:7.1f}  reheat {r['heat']:7.1f} kWh  "
                f"outside band {r['viol']:6.2f} K·h (at max airflow {r['viol_at_max']:6.2f})  {r['wall']:5.1f} s  failures {r['failures']} "
                f"not converged {r['not_converged']}",
                flush=True,
            )
    return rows


def verdicts(rows) -> list:
    """Per case and week: extended against base (K·h saved, energy and reheat change)."""
    out = []
    keys = sorted({(r["effect"], r["seed"], r["season"]) for r in rows}, key=str)
    for effect, seed, season in keys:
        by = {r["model"]: r for r in rows if (r["effect"], r["seed"], r["season"]) == (effect, seed, season)}
        b, e = by.get("base"), by.get("extended")
        if b and e:
            out.append(
                {
                    "effect": effect,
                    "seed": seed,
                    "season": season,
                    "found": b["found"],
                    "saved_Kh": b["viol"] - e["viol"],
                    "energy_change_percent": 100.0 * (e["energy"] / b["energy"] - 1.0),
                    "reheat_change_kWh": e["heat"] - b["heat"],
                    "better": e["viol"] < b["viol"]
                    and e["energy"] <= b["energy"] * 1.005
                    and e["heat"] <= b["heat"] + 1.0,
                }
            )
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=list(DEFAULT_CASES), help="seed:effect, e.g. 0:solar_gain:zone=W")
    ap.add_argument("--seasons", nargs="+", default=["summer", "winter"])
    ap.add_argument("--horizon", type=int, default=12)
    ap.add_argument("--days", type=float, default=7.0, help="days of each week to run (7: the whole week)")
    ap.add_argument("--joint", action="store_true", help="also control with the diagnosis's own extended model")
    args = ap.parse_args(argv)
    print(
        f"plant FMU per dataset, MPC N={args.horizon}; machine load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"
    )
    rows = []
    for case in args.cases:
        rows += run_case(case, args.seasons, args.horizon, args.days, args.joint)
    print(
        "\neffect | seed | found | week | K·h base -> extended (of which at max airflow) | Σu² change | reheat change "
        "| better"
    )
    for v in verdicts(rows):
        b = next(
            r
            for r in rows
            if (r["effect"], r["seed"], r["season"], r["model"]) == (v["effect"], v["seed"], v["season"], "base")
        )
        e = next(
            r
            for r in rows
            if (r["effect"], r["seed"], r["season"], r["model"]) == (v["effect"], v["seed"], v["season"], "extended")
        )
        print(
            f"{v['effect']} | {v['seed']} | {v['found']} | {v['season']} | {b['viol']:.2f} -> {e['viol']:.2f} "
            f"({b['viol_at_max']:.2f} -> {e['viol_at_max']:.2f}) | "
            f"{v['energy_change_percent']:+.1f} % | {v['reheat_change_kWh']:+.1f} kWh | {'yes' if v['better'] else 'no'}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
