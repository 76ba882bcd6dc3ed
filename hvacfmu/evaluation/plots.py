"""Figures of an evaluation result (matplotlib, Agg backend, imported lazily; no math here).

Called by :meth:`hvacfmu.evaluation.EvaluationResult.plot`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..plots import pyplot as _pyplot


def plot_rms_table(score, path, season_order=None, baselines=("persistence", "time-of-week mean")) -> Path:
    """Bar chart of the mean RMS by season and output: model vs both baselines.

    Parameters
    ----------
    score : hvacfmu.evaluation.ModelScore
    path : path of the PNG to write
    season_order : sequence of str, optional
    baselines : sequence of str
        Baseline names of ``score`` to draw beside the model.

    Returns
    -------
    Path
    """
    plt = _pyplot()
    tables = {"model": score.table("model", season_order)}
    tables.update({b: score.table(b, season_order) for b in baselines})
    seasons = [s for s in tables["model"].index if s != "all"]
    cols = list(score.outputs) + ["mean"]
    fig, axes = plt.subplots(
        1, max(len(seasons), 1), figsize=(3.2 * max(len(seasons), 1) + 1, 3.4), sharey=True, squeeze=False
    )
    width = 0.8 / len(tables)
    x = np.arange(len(cols))
    for ax, s in zip(axes[0], seasons):
        for i, (label, df) in enumerate(tables.items()):
            ax.bar(
                x + (i - (len(tables) - 1) / 2) * width,
                df.loc[s, cols].to_numpy(float),
                width,
                label=score.name if label == "model" else label,
            )
        ax.set_xticks(x, cols, rotation=45)
        ax.set_title(s)
        ax.grid(axis="y", alpha=0.3)
    axes[0][0].set_ylabel("24-h open-loop RMS [K]")
    axes[0][-1].legend(fontsize="small")
    fig.suptitle(f"{score.name}: prediction RMS on held-out weeks")
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_week_trajectories(trajectories, path) -> Path:
    """7-day open-loop trajectories (paper Fig. 5): measured and predicted, one panel per output.

    Parameters
    ----------
    trajectories : sequence of hvacfmu.evaluation.Trajectory
        All on the same week; models with different outputs get their own panels.
    path : path of the PNG to write

    Returns
    -------
    Path
    """
    plt = _pyplot()
    outputs = []
    for tr in trajectories:
        outputs += [o for o in tr.outputs if o not in outputs]
    n = len(outputs)
    ncol = 2 if n > 1 else 1
    nrow = -(-n // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(7 * ncol, 2.4 * nrow + 0.6), sharex=True, squeeze=False)
    measured_drawn = set()
    for k, o in enumerate(outputs):
        ax = axes[k // ncol][k % ncol]
        for tr in trajectories:
            if o not in tr.outputs:
                continue
            j = tr.outputs.index(o)
            t = tr.index.tz_localize(None)
            if o not in measured_drawn:
                ax.plot(t, tr.measured[:, j], color="tab:green", lw=1.2, label="measured")
                measured_drawn.add(o)
            rms = tr.rms()[j]
            ax.plot(t, tr.predicted[:, j], lw=1.0, label=f"{tr.name} (RMS {rms:.2f} K)")
        ax.set_title(o, fontsize="medium")
        ax.set_ylabel("T [°C]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize="x-small", loc="best")
    for k in range(n, nrow * ncol):
        axes[k // ncol][k % ncol].set_visible(False)
    tr0 = trajectories[0]
    fig.suptitle(f"7-day open-loop prediction, week {tr0.week} ({tr0.season}, from {tr0.index[0].date()})")
    fig.autofmt_xdate()
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


__all__ = ["plot_rms_table", "plot_week_trajectories"]
