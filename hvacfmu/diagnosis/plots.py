"""Diagnostic figures (matplotlib, Agg backend): residuals by hour/weekday/zone, ACF,
cumulated periodogram, and held-out RMS before/after."""

from __future__ import annotations

from pathlib import Path

import numpy as np


from ..plots import _pyplot as _plt
from ..plots import panel_grid, save_figure


def plot_all(report, folder) -> list:
    """Write every figure of ``report`` into ``folder``; returns the paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    files = [
        plot_residual_profiles(report, folder / "residuals_by_hour_weekday.png"),
        plot_residual_by_zone(report, folder / "residuals_by_zone.png"),
        plot_acf(report, folder / "acf.png"),
        plot_cpgram(report, folder / "cumulated_periodogram.png"),
    ]
    if report.heldout.get("zones"):
        files.append(plot_heldout(report, folder / "heldout_before_after.png"))
    return files


def _zones(report):
    return list(report.series["zones"])


def plot_residual_profiles(report, path):
    """Mean 24-hour open-loop error by hour of day and by weekday, per zone, before and after."""
    plt = _plt()
    s = report.series
    idx = s["index"]
    hours = np.asarray(idx.hour)
    wd = np.asarray(idx.day_of_week)
    zones = _zones(report)
    fig, axes = plt.subplots(2, 2, figsize=(12, 7), sharey="row")
    for col, key, title in ((0, "open_loop_before", "base model"), (1, "open_loop_after", "extended model")):
        r = s[key]
        for j, z in enumerate(zones):
            mh = [np.nanmean(r[hours == h, j]) if np.isfinite(r[hours == h, j]).any() else np.nan for h in range(24)]
            md = [np.nanmean(r[wd == d, j]) if np.isfinite(r[wd == d, j]).any() else np.nan for d in range(7)]
            axes[0, col].plot(range(24), mh, marker=".", label=z)
            axes[1, col].plot(range(7), md, marker="o", label=z)
        axes[0, col].set_title(f"{title}: mean 24-h open-loop error by hour")
        axes[0, col].set_xlabel("hour of day (local)")
        axes[1, col].set_xticks(range(7), ["Mon", "Tue", "Wed", "Thu", "Fri", "Sat", "Sun"])
        axes[1, col].set_title(f"{title}: by weekday")
        for a in axes[:, col]:
            a.axhline(0, color="k", lw=0.5)
            a.grid(alpha=0.3)
    axes[0, 0].set_ylabel("measured − predicted [K]")
    axes[1, 0].set_ylabel("measured − predicted [K]")
    axes[0, 1].legend(fontsize=8, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_residual_by_zone(report, path):
    """RMS of one-step and 24-hour open-loop errors per zone, before and after."""
    plt = _plt()
    s = report.series
    zones = _zones(report)
    x = np.arange(len(zones))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, pre, title in (
        (axes[0], "one_step", "one-step errors [K]"),
        (axes[1], "open_loop", "24-h open-loop errors [K]"),
    ):
        for k, (key, lab) in enumerate(((f"{pre}_before", "base"), (f"{pre}_after", "extended"))):
            r = s[key]
            rms = [
                np.sqrt(np.nanmean(r[:, j] ** 2)) if np.isfinite(r[:, j]).any() else np.nan for j in range(len(zones))
            ]
            ax.bar(x + (k - 0.5) * 0.38, rms, width=0.38, label=lab)
        ax.set_xticks(x, zones)
        ax.set_title(f"RMS of {title}")
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_acf(report, path, nlags=96):
    """Autocorrelation of the one-step residuals (training weeks), before and after, with the 95 % band."""
    from .residuals import acf

    s = report.series
    zones = _zones(report)
    plt, fig, axes, panels = panel_grid(len(zones), 3, (4.2, 3.0))
    for j, (z, ax) in enumerate(zip(zones, panels)):
        for key, lab in (("one_step_before", "base"), ("one_step_after", "extended")):
            r = np.where(s["train"], s[key][:, j], np.nan)
            ax.plot(np.arange(1, nlags + 1), acf(r, nlags)[1:], label=lab, lw=1)
        nn = max(np.isfinite(s["one_step_before"][:, j]).sum(), 1)
        ax.axhspan(-1.96 / np.sqrt(nn), 1.96 / np.sqrt(nn), color="grey", alpha=0.3)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_title(f"ACF of one-step residuals, {z}")
        ax.set_xlabel(f"lag [steps of {s['step'] / 60:g} min]")
    axes[0, 0].legend(fontsize=8)
    return save_figure(plt, fig, path)


def plot_cpgram(report, path):
    """Cumulated periodogram of the one-step residuals with the 1 % Kolmogorov–Smirnov band."""
    from .residuals import cumulated_periodogram

    s = report.series
    zones = _zones(report)
    plt, fig, axes, panels = panel_grid(len(zones), 3, (4.2, 3.0))
    for j, (z, ax) in enumerate(zip(zones, panels)):
        for key, lab in (("one_step_before", "base"), ("one_step_after", "extended")):
            r = np.where(s["train"], s[key][:, j], np.nan)
            f, C, bound, _, _ = cumulated_periodogram(r)
            if len(f):
                ax.plot(f, C, label=lab, lw=1)
        if len(f):
            line = f / 0.5
            ax.plot(f, line, "k", lw=0.5)
            ax.fill_between(f, line - bound, line + bound, color="grey", alpha=0.3)
        ax.set_title(f"cumulated periodogram, {z}")
        ax.set_xlabel("frequency [cycles per step]")
    axes[0, 0].legend(fontsize=8)
    return save_figure(plt, fig, path)


def plot_heldout(report, path):
    """Held-out 24-hour RMS per zone, base vs extended (all seasons)."""
    plt = _plt()
    ho = report.heldout
    zones = ho["zones"]
    x = np.arange(len(zones))
    b = [ho["base"]["all"][z] for z in zones]
    a = [ho["extended"]["all"][z] for z in zones]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.bar(x - 0.19, b, width=0.38, label="base")
    ax.bar(x + 0.19, a, width=0.38, label="extended")
    for i, z in enumerate(zones):
        g = ho["gain_percent"].get(z)
        if g is not None:
            ax.annotate(f"{g:+.0f} %", (x[i], max(b[i], a[i])), ha="center", va="bottom", fontsize=8)
    ax.set_xticks(x, zones)
    ax.set_ylabel("held-out 24-h RMS [K]")
    ax.set_title("held-out prediction error before / after the extensions")
    ax.legend()
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
