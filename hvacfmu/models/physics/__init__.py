"""Model B: a physics-based RC model built from the building's geometry (BRCM style), bilinear in VAV airflows.

- :func:`assemble` (building, parameters) -> :class:`RCNetwork` (continuous-time,
  sparse; ``.discretize(step)``);
- :class:`PhysicsModel`: the :class:`~hvacfmu.models.base.ZoneModel` of kind
  ``physics`` with ``discrete_matrices()`` / ``continuous_matrices()``
  (:class:`BilinearMatrices`);
- :func:`fit_physics`: the paper's two-step identification.
"""

from __future__ import annotations

from .geometry import PARAM_NAMES, PhysicsSpec, parse_physics, physics_problems
from .identification import fit_physics, refit_gains
from .model import PhysicsModel, kalman_gain
from .network import BilinearMatrices, DiscreteBilinear, NetworkTemplate, RCNetwork


def assemble(building, params=None, *, solar=False, **options) -> RCNetwork:
    """Assemble the continuous-time RC network of ``building`` for parameters ``params``.

    Parameters
    ----------
    building : hvacfmu.building.Building
        With physics tables.
    params : dict or sequence, optional
        ``U_win``, ``gamma_interior_wall``, ``gamma_exterior_wall``,
        ``gamma_floor``, ``gamma_ceiling`` [W/(m2 K)]; default the building's
        ``[physics].nominal``.
    solar : bool
        Model solar gains through windows.
    **options
        ``max_layer_thickness`` [m], ``furniture_capacity``, ``internal_mass`` [J/(K m2)].

    Returns
    -------
    RCNetwork
        ``.continuous_matrices()``, ``.discretize(step).matrices()``.
    """
    spec = parse_physics(building, **options)
    return NetworkTemplate(spec, solar=solar).build(spec.nominal if params is None else params)


__all__ = [
    "PARAM_NAMES",
    "BilinearMatrices",
    "DiscreteBilinear",
    "NetworkTemplate",
    "PhysicsModel",
    "PhysicsSpec",
    "RCNetwork",
    "assemble",
    "fit_physics",
    "refit_gains",
    "kalman_gain",
    "parse_physics",
    "physics_problems",
]
