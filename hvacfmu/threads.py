"""BLAS on one thread for the small dense algebra of this package.

The matrices here are small (tens to a few hundred rows). A second BLAS thread
only adds synchronisation, and on a shared machine it waits for a core: the
default 51-week diagnosis took 20.4 s wall / 38.9 s CPU with two OpenBLAS
threads on an idle 2-core machine and 21.5 s / 21.5 s with one; at a load of 5
the two-thread run took 110 s wall / 72.5 s CPU against 32 s / 22 s
(``benchmarks/bench_diagnosis.py``). Model B's kernels and the MPC's products
show the same: with the default two OpenBLAS threads under a load of ~10, one
72 x 72 by 72 x 105 product took 0.46 ms instead of 0.07 ms and Model B's
condensed sensitivity 22 ms instead of 1 ms; a 181-state eigendecomposition
took 2 ms to 0.6 s, with erratic timing (``hvacfmu.models.physics``,
``harness.mpc.controller``).
"""

from __future__ import annotations

import contextlib
import functools


@functools.lru_cache(maxsize=1)
def _controller():
    """The process's BLAS thread pools (threadpoolctl), found once; None without threadpoolctl."""
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - threadpoolctl is a dependency
        return None
    return ThreadpoolController()


def one_blas_thread():
    """Context running BLAS on one thread (about 10 µs to enter); the previous limits come back on exit."""
    pools = _controller()
    return contextlib.nullcontext() if pools is None else pools.limit(limits=1, user_api="blas")
