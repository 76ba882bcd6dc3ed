"""The machinery every hvacfmu pythonfmu slave shares: variables, get/set, checks, refusal, state, XML.

Not imported by the FMU: the slave scripts execute this file's text in their own
namespace before the subclass's (:func:`hvacfmu.fmu_slave.define_slave`; why: the
package docstring). It may also be imported as an ordinary module (tests, tools).
"""

from __future__ import annotations

import ctypes
import json
import logging
import math
import traceback
from xml.etree.ElementTree import SubElement

import numpy as np
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Initial, Fmi2Status

from hvacfmu.fmu_slave.values import contiguous


class StepRefused(RuntimeError):
    """A refused ``fmi2DoStep`` (wrong step, bad input, failed initialisation, ...): pythonfmu answers fmi2Fatal."""


class HvacfmuSlaveBase(Fmi2Slave):
    """Machinery shared by the hvacfmu slaves: value storage, checks, logging, XML, state.

    Subclasses implement :meth:`_setup` (read resources, return the variable
    layout), :meth:`_initialize`, :meth:`_advance` and the internal-state hooks.
    No method called by the FMU binary raises, except ``do_step`` when it refuses a step (:meth:`_fail`;
    the contract is in the package docstring).
    """

    author = "hvacfmu"
    #: relative tolerance on "the step is a whole multiple of the model step"
    STEP_RTOL = 1e-9
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
        self._refusal: str | None = None  # why the current step is refused
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
        self._in_block = self._input_vrs if contiguous(self._input_vrs) else None
        self._out_block = self._output_vrs if contiguous(self._output_vrs) else None
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
        """fmi2DoStep: True when the step is taken; a refused step raises :class:`StepRefused` (see :meth:`_fail`)."""
        self._refusal = None
        try:
            ok = self._try_step(current_time, step_size)
        except Exception:  # noqa: BLE001 - a bug or a model failure: refused like any other step
            self._refusal = f"exception in fmi2DoStep at t={current_time} s:\n{traceback.format_exc()}"
            ok = False
        if ok:
            return True
        self._fail(self._refusal or f"the step at t={current_time} s was refused")

    def _try_step(self, current_time, step_size) -> bool:
        """Checks, then :meth:`_advance`; False (after :meth:`_refuse`) when the step is refused."""
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

    def _refuse(self, message) -> bool:
        """Note why the step is refused (reported by :meth:`do_step`); returns False."""
        self._refusal = message
        return False

    def _fail(self, message):
        """Report a refused step (Python logging: stderr when the host configured none) and raise it.

        pythonfmu 0.7.0 cannot answer ``fmi2Error``: a ``do_step`` returning False
        is ``fmi2Discard``, on which FMPy's ``simulate_fmu`` stops and returns the
        truncated result with exit status 0; an exception is ``fmi2Fatal``, on which
        FMPy raises (``fmpy simulate`` exits 1) and the harness stops naming the
        time and status. pythonfmu logs ``Fatal py exception encountered: [doStep] ...
        StepRefused('<message>')`` to the host (when its FMU log is on). pythonfmu then releases its references to this instance,
        its class and its log list (``handle_py_exception``), and releases them
        again if the host still calls ``fmi2FreeInstance`` (``~PySlaveInstance``),
        which FMI forbids after ``fmi2Fatal`` but hosts do (the harness, libcosim);
        one extra reference to each, taken here, keeps both orders safe (in a host
        that never frees the instance, it stays alive: a few kB, once per failure).
        """
        # not self.log: pythonfmu would pass it to the host's logger callback while the exception is pending, and
        # a Python host's callback (FMPy) loses the exception; its message ends up in pythonfmu's fatal log entry
        logging.getLogger("hvacfmu.fmu").error("%s: %s", type(self).__name__, message)
        for obj in (self, type(self), self.log_queue):
            ctypes.pythonapi.Py_IncRef(ctypes.py_object(obj))
        raise StepRefused(message)

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
