"""Clean process exit for hosts that loaded pythonfmu FMUs.

The binary that pythonfmu 0.7.0 puts in every FMU (``libpythonfmu-export``)
keeps its interpreter state in a static ``std::shared_ptr<PyState>``, set at the
first ``fmi2Instantiate`` and never reset. At process exit two handlers of that
binary run in this order:

1. the C++ destructor of the static ``shared_ptr`` (registered with
   ``__cxa_atexit`` when the library was loaded) frees the ``PyState`` block;
2. the library's ELF destructor ``finalizePythonInterpreter`` assigns
   ``nullptr`` to that same, already destroyed ``shared_ptr``, so it reads the
   freed block and releases it again.

Whether the second release corrupts the heap depends on what the allocator has
done with the freed block in between, so a process that simulated such an FMU
aborts at exit now and then ("corrupted double-linked list", exit code -6;
shown without doubt by valgrind as an invalid read in
``finalizePythonInterpreter`` of a block freed by ``__run_exit_handlers`` and
allocated in ``pythonfmu::createInstance``). FMPy's ``dlclose`` does not unload
the library (it is marked not deletable), so every copy loaded in the process
takes part.

The cure is to empty each ``shared_ptr`` while the process is still healthy:
calling the library's own exported ``finalizePythonInterpreter`` once from a
Python exit hook sets it to ``nullptr`` (destroying the ``PyState``, whose
worker thread has long finished in a Python host); both exit handlers then see
an empty pointer and do nothing. This is what :func:`install` arranges.

Only in a Python *host* (the process's main thread runs the interpreter, as in
FMPy, pytest or our harness) is this safe. In a C/C++ host that pythonfmu
started Python in, ``finalizePythonInterpreter`` is what ends the interpreter
from the host's side and must not be called from inside Python; those hosts
should use a native FMU (``hvacfmu export --native``).
"""

from __future__ import annotations

import atexit
import ctypes
import os
import threading

_SYMBOL = "finalizePythonInterpreter"
_installed = False


def _loaded_fmu_libraries() -> list[str]:
    """Paths of the FMU binaries (``.../binaries/<platform>/*.so``) mapped into this process."""
    paths: list[str] = []
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as maps:
            for line in maps:
                fields = line.split(maxsplit=5)
                if len(fields) < 6:
                    continue
                path = fields[5].strip()
                if path.endswith(" (deleted)"):
                    path = path[: -len(" (deleted)")]
                if path.endswith(".so") and "/binaries/" in path and path not in paths:
                    paths.append(path)
    except OSError:  # not Linux: nothing to do (the handlers in question are ELF ones)
        return []
    return paths


def _python_is_the_host() -> bool:
    """True when the process's main thread runs this interpreter (FMPy, pytest), not a C host."""
    return threading.main_thread().native_id == os.getpid()


def release_pythonfmu_state() -> int:
    """Empty the ``PyState`` pointer of every pythonfmu binary loaded in this process.

    Returns
    -------
    int
        How many loaded FMU binaries exported ``finalizePythonInterpreter``
        (each was called once). 0 outside a Python host.
    """
    if not _python_is_the_host():
        return 0
    mode = getattr(os, "RTLD_NOLOAD", 4) | getattr(os, "RTLD_NOW", 2)
    done = 0
    for path in _loaded_fmu_libraries():
        try:
            lib = ctypes.CDLL(path, mode=mode)  # only finds an already loaded copy, never loads one
            fn = getattr(lib, _SYMBOL)
        except (OSError, AttributeError):
            continue  # not loaded any more, or not a pythonfmu binary
        fn.restype = None
        fn.argtypes = []
        fn()
        done += 1
    return done


def install() -> None:
    """Register :func:`release_pythonfmu_state` to run at interpreter exit (once per process)."""
    global _installed
    if not _installed:
        atexit.register(release_pythonfmu_state)
        _installed = True
