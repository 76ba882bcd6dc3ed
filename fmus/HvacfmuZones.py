"""pythonfmu slave of the hvacfmu FMUs for models of kind 'zones'.

A unique script and class name per FMU kind: pythonfmu names the FMU's binary
and Python module after them, and FMUs that share a name must not run each
other's code when loaded in one process. Built by ``hvacfmu.fmu``.

All logic is in ``hvacfmu/fmu_slave.py`` (host Python environment). Its source
is executed in this module's namespace instead of being imported, because the
pythonfmu 0.7.0 binary corrupts the interpreter when it frees an instance whose
class or methods were defined in another module (measured: the slave module's
dictionary is cleared and the next instance crashes the host).
"""

import hvacfmu.fmu_slave as _impl

exec(compile(_impl.source(), _impl.__file__, "exec"))  # defines ZoneModelSlave and its bases here


class HvacfmuZones(ZoneModelSlave):  # noqa: F821 - defined by the exec above
    """FMI 2.0 co-simulation slave (zones, resources/model.json)."""
