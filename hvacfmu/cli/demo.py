"""``hvacfmu demo``: the paper end to end on the built-in emulated building, with a report.

Stages (each timed and shown as it runs):

1. dataset   generate the emulated SDH-like floor (cached) and prepare it;
2. model A   fit the lumped and the six-zone data-driven model;
3. model B   fit the physics-based RC model;
4. evaluate  24-hour open-loop RMS on held-out weeks (Table I), 7-day trajectories;
5. diagnose  what the six-zone model gets wrong, the cause, the extension and its gain;
6. export    one FMU per model (and the emulator plant), validated with FMPy;
7. mpc       a closed-loop MPC week for both models through the FMPy harness,
             against each model's own FMU and against the emulator plant, and on the
             plant with the diagnosed terms on Model A (the control gain of the diagnosis;
             at lower comfort weights too when that run spends more energy than Model A's);
8. report    ``report.html`` / ``report.md`` with PNG figures.

Every number in the report comes from the objects these stages return; the
same numbers are written to ``report_numbers.json`` so tests can compare them.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
import traceback
from pathlib import Path

from .demo_results import label, stage_models

#: comfort weights [1/K per zone and step] of the extra MPC runs with the diagnosed model when its run at
#: the default weight (1e4) spends more energy than Model A's (README "Control gain of the diagnosis")
EQUAL_ENERGY_WEIGHTS = (50.0, 30.0)

#: The paper's Table I (Zhou, Hu, Tomlin), for side-by-side comparison [°C].
PAPER_TABLE = {
    "model A": {
        "fall": [0.98, 0.61, 0.28, 0.42, 0.28, 0.36, 0.488],
        "winter": [1.41, 0.34, 0.29, 0.26, 0.25, 0.21, 0.460],
        "spring": [0.56, 0.25, 0.31, 0.71, 0.17, 0.34, 0.390],
    },
    "model B": {
        "fall": [0.61, 0.46, 0.39, 0.39, 0.20, 0.32, 0.396],
        "winter": [0.55, 0.39, 0.34, 0.32, 0.18, 0.24, 0.338],
        "spring": [0.45, 0.28, 0.24, 0.33, 0.09, 0.19, 0.263],
    },
}
PAPER_ZONES = ("NW", "W", "S", "E", "NE", "C")
#: Published figures of the paper quoted beside ours.
PAPER_FIGURES = {
    "lumped_rms": {"fall": 0.22, "winter": 0.17, "spring": 0.23},
    "mpc_cost": {"model A": 1006.0, "model B": 1731.0},
    "mpc_week_seconds": {"model A": 5 * 60.0, "model B": 20 * 3600.0},
}


@dataclasses.dataclass
class StageTime:
    name: str
    seconds: float
    ok: bool
    error: str | None = None


@dataclasses.dataclass
class DemoResult:
    """What :func:`run_demo` produced: folders, stage times, and the report files."""

    out: Path
    stages: list
    report: dict
    failed: list

    @property
    def total_seconds(self) -> float:
        return sum(s.seconds for s in self.stages)

    def __str__(self):
        lines = ["", "hvacfmu demo: stage times"]
        for s in self.stages:
            lines.append(f"  {s.name:<10} {s.seconds:7.1f} s  {'ok' if s.ok else 'FAILED: ' + (s.error or '')}")
        lines.append(f"  {'total':<10} {self.total_seconds:7.1f} s")
        lines.append(f"report: {self.report.get('html')}")
        if self.failed:
            lines.append(f"FAILED stages: {', '.join(self.failed)} (see the report and the messages above)")
        return "\n".join(lines)


class _PartialFailure(Exception):
    """A stage that failed in part; ``result`` holds what it did produce."""

    def __init__(self, message, result):
        super().__init__(message)
        self.result = result


class _Stages:
    """Runs named stages, printing progress with elapsed times; a failure is recorded, not fatal."""

    def __init__(self, n, stream=None):
        self.n = n
        self.i = 0
        self.t0 = time.perf_counter()
        self.times: list[StageTime] = []
        self._stream = stream

    @property
    def stream(self):
        return self._stream or sys.stderr

    def run(self, name, what, func, *args, **kwargs):
        self.i += 1
        print(f"[{self.i}/{self.n}] {name}: {what} ...", file=self.stream, flush=True)
        t = time.perf_counter()
        try:
            out = func(*args, **kwargs)
            ok, err = True, None
        except _PartialFailure as exc:
            out, ok, err = exc.result, False, str(exc)
        except Exception as exc:  # noqa: BLE001 - a demo stage failure is reported, the rest goes on
            out, ok, err = None, False, f"{type(exc).__name__}: {exc}"
            traceback.print_exc(file=self.stream)
        dt = time.perf_counter() - t
        self.times.append(StageTime(name, dt, ok, err))
        status = "done" if ok else "FAILED"
        print(
            f"[{self.i}/{self.n}] {name}: {status} in {dt:.1f} s (elapsed {time.perf_counter() - self.t0:.1f} s)",
            file=self.stream,
            flush=True,
        )
        return out


def run_demo(
    out="hvacfmu-demo", weeks: int = 51, seed: int = 0, mpc_horizon: int | None = None, progress: bool = True
) -> DemoResult:
    """Run the whole paper on the emulated building and write a report.

    Parameters
    ----------
    out : path
        Output folder: ``models/``, ``fmus/``, ``figures/``, ``results/``, ``report.html``.
    weeks : int
        Length of the emulated dataset [weeks] (51 as in the paper).
    seed : int
        Seed of the emulator and of the train/test split.
    mpc_horizon : int, optional
        MPC horizon [steps of 15 min]; default the harness's (``harness.controllers.default_horizon``:
        3 h, 12 steps), what a controls engineer would use for a building's slow response; the paper used 3. The MPC runs with the harness's ``"plant"``
        preset (:func:`harness.mpc.adapter.preset_options`: offset-free estimation, move suppression,
        back-off, move blocking and per-step slack beyond 3 steps).
    progress : bool
        Passed to the stages that show their own progress.

    Returns
    -------
    DemoResult
    """
    out = Path(out)
    for sub in ("models", "fmus", "figures", "results"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    st = _Stages(8)
    r: dict = {"weeks": weeks, "seed": seed}

    r["data"] = st.run(
        "dataset", f"emulated SDH-like floor, {weeks} weeks of 1-minute data (cached)", _stage_dataset, out, weeks, seed
    )
    ds = r["data"]["dataset"] if r["data"] else None
    if mpc_horizon is None and ds is not None:
        from harness.controllers import default_horizon  # cosim's default: 3 h at the data's step

        mpc_horizon = default_horizon(ds.step)
    r["mpc_horizon"] = mpc_horizon
    r["model_a"] = (
        st.run("model A", "fit the lumped and six-zone data-driven models", _stage_model_a, out, ds) if ds else None
    )
    r["model_b"] = (
        st.run("model B", "fit the physics-based RC model", _stage_model_b, out, ds, progress) if ds else None
    )
    r["evaluation"] = (
        st.run("evaluate", "24-h open-loop RMS on held-out weeks", _stage_evaluate, out, ds, r) if ds else None
    )
    r["diagnosis"] = (
        st.run("diagnose", "what the six-zone model gets wrong", _stage_diagnose, out, ds, r)
        if ds and r["model_a"]
        else None
    )
    r["fmus"] = st.run("export", "FMI 2.0 co-simulation FMUs, validated with FMPy", _stage_export, out, r)
    r["mpc"] = (
        st.run(
            "mpc",
            f"closed-loop MPC weeks (N = {mpc_horizon}) through the FMPy harness",
            _stage_mpc,
            out,
            ds,
            r,
            mpc_horizon,
        )
        if ds and r["fmus"]
        else None
    )
    r["stage_times"] = st.times
    files = st.run("report", "write report.html and figures", _stage_report, out, r)
    failed = [s.name for s in st.times if not s.ok]
    result = DemoResult(out=out, stages=st.times, report=files or {}, failed=failed)
    if files:
        # the stage table in the report includes the report stage itself only in the printout
        (out / "stage_times.json").write_text(
            json.dumps([dataclasses.asdict(s) for s in st.times], indent=1), encoding="utf-8"
        )
    return result


# =============================================================================
# stages
# =============================================================================
def _stage_dataset(out, weeks, seed):
    from ..data import prepare
    from ..emulator import cached_dataset

    paths = cached_dataset(weeks=weeks, seed=seed)
    dataset = prepare(paths.measurements, paths.building, seed=seed)
    truth = json.loads(Path(paths.truth).read_text(encoding="utf-8"))
    return {"paths": paths, "dataset": dataset, "truth": truth}


def _stage_model_a(out, ds):
    from ..fitting import fit

    res = {}
    for kind in ("lumped", "zones"):
        t = time.perf_counter()
        model = fit(ds, kind, progress=False)
        res[kind] = {
            "model": model,
            "path": model.save(out / "models" / f"{kind}.json"),
            "seconds": time.perf_counter() - t,
        }
    return res


def _stage_model_b(out, ds, progress):
    from ..fitting import fit

    t = time.perf_counter()
    model = fit(ds, "physics", progress=progress)
    return {
        "physics": {
            "model": model,
            "path": model.save(out / "models" / "physics.json"),
            "seconds": time.perf_counter() - t,
        }
    }


def _stage_evaluate(out, ds, r):
    from ..evaluation import choose_week, evaluate, week_trajectory

    models = stage_models(r)
    res = {}
    zone_models = [(k, models[k]["model"]) for k in ("zones", "physics") if k in models]
    if zone_models:
        ev = evaluate([m for _, m in zone_models], ds, names=[label(k) for k, _ in zone_models])
        ev.save_json(out / "results" / "evaluation_zones.json")
        res["zones"] = ev
    if "lumped" in models:
        ev = evaluate(models["lumped"]["model"], ds, names=[label("lumped")])
        ev.save_json(out / "results" / "evaluation_lumped.json")
        res["lumped"] = ev
    week = choose_week(ds, None)
    res["week"] = week
    res["trajectories"] = [week_trajectory(m, ds, week, name=label(k)) for k, m in zone_models] if week else []
    return res


def _stage_diagnose(out, ds, r):
    from ..diagnosis import diagnose
    from ..diagnosis.control import terms_on_base

    base = r["model_a"]["zones"]["model"]
    rep = diagnose(ds, model=base, plots=None, progress=False)
    rep.save_json(out / "results" / "diagnosis.json")
    path = rep.model.save(out / "models" / "extended.json")
    res = {"report": rep, "path": path}
    if rep.findings:  # the found terms on Model A's own dynamics: the model the MPC stage controls with
        res["control_model"] = terms_on_base(ds, base, rep.model.terms, meta={"name": "extended (control)"})
        res["control_path"] = res["control_model"].save(out / "models" / "extended_control.json")
    return res


def _stage_export(out, r):
    from ..fmu import export_fmu, export_plant_fmu, validate

    res = {}
    models = stage_models(r)
    for kind in ("lumped", "zones", "physics"):
        if kind not in models:
            continue
        fmu = export_fmu(models[kind]["path"], out / "fmus" / f"{kind}.fmu")
        res[kind] = {"path": fmu, "problems": validate(fmu)}
    if r.get("diagnosis"):
        tz = r["data"]["dataset"].building.timezone
        fmu = export_fmu(r["diagnosis"]["path"], out / "fmus" / "extended.fmu", timezone=tz)
        res["extended"] = {"path": fmu, "problems": validate(fmu)}
    if r.get("data"):
        fmu = export_plant_fmu(r["data"]["paths"].truth, out / "fmus" / "plant.fmu")
        res["plant"] = {"path": fmu, "problems": validate(fmu)}
    return res


def _stage_mpc(out, ds, r, horizon):
    models = stage_models(r)
    week = r["evaluation"]["week"] if r.get("evaluation") else None
    if week is None:
        week = ds.test_weeks()[0]
    res = {"week": week, "runs": {}, "errors": {}}
    # (run label, fmu to run, controller name, controller model)
    runs = []
    for kind in ("zones", "physics"):
        if kind in models and kind in r["fmus"]:
            runs.append((f"MPC {label(kind)} on its own FMU", r["fmus"][kind]["path"], "mpc", kind))
    if "plant" in r["fmus"]:
        plant = r["fmus"]["plant"]["path"]
        runs.append(("replay of measured airflows on the plant", plant, "replay", None))
        runs.append(("rule-based PI on the plant", plant, "rule", None))
        for kind in ("zones", "physics"):
            if kind in models:
                runs.append((f"MPC {label(kind)} on the plant", plant, "mpc", kind))
        control = (r.get("diagnosis") or {}).get("control_model")
        if control is not None and "zones" in models:  # the control gain of the diagnosis (issue 18 p.5)
            models = {**models, "control": {"model": control}}
            runs.append((f"MPC {label('zones')} + diagnosed terms on the plant", plant, "mpc", "control"))
    for run_label, fmu, ctrl, kind in runs:
        _run_one(out, ds, res, week, run_label, fmu, ctrl, kind, models, horizon)
    if "control" in models:  # the same comparison at equal or lower energy
        _equal_energy_runs(out, ds, res, week, plant, models, horizon)
    if res["errors"]:
        raise _PartialFailure(
            "MPC runs failed: "
            + "; ".join(f"{k}: {v}" for k, v in res["errors"].items())
            + " (the other runs are in the report)",
            res,
        )
    return res


def _run_one(out, ds, res, week, run_label, fmu, ctrl, kind, models, horizon, options=None) -> bool:
    """One closed-loop week into ``res["runs"]`` (saved as ``results/cosim_<label>.csv``); False when it failed."""
    from harness.cosim import make_controller, run_cosim

    model = models[kind]["model"] if kind else None
    options = ({"horizon": horizon} | (options or {})) if ctrl == "mpc" else {}
    try:
        controller = make_controller(ctrl, model, ds.building, options)
        # on the plant, the rule and the MPCs heat through the boxes' discharge air commands (Td_<vav>);
        # only the replay keeps the boxes' own reheat loops (it sets local_reheat itself): both at once
        # would heat twice
        result = run_cosim(fmu, ds, controller, week=week.number, model=model, allow_partial=True)
    except Exception as exc:  # noqa: BLE001 - one failed run must not hide the others
        traceback.print_exc(file=sys.stderr)
        res["errors"][run_label] = f"{type(exc).__name__}: {exc}"
        return False
    slug = run_label.lower().replace(" ", "_").replace("(", "").replace(")", "").replace(",", "")
    result.save(out / "results" / f"cosim_{slug}.csv")
    res["runs"][run_label] = {"result": result, "kind": kind, "controller": ctrl, "fmu": str(fmu)}
    return True


def _equal_energy_runs(out, ds, res, week, plant, models, horizon) -> None:
    """The extended model's MPC at lower comfort weights until it uses no more energy than Model A's.

    "At equal or lower energy" (:class:`harness.energy.EnergyUse`): neither more fan/cooling
    Σu² nor more reheat than Model A's run on the plant at the default weight. When the
    default-weight run of the diagnosed model spends more, the weights of
    :data:`EQUAL_ENERGY_WEIGHTS` are tried in turn (each a real run, at most that many).
    """
    from harness.energy import EnergyUse

    runs = res["runs"]
    base = runs.get(f"MPC {label('zones')} on the plant")
    ext = runs.get(f"MPC {label('zones')} + diagnosed terms on the plant")
    if base is None or ext is None:
        return
    e0 = EnergyUse.of(base["result"].summary)
    if EnergyUse.of(ext["result"].summary).at_most(e0):
        return
    for w in EQUAL_ENERGY_WEIGHTS:
        lab = f"MPC {label('zones')} + diagnosed terms on the plant, comfort weight {w:g}"
        ok = _run_one(out, ds, res, week, lab, plant, "mpc", "control", models, horizon, {"comfort_penalty": w})
        if ok and EnergyUse.of(runs[lab]["result"].summary).at_most(e0):
            return


def _stage_report(out, r):
    from .demo_report import write_report

    return write_report(out, r, PAPER_TABLE, PAPER_ZONES, PAPER_FIGURES)
