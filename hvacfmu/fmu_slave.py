"""Run-time side of the hvacfmu FMUs: generic pythonfmu slaves.

The FMU binary built by pythonfmu calls into the host's Python interpreter and
imports the slave script named in ``resources/slavemodule.txt`` (one of
``fmus/Hvacfmu*.py``). Those scripts are one-line subclasses of the classes
here, so every FMU runs the same code and only its ``resources`` differ:

- :class:`ZoneModelSlave` runs any saved :class:`~hvacfmu.models.ZoneModel`
  (``resources/model.json``) through the model interface only
  (``step_state``/``output``/``gains``), so new model kinds work unchanged;
- :class:`PlantSlave` runs the emulated building
  (:class:`hvacfmu.emulator.Plant`, ``resources/truth.json``).

This is the only module (with :mod:`hvacfmu.fmu`) that speaks FMI, hence the
camelCase in the model description. Behaviour an importer can rely on:

- **Step sizes.** A communication step must be a whole multiple ``k >= 1`` of
  the model step (``DefaultExperiment/@stepSize``, 900 s by default); the state
  is advanced ``k`` model steps with the inputs held (zero-order hold). Any
  other step, or a step that does not start at the slave's current time, is
  refused: ``fmi2DoStep`` returns ``fmi2Discard`` with a logged message and
  the state is unchanged. The FMU declares
  ``canHandleVariableCommunicationStepSize="false"``. (The plant slave
  accepts any positive step: the emulator integrates exactly.)
- **Bad values.** NaN or out-of-range inputs (bounds in the model description)
  and steps before initialisation are refused the same way (``fmi2Discard`` +
  error log). A Python exception inside a step is logged with its traceback and
  also returns ``fmi2Discard``; the instance stays usable.
- **Never raise.** pythonfmu 0.7.0 turns a Python exception in *any* callback
  into ``fmi2Fatal`` and then leaves the slave module half-freed in
  ``sys.modules``: the next instance of the same FMU in that process fails or
  crashes the host (measured, segmentation fault). So no callback here raises.
  A model file that cannot be read (corrupt, newer format version, replaced)
  is reported in the log at ``fmi2Instantiate`` and ``fmi2ExitInitializationMode``
  and every ``fmi2DoStep`` returns ``fmi2Discard`` with the reason; the
  variables still exist because their layout is read from
  ``resources/interface.json`` (written at export). Getting or setting a
  variable of the wrong type or an unknown value reference is logged as an
  error and makes the next ``fmi2DoStep`` return ``fmi2Discard``.
- **State.** ``fmi2GetFMUstate``/``fmi2SetFMUstate`` and their serialisation
  save and restore the full internal state vector, the clock, the inputs and
  the parameters exactly (JSON of Python floats round-trips bit for bit).
- **Initial state.** Parameters ``T_<zone>_start`` set the outputs; unobserved
  states start at their steady state for those temperatures and the inputs
  set before ``fmi2ExitInitializationMode`` (see :func:`state_from_outputs`).
- **Time of week.** The internal-gain profile (a time-of-week table per season)
  is indexed at FMU time ``t`` by slot
  ``floor((start_time_of_week + t) / step) mod n_slots``; ``start_time_of_week``
  [s since Monday 00:00 local time] is the time of week at FMU time 0. The FMU
  clock has no daylight-saving shifts; a master that wants them (or any
  calendar) sets the optional input ``time_of_week`` [s] to the local time of
  week of each step's start (the harness does), which then places the profile.
- **Calendar.** A model whose internal gains depend on the date itself
  (:func:`calendar_dependent`: e.g. an extended model with holiday or
  daylight-saving terms, ``internal_gain_schedule``) and exported with a time
  zone has the extra parameter ``start_time`` [s]: the absolute time at FMU
  time 0 as a Unix epoch (seconds since 1970-01-01T00:00:00Z). When it is set
  (>= 0), the gains of model step ``k`` are the model's own
  ``gains_at(index, season)`` at the instant ``start_time + t_start + k*step``
  in the exported time zone (``timezone`` in ``resources/interface.json`` and
  in the parameter's description), exactly as in Python; ``start_time_of_week``
  and the ``time_of_week`` input are then ignored. Left at -1 (default), the
  FMU uses the seasonal time-of-week profile without the calendar (a warning
  is logged at initialisation). Models without calendar terms have no
  ``start_time`` and behave as described above.
"""

from __future__ import annotations

import json
import math
import operator
import traceback
from pathlib import Path
from xml.etree.ElementTree import SubElement

import numpy as np
from pythonfmu import DefaultExperiment, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Initial, Fmi2Status

#: version of the slave's variable layout; stored in the FMU description
SLAVE_API_VERSION = 1

#: physical bounds checked on every input before a step (min, max)
BOUNDS = {
    "degC": (-60.0, 80.0),
    "kg/s": (0.0, 50.0),
    "W/m2": (0.0, 2000.0),
}

_FACADES = {"N": "north", "E": "east", "S": "south", "W": "west"}

#: relative tolerance on "the step is a whole multiple of the model step"
_STEP_RTOL = 1e-9


def source() -> str:
    """Source text of this module; the slave scripts in ``fmus/`` execute it in their own namespace."""
    return Path(__file__).read_text(encoding="utf-8")


def tuple_getter(indices):
    """A fast function ``values -> tuple(values[i] for i in indices)``."""
    indices = list(indices)
    if not indices:
        return lambda values: ()
    get = operator.itemgetter(*indices)
    if len(indices) == 1:
        return lambda values: (get(values),)
    return get


def sanitize_name(name: str) -> str:
    """An FMI variable name without ``.``, ``[`` or ``]`` (any non-word character becomes ``_``)."""
    out = "".join(c if (c.isalnum() or c == "_") else "_" for c in str(name))
    return out if out and not out[0].isdigit() else "_" + out


def signal_unit(name: str) -> str | None:
    """Unit of a frame column / signal name (README nomenclature)."""
    if name.startswith(("T_", "Td_")):  # zone, outdoor, supply and discharge air temperatures
        return "degC"
    if name.startswith("m_"):
        return "kg/s"
    if name.startswith("I_") or name == "ghi":
        return "W/m2"
    return None


#: plausible ranges of disturbance inputs by name prefix (checked before every step)
SIGNAL_BOUNDS = {
    "T_out": (-60.0, 60.0),
    "T_supply": (0.0, 80.0),
    "Td_": (0.0, 80.0),
}

#: box airflow upper bound = this factor x the box's design maximum ``m_max`` (measured flows overshoot
#: ``m_max`` by a few per cent through sensor error and loop overshoot: up to 2 % in the emulated data)
M_MAX_MARGIN = 1.2


def signal_bounds(name: str):
    """(min, max) of an input signal: by name (``T_out``, ``T_supply*``, ``Td_*``) or by unit."""
    for prefix, bounds in SIGNAL_BOUNDS.items():
        if name == prefix or (prefix.endswith("_") and name.startswith(prefix)) or name.startswith(prefix + "_"):
            return bounds
    return BOUNDS.get(signal_unit(name) or "", (None, None))


def box_limits(model, building=None) -> dict:
    """Box name -> {"zone", "m_min", "m_max"} [kg/s] from ``building`` or the model's own building (physics).

    Empty when neither is known (data-driven model files keep only the building's name and hash).
    """
    b = building if building is not None else getattr(model, "building", None)
    if b is None:
        b = getattr(getattr(model, "base", None), "building", None)
    try:
        return {v.name: {"zone": v.zone, "m_min": float(v.m_min), "m_max": float(v.m_max)} for v in b.vavs}
    except AttributeError:
        return {}


def box_entry(b: str, limits: dict | None) -> dict:
    """Layout entry of the airflow input of box ``b``; bounds and nominal from its ``limits`` when known."""
    if not limits:
        return _entry(
            "m",
            sanitize_name(f"m_{b}"),
            "Real",
            "input",
            0.0,
            "kg/s",
            f"Supply air mass flow rate of VAV box {b} [kg/s]",
            BOUNDS["kg/s"],
        )
    hi = round(M_MAX_MARGIN * limits["m_max"], 12)
    e = _entry(
        "m",
        sanitize_name(f"m_{b}"),
        "Real",
        "input",
        0.0,
        "kg/s",
        f"Supply air mass flow rate of VAV box {b} serving zone {limits['zone']} [kg/s]; design range "
        f"m_min={limits['m_min']:g} to m_max={limits['m_max']:g} kg/s (building file), accepted up to "
        f"{M_MAX_MARGIN:g} x m_max",
        (0.0, hi),
    )
    e["nominal"] = limits["m_max"]
    return e


def signal_description(name: str) -> str:
    """A description a Modelica or EnergyPlus user can map by eye."""
    if name == "T_out":
        return "Outdoor air dry-bulb temperature [degC] (EnergyPlus: Site Outdoor Air Drybulb Temperature)"
    if name == "T_supply":
        return "Supply (discharge) air temperature of the VAV boxes [degC]"
    if name.startswith("T_supply_"):
        return f"Supply air temperature of air handler {name[len('T_supply_') :]} [degC]"
    if name.startswith("Td_"):
        return f"Discharge air temperature of VAV box {name[3:]} [degC] (after its reheat coil)"
    if name == "ghi":
        return "Global horizontal irradiance [W/m2]"
    if name.startswith("I_") and name[2:] in _FACADES:
        return (
            f"Total solar irradiance on a vertical {_FACADES[name[2:]]}-facing facade [W/m2] "
            "(EnergyPlus: Surface Outside Face Incident Solar Radiation Rate per Area)"
        )
    if name.startswith("m_"):
        return f"Air mass flow rate of {name[2:]} [kg/s]"
    return name


INTERFACE_FILE = "interface.json"


def _normalise(obj):
    """JSON round trip (tuples -> lists, numpy scalars -> floats) for comparing layouts."""
    return json.loads(json.dumps(obj, default=float))


class HvacfmuSlaveBase(Fmi2Slave):
    """Machinery shared by the hvacfmu slaves: value storage, checks, logging, XML, state.

    Subclasses implement :meth:`_setup` (read resources, return the variable
    layout), :meth:`_initialize`, :meth:`_advance` and the internal-state hooks.
    No method called by the FMU binary raises (see the module docstring).
    """

    author = "hvacfmu"
    license = "BSD-3-Clause"

    log_categories = {
        "logStatusWarning": "Log messages with fmi2Warning status.",
        "logStatusDiscard": "Log messages with fmi2Discard status.",
        "logStatusError": "Log messages with fmi2Error status.",
        "logStatusFatal": "Log messages with fmi2Fatal status.",
        "logAll": "Log all messages.",
    }

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._values: list = []  # value by value reference
        self._spec: list = []  # variable layout entries by value reference
        self._kind: list = []  # by vr: 0 = Real input/output, 1 = Real fixed parameter, 2 = Integer parameter
        self._lo_list: list = []  # bounds by vr (infinite when none)
        self._hi_list: list = []
        self._fixed_vrs: list = []
        self._input_vrs: list = []
        self._output_vrs: list = []
        self._bad: dict = {}  # vr -> value of inputs outside their bounds (or NaN)
        self._pending: str | None = None  # error from a get/set, reported by the next step
        self._initialized = False
        self._broken: str | None = None  # the FMU cannot run (unreadable resources)
        self._failed: str | None = None  # initialisation failed
        self._t = 0.0
        self._t_start = 0.0
        try:
            layout = self._setup()
        except Exception:  # noqa: BLE001 - never raise into pythonfmu
            layout = None
            self._broken = "the FMU could not be set up:\n" + traceback.format_exc()
        if layout:
            for entry in layout:
                self._declare(entry)
        # contiguous blocks of inputs and outputs: fast paths for the usual "set all, get all" calls
        self._in_block = self._input_vrs if _contiguous(self._input_vrs) else None
        self._out_block = self._output_vrs if _contiguous(self._output_vrs) else None
        self._in_lo = np.array([self._lo_list[vr] for vr in self._input_vrs], dtype=float)
        self._in_hi = np.array([self._hi_list[vr] for vr in self._input_vrs], dtype=float)
        self._unchecked = False  # inputs set by the fast path, bounds not checked yet
        self._w = None  # checked input block as an array (None: stale)
        if self._broken:
            self.log(self._broken, Fmi2Status.error)

    # ------------------------------------------------------------ declaring
    def _declare(self, entry):
        """Register one variable from a layout entry; returns its value reference."""
        vr = len(self._values)
        name, vtype, causality = entry["name"], entry["type"], entry["causality"]
        lo, hi = entry.get("min"), entry.get("max")
        self._values.append(entry["start"])
        self._spec.append(entry)
        self._kind.append(2 if vtype != "Real" else (1 if causality == "parameter" else 0))
        self._lo_list.append(-math.inf if lo is None or causality != "input" else lo)
        self._hi_list.append(math.inf if hi is None or causality != "input" else hi)
        kw = dict(description=entry.get("description") or None, getter=lambda vr=vr: self._values[vr])
        if causality == "input":
            var = Real(name, causality=Fmi2Causality.input, variability=Fmi2Variability.continuous, **kw)
            self._input_vrs.append(vr)
        elif causality == "output":
            var = Real(
                name,
                causality=Fmi2Causality.output,
                variability=Fmi2Variability.discrete,
                initial=Fmi2Initial.calculated,
                **kw,
            )
            self._output_vrs.append(vr)
        else:
            cls = Real if vtype == "Real" else Integer
            var = cls(
                name,
                causality=Fmi2Causality.parameter,
                variability=Fmi2Variability.fixed,
                initial=Fmi2Initial.exact,
                **kw,
            )
            self._fixed_vrs.append(vr)
        var.setter = lambda value, vr=vr: self._values.__setitem__(vr, value)
        self.register_variable(var, nested=False)
        return vr

    def vrs_with_role(self, role) -> list:
        """Value references of the layout entries with ``role``."""
        return [vr for vr, e in enumerate(self._spec) if e.get("role") == role]

    # ------------------------------------------------------------ values (fast paths, never raise)
    def _bad_access(self, what, vrs):
        msg = f"{what}: invalid value reference(s) or type in {list(vrs)!r}; ignored"
        self._pending = msg
        self.log(msg, Fmi2Status.error)

    def get_real(self, vrs):
        if vrs == self._out_block:
            a = vrs[0]
            return self._values[a : a + len(vrs)]
        values, kind = self._values, self._kind
        try:
            out = []
            for vr in vrs:
                if kind[vr] == 2:
                    raise TypeError
                out.append(float(values[vr]))
            return out
        except Exception:  # noqa: BLE001
            self._bad_access("fmi2GetReal", vrs)
            return [math.nan] * len(vrs)

    def get_integer(self, vrs):
        try:
            out = []
            for vr in vrs:
                if self._kind[vr] != 2:
                    raise TypeError
                out.append(int(self._values[vr]))
            return out
        except Exception:  # noqa: BLE001
            self._bad_access("fmi2GetInteger", vrs)
            return [0] * len(vrs)

    def get_boolean(self, vrs):
        self._bad_access("fmi2GetBoolean (no Boolean variables)", vrs)
        return [False] * len(vrs)

    def get_string(self, vrs):
        self._bad_access("fmi2GetString (no String variables)", vrs)
        return [""] * len(vrs)

    def set_real(self, vrs, values):
        if vrs == self._in_block and len(values) == len(vrs):
            a = vrs[0]
            self._values[a : a + len(vrs)] = values
            self._bad.clear()
            self._unchecked = True  # checked (vectorised) by the next step
            self._w = None
            return
        store, lo, hi, kind, bad = self._values, self._lo_list, self._hi_list, self._kind, self._bad
        self._w = None
        try:
            for vr, value in zip(vrs, values):
                k = kind[vr]
                if k != 0:
                    if k == 2:
                        raise TypeError
                    if self._initialized:
                        self._reject_fixed(vr, value)
                        continue
                store[vr] = value
                # NaN fails both comparisons
                if not (lo[vr] <= value <= hi[vr]):
                    bad[vr] = value
                elif bad:
                    bad.pop(vr, None)
        except Exception:  # noqa: BLE001
            self._bad_access("fmi2SetReal", vrs)

    def set_integer(self, vrs, values):
        try:
            for vr, value in zip(vrs, values):
                if self._kind[vr] != 2:
                    raise TypeError
                if self._initialized:
                    self._reject_fixed(vr, value)
                    continue
                self._values[vr] = int(value)
        except Exception:  # noqa: BLE001
            self._bad_access("fmi2SetInteger", vrs)

    def set_boolean(self, vrs, values):
        self._bad_access("fmi2SetBoolean (no Boolean variables)", vrs)

    def set_string(self, vrs, values):
        self._bad_access("fmi2SetString (no String variables)", vrs)

    def _reject_fixed(self, vr, value):
        self.log(
            f"{self._spec[vr]['name']} is a fixed parameter; setting it to {value!r} after initialisation "
            "is not allowed and was ignored (set it before fmi2ExitInitializationMode)",
            Fmi2Status.error,
        )

    # ------------------------------------------------------------ lifecycle
    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        try:
            self._t_start = float(start_time)
            self._t = float(start_time)
        except Exception:  # noqa: BLE001
            self._pending = f"fmi2SetupExperiment: invalid start time {start_time!r}"

    def exit_initialization_mode(self):
        if self._broken:
            self.log(self._broken, Fmi2Status.error)
            return
        try:
            problems = self._initialize()
        except Exception:  # noqa: BLE001 - never raise into pythonfmu
            problems = ["initialisation raised an exception:\n" + traceback.format_exc()]
        if problems:
            self._failed = "initialisation failed: " + "; ".join(problems)
            self.log(self._failed, Fmi2Status.error)
            self._initialized = False
        else:
            self._initialized = True
            self._failed = None

    def do_step(self, current_time, step_size):
        try:
            if self._broken:
                return self._refuse(self._broken)
            if self._pending:
                msg, self._pending = self._pending, None
                return self._refuse(f"step refused after an earlier error: {msg}")
            if not self._initialized:
                return self._refuse(
                    self._failed
                    or (
                        "fmi2DoStep called before initialisation; call fmi2SetupExperiment, "
                        "fmi2EnterInitializationMode and fmi2ExitInitializationMode first"
                    )
                )
            if self._unchecked:
                self._check_inputs()
            if self._bad:
                names = ", ".join(
                    f"{self._spec[vr]['name']}={value!r} (allowed [{self._lo_list[vr]}, {self._hi_list[vr]}] "
                    f"{self._spec[vr].get('unit') or ''})"
                    for vr, value in sorted(self._bad.items())
                )
                return self._refuse(f"at t={current_time} s: invalid input value(s): {names}; step not taken")
            if abs(current_time - self._t) > 1e-9 * max(1.0, abs(self._t)):
                return self._refuse(
                    f"fmi2DoStep at t={current_time!r} s but the FMU is at t={self._t!r} s; "
                    "steps must be contiguous (restore a saved FMU state to go back in time)"
                )
            return self._advance(current_time, step_size)
        except Exception:  # noqa: BLE001 - reported to the importer, instance stays usable
            self.log(f"exception in fmi2DoStep at t={current_time} s:\n{traceback.format_exc()}", Fmi2Status.error)
            return False

    def _check_inputs(self):
        """Bounds (and NaN) check of the inputs set by the fast path."""
        self._unchecked = False
        vrs = self._input_vrs
        a = vrs[0]
        w = np.array(self._values[a : a + len(vrs)], dtype=float)
        ok = (w >= self._in_lo) & (w <= self._in_hi)
        if not ok.all():
            for j in np.flatnonzero(~ok):
                self._bad[vrs[j]] = float(w[j])
        else:
            self._w = w

    def _refuse(self, message):
        self.log(message, Fmi2Status.error)
        return False

    # ------------------------------------------------------------ state
    def _get_fmu_state(self):
        try:
            return {
                "values": list(self._values),
                "bad": [[vr, v] for vr, v in self._bad.items()],
                "t": self._t,
                "t_start": self._t_start,
                "initialized": self._initialized,
                "failed": self._failed,
                "internal": self._get_internal_state(),
            }
        except Exception:  # noqa: BLE001
            self._pending = "fmi2GetFMUstate failed:\n" + traceback.format_exc()
            self.log(self._pending, Fmi2Status.error)
            return {}

    def _set_fmu_state(self, state):
        try:
            if not state:
                raise ValueError("empty FMU state (its fmi2GetFMUstate had failed)")
            values = list(state["values"])
            if len(values) != len(self._values):
                raise ValueError(f"FMU state has {len(values)} variables, this FMU {len(self._values)}")
            self._set_internal_state(state["internal"])
            self._values[:] = values
            self._bad = {int(vr): v for vr, v in state["bad"]}
            self._unchecked = bool(self._input_vrs)  # check the restored inputs at the next step
            self._w = None
            self._t = float(state["t"])
            self._t_start = float(state["t_start"])
            self._initialized = bool(state["initialized"])
            self._failed = state["failed"]
        except Exception:  # noqa: BLE001
            self._pending = "fmi2SetFMUstate failed, state unchanged:\n" + traceback.format_exc()
            self.log(self._pending, Fmi2Status.error)

    @staticmethod
    def _fmu_state_to_bytes(state) -> bytes:
        try:
            return json.dumps(state).encode("utf-8")  # NaN inputs are written as NaN and read back
        except Exception:  # noqa: BLE001
            return b"{}"

    @staticmethod
    def _fmu_state_from_bytes(state: bytes):
        try:
            return json.loads(bytes(state).decode("utf-8"))
        except Exception:  # noqa: BLE001 - _set_fmu_state reports the empty state
            return {}

    # ------------------------------------------------------------ model description
    def to_xml(self, model_options=dict()):  # noqa: B006 - pythonfmu's signature
        """The model description, completed for ``fmpy validate`` (units, bounds, model structure)."""
        root = super().to_xml(model_options)
        root.set("variableNamingConvention", "flat")
        try:
            from hvacfmu import __version__

            root.set("version", f"hvacfmu {__version__}")
        except ImportError:  # pragma: no cover
            pass
        cs = root.find("CoSimulation")
        cs.set("canHandleVariableCommunicationStepSize", "true" if self.VARIABLE_STEP else "false")
        from hvacfmu.fmu_description import type_definitions, unit_definitions, variable_type

        # <UnitDefinitions> and <TypeDefinitions> (one type per quantity) go right after <CoSimulation>
        at = list(root).index(cs) + 1
        units = unit_definitions(self._spec)
        if units is not None:
            root.insert(at, units)
            at += 1
        root.insert(at, type_definitions(self._spec))
        for sv, spec in zip(root.find("ModelVariables"), self._spec):
            typ = sv[0]
            typ.set("declaredType", variable_type(spec)[0])
            if spec.get("unit") and spec["type"] == "Real":
                typ.set("unit", spec["unit"])
            for key in ("min", "max", "nominal"):
                if spec.get(key) is not None:
                    typ.set(key, repr(float(spec[key])) if spec["type"] == "Real" else str(int(spec[key])))
        # complete model structure: outputs have no direct feedthrough from inputs;
        # at initialisation they depend on the start-value parameters
        structure = root.find("ModelStructure")
        for child in list(structure):
            structure.remove(child)
        start_deps = " ".join(str(vr + 1) for vr in self.vrs_with_role("y0"))
        outs = SubElement(structure, "Outputs")
        for vr in self._output_vrs:
            SubElement(outs, "Unknown", index=str(vr + 1), dependencies="")
        init = SubElement(structure, "InitialUnknowns")
        for vr in self._output_vrs:
            SubElement(init, "Unknown", index=str(vr + 1), dependencies=start_deps)
        return root

    # ------------------------------------------------------------ to implement
    #: whether any positive communication step is handled exactly
    VARIABLE_STEP = False

    def _setup(self) -> list:
        """Read the resources; return the variable layout (list of entries). May raise."""
        raise NotImplementedError

    def _initialize(self) -> list:
        """Set the initial state from the parameters; return a list of problems."""
        raise NotImplementedError

    def _advance(self, current_time, step_size) -> bool:
        raise NotImplementedError

    def _get_internal_state(self):
        raise NotImplementedError

    def _set_internal_state(self, state):
        raise NotImplementedError


#: (kind, digest of the resource files) -> what ``_setup`` built from them; models and plants are immutable,
#: so instances of one FMU share them instead of loading (and, for physics, discretising) them again
_SETUP_CACHE: dict = {}
_SETUP_CACHE_SIZE = 8


def _cached_setup(kind: str, resources, names, build):
    """``build()`` for the resource files ``names``, reused while their bytes are unchanged (errors not cached)."""
    import hashlib

    digest = hashlib.sha256()
    for name in names:
        path = Path(resources or ".") / name
        digest.update(name.encode() + b"\0" + (path.read_bytes() if path.is_file() else b"<missing>") + b"\0")
    key = (kind, digest.hexdigest())
    if key not in _SETUP_CACHE:
        value = build()
        while len(_SETUP_CACHE) >= _SETUP_CACHE_SIZE:
            _SETUP_CACHE.pop(next(iter(_SETUP_CACHE)))
        _SETUP_CACHE[key] = value
    return _SETUP_CACHE[key]


def _contiguous(vrs) -> bool:
    return bool(vrs) and list(vrs) == list(range(vrs[0], vrs[0] + len(vrs)))


def _entry(role, name, vtype, causality, start, unit=None, description="", bounds=(None, None)):
    return {
        "role": role,
        "name": name,
        "type": vtype,
        "causality": causality,
        "start": start,
        "unit": unit,
        "description": description,
        "min": bounds[0],
        "max": bounds[1],
    }


def _stored_timezone(resources) -> str | None:
    """The ``timezone`` written at export into ``interface.json`` (None when absent or unreadable)."""
    try:
        return json.loads((Path(resources or ".") / INTERFACE_FILE).read_text(encoding="utf-8")).get("timezone")
    except Exception:  # noqa: BLE001 - read_layout reports an unreadable file
        return None


def _stored_boxes(resources) -> dict | None:
    """The box limits written at export into ``interface.json`` ({} when absent, None when unreadable)."""
    try:
        return json.loads((Path(resources or ".") / INTERFACE_FILE).read_text(encoding="utf-8")).get("boxes", {})
    except Exception:  # noqa: BLE001 - read_layout reports an unreadable file
        return None


def read_layout(resources, model_layout, resource_name):
    """The FMU's variable layout: ``interface.json`` when present, checked against the model's.

    Returns ``(layout, problem)``; ``problem`` is None when the model matches.
    """
    path = Path(resources or ".") / INTERFACE_FILE
    stored = None
    if path.is_file():
        try:
            stored = json.loads(path.read_text(encoding="utf-8"))
        except Exception as exc:  # noqa: BLE001
            return (model_layout, f"{path} is unreadable: {exc}")
    if model_layout is None:
        return (stored, None)
    if stored is not None and _normalise(stored) != _normalise(model_layout):
        return (
            stored,
            f"resources/{resource_name} does not match the FMU's variables ({INTERFACE_FILE}); "
            "was the file replaced? Export the FMU again",
        )
    return (model_layout, None)


# =============================================================================
# zone models
# =============================================================================
def box_names(model) -> tuple:
    """VAV box names of a model: ``model.vavs``, ``model.base.vavs`` or ``model.building.vav_names``."""
    for get in (lambda m: m.vavs, lambda m: m.base.vavs, lambda m: m.building.vav_names):
        try:
            names = tuple(get(model) or ())
        except AttributeError:
            continue
        if names:
            return names
    return ()


def input_matrix(model) -> tuple[np.ndarray | None, tuple]:
    """The linear map from VAV-box airflows to the model's controlled inputs.

    Probes ``model.signals`` with unit airflows, so it works for every model
    kind that sums (or passes through) box airflows. Box names come from
    :func:`box_names`.

    Returns
    -------
    M : array (n_inputs, n_vavs) or None
        ``u = M @ m_vav``; None when the model has no per-box airflows.
    vavs : tuple of str
        Box names (empty when M is None).
    """
    import pandas as pd

    vavs = box_names(model)
    if not vavs:
        return None, ()
    n = len(vavs)
    idx = pd.date_range("2025-09-01", periods=n + 2, freq=f"{int(model.step)}s", tz="UTC")
    rng = np.random.default_rng(0)
    m = np.vstack([np.zeros(n), np.eye(n), rng.uniform(0.0, 1.0, n)])
    cols = {f"m_{b}": m[:, j] for j, b in enumerate(vavs)}
    for d in model.disturbances:
        cols[d] = np.full(n + 2, 1.0)
    for z in model.outputs:
        cols.setdefault(f"T_{z}", np.full(n + 2, 21.0))
    for z in getattr(model, "measured_zones", ()) or ():
        cols.setdefault(f"T_{z}", np.full(n + 2, 21.0))
    try:
        u, _ = model.signals(pd.DataFrame(cols, index=idx))
    except KeyError:
        return None, ()
    u = np.asarray(u, dtype=float)
    if u.shape != (n + 2, model.n_inputs) or np.any(u[0] != 0.0):
        return None, ()
    M = (u[1 : n + 1] - u[0]).T
    if not np.allclose(M @ m[-1], u[-1], rtol=1e-12, atol=1e-12):
        return None, ()
    return M, vavs


def output_matrix(model) -> np.ndarray:
    """C (n_outputs, n_states) of the linear output map (:func:`hvacfmu.models.state.output_matrix`)."""
    from hvacfmu.models.state import output_matrix as _output_matrix

    return _output_matrix(model)


def state_from_outputs(model, y0, u=None, v=None, q=None) -> np.ndarray:
    """Initial state with outputs ``y0`` [°C] (:func:`hvacfmu.models.state.state_from_outputs`)."""
    from hvacfmu.models.state import state_from_outputs as _state_from_outputs

    return _state_from_outputs(model, y0, u, v, q)


def calendar_dependent(model) -> bool:
    """True if the model's internal gains depend on the date, not only on the time of week.

    That is a model overriding :meth:`~hvacfmu.models.ZoneModel.gains_at` with
    calendar terms: an ``internal_gain_schedule`` term (holidays, daylight-saving
    shift), or gains that differ from the seasonal time-of-week profile on some
    day of a year in UTC.
    """
    import pandas as pd

    from hvacfmu.models.base import ZoneModel
    from hvacfmu.timeutil import time_of_week

    if type(model).gains_at is ZoneModel.gains_at:
        return False
    if any(getattr(t, "cause", None) == "internal_gain_schedule" for t in getattr(model, "terms", ())):
        return True
    index = pd.date_range("2025-01-06", "2026-01-05", freq=f"{int(model.step)}s", tz="UTC", inclusive="left")
    for season, prof in model.gains.items():
        prof = np.asarray(prof)
        plain = prof[time_of_week(index, model.step) % len(prof)]
        if not np.array_equal(np.asarray(model.gains_at(index, season)), plain):
            return True
    return False


def zone_model_layout(model, timezone: str | None = None, boxes: dict | None = None) -> tuple[dict, np.ndarray | None]:
    """Variable layout of the FMU of a zone model, and the box-to-input matrix.

    Parameters
    ----------
    model : ZoneModel
    timezone : str, optional
        IANA time zone of the building (e.g. ``America/Los_Angeles``). Given for a
        :func:`calendar_dependent` model, the layout gets the parameter
        ``start_time`` [s, Unix epoch] and the key ``timezone`` (see the module
        docstring); ignored for other models.
    boxes : dict, optional
        Box name -> ``{"zone", "m_min", "m_max"}`` (:func:`box_limits`): airflow
        inputs get ``max = M_MAX_MARGIN * m_max``, ``nominal = m_max`` and the zone
        in their description; stored as ``boxes`` in the layout. Default: the
        model's own building when it has one (physics), else generic bounds.

    Returns
    -------
    layout : dict
        JSON-ready: ``variables`` (in value-reference order) and model facts.
    M : array (n_inputs, n_vavs) or None
        ``u = M @ m_vav`` (see :func:`input_matrix`).
    """
    M, vavs = input_matrix(model)
    step = float(model.step)
    seasons = [str(s) for s in model.gains]
    boxes = {str(k): dict(v) for k, v in (boxes if boxes is not None else box_limits(model)).items()}
    var = []
    if M is not None:
        for b in vavs:
            var.append(box_entry(b, boxes.get(b)))
    else:
        for name in model.inputs:
            var.append(
                box_entry(name[2:], boxes.get(name[2:]))
                if name.startswith("m_") and name[2:] in boxes
                else _entry(
                    "m", sanitize_name(name), "Real", "input", 0.0, "kg/s", signal_description(name), BOUNDS["kg/s"]
                )
            )
    for name in model.disturbances:
        var.append(
            _entry(
                "v",
                sanitize_name(name),
                "Real",
                "input",
                _signal_start(name),
                signal_unit(name),
                signal_description(name),
                signal_bounds(name),
            )
        )
    var.append(
        _entry(
            "tow_in",
            "time_of_week",
            "Real",
            "input",
            -1.0,
            "s",
            "Optional: local time of week at the start of the step [s since Monday 00:00]; when >= 0 it "
            "places the internal-gain profile instead of the FMU clock (follow daylight-saving time); "
            "-1 (default): use start_time_of_week + time",
            (-1.0, 7 * 86400.0),
        )
    )
    label = "the floor (area-weighted mean)" if model.kind == "lumped" else "zone"
    for z in model.outputs:
        var.append(
            _entry(
                "y",
                sanitize_name(f"T_{z}"),
                "Real",
                "output",
                21.0,
                "degC",
                f"Air temperature of {label} {z} [degC] (EnergyPlus: Zone Mean Air Temperature)",
            )
        )
    for z in model.outputs:
        var.append(
            _entry(
                "y0",
                sanitize_name(f"T_{z}_start"),
                "Real",
                "parameter",
                21.0,
                "degC",
                f"Initial air temperature of {z} [degC]",
                BOUNDS["degC"],
            )
        )
    mapping = ", ".join(f"{i + 1} = {s}" for i, s in enumerate(seasons))
    var.append(
        _entry(
            "season",
            "season",
            "Integer",
            "parameter",
            1,
            None,
            f"Season of the internal-gain profile: {mapping}",
            (1, len(seasons)),
        )
    )
    var.append(
        _entry(
            "tow",
            "start_time_of_week",
            "Real",
            "parameter",
            0.0,
            "s",
            "Local time of week at FMU time 0 [s since Monday 00:00]; places the internal-gain "
            "profile: slot = floor((start_time_of_week + time)/step) mod slots",
            (0.0, 7 * 86400.0),
        )
    )
    calendar = timezone is not None and calendar_dependent(model)
    if calendar:
        var.append(
            _entry(
                "t_abs",
                "start_time",
                "Real",
                "parameter",
                -1.0,
                "s",
                "Absolute time at FMU time 0 [s since 1970-01-01T00:00:00Z, Unix epoch]; when >= 0 the "
                f"internal gains follow the model's calendar (holidays, daylight saving time in {timezone}) "
                "at start_time + time, and start_time_of_week and the time_of_week input are ignored; "
                "-1 (default): time-of-week profile without the calendar",
                (-1.0, None),
            )
        )
    names = [v["name"] for v in var]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"FMU variable names clash after sanitising: {dup}")
    layout = {
        "slave_api": SLAVE_API_VERSION,
        "kind": model.kind,
        "step": step,
        "seasons": seasons,
        "n_states": int(model.n_states),
        "description": (
            f"hvacfmu {model.kind} zone model: {model.n_outputs} zone temperature(s), {model.n_states} states, "
            f"model step {step:g} s (communication steps must be whole multiples of it). "
            "Runs in the host's Python, which needs the hvacfmu package."
        ),
        "variables": var,
    }
    if calendar:
        layout["timezone"] = str(timezone)
    if boxes:
        layout["boxes"] = {b: boxes[b] for b in sorted(boxes)}
    return layout, M


def _signal_start(name: str) -> float:
    """Start value of a disturbance input: typical conditions (15 degC outdoors, 14 degC supply air, no sun)."""
    if name == "T_out":
        return 15.0
    if name.startswith(("T_supply", "Td_")):
        return 14.0
    return 0.0


class ZoneModelSlave(HvacfmuSlaveBase):
    """FMU slave for any saved ZoneModel (``resources/model.json``).

    Variables (value references in this order):

    - inputs ``m_<vav>`` [kg/s] per VAV box (summed to the model's inputs with
      its input map), or the model's own inputs when it has no box map;
    - inputs for the model's disturbances (``T_out``, ``T_supply`` [°C],
      ``I_N`` ... ``I_W`` [W/m²] when used);
    - outputs ``T_<zone>`` [°C] (``T_floor`` for the lumped model);
    - parameters ``T_<zone>_start`` [°C], ``season`` (Integer, mapping in its
      description), ``start_time_of_week`` [s], and ``start_time`` [s, Unix
      epoch] for calendar-dependent models (see the module docstring).
    """

    #: model steps of internal gains computed at once from the calendar
    CALENDAR_CHUNK = 672

    MODEL_FILE = "model.json"

    def _setup(self):
        self.model = None
        problem = None
        try:

            def build():
                from hvacfmu.models import load_model  # host environment

                model = load_model(Path(self.resources or ".") / self.MODEL_FILE)
                return (model,) + zone_model_layout(
                    model, _stored_timezone(self.resources), _stored_boxes(self.resources)
                )

            model, layout, M = _cached_setup("model", self.resources, (self.MODEL_FILE, INTERFACE_FILE), build)
            layout = json.loads(json.dumps(layout, default=float))  # each instance its own copy
        except Exception as exc:  # noqa: BLE001 - reported, never raised
            model, layout, M = None, None, None
            from hvacfmu.errors import HvacfmuError

            detail = str(exc) if isinstance(exc, HvacfmuError) else traceback.format_exc()
            problem = f"cannot use the FMU's model file resources/{self.MODEL_FILE}: {detail}"
        layout, mismatch = read_layout(self.resources, layout, self.MODEL_FILE)
        problem = problem or mismatch
        if problem:
            self._broken = problem
        if layout is None:
            return []
        self.description = layout["description"]
        self.default_experiment = DefaultExperiment(start_time=0.0, stop_time=7 * 86400.0, step_size=layout["step"])
        self.seasons = tuple(layout["seasons"])
        self._step = float(layout["step"])
        self._timezone = layout.get("timezone")
        self._abs0 = None  # start_time [s] when the calendar is used
        self._q_chunk = (None, None)  # (first model step, gains) computed from the calendar
        if model is not None and not problem:
            self.model = model
            self._M = M
            self._MT = None if M is None else np.ascontiguousarray(M.T)
        self._x = None
        self._k = 0  # model steps taken since the start time
        self._slot0 = 0
        self._profile = None
        self._n_slots = None
        return layout["variables"]

    def _initialize(self):
        v = self._values
        self._y_vrs = self.vrs_with_role("y")
        self._y_start = self._y_vrs[0] if _contiguous(self._y_vrs) else None
        self._y0_vrs = self.vrs_with_role("y0")
        m_vrs, v_vrs, c_vrs = self.vrs_with_role("m"), self.vrs_with_role("v"), self.vrs_with_role("tow_in")
        self._nm = len(m_vrs)
        self._nmv = len(m_vrs) + len(v_vrs)
        self._has_clock_input = bool(c_vrs)
        in_vrs = m_vrs + v_vrs + c_vrs
        self._w_ok = in_vrs == self._input_vrs  # the checked input block is (m, v, time_of_week) in this order
        if _contiguous(in_vrs) and self._w_ok:
            a, b = in_vrs[0], in_vrs[0] + len(in_vrs)
            self._get_inputs = lambda values: values[a:b]
        else:
            self._get_inputs = tuple_getter(in_vrs)
        (season_vr,) = self.vrs_with_role("season")
        (tow_vr,) = self.vrs_with_role("tow")
        problems = []
        y0 = [v[vr] for vr in self._y0_vrs]
        lo, hi = BOUNDS["degC"]
        for vr, val in zip(self._y0_vrs, y0):
            if not (lo <= val <= hi):
                problems.append(f"{self._spec[vr]['name']}={val!r} degC is outside [{lo}, {hi}]")
        season = v[season_vr]
        if not (isinstance(season, int) and 1 <= season <= len(self.seasons)):
            problems.append(
                f"season={season!r} is not one of " + ", ".join(f"{i + 1} ({s})" for i, s in enumerate(self.seasons))
            )
        tow = v[tow_vr]
        if not (0.0 <= tow <= 7 * 86400.0):
            problems.append(f"start_time_of_week={tow!r} s is outside [0, 604800]")
        abs_vrs = self.vrs_with_role("t_abs")
        self._abs0 = None
        self._q_chunk = (None, None)
        if abs_vrs:
            t_abs = v[abs_vrs[0]]
            if t_abs == -1.0:
                self.log(
                    "start_time is not set (-1): the internal gains follow the time-of-week profile "
                    "without the model's calendar (holidays, daylight saving time); set start_time "
                    "[s, Unix epoch] to the absolute time at FMU time 0",
                    Fmi2Status.warning,
                )
            elif not (math.isfinite(t_abs) and t_abs >= 0.0):
                problems.append(f"start_time={t_abs!r} s is neither -1 (unset) nor a Unix epoch time >= 0")
            else:
                self._abs0 = float(t_abs)
        if problems:
            return problems
        self._season = season
        self._profile = np.asarray(self.model.gains[self.seasons[season - 1]], dtype=float)
        self._n_slots = self._profile.shape[0]
        # slot of model step k: floor((tow + t_start)/step) + k  (mod n_slots)
        self._slot0 = int(math.floor((tow + self._t_start) / self._step + 1e-9))
        # inputs set before fmi2ExitInitializationMode (FMPy applies the first input row) start the state
        w = np.array(self._get_inputs(v), dtype=float)
        nm, nmv = self._nm, self._nmv
        if not np.all(np.isfinite(w)):
            return ["inputs at initialisation are not finite"]
        u0 = w[:nm] @ self._MT if self._MT is not None else w[:nm]
        if self._abs0 is not None:
            q0 = self._calendar_gains(0, 1)[0]
        else:
            q0 = self._profile[self._slot(w, 0) % self._n_slots]
        self._x = state_from_outputs(self.model, np.asarray(y0, dtype=float), u0, w[nm:nmv], q0)
        self._k = 0
        self._t = self._t_start
        self._write_outputs(np.asarray(self.model.output(self._x), dtype=float).tolist())
        return []

    def _slot(self, w, k):
        """Gain-profile slot of model step ``k``: from the ``time_of_week`` input when set, else the clock."""
        if self._has_clock_input and w[self._nmv] >= 0.0:
            return int(math.floor(w[self._nmv] / self._step + 1e-9))
        return self._slot0 + k

    def _calendar_gains(self, k, n):
        """Internal gains (n, n_q) of model steps ``k .. k+n-1`` from the model's calendar (``gains_at``).

        The instants are ``start_time + t_start + j*step`` [s, Unix epoch], in
        the exported time zone, computed in whole milliseconds so that they
        equal the timestamps of a data index exactly. Gains are computed for
        :attr:`CALENDAR_CHUNK` steps at a time and reused.
        """
        first, q = self._q_chunk
        if q is None or k < first or k + n > first + len(q):
            import pandas as pd

            m = max(n, self.CALENDAR_CHUNK)
            t0_ms = int(round((self._abs0 + self._t_start) * 1000.0))
            ms = t0_ms + (k + np.arange(m, dtype=np.int64)) * int(round(self._step * 1000.0))
            index = pd.DatetimeIndex(pd.to_datetime(ms, unit="ms", utc=True)).tz_convert(self._timezone)
            q = np.asarray(self.model.gains_at(index, self.seasons[self._season - 1]), dtype=float)
            first = k
            self._q_chunk = (first, q)
        return q[k - first : k - first + n]

    def _write_outputs(self, y):
        a = self._y_start
        if a is not None:
            self._values[a : a + len(y)] = y
            return
        values = self._values
        for vr, val in zip(self._y_vrs, y):
            values[vr] = val

    def _advance(self, current_time, step_size):
        k = step_size / self._step
        n = int(round(k))
        if n < 1 or abs(k - n) > _STEP_RTOL * max(1.0, k):
            return self._refuse(
                f"communication step {step_size!r} s at t={current_time} s is not a whole multiple of the "
                f"model step {self._step:g} s; step refused (use a step of k*{self._step:g} s, k >= 1)"
            )
        w = self._w if self._w_ok else None
        if w is None:
            w = np.array(self._get_inputs(self._values), dtype=float)
        nm = self._nm
        u = w[:nm] @ self._MT if self._MT is not None else w[:nm]
        vdist = w[nm : self._nmv]
        x, model, prof, ns = self._x, self.model, self._profile, self._n_slots
        if self._abs0 is not None:
            for qj in self._calendar_gains(self._k, n):
                x = model.step_state(x, u, vdist, qj)
        else:
            slot = self._slot(w, self._k)
            for j in range(n):
                x = model.step_state(x, u, vdist, prof[(slot + j) % ns])
        y = np.asarray(model.output(x), dtype=float).tolist()
        if not math.isfinite(sum(y)):
            return self._refuse(
                f"the zone temperatures became non-finite in the step from t={current_time} s; step refused"
            )
        self._x = x
        self._k += n
        self._t = self._t_start + self._k * self._step
        self._write_outputs(y)
        return True

    def _get_internal_state(self):
        return {
            "x": None if self._x is None else self._x.tolist(),
            "k": self._k,
            "slot0": self._slot0,
            "season": getattr(self, "_season", None),
            "abs0": self._abs0,
        }

    def _set_internal_state(self, state):
        x = None if state["x"] is None else np.array(state["x"], dtype=float)
        season = state["season"]
        if season is not None:
            self._profile = np.asarray(self.model.gains[self.seasons[season - 1]], dtype=float)
            self._n_slots = self._profile.shape[0]
            self._season = season
        self._x = x
        self._k = int(state["k"])
        self._slot0 = int(state["slot0"])
        self._abs0 = state.get("abs0")
        self._q_chunk = (None, None)


# =============================================================================
# the emulated plant
# =============================================================================
FACADE_INPUTS = ("I_N", "I_E", "I_S", "I_W")


def plant_layout(plant, truth: dict) -> dict:
    """Variable layout of the plant FMU (:class:`hvacfmu.emulator.Plant`)."""
    var = []
    for b in plant.vavs:
        var.append(
            _entry(
                "m",
                sanitize_name(f"m_{b}"),
                "Real",
                "input",
                0.0,
                "kg/s",
                f"Supply air mass flow rate of VAV box {b} [kg/s]",
                BOUNDS["kg/s"],
            )
        )
    for name, start in (("T_out", 15.0), ("T_supply", 14.0)) + tuple((i, 0.0) for i in FACADE_INPUTS):
        unit = signal_unit(name)
        var.append(_entry("v", name, "Real", "input", start, unit, signal_description(name), BOUNDS[unit]))
    var.append(
        _entry(
            "ghi",
            "ghi",
            "Real",
            "input",
            -1.0,
            "W/m2",
            "Global horizontal irradiance [W/m2]; when >= 0 the facade irradiance is computed from it "
            "with the emulator's own model (Erbs + Perez) and I_N..I_W are ignored; "
            "-1 (default): use I_N..I_W",
            (-1.0, BOUNDS["W/m2"][1]),
        )
    )
    var.append(
        _entry(
            "exc",
            "excitation",
            "Real",
            "input",
            0.0,
            None,
            "1 while a forced-response experiment overrides the boxes (their local reheat loops are "
            "off and reset), 0 otherwise (default)",
            (0.0, 1.0),
        )
    )
    for z in plant.zones:
        var.append(
            _entry(
                "y",
                sanitize_name(f"T_{z}"),
                "Real",
                "output",
                21.0,
                "degC",
                f"Air temperature of zone {z} [degC] (EnergyPlus: Zone Mean Air Temperature)",
            )
        )
    for z in plant.zones:
        var.append(
            _entry(
                "y0",
                sanitize_name(f"T_{z}_start"),
                "Real",
                "parameter",
                21.0,
                "degC",
                f"Initial air temperature of zone {z} (all its nodes) [degC]",
                BOUNDS["degC"],
            )
        )
    var.append(
        _entry(
            "local_reheat",
            "local_reheat",
            "Integer",
            "parameter",
            0,
            None,
            "1: the boxes keep their local reheat loops (the building's own heating sequence; the "
            "commanded airflows replace only the airflow loops); 0 (default): no reheat",
            (0, 1),
        )
    )
    var += plant_discharge_entries(plant)
    start = truth.get("start", "?")
    return {
        "slave_api": SLAVE_API_VERSION,
        "kind": "plant",
        "step": PLANT_STEP,
        "start": start,
        "timezone": truth.get("timezone"),
        "span": float(plant.horizon),
        "description": (
            f"hvacfmu emulated building (plant): {len(plant.zones)} zones, {len(plant.vavs)} VAV boxes. "
            f"FMU time is seconds since the emulated dataset's start {start} ({truth.get('timezone')}); "
            f"defined for {plant.horizon:g} s. Communication steps must be multiples of {PLANT_STEP:g} s. "
            "Runs in the host's Python, which needs the hvacfmu package."
        ),
        "variables": var,
    }


#: internal step of the emulated plant [s]; communication steps must be multiples of it
PLANT_STEP = 60.0


# ----- plant: discharge air commands (issue 13 p.3; kept apart from the rest of the plant slave)
def plant_discharge_entries(plant) -> list:
    """Optional inputs ``Td_<vav>`` [degC] of the plant FMU: the discharge air each box heats its supply air to.

    Appended after every other variable (earlier value references unchanged). The start value 0 degC
    (below any supply air) means no reheat by this input: a box whose ``Td_`` is not set discharges at
    its unit's supply temperature, as the plant did before these inputs existed.
    """
    return [
        _entry(
            "td",
            sanitize_name(f"Td_{b}"),
            "Real",
            "input",
            0.0,
            "degC",
            f"Discharge air temperature command of VAV box {b} [degC]: the box reheats its supply air to it "
            "(m c_p (Td - T_supply)); at or below the supply temperature (default 0): no reheat",
            BOUNDS["degC"],
        )
        for b in plant.vavs
    ]


def plant_discharge_reheat(plant, values, td_vrs, m, T_supply):
    """Reheat power [W] per box from the ``Td_`` inputs (None when every one is at or below its supply air)."""
    Td = np.array([values[vr] for vr in td_vrs], dtype=float)
    if not Td.size or np.all(Td <= np.min(T_supply)):
        return None
    return plant.discharge_reheat(m, T_supply, Td)


class PlantSlave(HvacfmuSlaveBase):
    """FMU slave of the emulated building (``resources/truth.json``).

    Inputs ``m_<vav>`` [kg/s] for every box, ``T_out``, ``T_supply`` [°C],
    ``I_N`` ... ``I_W`` [W/m²], optional ``ghi`` [W/m²] (facades from it
    when >= 0), ``excitation`` (0/1) and ``Td_<vav>`` [°C] (discharge air
    commands, :func:`plant_discharge_entries`; unset: no reheat); outputs ``T_<zone>`` [°C]; parameters ``T_<zone>_start``
    [°C], ``local_reheat`` (0/1). FMU time is seconds since the dataset start.
    """

    TRUTH_FILE = "truth.json"

    def _setup(self):
        self.plant = None
        problem = None
        try:

            def build():
                from hvacfmu.emulator import Plant  # host environment

                truth = json.loads((Path(self.resources or ".") / self.TRUTH_FILE).read_text(encoding="utf-8"))
                plant = Plant.from_truth(truth)
                return plant, plant_layout(plant, truth)

            plant, layout = _cached_setup("plant", self.resources, (self.TRUTH_FILE, INTERFACE_FILE), build)
            layout = json.loads(json.dumps(layout, default=float))  # each instance its own copy
        except Exception as exc:  # noqa: BLE001 - reported, never raised
            plant, layout = None, None
            problem = f"cannot use the FMU's plant file resources/{self.TRUTH_FILE}: {type(exc).__name__}: {exc}"
        layout, mismatch = read_layout(self.resources, layout, self.TRUTH_FILE)
        problem = problem or mismatch
        if problem:
            self._broken = problem
        if layout is None:
            return []
        self.description = layout["description"]
        self.default_experiment = DefaultExperiment(start_time=0.0, stop_time=7 * 86400.0, step_size=900.0)
        if plant is not None and not problem:
            self.plant = plant
        self._x = None
        return layout["variables"]

    def _initialize(self):
        v = self._values
        self._y_vrs = self.vrs_with_role("y")
        m_vrs, v_vrs = self.vrs_with_role("m"), self.vrs_with_role("v")
        self._get_m = tuple_getter(m_vrs)
        self._get_v = tuple_getter(v_vrs)
        y0 = [v[vr] for vr in self.vrs_with_role("y0")]
        lo, hi = BOUNDS["degC"]
        problems = [
            f"{self._spec[vr]['name']}={val!r} degC is outside [{lo}, {hi}]"
            for vr, val in zip(self.vrs_with_role("y0"), y0)
            if not (lo <= val <= hi)
        ]
        k0 = self._t_start / PLANT_STEP
        if abs(k0 - round(k0)) > 1e-9 * max(1.0, k0) or self._t_start < 0:
            problems.append(f"start time {self._t_start} s must be a non-negative multiple of {PLANT_STEP:g} s")
        (rh_vr,) = self.vrs_with_role("local_reheat")
        if v[rh_vr] not in (0, 1):
            problems.append(f"local_reheat={v[rh_vr]!r} must be 0 or 1")
        if problems:
            return problems
        self._run = self.plant.with_local_reheat(bool(v[rh_vr]))
        (self._ghi_vr,) = self.vrs_with_role("ghi")
        (self._exc_vr,) = self.vrs_with_role("exc")
        self._td_vrs = self.vrs_with_role("td")
        self._x = self._run.initial_state(np.asarray(y0, dtype=float))
        self._t = self._t_start
        for vr, val in zip(self._y_vrs, self.plant.zone_temperatures(self._x).tolist()):
            v[vr] = val
        return []

    def _advance(self, current_time, step_size):
        n = step_size / PLANT_STEP
        if n < 1 - 1e-9 or abs(n - round(n)) > _STEP_RTOL * max(1.0, n):
            return self._refuse(
                f"communication step {step_size!r} s at t={current_time} s is not a whole multiple of the "
                f"plant step {PLANT_STEP:g} s; step refused"
            )
        if current_time + step_size > self.plant.horizon + 1e-6:
            return self._refuse(
                f"the step to t={current_time + step_size} s goes beyond the emulated span "
                f"({self.plant.horizon:g} s from the dataset start); step refused"
            )
        values = self._values
        w = self._get_v(values)
        t, dt = round(current_time / PLANT_STEP) * PLANT_STEP, round(n) * PLANT_STEP
        ghi = values[self._ghi_vr]
        irr = self._run.facades_from_ghi(t, dt, ghi) if ghi >= 0 else np.array(w[2:6], dtype=float)
        m = np.array(self._get_m(values), dtype=float)
        x, T = self._run.advance(
            self._x,
            t,
            dt,
            m,
            w[0],
            w[1],
            irr,
            reheat=plant_discharge_reheat(self._run, values, self._td_vrs, m, w[1]),
            excitation=values[self._exc_vr] >= 0.5,
        )
        self._x = x
        self._t = current_time + step_size
        for vr, val in zip(self._y_vrs, T.tolist()):
            values[vr] = val
        return True

    def _get_internal_state(self):
        return {"x": None if self._x is None else self._x.tolist()}

    def _set_internal_state(self, state):
        self._x = None if state["x"] is None else np.array(state["x"], dtype=float)
