"""The per-building pipeline of a fleet run: one function a Dask worker calls per building.

:func:`run_building` never raises for a problem of the building (bad data, a
refused fit ...): it records the stage that failed and why, so that one building
never stops the fleet. Its results are cached on disk under a key made of the
input files' content, the stages and the options, so an interrupted run resumes
without redoing finished buildings.
"""

from __future__ import annotations

import hashlib
import json
import resource
import time
import traceback
import warnings
from pathlib import Path

import numpy as np

from ..errors import HvacfmuError
from .manifest import BuildingSpec

#: Stages in pipeline order.
STAGES = ("check", "fit", "evaluate", "diagnose", "export")
#: Model kinds fitted by default.
DEFAULT_KINDS = ("lumped", "zones")
#: Version of the cached result layout; part of the cache key.
RESULT_VERSION = 2  # 2: per-season baselines and the seasons lost (_season_columns)


def stage_list(stages) -> tuple:
    """Validated stages, in pipeline order (``fit`` is implied by ``evaluate``/``export``)."""
    if isinstance(stages, str):
        stages = [s.strip() for s in stages.split(",") if s.strip()]
    unknown = sorted(set(stages) - set(STAGES))
    if unknown:
        raise ValueError(f"unknown fleet stage(s) {unknown}; choose from {', '.join(STAGES)}")
    wanted = set(stages)
    if wanted & {"evaluate", "export"}:
        wanted.add("fit")
    return tuple(s for s in STAGES if s in wanted)


def cache_key(spec: BuildingSpec, stages, options: dict) -> str:
    """Content key of one building's results: input bytes, stages, options, hvacfmu version."""
    from .. import __version__

    h = hashlib.sha256(spec.content_key().encode())
    h.update(
        json.dumps(
            {"stages": list(stages), "options": options, "version": __version__, "result_version": RESULT_VERSION},
            sort_keys=True,
            default=str,
        ).encode()
    )
    return h.hexdigest()[:20]


def result_path(out: Path, spec: BuildingSpec, key: str) -> Path:
    return Path(out) / "buildings" / spec.name / key / "result.json"


def run_building(spec: BuildingSpec, stages, out, options: dict | None = None) -> dict:
    """Run ``stages`` on one building; return its JSON-ready result (also written to disk).

    Parameters
    ----------
    spec : BuildingSpec
    stages : sequence of str
        Subset of :data:`STAGES`.
    out : path
        Fleet output folder; results go to ``out/buildings/<name>/<key>/``.
    options : dict
        ``kinds`` (model kinds to fit), ``step`` [s], ``horizon`` [steps].

    Returns
    -------
    dict
        ``name``, ``key``, ``status`` ("ok" or "failed"), ``failed_stage``, ``error``,
        ``seconds`` per stage, ``zones`` (rows of per-zone scores), ``findings``,
        ``fmus``, ``peak_rss_mb``, ``cached`` (False when computed now).
    """
    options = dict(options or {})
    stages = stage_list(stages)
    key = cache_key(spec, stages, options)
    path = result_path(out, spec, key)
    if path.exists():
        result = json.loads(path.read_text(encoding="utf-8"))
        result["cached"] = True
        return result
    result = {
        "name": spec.name,
        "key": key,
        "status": "ok",
        "failed_stage": None,
        "error": None,
        "seconds": {},
        "zones": [],
        "findings": [],
        "fmus": {},
        "notes": [],
        "measurements": str(spec.measurements),
        "building": str(spec.building),
    }
    state = {"folder": path.parent}
    path.parent.mkdir(parents=True, exist_ok=True)
    for stage in stages:
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                _STAGE_FUNCTIONS[stage](spec, state, result, options)
            result["notes"] += sorted({str(w.message).splitlines()[0] for w in caught})[:20]
        except HvacfmuError as exc:
            _fail(result, stage, f"{type(exc).__name__}: {exc}")
        except Exception as exc:  # noqa: BLE001 - one building must never stop the fleet
            tb = traceback.format_exc(limit=3).strip().splitlines()[-1]
            _fail(result, stage, f"internal error {type(exc).__name__}: {exc} ({tb})")
        result["seconds"][stage] = round(time.perf_counter() - t0, 3)
        if result["status"] != "ok":
            break
    result["peak_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1)
    text = json.dumps(result, indent=1, allow_nan=False, default=_jsonable)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)  # atomic: a crash never leaves a half-written result that a rerun would trust
    result["cached"] = False
    return result


def _fail(result: dict, stage: str, message: str) -> None:
    result["status"] = "failed"
    result["failed_stage"] = stage
    result["error"] = message


def _jsonable(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return str(x)


def _finite(x) -> float | None:
    x = float(x)
    return x if np.isfinite(x) else None


# ----------------------------------------------------------------------------- stages
def _dataset(spec, state, options):
    if "dataset" not in state:
        from ..data import prepare

        state["dataset"] = prepare(spec.measurements, spec.building, step=float(options.get("step", 900.0)))
    return state["dataset"]


def _stage_check(spec, state, result, options):
    from ..data import check

    report = check(spec.measurements, spec.building, step=float(options.get("step", 900.0)))
    if not report.ok:
        raise _CheckFailed("check refused the data:\n" + "\n".join(f"- {p}" for p in report.problems))


class _CheckFailed(HvacfmuError):
    pass


def _stage_fit(spec, state, result, options):
    from ..fitting import fit

    data = _dataset(spec, state, options)
    models = {}
    for kind in options.get("kinds", DEFAULT_KINDS):
        model = fit(data, kind, progress=False)
        model.save(state["folder"] / f"{kind}.json")
        models[kind] = model
    state["models"] = models


def _stage_evaluate(spec, state, result, options):
    from ..evaluation import evaluate

    data = _dataset(spec, state, options)
    names = list(state["models"])
    ev = evaluate([state["models"][k] for k in names], data, horizon=int(options.get("horizon", 96)), names=names)
    ev.save_json(state["folder"] / "evaluation.json")
    result["zones"] = _zone_rows(ev, names)


def _zone_rows(ev, names) -> list:
    verdicts = {}
    if getattr(ev, "verdict", None) is not None:
        verdicts = {(z.model, z.output): z for z in ev.verdict.zones}
    rows = []
    for name in names:
        sc = ev.score(name)
        tables = {w: sc.table(w, ev.season_order) for w in ("model", "persistence", "time-of-week mean")}
        for zone in sc.outputs:
            row = {"model": name, "zone": zone}
            for season, value in tables["model"][zone].items():
                row[f"rms_{season}"] = _finite(value)
            row["persistence_all"] = _finite(tables["persistence"][zone].get("all", np.nan))
            row["time_of_week_all"] = _finite(tables["time-of-week mean"][zone].get("all", np.nan))
            row.update(_season_columns(tables, zone))
            v = verdicts.get((name, zone))
            if v is not None:
                row.update(
                    verdict=v.status,
                    nmbe_percent=_finite(v.nmbe),
                    cvrmse_percent=_finite(v.cvrmse),
                    g14_calibrated=v.calibrated,
                )
            else:
                rms, pers = row.get("rms_all"), row["persistence_all"]
                row["verdict"] = (
                    "beats persistence"
                    if rms is not None and pers is not None and rms < pers
                    else "WORSE THAN PERSISTENCE"
                )
            rows.append(row)
    return rows


def _season_columns(tables: dict, zone: str) -> dict:
    """Both baselines per season and the seasons where the model loses to each.

    A model may beat persistence over all windows and still lose in one season; the row's ``verdict``
    is the all-windows one, so the season losses get their own columns (comma-separated season names).
    """
    out: dict = {}
    worse: dict = {"persistence": [], "time-of-week mean": []}
    for season, rms in tables["model"][zone].items():
        if season == "all":
            continue
        for which, key in (("persistence", "persistence"), ("time-of-week mean", "time_of_week")):
            base = _finite(tables[which][zone].get(season, np.nan))
            out[f"{key}_{season}"] = base
            if base is not None and np.isfinite(rms) and rms >= base:
                worse[which].append(str(season))
    out["seasons_worse_than_persistence"] = ", ".join(worse["persistence"])
    out["seasons_worse_than_time_of_week"] = ", ".join(worse["time-of-week mean"])
    return out


def _stage_diagnose(spec, state, result, options):
    from ..diagnosis import diagnose

    data = _dataset(spec, state, options)
    report = diagnose(data, progress=False)
    report.save_json(state["folder"] / "diagnosis.json")
    report.model.save(state["folder"] / "extended.json")
    state.setdefault("models", {})["extended"] = report.model
    result["diagnosis_verdict"] = report.to_dict().get("verdict")
    for f in report.findings:
        held = f.get("heldout") or {}
        result["findings"].append(
            {
                "cause": f.get("cause"),
                "location": json.dumps(f.get("location"), sort_keys=True),
                "gain_percent": _finite(held.get("gain_percent", np.nan)) if isinstance(held, dict) else None,
            }
        )


def _stage_export(spec, state, result, options):
    from ..fmu import export_fmu

    for kind in state.get("models", {}):
        model_path = state["folder"] / f"{kind}.json"
        out = state["folder"] / f"{kind}.fmu"
        export_fmu(model_path, out)
        result["fmus"][kind] = str(out)


_STAGE_FUNCTIONS = {
    "check": _stage_check,
    "fit": _stage_fit,
    "evaluate": _stage_evaluate,
    "diagnose": _stage_diagnose,
    "export": _stage_export,
}
