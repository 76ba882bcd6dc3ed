"""Plausibility of a fitted linear zone model: refuse what cannot be a building, flag what the data cannot tell.

Checked after every Model A fit (issue 17 p.3, issue 13 p.5):

Refused (:class:`~hvacfmu.errors.FitError`, with the reason):
- non-finite coefficients;
- spectral radius of ``A`` >= 1 (an unstable model; its open-loop "RMS" would be
  a meaningless 1e29 K);
- a slowest time constant ``-step / ln(rho)`` above ``max_time_constant_h``
  (default 30 days: no heat loss to speak of, an integrator);
- wrong signs: negative couplings between zones (a warmer neighbour must warm
  the zone), negative weather coefficients, airflow that warms (airflow form)
  or delivered heat that cools (delivered-heat form).

Flagged (a :class:`~hvacfmu.errors.HvacfmuWarning` and ``model.meta["warnings"]``):
- closed-loop data whose airflow/heat effect is not identifiable: the boxes'
  drive moves the zone temperature by less than ``min_effect_k`` in steady
  state over its observed range (5 %..95 %), typically together with time
  constants of minutes (``a`` of 0.4-0.6 per 15 minutes): the model learned
  the thermostat loop, not the building;
- a zone whose memory sits on a neighbour (``a_ij > a_ii``) or a state matrix with a negative real
  eigenvalue below ``-NEGATIVE_EIGENVALUE`` (:func:`memory_warnings`): not a building's RC network (whose
  exact discretisation has a positive spectrum), but what one-step least squares makes of mirror-twin
  zones whose temperatures are nearly collinear; the zones named, simulated together, feed each other's errors.

The numbers go to ``model.meta["plausibility"]``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import FitError, problems_message

#: Defaults of the checks (see the module docstring).
MAX_TIME_CONSTANT_H = 30 * 24.0
MIN_EFFECT_K = 0.2
FAST_TIME_CONSTANT_H = 1.0
#: A sign-constrained coefficient this far below 0 is the bounded solver's rounding of 0, not a sign error
#: (the diagnosis's joint refit of the EnergyPlus apartments gave C = -1.99e-19 on T_supply)
SIGN_TOL = 1e-12
#: A real eigenvalue of A below minus this is flagged: a mode that flips sign every step (no RC network has one;
#: the apartments' twin flats S1/S2 had -0.56 and -0.67 at 15 min) [-]
NEGATIVE_EIGENVALUE = 0.1
#: A coupling larger than the zone's own coefficient by more than this is flagged [-]
DOMINANCE_TOL = 1e-6


def time_constants_h(A, step) -> np.ndarray:
    """Time constants [h] of the modes of the discrete ``A`` (step [s]): ``-step / ln|lambda|``, slowest first."""
    lam = np.abs(np.linalg.eigvals(np.asarray(A, float)))
    with np.errstate(divide="ignore"):
        tau = np.where(lam >= 1.0, np.inf, np.where(lam <= 0.0, 0.0, -float(step) / np.log(np.maximum(lam, 1e-300))))
    return np.sort(tau)[::-1] / 3600.0


def memory_warnings(A, names) -> list[str]:
    """Warnings for a one-step state matrix ``A`` (states ``names``) that is not an RC network's.

    Names every zone whose own coefficient is below a neighbour's (``a_ij > a_ii``: its memory is carried by the
    neighbour, typically a mirror twin whose temperature is nearly collinear with its own), and every real
    eigenvalue below ``-NEGATIVE_EIGENVALUE`` with the zones that carry its mode (share of the eigenvector >= 20 %).
    Empty for a plausible matrix.
    """
    A = np.asarray(A, float)
    names = [str(n) for n in names]
    n = min(A.shape[0], len(names))
    out = []
    for i in range(n):
        row = A[i, :n].copy()
        row[i] = -np.inf
        j = int(np.argmax(row))
        if n > 1 and row[j] > A[i, i] + DOMINANCE_TOL:
            out.append(
                f"zone {names[i]}: its own coefficient a = {A[i, i]:.3g} is below its neighbour {names[j]}'s "
                f"{row[j]:.3g} (its memory sits on {names[j]}; near-collinear temperatures, e.g. mirror twins: "
                "simulated together the two feed each other's errors)"
            )
    if A.shape[0] and np.all(np.isfinite(A)):
        lam, vec = np.linalg.eig(A)
        for k in np.argsort(lam.real):
            if abs(lam[k].imag) > 1e-9 or lam[k].real >= -NEGATIVE_EIGENVALUE:
                continue
            w = np.abs(vec[:n, k]) ** 2
            w = w / max(float(w.sum()), 1e-300)
            zones = [names[i] for i in np.argsort(-w) if w[i] >= 0.2]
            out.append(
                f"A has the eigenvalue {lam[k].real:.3g} < -{NEGATIVE_EIGENVALUE:g} (a mode that flips sign every "
                f"step, which no thermal RC network has), carried by {', '.join(zones)}"
            )
    return out


def linear_problems(model, max_time_constant_h: float = MAX_TIME_CONSTANT_H, free_airflow=()) -> tuple[list[str], dict]:
    """Reasons why a :class:`~hvacfmu.models.linear.LinearZoneModel` cannot be a building, and the numbers.

    ``free_airflow``: states (output names) whose airflow coefficient ``B`` may have either sign, because
    an extension term carries the supply air's cooling there (``supply_air_bilinear``: the airflow's
    effect is ``B + coef (T_supply - T_zone)``; a positive ``B`` is then the delivered air's offset over
    the air handler's supply, as the diagnosis fits it).

    Returns
    -------
    problems : list of str
        Empty when plausible.
    numbers : dict
        ``spectral_radius``, ``time_constants_h`` (slowest first).
    """
    problems = []
    mats = {"A": model.A, "B": model.B, "C": model.C}
    if model.beta is not None:
        mats["beta"] = model.beta
    bad = [k for k, M in mats.items() if not np.all(np.isfinite(M))]
    if bad:
        return [f"coefficients {bad} are not finite"], {}
    rho = float(np.max(np.abs(np.linalg.eigvals(model.A))))
    tau = time_constants_h(model.A, model.step)
    numbers = {"spectral_radius": rho, "time_constants_h": tau.tolist()}
    if rho >= 1.0:
        problems.append(f"unstable: spectral radius of A is {rho:.6g} >= 1 (temperatures would grow without bound)")
    elif tau[0] > max_time_constant_h:
        problems.append(
            f"slowest time constant {tau[0]:.0f} h exceeds {max_time_constant_h:g} h: the model "
            "loses almost no heat (an integrator, not a building)"
        )
    off = model.A - np.diag(np.diag(model.A))
    if np.any(off < -SIGN_TOL):
        i, j = np.unravel_index(np.argmin(off), off.shape)
        problems.append(
            f"coupling A[{model.outputs[i]}, {model.outputs[j]}] = {off[i, j]:.3g} < 0 "
            "(a warmer neighbour would cool the zone)"
        )
    if np.any(model.C < -SIGN_TOL):
        i, j = np.unravel_index(np.argmin(model.C), model.C.shape)
        problems.append(
            f"C[{model.outputs[i]}, {model.disturbances[j]}] = {model.C[i, j]:.3g} < 0 "
            "(warmer weather or more sun would cool the zone)"
        )
    B = np.where(np.isin(np.asarray(model.outputs), list(free_airflow))[:, None], 0.0, model.B)
    if model.beta is None and np.any(B > 0):
        i = int(np.unravel_index(np.argmax(B), B.shape)[0])
        problems.append(
            f"airflow warms zone {model.outputs[i]} (B up to {np.max(B):.3g} > 0); in the airflow form the "
            "supply air must cool (use the delivered-heat form for heating with reheat)"
        )
    if model.beta is not None and np.any(model.beta < 0):
        problems.append(f"delivered heat cools the zone (beta down to {np.min(model.beta):.3g} < 0)")
    return problems, numbers


def drive_effect_k(model, frame) -> dict:
    """Steady-state effect [K] of each state's drive over its observed 5-95 % range.

    ``|b_i| / (1 - a_ii) * (p95 - p5 of drive_i)`` with the drive the zone's
    airflow [kg/s] (airflow form) or the heat its boxes deliver [kW]
    (delivered-heat form, with the measured zone temperatures).
    """
    u, v = model.signals(frame)
    if model.beta is None:
        drive, coef = u, np.diag(model.B)
    else:
        from .heat import delivered_heat

        x = model.measured_outputs(frame)
        Q = delivered_heat(u, v[:, model._inlet_idx], x[:, model._box_state])
        drive, coef = np.where(u == 0.0, 0.0, Q) @ model.heat_map.T, model.beta
    out = {}
    for i, name in enumerate(model.outputs):
        d = drive[:, i]
        d = d[np.isfinite(d)]
        if d.size < 10:
            continue
        spread = float(np.percentile(d, 95) - np.percentile(d, 5))
        a = float(model.A[i, i])
        out[name] = abs(float(coef[i])) / max(1.0 - a, 1e-9) * spread
    return out


def _identifiability_advice(model, frame, fast) -> str:
    """The end of the not-identifiable warning: what the (training) ``frame`` holds and what would help.

    It names only what the data lack: "without excitation" and "add excitation experiments" only when the
    training rows have none (else how many hours they have), "add discharge air temperatures" only when the
    data have no ``Td_<vav>`` column (a fit that ignores the data's ``Td_`` columns is told so instead).
    """
    exc = frame["excitation"].to_numpy(float) == 1.0 if "excitation" in frame.columns else np.zeros(len(frame), bool)
    hours = float(exc.sum()) * float(model.step) / 3600.0
    reads_td = any(str(c).startswith("Td_") for c in (getattr(model, "inlets", None) or ()))
    data_td = any(str(c).startswith("Td_") for c in frame.columns)
    out = ""
    if fast:
        data = (
            f"closed-loop data: the {hours:.0f} h of excitation experiments in the training weeks did not separate it"
            if hours > 0
            else "closed-loop data without excitation"
        )
        out += (
            f"; with time constants under {FAST_TIME_CONSTANT_H:g} h in {', '.join(fast)}, the model "
            f"learned the thermostat loop ({data}), not the building"
        )
    elif hours > 0:
        out += f" (the training weeks hold {hours:.0f} h of excitation experiments)"
    add = ["excitation experiments (column 'excitation')"] if hours == 0 else []
    if not data_td:
        add.append("discharge air temperatures (Td_<vav>)")
    elif reads_td and hours > 0:
        add.append("longer or more frequent excitation experiments")
    sentences = [f"Add {' or '.join(add)}"] if add else []
    if data_td and not reads_td:
        sentences.append(
            "This fit does not read the data's discharge air temperatures (Td_<vav>): the delivered-heat form "
            "(heat='auto' or 'delivered') does"
        )
    elif reads_td and hours > 0:
        sentences[-1] += ", or use the physics model (its box heat m·c_p·(T_in − T_zone) is not a fitted gain)"
    out += "".join(f". {s}" for s in sentences)
    return out


def check_fitted(
    model,
    dataset=None,
    warn=None,
    *,
    max_time_constant_h: float = MAX_TIME_CONSTANT_H,
    min_effect_k: float = MIN_EFFECT_K,
):
    """Refuse an implausible fitted Model A; flag a non-identifiable one. Returns the model with ``meta`` updated.

    Parameters
    ----------
    model : LinearZoneModel
    dataset : hvacfmu.data.Dataset, optional
        The fit's data (training weeks are used for the drive's range).
    warn : callable(str), optional
        Receives each warning (default: :func:`warnings.warn` with HvacfmuWarning).
    max_time_constant_h : float [h]
    min_effect_k : float [K]

    Raises
    ------
    FitError
        With every reason, for a model that cannot be a building.
    """
    import warnings

    from ..errors import HvacfmuWarning

    if getattr(model, "seasonal", False):
        return _check_seasons(model, dataset, warn, max_time_constant_h, min_effect_k)
    problems, numbers = linear_problems(model, max_time_constant_h)
    if dataset is not None and getattr(dataset, "building", None) is not None:
        from .loadcheck import box_drive_problems

        problems += box_drive_problems(model, dataset.building)
    if problems:
        raise FitError(problems_message(f"The fitted {model.kind} model is implausible and was refused", problems))
    notes = []
    if dataset is not None:
        frame = dataset.frame
        if getattr(dataset, "weeks", None):
            keep = np.zeros(len(frame), bool)
            for w in dataset.weeks:
                if w.train:
                    keep |= (frame.index >= w.start) & (frame.index < w.end)
            frame = frame[keep] if keep.any() else frame
        effect = drive_effect_k(model, frame)
        numbers["drive_effect_k"] = effect
        weak = {z: e for z, e in effect.items() if e < min_effect_k}
        if weak:
            a = np.clip(np.abs(np.diag(model.A)), 1e-300, 1 - 1e-15)
            tau_diag = -float(model.step) / np.log(a) / 3600.0  # [h] per state, from its own decay
            fast = [z for z in weak if tau_diag[model.outputs.index(z)] < FAST_TIME_CONSTANT_H]
            what = "delivered heat" if model.beta is not None else "airflow"
            msg = (
                f"the {what} of the boxes is not identifiable from these data: over its observed range it moves "
                f"the temperature by less than {min_effect_k:g} K in steady state in "
                + ", ".join(f"{z} ({e:.2g} K)" for z, e in weak.items())
            )
            msg += _identifiability_advice(model, frame, fast)
            notes.append(msg)
    numbers["identifiable"] = not notes
    memory = memory_warnings(model.A, model.outputs) if model.kind != "lumped" else []
    numbers["memory_warnings"] = memory
    notes += memory
    for msg in notes:
        (warn or (lambda m: warnings.warn(m, HvacfmuWarning, stacklevel=3)))(msg)
    meta = dict(model.meta)
    meta["plausibility"] = _plain(numbers)
    meta["warnings"] = list(meta.get("warnings") or []) + [m for m in notes if m not in (meta.get("warnings") or [])]
    return dataclasses.replace(model, meta=meta)


def _check_seasons(model, dataset, warn, max_time_constant_h, min_effect_k):
    """:func:`check_fitted` of a model with one coefficient set per season: every set, its drive's effect on the
    training weeks of its own season; a refusal names the season. ``meta["plausibility"]["seasons"]`` holds each
    set's numbers, ``meta["warnings"]`` every set's notes (prefixed by the season)."""
    import types

    per: dict = {}
    notes: list = []
    for s in model.seasons:
        ds = None
        if dataset is not None:
            weeks = [w for w in (getattr(dataset, "weeks", None) or ()) if w.season == s]
            ds = types.SimpleNamespace(frame=dataset.frame, weeks=weeks, building=getattr(dataset, "building", None))
        seen: list = []
        try:
            one = check_fitted(
                model.for_season(s),
                ds,
                warn=seen.append,
                max_time_constant_h=max_time_constant_h,
                min_effect_k=min_effect_k,
            )
        except FitError as exc:
            raise FitError(f"season {s}'s coefficient set: {exc}") from None
        per[s] = one.meta.get("plausibility")
        notes += [f"season {s}: {m}" for m in seen]
    for msg in notes:
        if warn is not None:
            warn(msg)
        else:
            import warnings

            from ..errors import HvacfmuWarning

            warnings.warn(msg, HvacfmuWarning, stacklevel=3)
    meta = dict(model.meta)
    meta["plausibility"] = {"seasons": per}
    meta["warnings"] = list(meta.get("warnings") or []) + [m for m in notes if m not in (meta.get("warnings") or [])]
    return dataclasses.replace(model, meta=meta)


def check_physics(model) -> dict:
    """Refuse an implausible fitted Model B: non-finite or non-positive parameters or gains, unstable dynamics.

    The discrete dynamics are checked at the state estimator's airflow
    (``options.kalman.airflow``, the training mean): ``A_d - c_p Gd diag(m)``
    must have spectral radius < 1.

    Returns
    -------
    dict
        ``spectral_radius``, ``time_constants_h`` (five slowest) for ``model.meta``.

    Raises
    ------
    FitError
    """
    from .heat import CP_AIR

    problems = []
    bad = {k: v for k, v in model.params.items() if not (np.isfinite(v) and v > 0)}
    if bad:
        problems.append(f"parameters {bad} are not finite and positive")
    if not np.all(np.isfinite(model.f_ig_const)):
        problems.append("constant internal gains are not finite")
    if any(not np.all(np.isfinite(g)) for g in model.gains.values()):
        problems.append("internal-gain profiles contain non-finite values")
    numbers = {}
    if not problems:
        d = model.discrete
        A = d.Ad.copy()
        nz = d.Vz.shape[0]
        airflow = np.asarray(model.options["kalman"]["airflow"], float)
        A[:, :nz] -= CP_AIR * d.physical_inputs[2] * airflow[None, :]
        eig, vec = np.linalg.eig(A)
        rho = float(np.max(np.abs(eig)))
        numbers = {"spectral_radius": rho, "time_constants_h": time_constants_h(A, model.step)[:5].tolist()}
        if not rho < 1.0:
            problems.append(
                f"unstable: spectral radius {rho:.6g} >= 1 at the training mean airflow"
                + _fast_air_hint(model, vec[:nz, int(np.argmax(np.abs(eig)))], airflow, d.network.template.capacity)
            )
    if problems:
        raise FitError(problems_message("The fitted physics model is implausible and was refused", problems))
    return _plain(numbers)


def _fast_air_hint(model, mode, airflow, capacity) -> str:
    """Why a Model B is unstable when a zone's airflow renews its air node's heat capacity more than once per step.

    The discrete model holds each box's bilinear airflow term over the step (zero-order hold, first order in
    ``c_p m h / C``): past a ratio of about 2 the zone's air node overshoots and oscillates. Names the zones of the
    unstable ``mode`` (their share of it >= 0.5) whose ratio exceeds 1, and what to do; "" when none does.
    """
    from .heat import CP_AIR

    nz = len(model.outputs)
    share = np.abs(mode[:nz]) / max(float(np.max(np.abs(mode[:nz]))), 1e-300)
    ratio = CP_AIR * airflow[:nz] * model.step / np.asarray(capacity, float)[:nz]
    zones = [i for i in range(nz) if share[i] >= 0.5 and ratio[i] > 1.0]
    if not zones:
        return ""
    named = ", ".join(f"{model.outputs[i]} ({airflow[i]:.3g} kg/s, {ratio[i]:.2f} times)" for i in zones)
    return (
        f"; the unstable mode is the air of {named}: the mean airflow carries more than its air node's heat "
        f"capacity (air and furniture) per {model.step:g} s step, faster than the step resolves (the model holds "
        "each box's airflow over the step); fit on a shorter step (prepare(..., step=300), hvacfmu fit --step 300) "
        "or use a Model A kind (zones, lumped)"
    )


def _plain(x):
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return float(x) if np.isfinite(x) else None
    if isinstance(x, np.bool_):
        return bool(x)
    return x


__all__ = [
    "check_fitted",
    "check_physics",
    "drive_effect_k",
    "linear_problems",
    "memory_warnings",
    "time_constants_h",
]
