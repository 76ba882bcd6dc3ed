"""Figures of the demo report (matplotlib Agg; no math here)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..plots import panel_grid, save_figure

DAY_NAMES = ("Mon", "Tue", "Wed", "Thu", "Fri", "Sat", "Sun")


def plot_gains(model, path, title, unit) -> Path:
    """Internal-gain profiles by season over the week (paper Figs. 2, 3 and 5).

    One panel per output (zone); one line per season.
    """
    seasons = list(model.gains)
    first = np.asarray(model.gains[seasons[0]])
    n_out = first.shape[1]
    names = list(model.outputs)[:n_out] if len(model.outputs) >= n_out else [f"q{i}" for i in range(n_out)]
    ncols = 1 if n_out == 1 else 2
    plt, fig, axes, panels = panel_grid(n_out, ncols, (5.5 if ncols == 2 else 9, 2.3), sharex=True)
    fig.set_figheight(2.3 * axes.shape[0] + 0.8)
    hours = np.arange(first.shape[0]) * float(model.step) / 3600.0
    for j, ax in enumerate(panels):
        for s in seasons:
            ax.plot(hours, np.asarray(model.gains[s])[:, j], lw=0.9, label=s)
        ax.set_title(names[j], fontsize="medium")
        ax.set_ylabel(unit)
        ax.set_xticks(np.arange(7) * 24 + 12, DAY_NAMES)
        for d in range(1, 7):
            ax.axvline(24 * d, color="0.85", lw=0.6)
        ax.grid(axis="y", alpha=0.3)
    axes[0][-1].legend(fontsize="small", ncol=2)
    fig.suptitle(title)
    return save_figure(plt, fig, path, dpi=100)


def plot_mpc(runs, measured, zones, vavs_of_zone, path_temp, path_flow, band=(20.0, 22.0)) -> tuple[Path, Path]:
    """MPC temperatures and airflows vs measured (paper Figs. 6 and 7).

    Parameters
    ----------
    runs : dict label -> pandas.DataFrame (the co-simulation tables)
    measured : pandas.DataFrame
        The measured data over the same span (``T_<zone>``, ``m_<vav>``).
    zones : sequence of zone names
    vavs_of_zone : dict zone -> list of VAV names
    """
    paths = []
    for kind, path in (("temp", path_temp), ("flow", path_flow)):
        plt, fig, axes, panels = panel_grid(len(zones), 2, (6, 2.4), sharex=True)
        fig.set_figheight(2.4 * axes.shape[0] + 0.8)
        for z, ax in zip(zones, panels):
            if kind == "temp" and f"T_{z}" in measured:
                ax.plot(measured.index, measured[f"T_{z}"], lw=1.1, color="k", label="measured")
            elif kind == "flow":
                cols = [f"m_{v}" for v in vavs_of_zone[z] if f"m_{v}" in measured]
                if cols:
                    ax.step(
                        measured.index, measured[cols].sum(axis=1), where="post", color="k", lw=1.1, label="measured"
                    )
        colors = ["tab:blue", "tab:orange", "tab:red", "tab:purple", "tab:brown", "tab:cyan"]
        for (label, table), color in zip(runs.items(), colors * 3):
            for z, ax in zip(zones, panels):
                if kind == "temp":
                    if f"T_{z}" in table:
                        ax.plot(table.index, table[f"T_{z}"], lw=0.9, color=color, label=label)
                else:
                    cols = [f"m_{v}" for v in vavs_of_zone[z] if f"m_{v}" in table]
                    if cols:
                        ax.step(table.index, table[cols].sum(axis=1), where="post", lw=0.9, color=color, label=label)
        for z, ax in zip(zones, panels):
            ax.set_title(z, fontsize="medium")
            if kind == "temp":
                for bnd in band:
                    ax.axhline(bnd, color="k", ls="--", lw=0.7)
                ax.set_ylabel("°C")
            else:
                ax.set_ylabel("kg/s")
            ax.grid(alpha=0.3)
        axes[0][-1].legend(fontsize="x-small")
        fig.suptitle("MPC zone temperatures" if kind == "temp" else "MPC zone airflows (sum of the zone's boxes)")
        fig.autofmt_xdate()
        paths.append(save_figure(plt, fig, path, dpi=100))
    return tuple(paths)


def plot_control_gain(rows: dict, path, title: str) -> Path:
    """Base against extended MPC on the plant: one bar panel per figure (comfort, fan/cooling, reheat).

    Parameters
    ----------
    rows : dict label -> dict with ``"comfort violation [K·h]"``, ``"energy proxy Σu² [(kg/s)²]"``,
        ``"reheat [kWh]"``
    path : path of the PNG
    title : str
    """
    metrics = ("comfort violation [K·h]", "energy proxy Σu² [(kg/s)²]", "reheat [kWh]")
    plt, fig, axes, panels = panel_grid(len(metrics), len(metrics), (3.2, 3.0))
    labels = list(rows)
    colors = ["tab:blue", "tab:green", "tab:orange", "tab:red"]
    for ax, mname in zip(panels, metrics):
        vals = [float(rows[k][mname]) for k in labels]
        ax.bar(range(len(labels)), vals, color=colors[: len(labels)])
        for i, v in enumerate(vals):
            ax.annotate(
                f"{v:.2f}" if "K·h" in mname else f"{v:.0f}", (i, v), ha="center", va="bottom", fontsize="small"
            )
        short = [_short_label(lab) for lab in labels]
        ax.set_xticks(range(len(labels)), short, fontsize="x-small")
        ax.margins(y=0.12)
        ax.set_title(mname, fontsize="medium")
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(title, fontsize="medium")
    return save_figure(plt, fig, path, dpi=100)


def _short_label(lab: str) -> str:
    """``"MPC Model A (six zones) + diagnosed terms on the plant, comfort weight 50"`` -> ``"+ terms\nweight 50"``."""
    lab = lab.removeprefix("MPC ").replace(" on the plant", "").replace(" (six zones)", "")
    lab = lab.replace("Model A + diagnosed terms", "+ terms").replace(", comfort weight ", "\nweight ")
    return lab
