"""Figure helpers shared by every layer's figures (matplotlib, Agg backend, imported lazily).

The figures themselves live beside the result they draw (``hvacfmu.evaluation.plots``,
``hvacfmu.diagnosis.plots``, ``harness.cosim_plots``) or in the application
(``hvacfmu.cli.demo_plots``); this module holds only the loader and the layout helpers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def pyplot():
    """``matplotlib.pyplot`` on the non-interactive Agg backend (imported on first use)."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def panel_grid(n, ncols, panel_size, **kwargs):
    """A figure with ``n`` panels on a grid of ``ncols`` columns (each ``panel_size`` = (w, h) [in]).

    Returns ``(plt, fig, axes, panels)`` where ``panels`` lists the first ``n`` axes in reading order.
    """
    plt = pyplot()
    ncols = max(1, min(ncols, n))
    nrows = int(np.ceil(n / ncols))
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(panel_size[0] * ncols, panel_size[1] * nrows), squeeze=False, **kwargs
    )
    flat = list(axes.ravel())
    for ax in flat[n:]:
        ax.axis("off")
    return plt, fig, axes, flat[:n]


def save_figure(plt, fig, path, dpi=110) -> Path:
    """Lay out, write (PNG) and close ``fig``; returns the path."""
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


#: old private name of :func:`pyplot` (used by the diagnosis figures)
_pyplot = pyplot

__all__ = ["panel_grid", "pyplot", "save_figure"]
