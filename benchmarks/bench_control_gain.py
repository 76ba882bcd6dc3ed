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

Energy is :class:`harness.energy.EnergyUse`: the fan/cooling proxy Σu² [(kg/s)²] and the
commanded reheat [kWh], both reported; "no more energy" means neither more (no factor
between them is invented). MPC's comfort weight (``comfort_penalty``, 1e4 by default) trades
K·h against energy, so one run per model says little: every week is run with both models
at each weight of ``--weights``, which gives two K·h-against-energy frontiers. The claim
"extended beats base in comfort at equal or lower energy" holds in a week when a real run
of the extended model uses no more energy than the base model's run at the default weight
and has fewer K·h (:func:`harness.energy.frontier_gain`; no interpolation). Printed per run:
Σu², reheat, K·h outside [20, 22] °C, the K·h spent while every box of the zone was at its
maximum airflow (capacity-limited: no controller could cool more at that moment) and the CPU
and wall time; then the frontiers and the verdict per case and week (with how many base runs
of any weight an extended run beats). Diagnoses are cached in
``$HVACFMU_CACHE/bench_control_gain/`` (keyed by the dataset and the diagnosis sources).

Usage::

    python3 benchmarks/bench_control_gain.py [--cases 0:solar_gain:zone=W,facade=W ...]
        [--seasons summer winter] [--horizon 12] [--days 7] [--weights 10000 50 30 10] [--joint]
        [--models base extended without:zone_coupling kept:zone_coupling]
        [--json runs.json] [--from-json runs.json ...]

Several effects in one dataset are joined by ``&`` (``core9/3:solar_gain:zone=SW,facade=W&zone_coupling:zones=SW+NW``).
Cases on another floor layout are written ``layout/seed:effect`` (``core9/3:zone_coupling:zones=N+SE,ua=1051``,
the coupling the diagnosis finds). ``without:<cause>`` controls with the extended model without that
cause's terms, ``kept:<cause>`` with them at the diagnosis's own coefficients, ``refit:<cause>`` with them
refitted even where the refit zeroes them (session 17's control model; since session 19 a zone coupling the
refit zeroes keeps the diagnosis's conductance by default): their verdicts against each other and the
extended model say what the cause's terms themselves bring. ``control_front_s19.py`` compares the models'
comfort-against-energy fronts over the weights.
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
    "1:solar_gain:zone=S,facade=S,shgc=0.1",
    "core9/3:zone_coupling:zones=N+SE,ua=1051",
    "core9/3:zone_coupling:zones=SW+NW,ua=1554",
)
#: the MPC's default comfort penalty (:class:`harness.mpc.problem.MPCSettings`) [1/K per output and step]
DEFAULT_WEIGHT = 1.0e4
#: options passed to ``diagnose`` (``--diagnose-option``; part of the diagnosis cache key and of the row labels)
DIAGNOSE_OPTIONS: dict = {}
#: the comfort weights swept per model (the default first)
DEFAULT_WEIGHTS = (DEFAULT_WEIGHT, 50.0, 30.0, 10.0)


def parse_case(case: str):
    """``[layout/]seed:effect`` -> (layout, seed, effect spec, row label); the layout defaults to ``sdh``.

    The row label is the effect spec, prefixed by the layout when it is not the default
    (``core9/zone_coupling:zones=N+SE,ua=1051``).
    """
    head, _, spec = case.partition(":")
    layout, _, seed = head.rpartition("/")
    layout = layout or "sdh"
    return layout, int(seed), spec, spec if layout == "sdh" else f"{layout}/{spec}"


def case_effects(spec: str) -> list:
    """The effect specs of a case's dataset: several effects are joined by ``&`` (each checked by the emulator's
    :func:`~hvacfmu.emulator.parse_effect`, so a typo fails before a 51-week dataset is generated)."""
    from hvacfmu.emulator import parse_effect

    parts = [p.strip() for p in spec.split("&")]
    for p in parts:
        parse_effect(p)
    return parts


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
    opts = "".join(f"-{k}={v}" for k, v in sorted(DIAGNOSE_OPTIONS.items()))
    folder = root / "bench_control_gain" / f"{Path(paths.truth).parent.name}-{_source_hash()}{opts}"
    if (folder / "findings.json").is_file():
        findings = json.loads((folder / "findings.json").read_text(encoding="utf-8"))
        return load_model(folder / "base.json"), findings, load_model(folder / "extended.json")
    rep = diagnose(ds, progress=False, **DIAGNOSE_OPTIONS)
    folder.mkdir(parents=True, exist_ok=True)
    rep.base_model.save(folder / "base.json")
    rep.model.save(folder / "extended.json")
    # every finding's place with its cross-validated gain [%] and t; the coupling candidates not found, with their
    # status and reason, beside them (a missed coupling says why)
    findings = [{"cause": f["cause"], "location": f.get("location"), **_cv(f)} for f in rep.findings]
    couplings = [
        {"location": c.get("location"), "status": c.get("status"), "reason": c.get("reason"), **_cv(c)}
        for c in rep.candidates
        if c["cause"] == "zone_coupling"
    ]
    (folder / "coupling_candidates.json").write_text(json.dumps(couplings), encoding="utf-8")
    (folder / "findings.json").write_text(json.dumps(findings), encoding="utf-8")
    return rep.base_model, findings, rep.model


def _option_value(text: str):
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    try:
        return float(text) if any(ch in text for ch in ".eE") else int(text)
    except ValueError:
        return text


def _cv(c: dict) -> dict:
    cv = c.get("cv") or {}
    return {"cv_gain_percent": cv.get("gain_percent"), "cv_t": cv.get("t")}


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


def run_week(fmu, ds, model, week, horizon, days, weight=None):
    """One closed-loop week (or ``days``) of MPC on the plant FMU; ``weight``: comfort penalty (None: default)."""
    import pandas as pd

    from harness.cosim import make_controller, run_cosim

    t0, w0 = time.process_time(), time.perf_counter()
    opts = {"horizon": horizon} if weight is None else {"horizon": horizon, "comfort_penalty": weight}
    ctrl = make_controller("mpc", model, ds.building, opts)
    span = {"week": week.number} if days >= 7 else {"start": week.start, "stop": week.start + pd.Timedelta(days=days)}
    r = run_cosim(fmu, ds, ctrl, model=model, **span)
    s = r.summary
    st = s.get("controller_stats") or {}
    return {
        "weight": DEFAULT_WEIGHT if weight is None else float(weight),
        "energy_proxy": s["energy_proxy"],
        "heating_kWh": s.get("heating_kWh", 0.0),
        "comfort_violation_Kh": s["comfort_violation_Kh"],
        "viol_at_max": capacity_limited_Kh(r.table.iloc[1:], ds.building),
        "cpu": time.process_time() - t0,
        "wall": time.perf_counter() - w0,
        "failures": st.get("failures", 0),
        "not_converged": st.get("not_converged", 0),
    }


def control_models(ds, base0, ext_joint, names) -> dict:
    """The models to control with, by name: ``base``, ``extended``, ``joint refit``, ``kept:<cause>``, ``without:<cause>``.

    ``without:<cause>`` is the extended model without the found terms of that cause (the
    others refitted the same way): controlling with it against ``extended`` isolates what the
    cause's terms bring (e.g. the coupling, beside the solar terms found with it).
    ``kept:<cause>`` is the extended model with that cause's terms at the diagnosis's own
    coefficients (not refitted on the base's dynamics; the others refitted around them).
    ``refit:<cause>`` refits that cause's terms even where the refit sets them to 0 (``keep_zeroed``
    without the cause; session 17's control model for a coupling).
    """
    from hvacfmu.diagnosis.control import KEEP_ZEROED, terms_on_base

    out = {}
    for name in names:
        if name == "base":
            out[name] = terms_on_base(ds, base0, ())
        elif name == "extended":
            out[name] = terms_on_base(ds, base0, ext_joint.terms)
        elif name == "joint refit":
            out[name] = ext_joint
        elif name.startswith("kept:"):
            out[name] = terms_on_base(ds, base0, ext_joint.terms, keep=(name.partition(":")[2],))
        elif name.startswith("refit:"):
            # session 17's control model: the cause's terms refitted even where the refit drops them (zeroes
            # every coefficient); the default keeps the diagnosis's coefficients there (``keep_zeroed``)
            cause = name.partition(":")[2]
            out[name] = terms_on_base(
                ds, base0, ext_joint.terms, keep_zeroed=tuple(c for c in KEEP_ZEROED if c != cause)
            )
        elif name.startswith("without:"):
            cause = name.partition(":")[2]
            out[name] = terms_on_base(ds, base0, [t for t in ext_joint.terms if t.cause != cause])
        else:
            raise SystemExit(
                f"unknown model {name!r}: base, extended, joint refit, kept:<cause>, refit:<cause> or without:<cause>"
            )
    return out


def run_case(case: str, seasons, horizon: int, days: float, names, weights, out=None) -> list:
    """Rows (effect, found, season, week, model, weight, figures) of one ``[layout/]seed:effect`` case."""
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.fmu import export_plant_fmu

    layout, seed, spec, label = parse_case(case)
    if DIAGNOSE_OPTIONS:
        label += " [" + ", ".join(f"{k}={v}" for k, v in sorted(DIAGNOSE_OPTIONS.items())) + "]"
    paths = cached_dataset(
        weeks=51, seed=seed, effects=case_effects(spec), **({} if layout == "sdh" else {"layout": layout})
    )
    ds = prepare(paths.measurements, paths.building, seed=seed)
    effects = json.loads(Path(paths.truth).read_text(encoding="utf-8"))["effects"]
    t0 = time.perf_counter()
    base0, findings, ext_joint = diagnosed(paths, ds)
    found = "; ".join(injected_found(e, findings) for e in effects)
    models = control_models(ds, base0, ext_joint, names)
    print(
        f"case seed {seed} {label}: diagnosis {time.perf_counter() - t0:.1f} s, {len(findings)} findings "
        f"({', '.join(sorted({f['cause'] for f in findings}))}), injected effect: {found}",
        flush=True,
    )
    fmu = export_plant_fmu(paths.truth, Path(tempfile.mkdtemp()) / "Plant.fmu")
    rows = []
    for season, week in pick_weeks(ds, seasons).items():
        for name, model in models.items():
            for w in weights:
                r = run_week(fmu, ds, model, week, horizon, days, None if w == DEFAULT_WEIGHT else w)
                row = {"effect": label, "seed": seed, "found": found, "season": season, "week": week.number}
                rows.append({**row, "model": name, **r})
                print(
                    f"  {season:<6} week {week.number:2d} {name:<11} weight {r['weight']:7g}  "
                    f"Σu² {r['energy_proxy']:7.1f}  reheat {r['heating_kWh']:7.1f} kWh  outside band "
                    f"{r['comfort_violation_Kh']:6.2f} K·h (at max airflow {r['viol_at_max']:6.2f})  "
                    f"{r['cpu']:5.1f} s CPU ({r['wall']:5.1f} s wall)  failures {r['failures']} not converged {r['not_converged']}",
                    flush=True,
                )
                if out:
                    Path(out).write_text(json.dumps(_previous(out, rows) + rows, indent=0), encoding="utf-8")
    return rows


def _reheat_kW(table, boxes):
    """Commanded reheat [kW] of ``boxes`` per row: Σ m c_p max(Td - T_supply, 0) (0 without discharge commands)."""
    import numpy as np

    from hvacfmu.models.heat import CP_AIR

    out = np.zeros(len(table))
    for v in boxes:
        if f"Td_{v}" in table and "T_supply" in table:
            dT = np.maximum(table[f"Td_{v}"].to_numpy(float) - table["T_supply"].to_numpy(float), 0.0)
            out += np.nan_to_num(table[f"m_{v}"].to_numpy(float) * CP_AIR * dT / 1e3)
    return out


class _Shadowed:
    """Controller protocol: the first MPC controls, the others only estimate their state from the same
    measurements and applied moves (their own Kalman filter), so every model's open-loop prediction can be
    scored on the one controlled trajectory."""

    name = "mpc"

    def __init__(self, ctrls: dict):
        self.ctrls = ctrls
        self.active = next(iter(ctrls))

    def reset(self, context) -> None:
        for c in self.ctrls.values():
            c.reset(context)
        self.x = {n: [] for n in self.ctrls}
        self.y, self.u = [], []

    def __call__(self, k, t, y, v):
        import numpy as np

        act = self.ctrls[self.active]
        y_model = act._W @ np.asarray(y, dtype=float)
        for n, c in self.ctrls.items():
            if n != self.active:
                self.x[n].append(c.mpc.estimate(c._W @ np.asarray(y, dtype=float), c.V[k], c.Q[k]))
        out = act(k, t, y, v)
        u = act.mpc._last[0]
        self.x[self.active].append(act.mpc.kf.x.copy() if act.mpc.kf is not None else y_model)
        for n, c in self.ctrls.items():
            if n != self.active:
                c.mpc._last = (u, c.V[k], c.Q[k])
        self.y.append(y_model)
        self.u.append(u)
        return out

    def stats(self) -> dict:
        return self.ctrls[self.active].stats()


def explain_coupling(case: str, seasons, horizon: int, days: float, hours: int = 24) -> None:
    """Why a found coupling brings (or not) comfort under MPC, measured on the weeks controlled.

    For each week: the extended model controls the plant FMU while the base model and the extended model
    without the coupling term estimate their own states from the same measurements and moves; printed are
    (1) the open-loop prediction RMS [K] of every zone of the pair over ``hours`` from every 2nd hour, and the
    one-step RMS, of the three models on that trajectory (no offset estimate: the models as they are);
    (2) the pair's temperature difference and the heat the coupling term carries [K/step] against the
    zone's drift; (3) the same week controlled with the model without the coupling: how far the applied box
    airflows and the pair's temperatures move between the two runs.
    """
    import numpy as np

    from harness.cosim import make_controller, run_cosim
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.fmu import export_plant_fmu

    layout, seed, spec, label = parse_case(case)
    paths = cached_dataset(
        weeks=51, seed=seed, effects=case_effects(spec), **({} if layout == "sdh" else {"layout": layout})
    )
    ds = prepare(paths.measurements, paths.building, seed=seed)
    base0, findings, ext_joint = diagnosed(paths, ds)
    models = control_models(ds, base0, ext_joint, ["extended", "base", "without:zone_coupling"])
    term = next((t for t in models["extended"].terms if t.cause == "zone_coupling"), None)
    if term is None:
        print(f"{label} seed {seed}: the extended model has no coupling term")
        return
    a, b = term.zone_a, term.zone_b
    print(f"{label} seed {seed}: coupling {a}+{b} coef {term.coef_ab:.4f} / {term.coef_ba:.4f} per step")
    fmu = export_plant_fmu(paths.truth, Path(tempfile.mkdtemp()) / "Plant.fmu")
    zones = list(models["extended"].outputs)
    ia, ib = zones.index(a), zones.index(b)
    L = int(round(hours * 3600 / ds.step))
    for season, week in pick_weeks(ds, seasons).items():
        opts = {"horizon": horizon}
        ctrls = {n: make_controller("mpc", m, ds.building, opts) for n, m in models.items()}
        sh = _Shadowed(ctrls)
        import pandas as pd

        span = (
            {"week": week.number} if days >= 7 else {"start": week.start, "stop": week.start + pd.Timedelta(days=days)}
        )
        r_ext = run_cosim(fmu, ds, sh, model=models["extended"], **span)
        Y, U = np.array(sh.y), np.array(sh.u)
        n = len(U)
        print(f"  {season} week {week.number}: extended controls, {r_ext.summary['comfort_violation_Kh']:.2f} K·h")
        for name, c in ctrls.items():
            pred = c.mpc.pred
            pred.offset = None
            X = np.array(sh.x[name])
            err_l, err_1 = [], []
            for k in range(0, n - L, max(1, L // 12)):
                Xp = pred.simulate(X[k], U[k : k + L], c.V[k : k + L], c.Q[k : k + L])
                err_l.append(Xp[1:] @ pred.C.T - Y[k + 1 : k + L + 1])
            for k in range(n - 1):
                err_1.append(pred.C @ pred.step(X[k], U[k], c.V[k], c.Q[k]) - Y[k + 1])
            El, E1 = np.concatenate(err_l), np.array(err_1)
            rms = lambda E, i: float(np.sqrt(np.mean(E[:, i] ** 2)))  # noqa: E731
            print(
                f"    {name:<22} open-loop {hours} h RMS {a} {rms(El, ia):.3f} K, {b} {rms(El, ib):.3f} K; "
                f"one-step RMS {a} {rms(E1, ia):.3f}, {b} {rms(E1, ib):.3f}; mean of all zones {hours} h "
                f"{float(np.sqrt(np.mean(El**2))):.3f}"
            )
        d = Y[:, ib] - Y[:, ia]
        flux_a = term.coef_ab * d  # [K/step] into a
        drift_a = np.abs(np.diff(Y[:, ia]))
        print(
            f"    {b} - {a}: mean {d.mean():+.3f} K, mean |.| {np.abs(d).mean():.3f} K, max |.| {np.abs(d).max():.2f} K; "
            f"coupling into {a}: mean |.| {np.abs(flux_a).mean():.4f} K/step (max {np.abs(flux_a).max():.3f}) "
            f"against the zone's mean |step change| {drift_a.mean():.3f} K/step"
        )
        r_wo = run_cosim(fmu, ds, make_controller("mpc", models["without:zone_coupling"], ds.building, opts),
                         model=models["without:zone_coupling"], **span)  # fmt: skip
        t1, t2 = r_ext.table, r_wo.table  # commands: rows 0..n-1; temperatures after them: rows 1..n
        for z in (a, b):
            boxes = [v.name for v in ds.building.vavs_of(z)]
            m1, m2 = (t[[f"m_{v}" for v in boxes]].to_numpy(float)[:-1] for t in (t1, t2))
            h1, h2 = (_reheat_kW(t, boxes)[:-1] for t in (t1, t2))
            dm = np.abs(m1.sum(axis=1) - m2.sum(axis=1))
            dT = np.abs(t1[f"T_{z}"].to_numpy(float)[1:] - t2[f"T_{z}"].to_numpy(float)[1:])
            print(
                f"    {z}: with vs without the coupling term: zone airflow differs by mean {dm.mean():.4f} kg/s "
                f"(max {dm.max():.3f}; mean airflow {m1.sum(axis=1).mean():.3f}), reheat by mean "
                f"{np.abs(h1 - h2).mean():.3f} kW (mean reheat {h1.mean():.3f}), zone temperature by mean "
                f"{dT.mean():.3f} K (max {dT.max():.2f})"
            )
        by1, by2 = (r.summary.get("comfort_by_output") or {} for r in (r_ext, r_wo))
        fmt = lambda v: "-" if v is None else f"{v[0]:.2f}, {v[1]:.2f}"  # noqa: E731
        pair = "; ".join(f"{z} {fmt(by1.get(f'T_{z}'))} / {fmt(by2.get(f'T_{z}'))}" for z in (a, b))
        print(
            f"    K·h with / without the coupling term: {r_ext.summary['comfort_violation_Kh']:.2f} / "
            f"{r_wo.summary['comfort_violation_Kh']:.2f} (below, above the band: {pair})",
            flush=True,
        )


def _previous(out, rows) -> list:
    """Rows already in the ``--json`` file that ``rows`` do not replace (same case, week, model and weight)."""
    p = Path(out)
    if not p.is_file():
        return []
    new = {_key(r) for r in rows}
    return [r for r in json.loads(p.read_text(encoding="utf-8")) if _key(r) not in new]


def _key(r) -> tuple:
    return (r["seed"], r["effect"], r["season"], r["model"], r["weight"])


def verdicts(rows, model: str = "extended", ref: str = "base") -> list:
    """Per case and week: the two frontiers, and the claim at the reference's default-weight energy.

    ``model`` is compared with ``ref`` (default: the extended model with the base; with
    ``ref="without:<cause>"`` the claim is what that cause's terms add to the other terms).

    The claim holds when a real extended run uses no more energy than the base model's run at
    the default comfort weight (:meth:`harness.energy.EnergyUse.at_most`: neither more Σu² nor
    more reheat) and has fewer K·h (:func:`harness.energy.frontier_gain`). ``dominated`` counts
    the base runs (of every weight) that some extended run beats that way.
    """
    from harness.energy import frontier_gain

    out = []
    keys = sorted({(r["effect"], r["seed"], r["season"]) for r in rows}, key=str)
    for effect, seed, season in keys:
        mine = [r for r in rows if (r["effect"], r["seed"], r["season"]) == (effect, seed, season)]
        base = sorted((r for r in mine if r["model"] == ref), key=lambda r: r["weight"])
        ext = sorted((r for r in mine if r["model"] == model), key=lambda r: r["weight"])
        b0 = next((r for r in base if r["weight"] == DEFAULT_WEIGHT), None)
        if b0 is None or not ext:
            continue
        e0 = next((r for r in ext if r["weight"] == DEFAULT_WEIGHT), None)
        gain = frontier_gain(b0, ext)
        dominated = sum(1 for b in base if (g := frontier_gain(b, ext)) is not None and g["saved_Kh"] > 0)
        out.append(
            {
                "effect": effect,
                "seed": seed,
                "season": season,
                "week": b0["week"],
                "found": b0["found"],
                "base": base,
                "extended": ext,
                "default_pair": (b0, e0),
                "gain": gain,
                "dominated": dominated,
                "holds": gain is not None and gain["saved_Kh"] > 0,
            }
        )
    return out


def _point(r) -> str:
    return f"{r['comfort_violation_Kh']:.2f} K·h @ {r['energy_proxy']:.0f} / {r['heating_kWh']:.0f} kWh"


def print_tables(rows) -> None:
    """The frontier table (every weight, both models) and the verdict per case and week.

    When ``without:<cause>`` runs are present, a second verdict compares the extended model
    with each of them (what the cause's terms add at no more energy).
    """
    print("\nfrontiers: K·h outside [20, 22] °C @ Σu² [(kg/s)²] / reheat [kWh], per comfort weight")
    for v in verdicts(rows):
        print(f"{v['effect']} (seed {v['seed']}), {v['season']} week {v['week']}, injected effect: {v['found']}")
        for name in ("base", "extended"):
            pts = "; ".join(f"w={r['weight']:g}: {_point(r)} ({r['viol_at_max']:.2f} at max)" for r in v[name])
            print(f"  {name:<8} {pts}")
        for ref in sorted({r["model"] for r in rows if r["model"].startswith(("without:", "kept:"))}):
            for w in verdicts(rows, ref=ref):
                if (w["effect"], w["seed"], w["season"]) == (v["effect"], v["seed"], v["season"]):
                    pts = "; ".join(
                        f"w={r['weight']:g}: {_point(r)} ({r['viol_at_max']:.2f} at max)" for r in w["base"]
                    )
                    print(f"  {ref} {pts}")
    _print_verdicts(rows, "base")
    for ref in sorted({r["model"] for r in rows if r["model"].startswith("without:")}):
        _print_verdicts(rows, ref)
        kept = "kept:" + ref.partition(":")[2]
        if any(r["model"] == kept for r in rows):
            _print_verdicts(rows, ref, kept)


def _print_verdicts(rows, ref: str, model: str = "extended") -> None:
    from harness.energy import EnergyUse

    print(
        f"\neffect | seed | found | week | default weight: {ref} -> {model} | {model} at no more energy than the "
        f"{ref} default run | saved K·h | {ref} runs beaten | holds"
    )
    for v in verdicts(rows, model=model, ref=ref):
        b0, e0 = v["default_pair"]
        pair = f"{_point(b0)} -> {_point(e0)}" if e0 else _point(b0)
        g = v["gain"]
        best = (
            f"w={g['run']['weight']:g}: {_point(g['run'])} ({EnergyUse.of(g['run']).change(EnergyUse.of(b0))})"
            if g
            else "none"
        )
        saved = f"{g['saved_Kh']:+.2f}" if g else "-"
        print(
            f"{v['effect']} | {v['seed']} | {v['found']} | {v['season']} {v['week']} | {pair} | {best} | {saved} | "
            f"{v['dominated']}/{len(v['base'])} | {'yes' if v['holds'] else 'no'}"
        )


def plot_frontiers(rows, path) -> None:
    """One panel per case and week: K·h against Σu² for both models (and ``without:<cause>`` ablations, grey)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    vs = verdicts(rows)
    ncol = 4
    nrow = -(-len(vs) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.0 * ncol, 3.2 * nrow), squeeze=False)
    for ax, v in zip(axes.ravel(), vs):
        for name, color in (("base", "tab:blue"), ("extended", "tab:orange")):
            pts = sorted(v[name], key=lambda r: r["energy_proxy"])
            x = [r["energy_proxy"] for r in pts]
            y = [r["comfort_violation_Kh"] for r in pts]
            ax.plot(x, y, "o-", color=color, label=name, ms=4)
            for r in pts:
                ax.annotate(f"{r['weight']:g}", (r["energy_proxy"], r["comfort_violation_Kh"]), fontsize=6, color=color)
        same = [r for r in rows if (r["effect"], r["seed"], r["season"]) == (v["effect"], v["seed"], v["season"])]
        for name in sorted({r["model"] for r in same if r["model"].startswith("without:")}):
            pts = sorted((r for r in same if r["model"] == name), key=lambda r: r["energy_proxy"])
            ax.plot([r["energy_proxy"] for r in pts], [r["comfort_violation_Kh"] for r in pts], "s--", color="grey",
                    label=name, ms=3)  # fmt: skip
        b0 = v["default_pair"][0]
        ax.axvline(b0["energy_proxy"], color="tab:blue", lw=0.6, ls=":")
        case = v["effect"].replace("solar_gain:", "solar ").replace("zone_coupling:", "coupling ")
        ax.set_title(f"{case} s{v['seed']} {v['season']}: {'yes' if v['holds'] else 'no'}", fontsize=7)
        ax.set_xlabel("Σu² [(kg/s)²]", fontsize=7)
        ax.set_ylabel("K·h", fontsize=7)
        ax.tick_params(labelsize=6)
    for ax in axes.ravel()[len(vs) :]:
        ax.axis("off")
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    print(f"frontier figure: {path}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--cases",
        nargs="+",
        default=list(DEFAULT_CASES),
        help="[layout/]seed:effect, e.g. 0:solar_gain:zone=W or core9/3:zone_coupling:zones=N+SE,ua=1051",
    )
    ap.add_argument("--seasons", nargs="+", default=["summer", "winter"])
    ap.add_argument("--horizon", type=int, default=12)
    ap.add_argument("--days", type=float, default=7.0, help="days of each week to run (7: the whole week)")
    ap.add_argument(
        "--weights",
        nargs="+",
        type=float,
        default=list(DEFAULT_WEIGHTS),
        help=f"comfort penalties [1/K per step] to sweep ({DEFAULT_WEIGHT:g}: the MPC default)",
    )
    ap.add_argument("--joint", action="store_true", help="also control with the diagnosis's own extended model")
    ap.add_argument(
        "--models",
        nargs="+",
        default=["base", "extended"],
        help="models to control with: base, extended, 'joint refit', without:<cause> (the extended model "
        "without that cause's terms, e.g. without:zone_coupling), kept:<cause> (at the diagnosis's coefficients), "
        "refit:<cause> (refitted even where the refit zeroes them)",
    )
    ap.add_argument("--json", help="write every run's figures here (rewritten after each run)")
    ap.add_argument("--from-json", nargs="+", help="print the tables of --json files (joined) without running")
    ap.add_argument("--plot", help="also draw the frontiers (K·h against Σu², labelled by weight) into this PNG")
    ap.add_argument(
        "--explain",
        action="store_true",
        help="for coupling cases: open-loop prediction of the pair with base / without / extended on the weeks "
        "the extended model controls, the heat the coupling carries, and the applied moves with and without it",
    )
    ap.add_argument(
        "--diagnose-option",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="an option of diagnose (true/false, a number or a word), e.g. coupling_alone_unshared=false",
    )
    args = ap.parse_args(argv)
    for kv in args.diagnose_option:
        key, _, value = kv.partition("=")
        DIAGNOSE_OPTIONS[key] = _option_value(value)
    if args.explain:
        for case in args.cases:
            explain_coupling(case, args.seasons, args.horizon, args.days)
        return 0
    if args.from_json:
        rows = [r for f in args.from_json for r in json.loads(Path(f).read_text(encoding="utf-8"))]
        print_tables(rows)
        if args.plot:
            plot_frontiers(rows, args.plot)
        return 0
    print(
        f"plant FMU per dataset, MPC N={args.horizon}; machine load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"
    )
    names = list(args.models) + (["joint refit"] if args.joint and "joint refit" not in args.models else [])
    rows = []
    for case in args.cases:
        rows += run_case(case, args.seasons, args.horizon, args.days, names, args.weights, args.json)
    print_tables(rows)
    if args.plot:
        plot_frontiers(rows, args.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
