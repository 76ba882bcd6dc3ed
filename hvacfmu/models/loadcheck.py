"""Plausibility of a model read from a file: the checks of a fresh fit, applied again on load (issue 17 p.2, p.5).

A model file is JSON and can be edited, truncated or written by another tool. Its schema
(names, shapes, finite numbers, ``format_version``) is validated by each kind's ``from_dict``;
this module then refuses a model that parses but cannot be a building, so that no command
ever runs an unstable or absurd model and reports its numbers:

- Model A (``lumped``, ``zones``) and the base of an ``extended`` model: every check of
  :func:`~hvacfmu.models.plausibility.linear_problems` (finite, spectral radius < 1, slowest
  time constant, signs of couplings, weather and airflow), plus the internal-gain profile,
  whose per-step heat may not exceed ``MAX_GAIN_STEP_K`` (no internal gain warms a zone by 50 K in
  one step; fitted models: under 5 K per step), output weights that are area shares, a 0/1
  box-to-state map, and coefficients whose steady-state response to a generous swing of every
  input stays under ``MAX_RESPONSE_K`` (:func:`response_k`). The limits refuse edited or
  scaled files, not slow buildings: a model fitted on closed-loop data can have a nearly
  integrating zone (an EnergyPlus small office: 568 K response, gains moving the steady state by
  1,360 K), and every model a fit accepts must load again;
- ``extended``: the spectral radius of the augmented matrix form at zero airflow
  (coupling, thermal-mass and delay terms) must stay below 1, at zero disturbances and, with a
  disturbance that multiplies the state (``Bxv``: wind infiltration), at that disturbance's swing;
- Model B (``physics``): positive finite parameters (a passive RC network with positive
  conductances and capacities is stable, so no eigenvalues are computed at load), finite gains,
  and internal gains of at most ``MAX_GAIN_W_PER_M2`` per zone floor area.

Other kinds (plugins) are loaded as their ``from_dict`` allows.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError, problems_message

#: Largest internal gain [K per step] of a linear model's profile (fitted models: under 5 K per step).
MAX_GAIN_STEP_K = 50.0
#: Largest steady-state response [K] of a linear model's state to a generous swing of all its inputs
#: (fitted models: 6-15 K on the emulator, 568 K on a nearly integrating EnergyPlus zone).
MAX_RESPONSE_K = 1.0e4
#: Largest internal gain [W/m²] of a physics model's zone (a dense server room is about 1000).
MAX_GAIN_W_PER_M2 = 3000.0
#: Largest change [K] of a state in one step that its boxes at ``m_max`` may cause (airflow form): air that leaves a
#: box cannot take the room past its own temperature, and room and supply air are less than 30 K apart in any
#: building (fitted models: under 2 K on the emulator).
MAX_STEP_DRIVE_K = 30.0
#: Largest share of the gap between inlet air and room that the boxes at ``m_max`` may close in one step
#: (delivered-heat form): a fully mixed room reaches its inlet temperature only with infinite airflow.
MAX_GAP_SHARE = 1.0


def model_problems(model) -> list[str]:
    """Reasons why a loaded ``model`` cannot be a building (empty when plausible)."""
    kind = getattr(model, "kind", None)
    if getattr(model, "seasonal", False):  # one coefficient set per season: every set is checked
        return [f"season {s}: {p}" for s in model.seasons for p in model_problems(model.for_season(s))]
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


def box_drive(model, building) -> dict:
    """State name -> ``(what, value)``: what the state's boxes at their ``m_max`` do in one step.

    ``("K", v)``: airflow form, ``v = sum_j |B u_j|`` [K per step] with ``u_j`` box j at its ``m_max``;
    ``("share", v)``: delivered-heat form, ``v = beta c_p sum_j m_max_j`` [-], the share of the gap between the
    boxes' inlet air and the state closed in one step. Empty for models without such coefficients (physics)
    or boxes the building does not declare (``building_mismatch`` names them).
    """
    linear = getattr(model, "base", model)
    if getattr(linear, "kind", None) not in ("lumped", "zones") or building is None:
        return {}
    limits = {v.name: float(v.m_max) for v in getattr(building, "vavs", ())}
    boxes = [str(v) for v in linear.vavs]
    if any(b not in limits for b in boxes):
        return {}
    m_max = np.array([limits[b] for b in boxes])
    out: dict = {}
    Bbox = np.abs(np.asarray(linear.B, float) @ np.asarray(linear.input_map, float))  # state x box
    drive_k = Bbox @ m_max
    beta = getattr(linear, "beta", None)
    from .heat import CP_AIR

    for i, name in enumerate(linear.outputs):
        if beta is not None:
            share = abs(float(beta[i])) * CP_AIR / 1000.0 * float(np.asarray(linear.heat_map, float)[i] @ m_max)
            out[name] = ("share", share, float(drive_k[i]))
        else:
            out[name] = ("K", float(drive_k[i]), 0.0)
    return out


def box_drive_problems(model, building) -> list[str]:
    """Reasons why ``model``'s box coefficients cannot be a building with ``building``'s box limits.

    An airflow gain that moves a state by more than :data:`MAX_STEP_DRIVE_K` in one step at the boxes' ``m_max``,
    or a delivered-heat coefficient that closes more than :data:`MAX_GAP_SHARE` of the gap to the inlet air in
    one step (the room would overshoot the air that cools or heats it): an edited file or a unit slip (airflow
    in L/s fitted as kg/s), never a fit on kg/s data.
    """
    if getattr(model, "seasonal", False):  # one coefficient set per season: every set is checked
        return [f"season {s}: {p}" for s in model.seasons for p in box_drive_problems(model.for_season(s), building)]
    problems = []
    for name, (what, value, extra_k) in box_drive(model, building).items():
        if what == "K" and value > MAX_STEP_DRIVE_K:
            problems.append(
                f"state {name}: its boxes at m_max ({building.name!r}) move it by {value:.3g} K in one step, above "
                f"{MAX_STEP_DRIVE_K:g} K (no supply air is that far from the room): the airflow coefficients (B) "
                "are too large, an edited model file or airflows fitted in other units than kg/s"
            )
        elif what == "share" and (value > MAX_GAP_SHARE or extra_k > MAX_STEP_DRIVE_K):
            problems.append(
                f"state {name}: its boxes at m_max ({building.name!r}) close {value:.3g} of the gap to their inlet "
                f"air in one step (at most {MAX_GAP_SHARE:g}: the room would overshoot the air that heats or cools "
                "it): the delivered-heat coefficient (beta) is too large, an edited model file or airflows fitted in "
                "other units than kg/s"
                if value > MAX_GAP_SHARE
                else f"state {name}: its boxes at m_max ({building.name!r}) move it by {extra_k:.3g} K in one step "
                f"through B, above {MAX_STEP_DRIVE_K:g} K: an edited model file"
            )
    return problems


def require_box_drive(model, building, what: str = "the model") -> None:
    """Raise :class:`ModelError` naming ``what`` and every :func:`box_drive_problems` reason, if there are any
    (``evaluate``, ``diagnose --model``, ``cosim``: where a model meets the building it is run with)."""
    problems = box_drive_problems(model, building)
    if problems:
        raise ModelError(problems_message(f"{what} cannot be a model of building {building.name!r}", problems))


def _linear(model, free_airflow=()) -> list[str]:
    from .plausibility import linear_problems

    problems, numbers = linear_problems(model, free_airflow=free_airflow)
    problems += _maps(model)
    rho = numbers.get("spectral_radius")
    if not model.gains:
        problems.append("gains: no internal-gain profile for any season (the model cannot predict)")
    if problems or rho is None:
        return problems
    problems += _response(model)
    for season, g in model.gains.items():
        g = np.asarray(g, float)
        peak = float(np.max(np.abs(g))) if g.size else 0.0
        if peak > MAX_GAIN_STEP_K:
            problems.append(
                f"gains[{season!r}]: the internal-gain profile warms a zone by up to {peak:.3g} K per step, "
                f"above {MAX_GAIN_STEP_K:g} K per step"
            )
    return problems


def _maps(model) -> list[str]:
    """Output weights (area shares: >= 0, rows summing to 1) and the box-to-state map (0/1, one state per box)."""
    problems = []
    W = np.asarray(model.output_weights, float)
    if np.any(W < 0) or not np.allclose(W.sum(axis=1), 1.0, rtol=0, atol=1e-6):
        problems.append("output_weights: each row must hold shares >= 0 summing to 1 (zone area weights)")
    M = np.asarray(model.input_map, float)
    if not np.all(np.isin(M, (0.0, 1.0))) or not np.all(M.sum(axis=0) == 1.0):
        problems.append("input_map: every VAV box must feed exactly one state (entries 0 or 1)")
    return problems


def _signal_scale(name: str) -> float:
    """A generous swing of one input [its unit]: 50 K for temperatures, 1000 W/m² for irradiance, 20 m/s of wind,
    1 otherwise."""
    if name.startswith("T"):
        return 50.0
    if name.startswith(("I_", "ghi")):
        return 1000.0
    if name == "wind":
        return 20.0
    return 1.0


def response_k(eq) -> np.ndarray:
    """Steady-state response [K] of each state to every input swinging by its :func:`_signal_scale`, all at once.

    ``(I - A)^-1`` times the absolute input matrices: ``|Bu|`` at 1 kg/s per box, ``|Bv|`` at the
    disturbance scale, the bilinear ``|Bxu|``, ``|Bvu|`` at 1 kg/s times 50 K or the disturbance scale,
    the disturbance products ``|Bxv_j|``, ``|Bvv_j|`` at disturbance j's scale times 50 K or the disturbance
    scale, and the switches' gains. Fitted models on the emulator: under 15 K.
    """
    nx = eq.A.shape[0]
    sv = np.array([_signal_scale(d) for d in eq.disturbances])
    drive = np.abs(eq.Bu).sum(axis=1) + np.abs(eq.Bv) @ sv
    for M in eq.Bxu:
        drive = drive + 50.0 * np.abs(np.asarray(M, float)).sum(axis=1)
    for M in eq.Bvu:
        drive = drive + np.abs(np.asarray(M, float)) @ sv
    for j, M in enumerate(getattr(eq, "Bxv", ())):
        drive = drive + sv[j] * 50.0 * np.abs(np.asarray(M, float)).sum(axis=1)
    for j, M in enumerate(getattr(eq, "Bvv", ())):
        drive = drive + sv[j] * (np.abs(np.asarray(M, float)) @ sv)
    for sw in eq.switches:
        scale = sv[sw.scale_by] if sw.scale_by is not None else 1.0
        drive = drive + np.abs(np.asarray(sw.gain, float)) * scale
    return np.abs(np.linalg.solve(np.eye(nx) - eq.A, np.eye(nx))) @ drive


def _response(model) -> list[str]:
    try:
        eq = model.equations()
    except ModelError:  # calendar terms: no time-invariant matrices
        return []
    with np.errstate(all="ignore"):
        r = response_k(eq)
    worst = int(np.argmax(np.where(np.isfinite(r), r, np.inf))) if r.size else 0
    if r.size and not (np.isfinite(r[worst]) and r[worst] <= MAX_RESPONSE_K):
        return [
            f"coefficients too large: the steady state of state {worst} moves by {r[worst]:.3g} K for a 1 kg/s, "
            f"50 K, 1000 W/m² swing of the inputs, above {MAX_RESPONSE_K:g} K"
        ]
    return []


def _extended(model) -> list[str]:
    # a limiter (held_setpoint) bounds the temperatures it acts on; the model inside the band must be a building
    # on its own (a limiter must not hide a diverging mode, and it has no matrix form to check)
    if any(getattr(t, "limiter", False) for t in model.terms):
        model = model.with_terms([t for t in model.terms if not getattr(t, "limiter", False)])
    # a zone with a bilinear supply-air term: the term carries the cooling, the base's B is fitted free of sign
    free = [t.zone for t in model.terms if getattr(t, "cause", None) == "supply_air_bilinear"]
    problems = [f"base: {p}" for p in _linear(model.base, free_airflow=free)]
    if problems:
        return problems
    try:
        eq = model.equations()
    except ModelError:  # calendar terms: no time-invariant matrices; the state map probed instead
        A = zero_input_state_matrix(model)
        rho = float(np.max(np.abs(np.linalg.eigvals(A)))) if A.size else 0.0
        if not np.isfinite(rho) or rho >= 1.0:
            problems.append(
                f"unstable: the spectral radius of the extended model's state map at zero airflow and zero "
                f"disturbances is {rho:.6g} >= 1 (an extension term's coefficient makes temperatures grow without bound)"
            )
        return problems
    rho = float(np.max(np.abs(np.linalg.eigvals(eq.A)))) if eq.A.size else 0.0
    if not np.isfinite(rho) or rho >= 1.0:
        problems.append(
            f"unstable: the spectral radius of the extended model's state matrix is {rho:.6g} >= 1 "
            "(an extension term's coefficient makes temperatures grow without bound)"
        )
    for j, M in enumerate(getattr(eq, "Bxv", ())):  # a disturbance times the state: A at its swing too
        if not np.any(M):
            continue
        name = eq.disturbances[j]
        s = _signal_scale(name)
        with np.errstate(all="ignore"):
            rho_j = float(np.max(np.abs(np.linalg.eigvals(eq.A + s * np.asarray(M, float)))))
        if not np.isfinite(rho_j) or rho_j >= 1.0:
            problems.append(
                f"unstable: the spectral radius of the extended model's state matrix at {name} = {s:g} is "
                f"{rho_j:.6g} >= 1 (a term multiplying {name} by the state makes temperatures grow without bound)"
            )
    return problems + _response(model)


def zero_input_state_matrix(model) -> np.ndarray:
    """The state matrix of ``model.step_state`` at zero inputs, disturbances and gains, probed column by column
    (exact for a step affine in the state there; for models without a matrix form, e.g. a term multiplying a
    disturbance by the state, which vanishes at zero disturbance)."""
    nx, nu, nv = int(model.n_states), len(model.inputs), len(model.disturbances)
    nq = np.asarray(next(iter(model.gains.values()))).shape[1] if model.gains else 0
    u, v, q = np.zeros(nu), np.zeros(nv), np.zeros(nq)
    x0 = np.asarray(model.step_state(np.zeros(nx), u, v, q), float)
    return np.column_stack([np.asarray(model.step_state(e, u, v, q), float) - x0 for e in np.eye(nx)])


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


__all__ = [
    "MAX_GAIN_STEP_K",
    "MAX_GAIN_W_PER_M2",
    "MAX_GAP_SHARE",
    "MAX_RESPONSE_K",
    "MAX_STEP_DRIVE_K",
    "box_drive",
    "box_drive_problems",
    "model_problems",
    "require_box_drive",
    "require_plausible",
    "response_k",
]
