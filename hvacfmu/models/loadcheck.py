"""Plausibility of a model read from a file: the checks of a fresh fit, applied again on load (issue 17 p.2, p.5).

A model file is JSON and can be edited, truncated or written by another tool. Its schema
(names, shapes, finite numbers, ``format_version``) is validated by each kind's ``from_dict``;
this module then refuses a model that parses but cannot be a building, so that no command
ever runs an unstable or absurd model and reports its numbers:

- Model A (``lumped``, ``zones``) and the base of an ``extended`` model: every check of
  :func:`~hvacfmu.models.plausibility.linear_problems` (finite, spectral radius < 1, slowest
  time constant, signs of couplings, weather and airflow), plus the internal-gain profile,
  whose steady-state offset ``max |g| / (1 - rho)`` must stay under ``MAX_GAIN_OFFSET_K``
  (fitted six-zone models on the emulator: 31 K);
- ``extended``: the spectral radius of the augmented matrix form at zero airflow
  (coupling, thermal-mass and delay terms) must stay below 1;
- Model B (``physics``): positive finite parameters (a passive RC network with positive
  conductances and capacities is stable, so no eigenvalues are computed at load), finite gains,
  and internal gains of at most ``MAX_GAIN_W_PER_M2`` per zone floor area.

Other kinds (plugins) are loaded as their ``from_dict`` allows.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError, problems_message

#: Largest steady-state offset [K] the internal-gain profile of a linear model may cause.
MAX_GAIN_OFFSET_K = 200.0
#: Largest internal gain [W/m²] of a physics model's zone (a dense server room is about 1000).
MAX_GAIN_W_PER_M2 = 3000.0


def model_problems(model) -> list[str]:
    """Reasons why a loaded ``model`` cannot be a building (empty when plausible)."""
    kind = getattr(model, "kind", None)
    if kind in ("lumped", "zones"):
        return _linear(model)
    if kind == "extended":
        return _extended(model)
    if kind == "physics":
        return _physics(model)
    return []


def require_plausible(model, source: str = "model file"):
    """Return ``model``; raise :class:`ModelError` naming ``source``, every reason and the fix otherwise."""
    problems = model_problems(model)
    if problems:
        raise ModelError(
            problems_message(
                f"{source}: the {getattr(model, 'kind', '?')} model it holds cannot be a building (edited or "
                "corrupted file?); refit it with hvacfmu fit, or restore the file that fit wrote",
                problems,
            )
        )
    return model


def _linear(model) -> list[str]:
    from .plausibility import linear_problems

    problems, numbers = linear_problems(model)
    rho = numbers.get("spectral_radius")
    if not model.gains:
        problems.append("gains: no internal-gain profile for any season (the model cannot predict)")
    if problems or rho is None:
        return problems
    for season, g in model.gains.items():
        g = np.asarray(g, float)
        offset = float(np.max(np.abs(g))) / max(1.0 - rho, 1e-12) if g.size else 0.0
        if offset > MAX_GAIN_OFFSET_K:
            problems.append(
                f"gains[{season!r}]: the internal-gain profile (up to {np.max(np.abs(g)):.3g} K per step) moves "
                f"the steady state by {offset:.3g} K, above {MAX_GAIN_OFFSET_K:g} K"
            )
    return problems


def _extended(model) -> list[str]:
    problems = [f"base: {p}" for p in _linear(model.base)]
    if problems:
        return problems
    try:
        eq = model.equations()
    except ModelError:  # calendar terms: no time-invariant matrices; their coefficients were checked on load
        return []
    rho = float(np.max(np.abs(np.linalg.eigvals(eq.A)))) if eq.A.size else 0.0
    if not np.isfinite(rho) or rho >= 1.0:
        problems.append(
            f"unstable: the spectral radius of the extended model's state matrix is {rho:.6g} >= 1 "
            "(an extension term's coefficient makes temperatures grow without bound)"
        )
    return problems


def _physics(model) -> list[str]:
    # A passive RC network with positive conductances and capacities is stable, and its exact
    # discretisation too: positive finite parameters are the stability check (no eigenvalues here,
    # which would cost seconds at every load of a 270-state model).
    problems = []
    bad = {k: v for k, v in model.params.items() if not (np.isfinite(v) and v > 0)}
    if bad:
        problems.append(f"params {bad} must be finite and > 0")
    if not np.all(np.isfinite(model.f_ig_const)):
        problems.append("f_ig_const: constant internal gains are not finite")
    areas = np.array([model.building.zone(z).area for z in model.outputs], float)
    for season, g in model.gains.items():
        g = np.asarray(g, float)
        if g.ndim == 2 and g.shape[1] >= len(areas):
            per_area = np.max(np.abs(g[:, : len(areas)]), axis=0) / areas
            if np.any(per_area > MAX_GAIN_W_PER_M2):
                i = int(np.argmax(per_area))
                problems.append(
                    f"gains[{season!r}]: internal gain of zone {model.outputs[i]} reaches {per_area[i]:.3g} W/m², "
                    f"above {MAX_GAIN_W_PER_M2:g} W/m²"
                )
    return problems


__all__ = ["MAX_GAIN_OFFSET_K", "MAX_GAIN_W_PER_M2", "model_problems", "require_plausible"]
