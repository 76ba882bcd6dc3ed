"""Checks of what is identified on EnergyPlus data: margins against the baselines, closed-loop airflow gains.

Duck-typed on purpose: this package sits below :mod:`hvacfmu.models` and
:mod:`hvacfmu.evaluation` and imports neither; it reads an ``EvaluationResult``'s
``scores`` and a linear model's ``B``/``outputs``/``inputs`` attributes.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

#: Baseline names of :func:`hvacfmu.evaluation.evaluate`.
BASELINES = ("persistence", "time-of-week mean")
CP_AIR = 1005.0  # [J/(kg K)]
RHO_AIR = 1.2  # [kg/m3]
#: Largest plausible effective heat capacity of a zone, as a multiple of its air's (furniture, light structure).
MAX_CAPACITY_FACTOR = 30.0
#: Smallest supply-to-zone temperature difference [K] while a box cools or heats noticeably.
MIN_DELTA_T = 2.0


def margins_table(result) -> pd.DataFrame:
    """Per model and season: RMS [K] (mean over outputs) of the model and the baselines, the margin against each
    baseline [%, positive = the model is better] and the worst output's margin [%].

    Parameters
    ----------
    result : hvacfmu.evaluation.EvaluationResult
    """
    rows = []
    for sc in result.scores:
        seasons = np.asarray(sc.seasons, dtype=object)
        for season in [*dict.fromkeys(sc.seasons), "all"]:
            sel = np.ones(len(seasons), bool) if season == "all" else seasons == season
            if not sel.any():
                continue
            model = np.nanmean(sc.rms[sel], axis=0)
            row = {"model": sc.name, "season": season, "windows": int(sel.sum()), "rms": float(np.mean(model))}
            for b in BASELINES:
                base = np.nanmean(sc.baselines[b][sel], axis=0)
                short = "pers" if b == "persistence" else "tow"
                row[short] = float(np.mean(base))
                row[f"margin_{short}_%"] = 100.0 * (1.0 - row["rms"] / row[short])
                row[f"worst_{short}_%"] = float(np.min(100.0 * (1.0 - model / base)))
            rows.append(row)
    return pd.DataFrame(rows).set_index(["model", "season"])


def airflow_identifiability(model, building, step: float | None = None) -> list:
    """Lines reporting, per zone, the fitted effect of the boxes' air against the smallest plausible one.

    Airflow form (``x+ = ... + B u``): the gain ``B_ii`` [K per (kg/s) per step] against ``cp · ΔT_min · step /
    C_max``; delivered-heat form (``beta_i · m cp (T_in - x)``): ``beta_i`` [K per step per kW] against
    ``1000 · step / C_max``. ``C_max`` is ``MAX_CAPACITY_FACTOR`` times the zone air's heat capacity and
    ``ΔT_min = 2 K``. A fitted value below the minimum means the air's effect was not identified: closed-loop data
    without excitation let the thermostat loop (airflow follows temperature) explain the response instead.
    """
    outputs = tuple(getattr(model, "outputs", ()))
    beta = getattr(model, "beta", None)
    B = getattr(model, "B", None)
    if (B is None and beta is None) or not outputs or outputs == ("floor",):
        return ["airflow identifiability: not a zones model, not checked"]
    step = float(step if step is not None else model.step)
    if beta is not None:
        values, unit, what = np.asarray(beta, dtype=float), "K/step per kW", "delivered-heat gain"
    else:
        values, unit, what = np.diag(np.asarray(B, dtype=float)), "K/(kg/s)/step", "airflow gain"
    lines, flagged = [], []
    for i, zone in enumerate(outputs[: len(values)]):
        c_max = MAX_CAPACITY_FACTOR * RHO_AIR * CP_AIR * building.zone(zone).volume
        g_min = (1000.0 if beta is not None else CP_AIR * MIN_DELTA_T) * step / c_max
        ok = abs(values[i]) >= g_min
        if not ok:
            flagged.append(zone)
        lines.append(
            f"{zone}: {what} {values[i]:+.3g} {unit}, smallest plausible {g_min:.3g}"
            + ("" if ok else "  -> NOT IDENTIFIED (closed loop, no excitation)")
        )
    head = f"airflow identifiability: {len(flagged)} of {len(outputs)} zone gains below the physical minimum" + (
        f" ({', '.join(flagged)})" if flagged else ""
    )
    return [head, *lines]
