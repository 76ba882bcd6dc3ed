"""Native FMI 2.0 co-simulation FMUs: the model as generated C code, no Python at run time.

:func:`export_native_fmu` writes an FMU whose ``sources/`` hold the fixed FMI
runtime ``hvacfmu_native.c`` (shipped with hvacfmu) and the generated header
``hvacfmu_model.h`` (the model's :class:`~hvacfmu.models.equations.ModelEquations`
as constant tables: sparse matrices in exact hexadecimal floating point, the
seasonal time-of-week gain tables, the box-to-input map and the variable
layout; a large model whose ``A`` has real eigenvalues, such as Model B, in modal
form, :mod:`hvacfmu.fmu_native_modal`). Both are listed in ``<SourceFiles>`` so that ``fmpy compile`` or any
FMI tool can rebuild the binary; the export compiles
``binaries/linux64/<modelIdentifier>.so`` with the system C compiler (``gcc``
or ``$CC``). The variables, their value references and the run-time behaviour
(whole-multiple steps, time of week, initial state) are those of the pythonfmu
FMU of the same model (:mod:`hvacfmu.fmu_slave`), except that calendar-dependent
models (holidays, daylight-saving terms) are refused. A refused step (a step
that is not a whole multiple of the model step, a NaN or out-of-range input, a
non-contiguous time) returns ``fmi2Error`` with a logged message naming the
time, the variable and the value, so that ``fmpy simulate`` fails loudly instead
of returning a short result (FMPy ends a run quietly on ``fmi2Discard``).

Examples
--------
>>> export_native_fmu(load_model("model.json"), "Zones.fmu")   # doctest: +SKIP
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
import subprocess
import tempfile
import uuid
import zipfile
from pathlib import Path

import numpy as np

from .errors import FMUError, problems_message
from .fmu_native_modal import header_tables, modal_form

logger = logging.getLogger(__name__)

#: the fixed runtime written once; the model is in the generated header
RUNTIME_SOURCE = Path(__file__).with_name("fmu_native.c")
RUNTIME_NAME = "hvacfmu_native.c"
HEADER_NAME = "hvacfmu_model.h"

_ROLES = {"m": 0, "v": 1, "tow_in": 2, "y": 3, "y0": 4, "season": 5, "tow": 6}


def native_identifier(kind: str) -> str:
    """modelIdentifier (a C identifier) of the native FMU of model ``kind``."""
    return "HvacfmuNative" + "".join(p.capitalize() for p in str(kind).replace("-", "_").split("_") if p)


# ----------------------------------------------------------------------------- checks
def native_equations(model, model_name="the model"):
    """The model's equations, checked for the native FMU; FMUError with the reason otherwise.

    Refused: a model without ``equations()``, a calendar-dependent model
    (holidays, daylight-saving terms), equations whose inputs or disturbances
    differ from the model's, an output map that is not a selection of states,
    and equations that differ from the model's ``step_state``.
    """
    from .fmu_slave import calendar_dependent
    from .fmu_slave.zone_layout import without_holidays
    from .models.equations import check_equations

    kind = getattr(model, "kind", type(model).__name__)
    if calendar_dependent(without_holidays(model)):
        raise FMUError(
            f"cannot export {model_name} as a native FMU: its internal gains depend on the calendar "
            "(holidays, daylight-saving or sensor-offset terms), which the native FMU does not compute; export the "
            "pythonfmu FMU instead (without --native; its calendar's time zone from --timezone or the building "
            "file, -b)"
        )
    no_form = [t for t in getattr(model, "terms", ()) if not getattr(t, "matrix_form", True)]
    if no_form:
        raise FMUError(
            f"cannot export {model_name} as a native FMU: "
            + ", ".join(f"{t.cause} in {', '.join(t.zones())}" for t in no_form)
            + " has no matrix form (a held setpoint limits the temperature to a band, an unmetered thermostat); "
            "export the pythonfmu FMU instead (hvacfmu export without --native), which runs every term"
        )
    if not callable(getattr(model, "equations", None)):
        raise FMUError(
            f"cannot export {model_name} as a native FMU: model kind {kind!r} has no equations() "
            "(it is not linear or bilinear in a finite state); export the pythonfmu FMU instead "
            "(hvacfmu export without --native)"
        )
    eq = model.equations()
    problems = []
    if tuple(eq.inputs) != tuple(model.inputs):
        problems.append(f"equation inputs {eq.inputs} differ from the model's {tuple(model.inputs)}")
    if tuple(eq.disturbances) != tuple(model.disturbances):
        problems.append(f"equation disturbances {eq.disturbances} differ from the model's {tuple(model.disturbances)}")
    if output_states(eq.C) is None:
        problems.append("the output map C is not a selection of states (y = x[i])")
    seasons = {np.asarray(g).shape[1:] for g in eq.gains.values()}
    if seasons != {(eq.Bq.shape[1],)}:
        problems.append(f"gain tables have columns {sorted(seasons)}, Bq has {eq.Bq.shape[1]}")
    if problems:
        raise FMUError(problems_message(f"cannot export {model_name} as a native FMU", problems))
    check_equations(model, eq)
    return eq


def output_states(C) -> list | None:
    """State index of each output when ``C`` selects states (one 1 per row, distinct columns), else None."""
    C = np.asarray(C, dtype=float)
    idx = []
    for row in C:
        nz = np.flatnonzero(row)
        if len(nz) != 1 or row[nz[0]] != 1.0:
            return None
        idx.append(int(nz[0]))
    return idx if len(set(idx)) == len(idx) else None


# ----------------------------------------------------------------------------- C header
def _c_double(x: float) -> str:
    x = float(x)
    if x - x == 0.0:  # finite (the common case first: headers hold hundreds of thousands of numbers)
        return x.hex()
    if x != x:
        raise FMUError("a model coefficient is NaN; the model cannot be exported")
    return "HUGE_VAL" if x > 0 else "(-HUGE_VAL)"


def _c_array(ctype: str, name: str, values, fmt=str) -> str:
    values = list(values)
    if not values:
        values = [0]  # C has no empty arrays; the count says 0
    body = ",".join(fmt(v) for v in values)
    return f"static const {ctype} {name}[{len(values)}] = {{{body}}};\n"


#: matrices with more nonzeros than this fraction are stored dense
DENSE_ABOVE = 0.25


def _is_dense(M) -> bool:
    M = np.asarray(M, dtype=float)
    return M.size > 0 and np.count_nonzero(M) > DENSE_ABOVE * M.size


def _c_sparse(name: str, M) -> str:
    M = np.asarray(M, dtype=float)
    if _is_dense(M):  # column-major
        return _c_array("double", f"{name}_val", M.T.ravel().tolist(), _c_double)
    rows, cols = np.nonzero(M)
    out = _c_array("int", f"{name}_row", rows.tolist())
    out += _c_array("int", f"{name}_col", cols.tolist())
    out += _c_array("double", f"{name}_val", M[rows, cols].tolist(), _c_double)
    return out


def _sparse_ref(name: str, M) -> str:
    M = np.asarray(M, dtype=float)
    nr, nc = M.shape
    if _is_dense(M):
        return f"{{{M.size}, 0, 0, {name}_val, {nr}, {nc}}}"
    return f"{{{int(np.count_nonzero(M))}, {name}_row, {name}_col, {name}_val, {nr}, {nc}}}"


def _c_string(s: str) -> str:
    return '"' + str(s).replace("\\", "\\\\").replace('"', '\\"').replace("%", " ") + '"'


def _matrix_tables(eq, prefix: str = "hv_") -> tuple[str, dict]:
    """C tables of A, Bu, Bv, Bq, Bxu_i, Bvu_i (with input products), Bxv_j, Bvv_j (with disturbance products),
    named ``<prefix><matrix>_``, and each matrix's ``hv_sparse`` initialiser (a list for the per-input ones)."""
    nx, nu, nv = eq.n_states, len(eq.inputs), len(eq.disturbances)
    out, refs = "", {}
    for name in ("A", "Bu", "Bv", "Bq"):
        out += _c_sparse(f"{prefix}{name}_", getattr(eq, name))
        refs[name] = _sparse_ref(f"{prefix}{name}_", getattr(eq, name))
    if eq.bilinear:
        refs.update(Bxu=[], Bvu=[])
        for i in range(nu):
            for key, mats, shape in (("Bxu", eq.Bxu, (nx, nx)), ("Bvu", eq.Bvu, (nx, len(eq.disturbances)))):
                M = np.asarray(mats[i], dtype=float) if mats else np.zeros(shape)
                out += _c_sparse(f"{prefix}{key}_{i}_", M)
                refs[key].append(_sparse_ref(f"{prefix}{key}_{i}_", M))
    if eq.disturbance_products:
        refs.update(Bxv=[], Bvv=[])
        for j in range(nv):
            for key, mats, shape in (("Bxv", eq.Bxv, (nx, nx)), ("Bvv", eq.Bvv, (nx, nv))):
                M = np.asarray(mats[j], dtype=float) if mats else np.zeros(shape)
                out += _c_sparse(f"{prefix}{key}_{j}_", M)
                refs[key].append(_sparse_ref(f"{prefix}{key}_{j}_", M))
    return out, refs


def _matrices(eq) -> str:
    """C tables of the equations' matrices and the ``hv_sparse`` descriptors the runtime reads (``hv_A`` ...)."""
    out, refs = _matrix_tables(eq)
    for key, r in refs.items():
        if isinstance(r, list):
            out += f"static const hv_sparse hv_{key}[{len(r)}] = {{{', '.join(r)}}};\n"
        else:
            out += f"static const hv_sparse hv_{key} = {r};\n"
    return out


def _season_matrices(sets: list) -> str:
    """C tables of one set of matrices per season (a model with one coefficient set per season,
    :class:`~hvacfmu.models.linear.SeasonalZoneModel`): ``hv_A_set[season - 1]`` ..., the runtime picks the set of
    its ``season`` parameter (``HV_SEASONAL``)."""
    out, all_refs = "", []
    for k, e in enumerate(sets):
        text, refs = _matrix_tables(e, f"hv_s{k}_")
        out += text
        all_refs.append(refs)
    n = len(sets)
    for key, r0 in all_refs[0].items():
        if isinstance(r0, list):
            rows = ", ".join("{" + ", ".join(r[key]) + "}" for r in all_refs)
            out += f"static const hv_sparse hv_{key}_set[{n}][{len(r0)}] = {{{rows}}};\n"
        else:
            out += f"static const hv_sparse hv_{key}_set[{n}] = {{{', '.join(r[key] for r in all_refs)}}};\n"
    return "#define HV_SEASONAL 1\n" + out


def seasonal_equations(model, model_name="the model") -> list:
    """Each season's checked equations (:func:`native_equations` of ``model.for_season(s)``) of a model with one
    coefficient set per season, in ``model.seasons`` order; FMUError when the sets differ in more than their
    coefficients (inputs, disturbances, outputs, bilinear structure, switches)."""
    eqs = [native_equations(model.for_season(s), f"{model_name}, season {s}") for s in model.seasons]
    first = eqs[0]
    for s, e in zip(model.seasons, eqs):
        same = (
            e.inputs == first.inputs
            and e.disturbances == first.disturbances
            and e.outputs == first.outputs
            and np.array_equal(e.C, first.C)
            and e.bilinear == first.bilinear
            and e.disturbance_products == first.disturbance_products
            and len(e.switches) == 0
            and e.A.shape == first.A.shape
            and e.Bq.shape == first.Bq.shape
            and e.step == first.step
        )
        if not same:
            raise FMUError(
                f"cannot export {model_name} as a native FMU: season {s}'s equations differ from the first season's "
                "in structure (inputs, outputs, bilinear terms or switches), not only in coefficients"
            )
    return eqs


def _switches(eq) -> str:
    out, entries = "", []
    for s_i, s in enumerate(eq.switches):
        out += _c_array("double", f"hv_switch_gain_{s_i}", np.asarray(s.gain, dtype=float).tolist(), _c_double)
        entries.append(
            "{"
            + ", ".join(
                [
                    str(-1 if s.input_index is None else int(s.input_index)),
                    _c_double(s.input_below),
                    str(-1 if s.disturbance_index is None else int(s.disturbance_index)),
                    _c_double(s.disturbance_below),
                    str(-1 if s.scale_by is None else int(s.scale_by)),
                    f"hv_switch_gain_{s_i}",
                ]
            )
            + "}"
        )
    if not entries:
        entries = ["{-1, 0.0, -1, 0.0, -1, 0}"]
    out += f"static const hv_switch hv_switches[{len(entries)}] = {{{', '.join(entries)}}};\n"
    return out


def _gain_tables(eq, seasons) -> str:
    tables = [np.asarray(eq.gains[s], dtype=float) for s in seasons]
    offsets = np.cumsum([0] + [t.size for t in tables])[:-1]
    out = _c_array("double", "hv_gains", np.concatenate([t.ravel() for t in tables]).tolist(), _c_double)
    out += _c_array("long long", "hv_gain_offset", [int(o) for o in offsets])
    out += _c_array("long long", "hv_gain_nslots", [t.shape[0] for t in tables])
    return out


def _variables(layout) -> str:
    var = layout["variables"]

    def bound(e, key, default):
        return default if e.get(key) is None or e["causality"] != "input" else float(e[key])

    out = _c_array("int", "hv_var_role", [_ROLES[e["role"]] for e in var])
    out += f"static const char *const hv_var_name[{len(var)}] = {{{', '.join(_c_string(e['name']) for e in var)}}};\n"
    out += _c_array("double", "hv_var_start", [float(e["start"]) for e in var], _c_double)
    out += _c_array("double", "hv_var_min", [bound(e, "min", -np.inf) for e in var], _c_double)
    out += _c_array("double", "hv_var_max", [bound(e, "max", np.inf) for e in var], _c_double)
    for role in ("m", "v", "y", "y0"):
        out += _c_array("int", f"hv_vr_{role}", [i for i, e in enumerate(var) if e["role"] == role])
    inputs = [i for i, e in enumerate(var) if e["role"] in ("m", "v", "tow_in")]
    out += f"#define HV_NIN {len(inputs)}\n" + _c_array("int", "hv_vr_in", inputs)
    for role, macro in (("season", "HV_VR_SEASON"), ("tow", "HV_VR_TOW"), ("tow_in", "HV_VR_TOWIN")):
        vrs = [i for i, e in enumerate(var) if e["role"] == role]
        out += f"#define {macro} {vrs[0] if vrs else -1}\n"
    return out


def _idle_tables(layout) -> str:
    """The idle supply rule (``layout["idle_supply"]``, :class:`hvacfmu.data.idle.IdleStep`) as C tables.

    Per replaced disturbance ``i``: ``hv_idle_target[i]`` (index into ``v``), its boxes ``hv_idle_box`` (index
    into the airflow inputs) and off bounds ``hv_idle_bound`` from ``hv_idle_bstart[i]`` to
    ``hv_idle_bstart[i + 1]``, its zones ``hv_idle_zone`` (output index) and weights ``hv_idle_w`` likewise
    (none: hold the last running value).
    """
    idle = layout.get("idle_supply")
    cols = idle["columns"] if idle else []
    out = f"#define HV_NIDLE {len(cols)}\n#define HV_IDLE_LAST {int(bool(idle) and idle['mode'] == 'last')}\n"
    if not cols:
        return out
    out += _c_array("int", "hv_idle_target", [c["target"] for c in cols])
    for key, items, vals in (("b", "boxes", "bounds"), ("z", "zones", "weights")):
        out += _c_array("int", f"hv_idle_{key}start", np.cumsum([0] + [len(c[items]) for c in cols]).tolist())
        out += _c_array("int", "hv_idle_box" if key == "b" else "hv_idle_zone", [i for c in cols for i in c[items]])
        name = "hv_idle_bound" if key == "b" else "hv_idle_w"
        out += _c_array("double", name, [x for c in cols for x in c[vals]], _c_double)
    return out


def generate_header(eq, layout, M, guid: str, form=None, sets=None) -> str:
    """Text of ``hvacfmu_model.h`` for equations ``eq``, the FMU's variable ``layout`` and box map ``M``.

    With ``form`` (a :class:`~hvacfmu.fmu_native_modal.ModalForm` of ``eq``) the
    model runs in modal coordinates; otherwise with the physical matrices. ``sets``: one equations object per season
    of ``layout["seasons"]`` (a model with one coefficient set per season; physical form only): the runtime runs
    the set of its ``season`` parameter (``eq`` then gives the structure and every season's gain table).
    """
    if sets is not None and (form is not None or len(sets) != len(layout["seasons"])):
        raise FMUError("per-season matrices need the physical form and one set per season of the layout")
    nx, nu, nv, ny = eq.n_states, len(eq.inputs), len(eq.disturbances), len(eq.outputs)
    seasons = list(layout["seasons"])
    out_idx = output_states(eq.C)
    hidden = [j for j in range(nx) if j not in out_idx]
    hidden_index = [hidden.index(j) if j in hidden else -1 for j in range(nx)]
    nb = M.shape[1] if M is not None else nu
    mapping = ", ".join(f"{i + 1} = {s}" for i, s in enumerate(seasons))
    head = [
        f"/* Generated by hvacfmu.fmu_native from the equations of a {layout['kind']} model. Do not edit. */",
        f"#define HV_GUID {_c_string(guid)}",
        f"#define HV_STEP {_c_double(eq.step)}",
        f"#define HV_NX {nx}",
        f"#define HV_NU {nu}",
        f"#define HV_NB {nb}",
        f"#define HV_NV {nv}",
        f"#define HV_NY {ny}",
        f"#define HV_NQ {eq.Bq.shape[1]}",
        f"#define HV_NSEASON {len(seasons)}",
        f"#define HV_SEASONS {_c_string(mapping)}",
        f"#define HV_NVARS {len(layout['variables'])}",
        f"#define HV_NSWITCH {len(eq.switches)}",
        f"#define HV_BILINEAR {int(eq.bilinear)}",
        f"#define HV_DPRODUCTS {int(eq.disturbance_products)}",
        f"#define HV_HAS_MAP {int(M is not None)}",
        f"#define HV_MODAL {int(form is not None)}",
        "",
    ]
    out = "\n".join(head)
    if M is not None:
        Mf = np.asarray(M, dtype=float)  # CSR: row i's nonzeros at hv_map_start[i] .. hv_map_start[i + 1]
        out += _c_array("int", "hv_map_start", np.concatenate([[0], np.cumsum(np.count_nonzero(Mf, axis=1))]).tolist())
        out += _c_array("int", "hv_map_col", np.nonzero(Mf)[1].tolist())
        out += _c_array("double", "hv_map_val", Mf[np.nonzero(Mf)].tolist(), _c_double)
    out += _c_array("int", "hv_out_state", out_idx)
    out += _c_array("int", "hv_hidden_state", hidden)
    out += _c_array("int", "hv_hidden_index", hidden_index)
    if sets is not None:
        out += _season_matrices(sets)
    else:
        out += header_tables(form, _c_double) if form is not None else _matrices(eq)
    out += _switches(eq) + _gain_tables(eq, seasons) + _variables(layout) + _idle_tables(layout)
    return out


# ----------------------------------------------------------------------------- build
def fmi_include_dir() -> Path:
    """Folder with the FMI 2.0 headers (``fmi2Functions.h``) used to compile: FMPy's copy."""
    import fmpy

    d = Path(fmpy.__file__).parent / "c-code"
    if not (d / "fmi2Functions.h").is_file():
        raise FMUError(f"FMI 2.0 headers not found in {d} (fmpy installation incomplete?)")
    return d


def compile_binary(sources: Path, identifier: str, out_dir: Path) -> Path:
    """Compile ``sources/hvacfmu_native.c`` into ``out_dir/<identifier>.so`` with ``$CC`` or gcc."""
    cc = os.environ.get("CC") or shutil.which("gcc") or shutil.which("cc")
    if not cc:
        raise FMUError(
            "no C compiler found for the native FMU (install gcc or set CC); the FMU's sources can "
            "also be compiled later with `fmpy compile`"
        )
    out_dir.mkdir(parents=True, exist_ok=True)
    lib = out_dir / f"{identifier}.so"
    cmd = [
        cc,
        "-std=c99",
        "-O3",
        "-fPIC",
        "-shared",
        "-fvisibility=default",
        "-Wall",
        "-I",
        str(sources),
        "-I",
        str(fmi_include_dir()),
        "-o",
        str(lib),
        str(sources / RUNTIME_NAME),
    ]
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise FMUError(f"compiling the native FMU failed: {exc}") from None
    if r.returncode != 0:
        raise FMUError(f"compiling the native FMU failed ({' '.join(cmd)}):\n{r.stderr[-4000:]}")
    if r.stderr.strip():
        logger.debug("compiler messages:\n%s", r.stderr)
    return lib


def _zip_folder(folder: Path, out_path: Path) -> None:
    tmp = out_path.with_suffix(".fmu.part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for p in sorted(folder.rglob("*")):
            if p.is_file():
                z.write(p, p.relative_to(folder).as_posix())
    tmp.replace(out_path)


def export_native_fmu(
    model, out_path, *, model_name: str | None = None, compile: bool = True, building=None, modal: bool = True
) -> Path:
    """Export a zone model as a native FMI 2.0 co-simulation FMU (generated C code, no Python at run time).

    Parameters
    ----------
    model : ZoneModel
        A model whose kind provides ``equations()`` (lumped, zones, physics, ...).
    out_path : path
        FMU to write (``.fmu``); parent folders are created.
    model_name : str, optional
        Name used in messages and the model description (default: the kind).
    compile : bool
        Compile ``binaries/linux64`` now (default); without it the FMU holds only
        its sources (``fmpy compile`` builds them).
    building : Building, optional
        Box airflow bounds (``m_max``) and zones, as for :func:`hvacfmu.fmu.export_fmu`.
    modal : bool
        Run a large model in modal coordinates when its ``A`` allows it
        (:mod:`hvacfmu.fmu_native_modal`, default); False keeps the physical matrices.

    Returns
    -------
    Path
        The FMU, checked with ``fmpy.validate_fmu`` (no problems).

    Raises
    ------
    FMUError
        The model cannot be exported natively (reason named), compiling or
        validating failed.
    """
    from .fmu_description import documentation_html, model_description_xml
    from .fmu_slave import INTERFACE_FILE, box_limits, zone_model_layout

    out_path = Path(out_path)
    if out_path.suffix != ".fmu":
        raise FMUError(f"output file {out_path} must end in .fmu")
    name = model_name or f"{model.kind} model"
    sets = None
    if getattr(model, "seasonal", False):  # one coefficient set per season: the runtime picks it by `season`
        import dataclasses

        sets = seasonal_equations(model, name)
        eq = dataclasses.replace(sets[0], gains={s: e.gains[s] for s, e in zip(model.seasons, sets)})
        modal = False
    else:
        eq = native_equations(model, name)
    if getattr(model, "holidays", ()):
        import warnings

        from .errors import HvacfmuWarning

        warnings.warn(
            f"{name} reads Sunday's internal gains on {len(model.holidays)} holiday(s) of its calendar (the first "
            f"{model.holidays[0]}); the native FMU does not know dates: on a holiday the master must set its "
            "time_of_week input to Sunday's time of week (6*86400 s + the time of day), or export the pythonfmu "
            "FMU (without --native), which follows the calendar from its start_time",
            HvacfmuWarning,
            stacklevel=2,
        )
    try:
        layout, M = zone_model_layout(model, None, box_limits(model, building))
    except ValueError as exc:
        raise FMUError(f"cannot export {name}: {exc}") from None
    layout["description"] = layout["description"].replace(
        "Runs in the host's Python, which needs the hvacfmu package.",
        "Native FMU: generated C code, no Python needed at run time.",
    )
    for e in layout["variables"]:
        if e["role"] == "season":  # no calendar here: one season per run (issue 13)
            e["description"] += (
                "; one season for the whole run: this FMU has no calendar, season = 0 (follow the calendar) is "
                "refused; split a run that crosses a season boundary, or use the Python FMU exported with the "
                "building file"
            )
    identifier = native_identifier(model.kind)
    form = modal_form(eq, output_states(eq.C)) if modal else None
    logger.info("native FMU of %s: %s form", name, "modal" if form is not None else "physical")
    if sets is not None and list(layout["seasons"]) != list(model.seasons):
        raise FMUError(f"cannot export {name}: the FMU's seasons {layout['seasons']} are not the model's sets'")
    header_wo_guid = generate_header(eq, layout, M, "", form, sets)
    guid = "{" + str(uuid.UUID(hashlib.sha256(header_wo_guid.encode()).hexdigest()[:32])) + "}"
    header = header_wo_guid.replace('#define HV_GUID ""', f"#define HV_GUID {_c_string(guid)}", 1)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="hvacfmu_native_") as tmp:
        root = Path(tmp)
        src = root / "sources"
        src.mkdir()
        shutil.copyfile(RUNTIME_SOURCE, src / RUNTIME_NAME)
        (src / HEADER_NAME).write_text(header, encoding="utf-8")
        xml = model_description_xml(
            layout, identifier=identifier, guid=guid, native=True, source_files=[RUNTIME_NAME], model_name=name
        )
        (root / "modelDescription.xml").write_bytes(xml)
        (root / "documentation").mkdir()
        (root / "documentation" / "index.html").write_text(documentation_html(layout, native=True), encoding="utf-8")
        # the variables' roles (start temperatures, season, time of week) as in the pythonfmu FMU: data, not code;
        # hosts such as `hvacfmu cosim` set the start values from it (without it they kept the defaults silently)
        (root / "resources").mkdir()
        (root / "resources" / INTERFACE_FILE).write_text(json.dumps(layout, indent=1), encoding="utf-8")
        if compile:
            compile_binary(src, identifier, root / "binaries" / "linux64")
        _zip_folder(root, out_path)
    from .fmu import validate

    problems = validate(out_path, native=True)
    if problems:
        raise FMUError(problems_message(f"the native FMU {out_path} is not valid", problems))
    logger.info("exported %s as native FMU %s", name, out_path)
    return out_path


__all__ = [
    "export_native_fmu",
    "generate_header",
    "native_equations",
    "native_identifier",
    "output_states",
    "seasonal_equations",
]
