"""The demo's report: tables and figures from the stage results, with the paper's numbers beside ours."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from .demo_results import stage_models
from .report import Report


def write_report(out, r, paper_table, paper_zones, paper_figures) -> dict:
    """Build ``report.html``/``report.md`` in ``out`` from the demo's stage results ``r``."""
    out = Path(out)
    figs = out / "figures"
    figs.mkdir(parents=True, exist_ok=True)
    rep = Report("hvacfmu demo: data-driven vs physics-based models of an SDH-like office floor")
    rep.paragraph(
        "Reproduction of Zhou, Hu & Tomlin, 'Model Comparison of a Data-Driven and a Physical Model for "
        "Simulating HVAC Systems', on the emulated building shipped with hvacfmu (the paper's Sutardja Dai Hall "
        "data are not available). Every number below is computed by this run; the paper's published numbers "
        "are shown beside ours where they exist."
    )
    _section_data(rep, r)
    _section_table1(rep, r, paper_table, paper_zones, paper_figures)
    _section_gains(rep, r, figs)
    _section_trajectories(rep, r, figs)
    _section_mpc(rep, r, figs, paper_figures)
    _section_diagnosis(rep, r)
    _section_control_gain(rep, r, figs)
    _section_fmus(rep, r)
    _section_comparison(rep, r)
    _section_times(rep, r)
    return rep.write(out)


# =============================================================================
def _section_data(rep, r):
    rep.heading("Data")
    d = r.get("data")
    if not d:
        rep.paragraph("The dataset stage failed; nothing else could run.")
        return
    ds = d["dataset"]
    b = ds.building
    rows = {}
    for s in b.season_names:
        n_train = len(ds.train_weeks(s))
        n_test = len(ds.test_weeks(s))
        if n_train + n_test:
            rows[s] = {"weeks": n_train + n_test, "training": n_train, "test": n_test}
    df = pd.DataFrame.from_dict(rows, orient="index")
    df.index.name = "season"
    rep.paragraph(
        f"Building '{b.name}': {len(b.zones)} zones ({', '.join(b.zone_names)}), {len(b.vavs)} VAV boxes. "
        f"{len(ds.weeks)} weeks from {ds.frame.index[0]:%Y-%m-%d} at a {ds.step / 60:g}-minute model step "
        f"(emulated 1-minute data, seed {r['seed']}); measurements: {d['paths'].measurements}."
    )
    rep.table("data.weeks", df, "Weeks per season and the seeded 90/10 train/test split", digits=0)


def _section_table1(rep, r, paper_table, paper_zones, paper_figures):
    rep.heading("Prediction accuracy (the paper's Table I)")
    ev = r.get("evaluation")
    if not ev:
        rep.paragraph("The evaluation stage failed.")
        return
    rep.paragraph(
        f"RMS [K] of 24-hour open-loop predictions (N = {ev['zones'].horizon if 'zones' in ev else 96} steps) "
        "started at every midnight of the held-out test weeks from the measured temperature, driven by measured "
        "inputs and disturbances and the season's internal-gain profile; averaged by zone and season. "
        "Baselines: persistence (temperature held for 24 h) and the seasonal time-of-week mean of the training weeks."
    )
    _verdict(rep, ev)
    if "zones" in ev:
        res = ev["zones"]
        for sc in res.scores:
            rep.table(
                f"table1.{sc.name}", sc.table("model", res.season_order), f"{sc.name}: RMS [K] by zone and season"
            )
        sc0 = res.scores[0]
        for bname in sc0.baselines:
            rep.table(
                f"table1.baseline.{bname}",
                sc0.table(bname, res.season_order),
                f"Baseline '{bname}': RMS [K] on the same windows",
            )
    for key, label in (("model A", "Model A"), ("model B", "Model B")):
        df = pd.DataFrame(paper_table[key], index=list(paper_zones) + ["mean"]).T
        df.index.name = "season"
        rep.table(f"paper.{key}", df, f"Published (paper, SDH): {label} RMS [°C]", digits=2)
    if "lumped" in ev:
        sc = ev["lumped"].scores[0]
        t = sc.table("model", ev["lumped"].season_order)
        paper = pd.Series(paper_figures["lumped_rms"])
        df = pd.DataFrame({"ours": t["mean"], "paper": paper.reindex(t.index)})
        df.index.name = "season"
        rep.table("table1.lumped", df, "Lumped Model A: mean RMS [K], ours vs the paper's")


def _verdict(rep, ev):
    """The verdict first: per zone against persistence and the time-of-week mean, ASHRAE Guideline 14."""
    for key in ("zones", "lumped"):
        verdict = ev[key].verdict if key in ev else None
        if verdict is None:
            continue
        models = list(dict.fromkeys(z.model for z in verdict.zones))
        rep.bullets(
            [verdict.summary(m) for m in models]
            + [
                f"{z.model}: worse than persistence in {z.output} ({z.rms:.3f} K against {z.persistence:.3f} K)"
                for z in verdict.losing()
            ]
            + [f"likely cause for {m}: {c}" for m, cs in verdict.causes.items() for c in cs]
        )
        df = pd.DataFrame(
            [
                {
                    "model / zone": f"{z.model} / {z.output}",
                    "RMS [K]": z.rms,
                    "persistence [K]": z.persistence,
                    "time-of-week [K]": z.time_of_week,
                    "NMBE [%]": z.nmbe,
                    "CV(RMSE) [%]": z.cvrmse,
                }
                for z in verdict.zones
            ]
        )
        rep.table(
            f"verdict.{key}",
            df.set_index("model / zone"),
            "Verdict per zone: 24-h open-loop RMS against the baselines; ASHRAE Guideline 14 hourly NMBE "
            "and CV(RMSE) (calibrated: |NMBE| <= 10 %, CV(RMSE) <= 30 %)",
        )


def _section_gains(rep, r, figs):
    from .demo_plots import plot_gains

    rep.heading("Estimated internal gains (the paper's Figures 2, 3 and 5)")
    models = {kind: d["model"] for kind, d in stage_models(r).items()}
    spec = {
        "lumped": ("Model A, lumped: q_IG by season (Fig. 2)", "K per step"),
        "zones": ("Model A, six zones: q_IG by zone and season (Fig. 3)", "K per step"),
        "physics": ("Model B: internal gains f_IG = f_c + f_v by zone and season (Fig. 5)", "W"),
    }
    for kind, (title, unit) in spec.items():
        if kind not in models:
            rep.paragraph(f"{title}: not available (the fit failed).")
            continue
        m = models[kind]
        path = plot_gains(_gains_view(m), figs / f"gains_{kind}.png", title, unit)
        rep.figure(path, title)
        view = _gains_view(m)
        means = pd.DataFrame({s: g.mean(axis=0) for s, g in view.gains.items()}, index=list(m.outputs)).T
        means.index.name = "season"
        rep.table(f"gains.{kind}", means, f"{title}: weekly mean [{unit}]")


class _GainsView:
    """The internal-gain columns of a model's profiles (Model B's q may carry a ground temperature too)."""

    def __init__(self, model):
        self.outputs = model.outputs
        self.step = model.step
        n = len(model.outputs)
        self.gains = {s: np.asarray(g)[:, :n] for s, g in model.gains.items()}


def _gains_view(model):
    return _GainsView(model)


def _section_trajectories(rep, r, figs):
    from ..evaluation.plots import plot_week_trajectories

    rep.heading("Seven-day open-loop predictions (the paper's Figure 4)")
    ev = r.get("evaluation")
    if not ev or not ev.get("trajectories"):
        rep.paragraph("Not available.")
        return
    wk = ev["week"]
    path = plot_week_trajectories(ev["trajectories"], figs / f"open_loop_week_{wk.number}.png")
    rep.paragraph(
        f"Held-out {wk.season} week {wk.number} starting {wk.start:%Y-%m-%d}, one 7-day simulation per model "
        "from the measured temperatures at its start."
    )
    rep.figure(path, "7-day open-loop predictions vs measured")
    df = pd.DataFrame({tr.name: tr.rms() for tr in ev["trajectories"]}, index=list(ev["trajectories"][0].outputs)).T
    df.index.name = "model"
    rep.table("open_loop_week.rms", df, "RMS [K] over the 7-day open-loop trajectory")


def _section_mpc(rep, r, figs, paper_figures):
    from .demo_plots import plot_mpc

    rep.heading("Energy-efficient MPC (the paper's Figures 6 and 7)")
    mpc = r.get("mpc")
    if not mpc or not mpc.get("runs"):
        rep.paragraph("The MPC stage failed or produced no run (see the stage table).")
        return
    wk = mpc["week"]
    rep.paragraph(
        f"Receding-horizon MPC, horizon N = {r['mpc_horizon']} steps of 15 minutes, comfort band [20, 22] °C, "
        f"soft input limits with penalty ρ = 100, over held-out {wk.season} week {wk.number}, with the harness's "
        "'plant' preset (offset-free disturbance estimate, move suppression, 0.4 K back-off from the band edges, "
        "move blocking and per-step slack beyond 3 steps). As in the paper, each "
        "model's MPC runs against that model's own FMU; beyond the paper, each MPC also controls the emulator's plant "
        "FMU (a building that is neither model) with state feedback every step, next to the replay of measured "
        "airflows and a rule-based PI controller; there the rule (a VAV reheat sequence) and the MPCs also "
        "command each box's discharge air (reheat), the replay keeps the boxes' own reheat loops, and each run starts after a week of warm-up on measured data. All runs go through the FMPy "
        "co-simulation harness."
    )
    rows = {}
    for label, d in mpc["runs"].items():
        s = d["result"].summary
        rows[label] = {
            "steps": f"{s['steps_completed']}/{s['steps_requested']}",
            "energy proxy Σu² [(kg/s)²]": s["energy_proxy"],
            "total airflow [kg]": s["total_airflow_kg"],
            "comfort violation [K·h]": s["comfort_violation_Kh"],
            "median step [ms]": 1e3 * s["controller_time_median"],
            "max step [ms]": 1e3 * s["step_time_max"],
            "week [s]": float(np.nansum(d["result"].table.get("controller_time", pd.Series(dtype=float)))),
        }
    df = pd.DataFrame.from_dict(rows, orient="index")
    df.index.name = "run"
    rep.table("mpc.runs", df, "Closed-loop weeks: energy proxy, comfort and compute time")
    ours = {label: v["week [s]"] for label, v in rows.items() if "own FMU" in label}
    if ours:
        rep.paragraph(
            "The paper needed under 5 minutes (Model A) and about 20 hours (Model B) for the week; here: "
            + "; ".join(f"{k}: {rep.value('mpc.week_seconds.' + k, v, 1)} s" for k, v in ours.items())
            + "."
        )
    b = r["data"]["dataset"].building
    zones = list(b.zone_names)
    vavs = {z: [v.name for v in b.vavs_of(z)] for z in zones}
    own = {k: d["result"].table for k, d in mpc["runs"].items() if "own FMU" in k}
    plant = {k: d["result"].table for k, d in mpc["runs"].items() if "plant" in k}
    for name, runs in (("own", own), ("plant", plant)):
        if not runs:
            continue
        first = next(iter(runs.values()))
        measured = r["data"]["dataset"].frame.reindex(first.index)
        pt, pf = plot_mpc(
            runs, measured, zones, vavs, figs / f"mpc_{name}_temperature.png", figs / f"mpc_{name}_airflow.png"
        )
        where = "each model's own FMU" if name == "own" else "the emulator plant FMU"
        rep.figure(pt, f"MPC zone temperatures on {where} (Fig. 6)")
        rep.figure(pf, f"MPC airflows on {where} (Fig. 7)")


def _section_diagnosis(rep, r):
    rep.heading("Diagnosis: what the six-zone model gets wrong")
    d = r.get("diagnosis")
    if not d:
        rep.paragraph("The diagnosis stage failed.")
        return
    dr = d["report"]
    rep.paragraph(f"Verdict: {dr.verdict}. {dr.summary()}")
    rows = {}
    for i, f in enumerate(dr.findings):
        loc = ", ".join(f"{k}={v}" for k, v in (f.get("location") or {}).items())
        gain = f.get("gain_percent")
        if gain is None:
            gain = (f.get("heldout") or {}).get("gain_percent")
        rows[f"{i + 1}. {f['cause']}"] = {"location": loc, "held-out gain [%]": _as_float(gain)}
    if rows:
        df = pd.DataFrame.from_dict(rows, orient="index")
        df.index.name = "finding"
        rep.table("diagnosis.findings", df, "Causes found (forward selection), with the held-out RMS gain")
    ho = dr.heldout or {}
    overall = ho.get("overall") or ho.get("all")
    if isinstance(overall, dict) and overall:
        try:
            df = pd.DataFrame(overall).T if isinstance(next(iter(overall.values())), dict) else pd.DataFrame([overall])
            df.index.name = "zone"
            rep.table("diagnosis.heldout", df, "Held-out 24-h RMS [K] before and after the extension")
        except (ValueError, TypeError):
            pass
    rep.code(dr.format())
    rep.paragraph(f"Extended model saved as {d['path']}; it evaluates with `hvacfmu evaluate` and exports as an FMU.")


def _control_runs(r) -> dict:
    """Label -> summary of the plant runs of Model A and of Model A + the diagnosed terms."""
    runs = (r.get("mpc") or {}).get("runs") or {}
    out = {}
    for lab, d in runs.items():
        if d.get("controller") == "mpc" and d.get("kind") in ("zones", "control") and "plant" in lab:
            out[lab] = d["result"].summary
    return out


def _section_control_gain(rep, r, figs):
    """The control gain of the diagnosis: MPC with Model A against MPC with Model A + the found terms.

    The claim is made at equal or lower energy (:mod:`harness.energy`: neither more Σu² nor more
    reheat than Model A's run at the default comfort weight), over the real runs of the diagnosed
    model (the default weight, and the lower weights the MPC stage ran when that one spent more).
    """
    from harness.energy import EnergyUse, frontier_gain

    from .demo_plots import plot_control_gain

    d = r.get("diagnosis") or {}
    runs = _control_runs(r)
    if not d or not r.get("mpc"):
        return
    rep.heading("Control gain of the diagnosis")
    if "control_model" not in d:
        rep.paragraph("The diagnosis found no term to add, so there is no extended model to control with.")
        return
    if len(runs) < 2:
        rep.paragraph("The MPC run with the diagnosed terms on the plant failed (see the MPC section).")
        return
    causes = [
        f"{f['cause']} ({', '.join(str(v) for v in (f.get('location') or {}).values())})" for f in d["report"].findings
    ]
    (base_lab, b), *ext = list(runs.items())
    e0 = EnergyUse.of(b)
    rows = {
        lab: {
            "comfort violation [K·h]": s["comfort_violation_Kh"],
            "energy proxy Σu² [(kg/s)²]": s["energy_proxy"],
            "reheat [kWh]": s.get("heating_kWh", 0.0),
            "no more energy than Model A": "-" if lab == base_lab else ("yes" if EnergyUse.of(s).at_most(e0) else "no"),
        }
        for lab, s in runs.items()
    }
    e = ext[0][1]
    saved = rep.value("control_gain.saved_Kh", b["comfort_violation_Kh"] - e["comfort_violation_Kh"], 2)
    de = EnergyUse.of(e).change(e0)
    rep.value("control_gain.energy_change_percent", EnergyUse.of(e).airflow_change_percent(e0))
    rep.value("control_gain.reheat_change_kWh", e.get("heating_kWh", 0.0) - b.get("heating_kWh", 0.0))
    g = frontier_gain(b, [s for _, s in ext])
    rep.value("control_gain.saved_Kh_equal_energy", None if g is None else g["saved_Kh"])
    if g is None:
        claim = "no run of the diagnosed model used no more energy than Model A's, so there is no equal-energy claim"
    else:
        lab = next(k for k, s in ext if s is g["run"])
        verb = (
            f"saves {g['saved_Kh']:.2f}" if g["saved_Kh"] > 0 else f"does NOT save comfort: {-g['saved_Kh']:.2f} more"
        )
        claim = (
            f"at no more energy (neither more Σu² nor more reheat than Model A's run) the best run of the diagnosed "
            f"model ('{lab}') {verb} K·h ({EnergyUse.of(g['run']).change(e0)})"
        )
    rep.paragraph(
        f"The diagnosis found {len(causes)} term(s): {'; '.join(causes)}. Controlling the plant with them "
        f"(the same MPC, the found terms refitted on Model A's own dynamics, its gain profiles re-estimated) "
        f"saves {saved} K·h of comfort violation in the MPC week at the default comfort weight, at {de} "
        f"(negative saved = worse); {claim}. The diagnosis's own extended model is not controlled: its one-step "
        "refit has about a tenth of the building's first-step airflow response (README 'Control gain of the "
        "diagnosis')."
    )
    df = pd.DataFrame.from_dict(rows, orient="index")
    df.index.name = "run"
    rep.table("control_gain.runs", df, "MPC on the plant: Model A against Model A + the diagnosed terms")
    path = plot_control_gain(rows, figs / "control_gain.png", "MPC on the plant: base model against diagnosed")
    rep.figure(path, "Control gain of the diagnosis on the plant (same week, same MPC)")


def _as_float(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def _section_fmus(rep, r):
    rep.heading("FMUs")
    fm = r.get("fmus")
    if not fm:
        rep.paragraph("The export stage failed.")
        return
    rows = {
        k: {"file": str(v["path"]), "fmpy validate": "no problems" if not v["problems"] else "; ".join(v["problems"])}
        for k, v in fm.items()
    }
    df = pd.DataFrame.from_dict(rows, orient="index")
    df.index.name = "model"
    rep.table("fmus", df, "FMI 2.0 co-simulation FMUs and their validation")
    z = fm.get("zones", next(iter(fm.values())))["path"]
    rep.paragraph("Run them with the FMPy command line (inputs from a CSV with a `time` column in seconds):")
    rep.code(f"fmpy info {z}\nfmpy simulate {z} --input-file inputs.csv --output-interval 900 --output-file out.csv")


def _section_comparison(rep, r):
    rep.heading("Qualitative comparison (from the numbers above)")
    items = []
    ev = r.get("evaluation") or {}
    if "zones" in ev and len(ev["zones"].scores) >= 2:
        a, b = ev["zones"].scores[0], ev["zones"].scores[1]
        ma = float(a.table("model").loc["all", "mean"])
        mb = float(b.table("model").loc["all", "mean"])
        diff = rep.value("comparison.rms_difference", ma - mb)
        better = b.name if mb < ma else a.name
        items.append(
            f"Accuracy: mean RMS {a.name} {rep.value('comparison.rms_a', ma)} K vs {b.name} "
            f"{rep.value('comparison.rms_b', mb)} K (difference {diff} K); {better} predicts better on "
            "this building. The paper found Model B better by about 0.1 K."
        )
        per_zone = (a.table("model").loc["all"] - b.table("model").loc["all"]).drop("mean")
        items.append(
            "Largest per-zone differences (A − B): "
            + ", ".join(f"{z} {v:+.3f} K" for z, v in per_zone.sort_values(key=abs, ascending=False).items())
        )
    models = stage_models(r)
    if "zones" in models and "physics" in models:
        na, nb = models["zones"]["model"].n_states, models["physics"]["model"].n_states
        items.append(
            f"Complexity: Model A has {rep.value('comparison.states_a', na)} states, Model B "
            f"{rep.value('comparison.states_b', nb)}; identification took "
            f"{rep.value('comparison.fit_seconds_a', models['zones']['seconds'], 1)} s vs "
            f"{rep.value('comparison.fit_seconds_b', models['physics']['seconds'], 1)} s. Model B needs "
            "geometry and construction data; Model A only temperatures, airflows and zone adjacency."
        )
    mpc = r.get("mpc") or {}
    runs = mpc.get("runs") or {}
    plant_runs = {k: v["result"].summary for k, v in runs.items() if "plant" in k}
    if plant_runs:
        items.append(
            "On the emulator plant: "
            + "; ".join(
                f"{k}: Σu² {s['energy_proxy']:.1f}, comfort violation {s['comfort_violation_Kh']:.1f} K·h"
                for k, s in plant_runs.items()
            )
            + "."
        )
    if not items:
        items.append("Not enough stages succeeded to compare the models.")
    rep.bullets(items)


def _section_times(rep, r):
    rep.heading("Run time by stage")
    times = r.get("stage_times") or []
    df = pd.DataFrame(
        {"seconds": [s.seconds for s in times], "ok": ["yes" if s.ok else "FAILED: " + (s.error or "") for s in times]},
        index=[s.name for s in times],
    )
    df.index.name = "stage"
    rep.table("stage_times", df, "Stage times of this run (the report stage itself is not included)", digits=1)
