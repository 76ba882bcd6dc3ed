"""Figures of a co-simulation run (matplotlib, Agg backend): zone temperatures in the band, airflows."""

from __future__ import annotations

from pathlib import Path


def plot_cosim(result, path) -> Path:
    """Two panels over the run: FMU zone temperatures [°C] with the comfort band (and the measured
    ones, dashed, when known), and the total commanded airflow [kg/s]. Returns the written file."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tab, s = result.table, result.summary
    temps = [
        c for c in tab.columns if c.startswith("T_") and not c.endswith("_measured") and c not in ("T_out", "T_supply")
    ]
    boxes = [c for c in tab.columns if c.startswith("m_")]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(11, 6.5), sharex=True, height_ratios=(2, 1))
    for c in temps:
        (line,) = ax1.plot(tab.index, tab[c], lw=1.0, label=c)
        if f"{c}_measured" in tab:
            ax1.plot(tab.index, tab[f"{c}_measured"], lw=0.8, ls="--", color=line.get_color())
    lo, hi = s["band"]
    ax1.axhspan(lo, hi, color="tab:green", alpha=0.12, label=f"band [{lo:g}, {hi:g}] °C")
    ax1.set_ylabel("zone temperature [°C]")
    ax1.set_title(
        f"{s['fmu']}, controller {s['controller']}: {s['comfort_violation_Kh']:.1f} K·h outside the band, "
        f"Σm² = {s['energy_proxy']:.1f}" + ("" if s["covered"] else "  (STOPPED EARLY)"),
        fontsize=10,
    )
    ax1.legend(ncol=4, fontsize=7, loc="upper right")
    ax2.plot(tab.index, tab[boxes].sum(axis=1, min_count=1), lw=1.0, color="tab:blue")
    ax2.set_ylabel("total airflow [kg/s]")
    ax2.set_xlabel("local time")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
