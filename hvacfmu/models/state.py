"""Initial states of a zone model from measured outputs (used by the model FMUs and by MPC).

Only the :class:`~hvacfmu.models.base.ZoneModel` interface is used (``output``,
``step_state``, ``n_states``, ``n_outputs``), so every model kind gets the same start:
the FMU slaves start from :func:`state_from_outputs`, and an MPC run against its own
model's FMU starts from the same state.
"""

from __future__ import annotations

import numpy as np


def output_matrix(model) -> np.ndarray:
    """C (n_outputs, n_states) of the linear output map ``y = output(x)``."""
    nx = model.n_states
    C = np.asarray(model.output(np.eye(nx)), dtype=float).T
    x = np.random.default_rng(1).uniform(15, 25, nx)
    if C.shape != (model.n_outputs, nx) or not np.allclose(C @ x, model.output(x), rtol=1e-12, atol=1e-10):
        raise ValueError("the model's output map is not linear; the FMU needs y = C x")
    return C


def state_from_outputs(model, y0, u=None, v=None, q=None) -> np.ndarray:
    """Initial state with outputs ``y0`` [°C]; unobserved states at their steady state.

    For models whose state is the zone temperatures this is ``x0 = y0``.
    Otherwise (walls, thermal masses, delayed airflows) the unobserved states
    are at their steady state for outputs held at ``y0`` and inputs ``u``
    [kg/s], disturbances ``v`` and gains ``q`` held: the unobserved part of
    ``x = F x + g`` is solved with ``output(x0) = y0`` (the affine step map
    ``F, g`` is found by probing ``step_state``). Without inputs, or if the step is not affine in
    the state, unobserved states start at ``mean(y0)``.

    Parameters
    ----------
    model : ZoneModel
    y0 : array (n_outputs,) [°C]
    u, v, q : arrays, optional
        The model's inputs, disturbances and gain term at the start.
    """
    y0 = np.asarray(y0, dtype=float)
    C = output_matrix(model)
    nx = C.shape[1]
    if C.shape[0] == nx and np.array_equal(C, np.eye(nx)):
        return y0.copy()
    x_ref = np.full(nx, float(np.mean(y0)))
    fallback = x_ref + np.linalg.pinv(C) @ (y0 - C @ x_ref)
    if u is None or v is None or q is None:
        return fallback
    u, v, q = (np.asarray(a, dtype=float) for a in (u, v, q))
    try:
        g = np.asarray(model.step_state(np.zeros(nx), u, v, q), dtype=float)
        F = np.column_stack([np.asarray(model.step_state(e, u, v, q), dtype=float) - g for e in np.eye(nx)])
        probe = np.random.default_rng(2).uniform(10.0, 30.0, nx)
        if not np.allclose(model.step_state(probe, u, v, q), F @ probe + g, rtol=1e-9, atol=1e-9):
            return fallback
        from scipy.linalg import null_space

        N = null_space(C)
        xp = np.linalg.pinv(C) @ y0
        if N.shape[1] == 0:
            return xp
        R = N.T @ (F - np.eye(nx))  # steady state of the unobserved part only
        z = np.linalg.lstsq(R @ N, -(R @ xp + N.T @ g), rcond=None)[0]
        x0 = xp + N @ z
    except Exception:  # noqa: BLE001 - a model whose step cannot be probed keeps the simple start
        return fallback
    return x0 if np.all(np.isfinite(x0)) else fallback
