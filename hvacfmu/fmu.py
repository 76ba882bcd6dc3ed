"""Export identified models (and the emulated plant) as FMI 2.0 co-simulation FMUs.

The FMUs are built with pythonfmu from the slave scripts in the repository's
``fmus/`` folder (one uniquely named script and class per model kind; the
logic is in the package :mod:`hvacfmu.fmu_slave`). The model file travels in the FMU's
``resources/``; at run time the FMU needs only the host's Python environment
with hvacfmu installed (pythonfmu FMUs run in the importer's interpreter).

Examples
--------
>>> export_fmu("model.json", "fmus/build/Zones.fmu")          # doctest: +SKIP
>>> export_plant_fmu("truth.json", "fmus/build/Plant.fmu")    # doctest: +SKIP
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import sys
import tempfile
import time
import zipfile
from pathlib import Path

from .errors import FMUError, ModelError, problems_message

logger = logging.getLogger(__name__)

#: slave for model kinds without a dedicated script
GENERIC_SLAVE = "HvacfmuModel"
#: slave of the emulated plant
PLANT_SLAVE = "HvacfmuPlant"

#: FMI capability flags passed to the pythonfmu builder
BUILD_OPTIONS = {
    "canGetAndSetFMUstate": True,
    "canSerializeFMUstate": True,
    "canHandleVariableCommunicationStepSize": False,
}


def slave_specs() -> dict:
    """Slave script name -> (what it serves, base class, doc) for every slave: one per registered model kind
    (:func:`hvacfmu.models.registry.kinds`, ``ModelKind.fmu_slave``), the generic one and the plant's.

    The scripts in ``fmus/`` are exactly :func:`slave_source` of these (``tests/test_fmu.py`` checks it).
    """
    from .models.registry import kinds

    specs = {}
    for k in kinds():
        if k.fmu_slave != GENERIC_SLAVE:
            specs.setdefault(
                k.fmu_slave, (f"models of kind '{k.name}'", "ZoneModelSlave", f"{k.name}, resources/model.json")
            )
    specs[GENERIC_SLAVE] = (
        "models of a kind without a dedicated slave",
        "ZoneModelSlave",
        "kinds without a dedicated slave, resources/model.json",
    )
    specs[PLANT_SLAVE] = ("the emulated building (plant)", "PlantSlave", "emulated plant, resources/truth.json")
    return specs


def slave_name(kind: str) -> str:
    """Slave script (and class) name serving model ``kind``: the registry's ``fmu_slave``, else the generic one."""
    from .errors import ModelError as _ModelError
    from .models.registry import get_kind

    try:
        return get_kind(kind).fmu_slave
    except _ModelError:
        return GENERIC_SLAVE


_SLAVE_TEMPLATE = '''"""pythonfmu slave of the hvacfmu FMUs for {what}.

A unique script and class name per FMU kind: pythonfmu names the FMU's binary
and Python module after them, and FMUs that share a name must not run each
other's code when loaded in one process. Built by ``hvacfmu.fmu``.

All logic is in the package ``hvacfmu.fmu_slave`` (host Python environment). The
source of the slave classes is executed in this module's namespace instead of
being imported (``hvacfmu.fmu_slave.define_slave``), because the
pythonfmu 0.7.0 binary corrupts the interpreter when it frees an instance whose
class or methods were defined in another module (measured: the slave module's
dictionary is cleared and the next instance crashes the host).

pythonfmu 0.7.0 also executes this script again for every new instance (its
``findClass`` runs the file in this module's namespace with fresh locals) and
then releases a reference to this module's ``__dict__`` that it never took
(``Py_DECREF`` of the borrowed ``PyModule_GetDict``): after enough instances the
dictionary is freed while still in use, which corrupts the heap ("corrupted
double-linked list" at exit). The first branch below gives that reference
back and hands over the class defined at import instead of defining new
copies (each copy stayed alive through an MRO list pythonfmu never frees).

At exit, the same binary releases its interpreter state twice (a C++ exit
handler, then its ELF destructor): ``hvacfmu.fmu_exit`` empties that state
from a Python exit hook first, so the host does not abort at exit now and then.
"""

if "_hvacfmu_slave_class" in globals():  # executed again by pythonfmu for a new instance
    import ctypes as _ctypes

    _ctypes.pythonapi.Py_IncRef(_ctypes.py_object(globals()))  # the reference pythonfmu will drop
    {name} = _hvacfmu_slave_class  # noqa: F821 - the class made at import
else:
    try:
        from hvacfmu.fmu_slave import define_slave as _define
    except ImportError as _exc:  # the host lacks hvacfmu or one of its packages: say so, do not crash
        _define, _missing = None, f"{{type(_exc).__name__}}: {{_exc}}"

    if _define is not None:
        import hvacfmu.fmu_exit as _exit

        _exit.install()  # pythonfmu's binary frees its interpreter state twice at exit: see hvacfmu/fmu_exit.py
        _define(globals(), "{base}")  # executes the source of {base} and its bases here
    else:
        from pythonfmu import Fmi2Slave
        from pythonfmu.enums import Fmi2Status

        class {base}(Fmi2Slave):
            """Stand-in when the host cannot import the FMU's Python packages: logs why, refuses every step."""

            def __init__(self, **kwargs):
                super().__init__(**kwargs)
                self._why = (
                    "this FMU runs in the host's Python interpreter and needs the Python packages hvacfmu, "
                    "numpy, scipy and pandas importable there (versions: the FMU's documentation/index.html); "
                    "importing them failed: " + _missing + ". Install hvacfmu in that interpreter (pip install "
                    "hvacfmu) or use a native FMU (hvacfmu export --native), which needs no Python")
                self.log(self._why, Fmi2Status.error)

            def exit_initialization_mode(self):
                self.log(self._why, Fmi2Status.error)

            def do_step(self, current_time, step_size):
                self.log(self._why, Fmi2Status.error)
                return False

            def get_real(self, vrs):
                return [float("nan")] * len(vrs)

            def get_integer(self, vrs):
                return [0] * len(vrs)

            def set_real(self, vrs, values):
                pass

            def set_integer(self, vrs, values):
                pass

    class {name}({base}):  # noqa: F821 - defined by the exec above
        """FMI 2.0 co-simulation slave ({doc})."""

    _hvacfmu_slave_class = {name}
'''


def slave_source(name: str) -> str:
    """Text of the slave script ``name`` (a key of :func:`slave_specs`)."""
    what, base, doc = slave_specs()[name]
    return _SLAVE_TEMPLATE.format(what=what, base=base, name=name, doc=doc)


def write_slaves(folder) -> list:
    """Write every slave script into ``folder`` (how ``fmus/`` is made); returns the paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in slave_specs():
        path = folder / f"{name}.py"
        path.write_text(slave_source(name), encoding="utf-8")
        paths.append(path)
    return paths


def slave_dir() -> Path:
    """Folder holding the slave scripts.

    ``$HVACFMU_SLAVE_DIR`` if set, else the repository's ``fmus/`` (editable
    install), else a folder in the user cache where the scripts are written from
    :func:`slave_source` (an installation without the source tree).
    """
    env = os.environ.get("HVACFMU_SLAVE_DIR")
    if env:
        if not (Path(env) / f"{GENERIC_SLAVE}.py").is_file():
            raise FMUError(f"HVACFMU_SLAVE_DIR={env} holds no slave scripts ({GENERIC_SLAVE}.py ...)")
        return Path(env)
    repo = Path(__file__).resolve().parents[1] / "fmus"
    if (repo / f"{GENERIC_SLAVE}.py").is_file():
        return repo
    from . import __version__

    cache = Path(os.environ.get("HVACFMU_CACHE", Path.home() / ".cache" / "hvacfmu")) / f"fmu-slaves-{__version__}"
    if not all(
        (cache / f"{n}.py").is_file() and (cache / f"{n}.py").read_text() == slave_source(n) for n in slave_specs()
    ):
        write_slaves(cache)
    return cache


def slave_script(kind: str) -> Path:
    """The slave script used for model ``kind``."""
    d = slave_dir()
    name = slave_name(kind)
    path = d / f"{name}.py"
    if not path.is_file() and name in slave_specs():  # a kind registered by a plugin: write its stub
        from . import __version__

        cache = Path(os.environ.get("HVACFMU_CACHE", Path.home() / ".cache" / "hvacfmu")) / f"fmu-slaves-{__version__}"
        cache.mkdir(parents=True, exist_ok=True)
        path = cache / f"{name}.py"
        path.write_text(slave_source(name), encoding="utf-8")
    if not path.is_file():
        raise FMUError(f"slave script {path} for model kind {kind!r} is missing")
    return path


def _resolve_building(building, model_path):
    """A Building from a path or Building (None stays None); errors name the file."""
    if building is None or hasattr(building, "vavs"):
        return building
    from .building import load_building

    return load_building(building)


def export_fmu(model_path, out_path, *, timezone: str | None = None, building=None) -> Path:
    """Export a saved zone model as an FMI 2.0 co-simulation FMU.

    Parameters
    ----------
    model_path : path
        Model file (JSON) of any kind :func:`hvacfmu.models.load_model` reads.
    out_path : path
        FMU to write (``.fmu``); parent folders are created.
    timezone : str, optional
        IANA time zone of the building (e.g. ``America/Los_Angeles``), needed
        only by models whose internal gains depend on the date (holidays,
        daylight-saving shift: :func:`hvacfmu.fmu_slave.calendar_dependent`);
        defaults to the model's ``meta["timezone"]``. With it such an FMU gets the
        parameter ``start_time`` [s, Unix epoch] and reproduces the Python
        model's gains exactly; without it the export warns that the FMU
        follows the time-of-week profile only. Ignored for other models.
    building : Building or path, optional
        The building file the model was fitted on: the box airflow inputs get
        ``max`` = 1.2 x the box's ``m_max``, ``nominal`` = ``m_max`` and their zone in
        the description. Physics models carry their building; data-driven model
        files keep only its name, so without it the bounds are generic (0..50 kg/s).

    Returns
    -------
    Path
        The FMU, checked with ``fmpy.validate_fmu`` (no problems).

    Raises
    ------
    ModelError
        The model file cannot be read.
    FMUError
        Building or validating the FMU failed.

    Notes
    -----
    Variables: inputs ``m_<vav>`` [kg/s] per VAV box and the model's
    disturbances (``T_out``, ``T_supply`` [°C], ``I_N`` ... ``I_W`` [W/m²]);
    outputs ``T_<zone>`` [°C]; parameters ``T_<zone>_start`` [°C],
    ``season`` (Integer, mapping in its description) and
    ``start_time_of_week`` [s], and for calendar-dependent models exported
    with a time zone ``start_time`` [s since 1970-01-01T00:00:00Z]: the
    absolute time at FMU time 0, from which the FMU computes the model's
    calendar gains. Communication steps must be whole multiples of the model
    step. See :mod:`hvacfmu.fmu_slave`.
    """
    from .models import load_model

    from .fmu_slave import INTERFACE_FILE, box_limits, calendar_dependent, zone_model_layout

    model_path = Path(model_path)
    model = load_model(model_path)  # validates the file before anything is built
    building = _resolve_building(building, model_path)
    calendar = calendar_dependent(model)
    if calendar:
        timezone = timezone or (getattr(model, "meta", None) or {}).get("timezone")
        if timezone is not None:
            _check_timezone(timezone, model_path)
        else:
            _warn_calendar_gains(model, model_path)
    try:
        layout, _ = zone_model_layout(model, timezone if calendar else None, box_limits(model, building))
    except ValueError as exc:
        raise FMUError(f"cannot export {model_path}: {exc}") from None
    with tempfile.TemporaryDirectory(prefix="hvacfmu_export_") as tmp:
        res = Path(tmp) / "model.json"
        shutil.copyfile(model_path, res)
        interface = Path(tmp) / INTERFACE_FILE
        interface.write_text(json.dumps(layout, indent=1), encoding="utf-8")
        path = _build(slave_script(model.kind), out_path, [res, interface], _documentation(tmp, layout))
    logger.info("exported %s model %s to %s", model.kind, model_path, path)
    return path


def _warn_calendar_gains(model, model_path):
    """Warn that a calendar-dependent model exported without a time zone cannot follow its calendar."""
    import warnings

    from .errors import HvacfmuWarning

    warnings.warn(
        f"{model_path}: the {model.kind} model's internal gains depend on the calendar (e.g. holidays); "
        "without a time zone the FMU uses the seasonal time-of-week profile and will differ from the Python "
        "model on those days: export with timezone=... (hvacfmu export --timezone) to give the FMU the "
        "parameter start_time",
        HvacfmuWarning,
        stacklevel=3,
    )


def _check_timezone(timezone, model_path):
    """FMUError unless ``timezone`` is an IANA time zone name known here."""
    import zoneinfo

    try:
        zoneinfo.ZoneInfo(str(timezone))
    except (zoneinfo.ZoneInfoNotFoundError, ValueError, TypeError):
        raise FMUError(
            f"cannot export {model_path}: unknown time zone {timezone!r}; give an IANA name such as "
            "'America/Los_Angeles'"
        ) from None


def export_plant_fmu(truth_path, out_path) -> Path:
    """Export the emulated building (``truth.json`` of :func:`hvacfmu.emulator.generate`) as a plant FMU.

    The plant FMU has inputs ``m_<vav>`` [kg/s] for every box, ``T_out``,
    ``T_supply`` [°C], facade irradiance ``I_N`` ... ``I_W`` [W/m²]; outputs
    ``T_<zone>`` [°C]; parameters ``T_<zone>_start`` [°C].

    Parameters
    ----------
    truth_path : path
        The emulator's ``truth.json``.
    out_path : path
        FMU to write.
    """
    truth_path = Path(truth_path)
    try:
        truth = json.loads(truth_path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ModelError(f"cannot read plant truth file {truth_path}: {exc}") from None
    from .emulator import Plant
    from .fmu_slave import INTERFACE_FILE, plant_layout

    try:
        plant = Plant.from_truth(truth)  # fails here, not inside the FMU, when the file is unusable
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelError(f"plant truth file {truth_path} is unusable: {type(exc).__name__}: {exc}") from None
    layout = plant_layout(plant, truth)
    with tempfile.TemporaryDirectory(prefix="hvacfmu_export_") as tmp:
        res = Path(tmp) / "truth.json"
        shutil.copyfile(truth_path, res)
        interface = Path(tmp) / INTERFACE_FILE
        interface.write_text(json.dumps(layout, indent=1), encoding="utf-8")
        script = slave_dir() / f"{PLANT_SLAVE}.py"
        path = _build(script, out_path, [res, interface], _documentation(tmp, layout))
    logger.info("exported plant %s to %s", truth_path, path)
    return path


def export_file(path, out_path, *, timezone: str | None = None, native: bool = False, building=None) -> Path:
    """Export a model file or an emulator ``truth.json`` (recognised by its content) as an FMU.

    This is what ``hvacfmu export FILE -o OUT.fmu [--timezone TZ] [--native]`` runs;
    ``timezone`` is passed to :func:`export_fmu` (plants ignore it); ``native``
    writes a native FMU (:func:`hvacfmu.fmu_native.export_native_fmu`, model
    files only); ``building`` (path or Building) gives the box airflow bounds.
    """
    path = Path(path)
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        d = None  # load_model reports it
    plant = isinstance(d, dict) and "kind" not in d and "baseline" in d and "zones" in d
    if native:
        if plant:
            raise FMUError(
                f"{path} is an emulated plant (truth.json): it has no linear equations and cannot be "
                "exported as a native FMU; export it without --native"
            )
        from .fmu_native import export_native_fmu
        from .models import load_model

        return export_native_fmu(
            load_model(path), out_path, model_name=path.name, building=_resolve_building(building, path)
        )
    if plant:
        return export_plant_fmu(path, out_path)
    return export_fmu(path, out_path, timezone=timezone, building=building)


def _documentation(tmp, layout) -> Path:
    """A ``documentation/`` folder (index.html: description, run-time needs, variables) in ``tmp``."""
    from .fmu_description import documentation_html

    d = Path(tmp) / "documentation"
    d.mkdir(exist_ok=True)
    (d / "index.html").write_text(documentation_html(layout, native=False), encoding="utf-8")
    return d


def _build(script: Path, out_path, resources, documentation=None) -> Path:
    """Run the pythonfmu builder in this process, then validate the FMU."""
    from pythonfmu.builder import FmuBuilder

    out_path = Path(out_path)
    if out_path.suffix != ".fmu":
        raise FMUError(f"output file {out_path} must end in .fmu")
    out_path.parent.mkdir(parents=True, exist_ok=True)
    module = script.stem
    saved_path = list(sys.path)
    had_module = module in sys.modules
    t0 = time.perf_counter()
    try:
        path = FmuBuilder.build_FMU(
            script,
            dest=out_path,
            project_files=[Path(r) for r in resources],
            documentation_folder=documentation,
            **BUILD_OPTIONS,
        )
    except ModelError:
        raise
    except Exception as exc:  # noqa: BLE001 - pythonfmu raises plain exceptions
        raise FMUError(f"building the FMU from {script.name} failed: {type(exc).__name__}: {exc}") from exc
    finally:
        sys.path[:] = saved_path
        if not had_module:
            sys.modules.pop(module, None)  # later loads import the FMU's own copy
    logger.debug("pythonfmu built %s in %.2f s", path, time.perf_counter() - t0)
    problems = validate(path)
    if problems:
        raise FMUError(problems_message(f"the FMU {path} is not valid", problems))
    return Path(path)


def export_native_fmu(model, out_path, **kwargs) -> Path:
    """Native FMU of ``model`` (generated C, no Python at run time); see :func:`hvacfmu.fmu_native.export_native_fmu`."""
    from .fmu_native import export_native_fmu as _export

    return _export(model, out_path, **kwargs)


def validate(path, native: bool | None = None) -> list[str]:
    """Problems ``fmpy.validate_fmu`` finds in an FMU, plus hvacfmu's own checks (empty when fine).

    ``native``: the FMU is a native one (C sources, no resources); None: recognised by its ``sources/``.
    """
    from fmpy.validation import validate_fmu

    problems = list(validate_fmu(str(path)))
    with zipfile.ZipFile(path) as z:
        names = set(z.namelist())
    if native is None:
        native = any(n.startswith("sources/") for n in names)
    if native:
        if not any(n.startswith("sources/") and n.endswith(".c") for n in names):
            problems.append("no C sources in the native FMU's sources/")
    elif not any(n.startswith("resources/") and n.endswith((".json",)) for n in names):
        problems.append("no model file (JSON) in the FMU's resources")
    return problems


__all__ = [
    "export_file",
    "export_fmu",
    "export_native_fmu",
    "export_plant_fmu",
    "slave_dir",
    "slave_name",
    "slave_script",
    "slave_specs",
    "validate",
]
