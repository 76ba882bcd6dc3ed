"""Shared fixtures: small hand-written buildings and models, session-scoped expensive data."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from hvacfmu.building import building_from_dict

# ----------------------------------------------------------------------------- BLAS on one thread
# Each test process runs BLAS on one thread, and the CLI and FMU processes it starts inherit the variables
# (an explicit OPENBLAS_NUM_THREADS / OMP_NUM_THREADS is kept). ``-n 2`` on 2 cores already keeps both cores busy;
# OpenBLAS's own second thread only synchronises and spins on small products (hvacfmu.threads): an emulator
# dataset took 0.85 against 0.56 CPU-s to generate (identical files), a physics FMU cycle 1.16 against 0.19 s,
# and the not-slow tier's tests 329 against 180 CPU-s (session 16, DEVELOPING.md "Working rules").
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
try:
    from threadpoolctl import threadpool_limits

    threadpool_limits(int(os.environ["OPENBLAS_NUM_THREADS"]), user_api="blas")  # numpy is loaded: limit its pool
except ImportError:  # pragma: no cover - threadpoolctl is a dependency
    pass

SMALL_BUILDING = {
    "name": "two rooms",
    "latitude": 37.875,
    "longitude": -122.259,
    "timezone": "America/Los_Angeles",
    "zones": [
        {
            "name": "A",
            "area": 100.0,
            "volume": 300.0,
            "adjacent": ["B"],
            "facades": [{"orientation": "S", "window_area": 10.0, "wall_area": 20.0}],
        },
        {
            "name": "B",
            "area": 50.0,
            "volume": 150.0,
            "adjacent": ["A"],
            "facades": [{"orientation": "N", "window_area": 5.0, "wall_area": 10.0}],
        },
    ],
    "vavs": [
        {"name": "V1", "zone": "A", "m_min": 0.05, "m_max": 0.6},
        {"name": "V2", "zone": "A", "m_min": 0.05, "m_max": 0.6},
        {"name": "V3", "zone": "B", "m_min": 0.03, "m_max": 0.4},
    ],
}


@pytest.fixture
def small_building_dict():
    import copy

    return copy.deepcopy(SMALL_BUILDING)


@pytest.fixture
def small_building():
    return building_from_dict(SMALL_BUILDING)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture
def cli(capsys):
    """``cli(*args)`` runs ``hvacfmu <args>`` in this process (``hvacfmu.cli.main``) and returns a
    ``subprocess.CompletedProcess`` with the exit code and the captured stdout and stderr.

    A Python start-up costs at least 1.7 CPU-s: tests of a command's messages, options and refusals use this;
    each command keeps at least one real ``python -m hvacfmu`` subprocess test. An exception escaping ``main``
    (a traceback for the user) fails the test here as it would print "Traceback" from the subprocess.
    """
    import subprocess

    from hvacfmu.cli import main

    def run(*args):
        argv = [str(a) for a in args]
        capsys.readouterr()
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's usage errors (exit 2), as the command line gives them
            code = exc.code if isinstance(exc.code, int) else 1
        out = capsys.readouterr()
        return subprocess.CompletedProcess(["hvacfmu", *argv], code, out.out, out.err)

    return run


@pytest.fixture(scope="session")
def default_dataset():
    """The emulator's default 51-week dataset, prepared (generated once into $HVACFMU_CACHE)."""
    import warnings

    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset
    from hvacfmu.errors import HvacfmuWarning

    paths = cached_dataset()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(paths.measurements, paths.building)


@pytest.fixture(scope="session")
def default_paths():
    """Files of the emulator's default dataset (51 weeks, seed 0), generated once into $HVACFMU_CACHE."""
    from hvacfmu.emulator import cached_dataset

    return cached_dataset(weeks=51, seed=0)


#: Four emulated weeks across the winter/spring boundary (2026-01-12..02-09, seed 0): two seasons with a test
#: week each, reheat in every week. The not-slow tier's stand-in for the 51-week default dataset, whose
#: generation and preparation cost about 20 CPU-s on an empty cache (this one about 2.5).
WINTER_WEEKS = {"weeks": 4, "seed": 0, "start": "2026-01-12T00:00:00"}


@pytest.fixture(scope="session")
def winter_paths():
    """Files of :data:`WINTER_WEEKS`, generated once into $HVACFMU_CACHE."""
    from hvacfmu.emulator import cached_dataset

    return cached_dataset(**WINTER_WEEKS)


@pytest.fixture(scope="session")
def winter_dataset(winter_paths):
    """:data:`WINTER_WEEKS`, prepared."""
    import warnings

    from hvacfmu.data import prepare
    from hvacfmu.errors import HvacfmuWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(winter_paths.measurements, winter_paths.building)


@pytest.fixture(scope="session")
def short_paths():
    """Files of a short emulator dataset (8 weeks, seed 0), generated once into $HVACFMU_CACHE."""
    from hvacfmu.emulator import cached_dataset

    return cached_dataset(weeks=8, seed=0)


# ----------------------------------------------------------------------------- test cost on a busy machine
# HVACFMU_TEST_CPU=cost.tsv appends one line per test: worker, CPU seconds of the test process (setup + call +
# teardown), CPU seconds of the subprocesses it waited for (CLI runs), wall seconds, test id; and one line per
# worker when its collection ends. On a shared machine wall durations (--durations) grow with the load; CPU
# seconds do not: the tier's CPU total / 2 is its time on a quiet 2-core machine (-n 2, both workers busy).
_COST_FILE = os.environ.get("HVACFMU_TEST_CPU")


def _cpu_seconds():
    t = os.times()
    return t.user + t.system, t.children_user + t.children_system


def _cost_line(*fields):
    with open(_COST_FILE, "a", encoding="utf-8") as f:
        f.write("\t".join(str(x) for x in (os.environ.get("PYTEST_XDIST_WORKER", "-"), *fields)) + "\n")


if _COST_FILE:

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(item, nextitem):
        (s0, c0), w0 = _cpu_seconds(), time.time()
        yield
        (s1, c1), w1 = _cpu_seconds(), time.time()
        _cost_line(f"{s1 - s0:.2f}", f"{c1 - c0:.2f}", f"{w1 - w0:.1f}", item.nodeid)

    def pytest_collection_finish(session):
        s, c = _cpu_seconds()
        _cost_line(f"{s:.2f}", f"{c:.2f}", "", "<collection and start-up>")

    def _log_generations():
        """One line per dataset ``cached_dataset`` generates (empty CPU columns: the seconds are already the
        test's; they are in the text): on an empty cache, which tests pay for which data, and whether both
        workers generated the same dataset at once (its name twice)."""
        import sys

        import hvacfmu.emulator  # noqa: F401

        module = sys.modules["hvacfmu.emulator.generate"]
        plain = module.generate

        def generate(out, *args, **kwargs):
            (s0, _), w0 = _cpu_seconds(), time.time()
            try:
                return plain(out, *args, **kwargs)
            finally:
                (s1, _), w1 = _cpu_seconds(), time.time()
                name = os.path.basename(str(out)).lstrip(".").rsplit("-", 1)[0]
                _cost_line("", "", f"{w1 - w0:.1f}", f"<generated {name}: {s1 - s0:.2f} CPU-s>")

        module.generate = generate

    _log_generations()


# ----------------------------------------------------------------------------- order: the longest module first
#: Modules that start the run, the most CPU-expensive first (full suite, ``-n 1``, empty cache, session 19:
#: ``benchmarks/test_tiers_s19.md``); the rest keep pytest's alphabetical order. pytest-xdist runs with
#: ``--dist loadfile --no-loadscope-reorder`` (``pyproject.toml`` addopts): each worker takes one whole file at a
#: time in this order, so a module's fixtures and per-worker caches (test_diagnosis.py's emulator diagnoses, module
#: fixtures that fit or export) are built once, and with the longest files handed out first (LPT) the two workers
#: end within about the length of the last small file. Under ``load`` (session 16-18) xdist handed out contiguous
#: chunks of tests and a module could run on both workers. A new file that costs more than about 15 CPU-s belongs
#: in this list at its place.
RUN_FIRST = (
    "test_diagnosis.py",  # 462 CPU-s (19 emulator diagnoses of 16 weeks, 8 battery cases)
    "test_fmu_lifecycle.py",  # 149 (60 plant FMU processes)
    "test_bms_walkthrough.py",  # 95 (17 CLI processes)
    "test_energyplus_slow.py",  # 78
    "test_demo.py",  # 65 (one `hvacfmu demo` process)
)


def pytest_collection_modifyitems(config, items):
    first = {name: i for i, name in enumerate(RUN_FIRST)}
    items.sort(key=lambda item: first.get(item.path.name, len(first)))  # stable: the rest keep their order
