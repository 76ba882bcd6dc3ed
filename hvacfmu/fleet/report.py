"""The portfolio report page: distribution of errors and findings over the fleet (HTML + PNG figures)."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
import pandas as pd


def write_report(result, path) -> Path:
    """Write ``report.html`` (and its figures beside it) for a :class:`~hvacfmu.fleet.run.FleetResult`."""
    path = Path(path)
    figs = []
    t = result.table
    if "rms_all" in t and t["rms_all"].notna().any():
        figs.append(_plot_ratio(t, path.with_name("fleet_rms_ratio.png")))
    if result.buildings and any(b.get("findings") for b in result.buildings):
        figs.append(_plot_findings(result.buildings, path.with_name("fleet_findings.png")))
    parts = [
        "<!doctype html><meta charset='utf-8'><title>hvacfmu fleet report</title>",
        "<style>body{font-family:sans-serif;max-width:70em;margin:auto}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:2px 6px;font-size:90%}.bad{color:#b00}</style>",
        "<h1>Portfolio report</h1>",
        f"<pre>{html.escape(result.summary())}</pre>",
    ]
    failed = [b for b in result.buildings if b["status"] != "ok"]
    if failed:
        parts.append(
            "<h2 class='bad'>Buildings that failed</h2><table><tr><th>building</th><th>stage</th><th>why</th></tr>"
        )
        parts += [
            f"<tr><td>{html.escape(b['name'])}</td><td>{b['failed_stage']}</td>"
            f"<td><pre>{html.escape(str(b['error']))}</pre></td></tr>"
            for b in failed
        ]
        parts.append("</table>")
    for f in figs:
        parts.append(f"<p><img src='{f.name}' style='max-width:100%'></p>")
    cols = [
        c
        for c in (
            "building",
            "model",
            "zone",
            "verdict",
            "rms_all",
            "persistence_all",
            "time_of_week_all",
            "seasons_worse_than_persistence",
            "seasons_worse_than_time_of_week",
            "nmbe_percent",
            "cvrmse_percent",
            "zone_findings",
        )
        if c in t
    ]
    if cols:
        parts.append("<h2>Per building and zone</h2>")
        parts.append(t[cols].to_html(index=False, float_format=lambda x: f"{x:.3f}", na_rep=""))
    path.write_text("\n".join(parts), encoding="utf-8")
    return path


def _plot_ratio(t: pd.DataFrame, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.5))
    for model, g in t.dropna(subset=["rms_all", "persistence_all"]).groupby("model"):
        ratio = (g["rms_all"] / g["persistence_all"]).to_numpy()
        ax.hist(
            ratio,
            bins=np.linspace(0, max(1.5, float(np.nanmax(ratio)) * 1.05), 25),
            alpha=0.6,
            label=f"{model} ({len(ratio)} zones)",
        )
    ax.axvline(1.0, color="k", lw=1)
    ax.text(1.01, ax.get_ylim()[1] * 0.9, "persistence", fontsize=8)
    ax.set_xlabel("24-h RMS / persistence RMS [-] (left of 1: the model wins)")
    ax.set_ylabel("zones")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _plot_findings(buildings: list, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    counts = pd.Series([f["cause"] for b in buildings for f in b.get("findings", [])]).value_counts()
    fig, ax = plt.subplots(figsize=(7, 3.0))
    ax.barh(counts.index[::-1], counts.to_numpy()[::-1])
    ax.set_xlabel("findings over the fleet")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
