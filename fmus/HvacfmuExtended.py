"""pythonfmu slave of the hvacfmu FMUs for models of kind 'extended'.

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
    HvacfmuExtended = _hvacfmu_slave_class  # noqa: F821 - the class made at import
else:
    try:
        from hvacfmu.fmu_slave import define_slave as _define
    except ImportError as _exc:  # the host lacks hvacfmu or one of its packages: say so, do not crash
        _define, _missing = None, f"{type(_exc).__name__}: {_exc}"

    if _define is not None:
        import hvacfmu.fmu_exit as _exit

        _exit.install()  # pythonfmu's binary frees its interpreter state twice at exit: see hvacfmu/fmu_exit.py
        _define(globals(), "ZoneModelSlave")  # executes the source of ZoneModelSlave and its bases here
    else:
        from pythonfmu import Fmi2Slave
        from pythonfmu.enums import Fmi2Status

        class ZoneModelSlave(Fmi2Slave):
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

    class HvacfmuExtended(ZoneModelSlave):  # noqa: F821 - defined by the exec above
        """FMI 2.0 co-simulation slave (extended, resources/model.json)."""

    _hvacfmu_slave_class = HvacfmuExtended
