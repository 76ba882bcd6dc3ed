"""Control gain of the diagnosis on comfort-against-energy fronts (issue 18 point 5, session 19).

One run per controller at one comfort weight conflates the comfort/energy trade-off: a controller that
holds fewer K·h while spending more energy may only sit further along the same front. So each
controller (the base Model A, the diagnosed model refitted on it, and variants such as the diagnosis's
coupling kept) is run at several comfort weights (the MPC's ``comfort_penalty``, an exact ℓ1 penalty on
the band excess against Σu² of the airflows), which gives each a front of K·h against energy; then

* **comfort at equal energy**: for every run of one controller, the other controller's front
  interpolated at that run's energy (linear between its Pareto points, inside its range only),
  minus the run's K·h (positive: the run holds fewer K·h than the other front at the same energy);
* **energy at equal comfort**: likewise the other front's energy at the run's K·h;
* **front against front**: both Pareto fronts as piecewise-linear curves over the energy range both
  cover: the difference in K·h at its ends, its smallest, largest and mean.

Energy is either axis of :class:`harness.energy.EnergyUse`: Σu² [(kg/s)²] (what the MPC minimises;
the primary axis) and commanded reheat [kWh]; the two are not added (README "One energy measure"),
so every comparison is made on each axis, and the other axis's difference is printed beside it
(interpolated on the same front). A point interpolated between two runs is not a run: read the
interpolation as "what a weight between the two would give", valid where the front is smooth; the
runs themselves are printed too.

The runs are :func:`bench_control_gain.run_case`'s (the same datasets, diagnosis cache and plant FMUs),
so its ``--json`` files are read here too::

    python3 benchmarks/control_front_s19.py --cases "quad4/34:zone_coupling:zones=NW+SE,ua=1051" \\
        --models base extended kept:zone_coupling --weights 10000 100 30 10 3 --json q34.json
    python3 benchmarks/control_front_s19.py --from-json q34.json [--pairs base,extended base,kept:zone_coupling] \\
        [--min-weight 10] [--plot fronts.png]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

KH = "comfort_violation_Kh"
AXES = {"energy_proxy": "Σu²", "heating_kWh": "reheat"}


def pareto(runs, x: str = "energy_proxy") -> list:
    """The runs no other run beats in both ``x`` and K·h (ties kept once), sorted by ``x``.

    A run with more energy and no fewer K·h than another is off the front: a weight that gave it is
    never the one to choose.
    """
    pts = sorted(runs, key=lambda r: (r[x], r[KH]))
    out: list = []
    for r in pts:
        if out and r[KH] >= out[-1][KH]:
            continue  # no fewer K·h for no less energy
        out.append(r)
    return out


def interp(front, value: float, x: str = "energy_proxy", y: str = KH):
    """``y`` of a Pareto ``front`` at ``x = value`` (linear between neighbours), ``None`` outside its range."""
    xs = [r[x] for r in front]
    if not front or value < xs[0] or value > xs[-1]:
        return None
    for a, b in zip(front, front[1:]):
        if a[x] <= value <= b[x]:
            if b[x] == a[x]:
                return min(a[y], b[y])
            f = (value - a[x]) / (b[x] - a[x])
            return a[y] + f * (b[y] - a[y])
    return front[-1][y]  # a one-point front at exactly its value


def interp_energy(front, kh: float, x: str = "energy_proxy"):
    """The energy ``x`` a Pareto ``front`` needs for ``kh`` K·h (linear between neighbours), ``None`` outside.

    On a Pareto front K·h falls strictly as energy rises, so the inverse is a function.
    """
    ks = [r[KH] for r in front]
    if not front or kh > ks[0] or kh < ks[-1]:
        return None
    for a, b in zip(front, front[1:]):
        if b[KH] <= kh <= a[KH]:
            f = (a[KH] - kh) / (a[KH] - b[KH])
            return a[x] + f * (b[x] - a[x])
    return front[0][x]


def at_equal(runs, other, x: str = "energy_proxy") -> list:
    """For each run of ``runs``: the ``other`` front's K·h at the run's ``x`` and its ``x`` at the run's K·h.

    ``saved_Kh`` = other front's K·h − the run's (positive: the run is better at equal energy),
    ``saved_energy`` = other front's energy − the run's (positive: the run needs less for equal comfort);
    ``None`` where the run lies outside the other front's range. ``other_axis`` is the run's other
    energy axis minus the other front's at the same ``x`` (positive: the run spends more of it there).
    """
    front = pareto(other, x)
    y = "heating_kWh" if x == "energy_proxy" else "energy_proxy"
    out = []
    for r in sorted(runs, key=lambda r: r["weight"], reverse=True):
        kh = interp(front, r[x], x)
        e = interp_energy(front, r[KH], x)
        o = interp(front, r[x], x, y)
        out.append(
            {
                "run": r,
                "saved_Kh": None if kh is None else kh - r[KH],
                "saved_energy": None if e is None else e - r[x],
                "other_axis": None if o is None else r[y] - o,
            }
        )
    return out


def front_gap(ref, model, x: str = "energy_proxy", n: int = 201) -> dict | None:
    """K·h of ``ref``'s Pareto front minus ``model``'s, over the ``x`` range both cover (``None``: no overlap).

    Returns ``{"lo", "hi", "at_lo", "at_hi", "min", "max", "mean"}`` (the mean over ``n`` evenly spaced
    energies; positive: the model holds fewer K·h at equal energy).
    """
    fr, fm = pareto(ref, x), pareto(model, x)
    if not fr or not fm:
        return None
    lo, hi = max(fr[0][x], fm[0][x]), min(fr[-1][x], fm[-1][x])
    if lo > hi:
        return None
    # clamped: lo + (hi - lo) * 1 can round past hi and off the front
    grid = [min(hi, lo + (hi - lo) * i / (n - 1)) for i in range(n - 1)] + [hi] if hi > lo else [lo]
    d = [interp(fr, g, x) - interp(fm, g, x) for g in grid]
    return {"lo": lo, "hi": hi, "at_lo": d[0], "at_hi": d[-1], "min": min(d), "max": max(d), "mean": sum(d) / len(d)}


def _weeks(rows):
    return sorted({(r["effect"], r["seed"], r["season"], r["week"]) for r in rows}, key=str)


def _of(rows, key, model):
    return [r for r in rows if (r["effect"], r["seed"], r["season"], r["week"]) == key and r["model"] == model]


def _f(v, fmt="{:+.2f}"):
    return "-" if v is None else fmt.format(v)


def print_fronts(rows, pairs) -> None:
    """Per case and week: every run, then for each (ref, model) pair the comparisons on each energy axis."""
    for key in _weeks(rows):
        effect, seed, season, week = key
        print(f"\n{effect} (seed {seed}), {season} week {week}")
        for model in sorted({r["model"] for r in rows if (r["effect"], r["seed"], r["season"], r["week"]) == key}):
            runs = sorted(_of(rows, key, model), key=lambda r: r["weight"], reverse=True)
            on = {id(r) for r in pareto(runs)}
            pts = "; ".join(
                f"w={r['weight']:g}: {r[KH]:.2f} ({r['viol_at_max']:.2f}) @ {r['energy_proxy']:.1f} / "
                f"{r['heating_kWh']:.1f}{'' if id(r) in on else ' [off]'}"
                for r in runs
            )
            print(f"  {model:<22} {pts}")
        for ref, model in pairs:
            a, b = _of(rows, key, ref), _of(rows, key, model)
            if not a or not b:
                continue
            for x, name in AXES.items():
                g = front_gap(a, b, x)
                gap = (
                    "no overlap"
                    if g is None
                    else f"over {name} {g['lo']:.1f}..{g['hi']:.1f}: K·h {ref} − {model} mean {g['mean']:+.2f}, "
                    f"min {g['min']:+.2f}, max {g['max']:+.2f} (at the ends {g['at_lo']:+.2f} / {g['at_hi']:+.2f})"
                )
                print(f"  [{name}] front {model} against {ref}: {gap}")
                for who, runs, other, oname in ((model, b, a, ref), (ref, a, b, model)):
                    cells = []
                    for c in at_equal(runs, other, x):
                        other_name = "reheat" if x == "energy_proxy" else "Σu²"
                        cells.append(
                            f"w={c['run']['weight']:g}: {_f(c['saved_Kh'])} K·h, {_f(c['saved_energy'], '{:+.1f}')} "
                            f"{name}, {other_name} {_f(c['other_axis'], '{:+.1f}')}"
                        )
                    print(f"    {who} runs against the {oname} front: " + "; ".join(cells))


def summary_table(rows, pairs, x: str = "energy_proxy") -> None:
    """One markdown row per case, week and pair: the front gap and the default-weight runs at equal energy."""
    print(
        f"\n| case | week | {AXES[x]} front: ref − model, mean (min … max) K·h | model's default run vs ref front: "
        "K·h saved at equal energy / energy saved at equal K·h | ref's default run vs model front: K·h saved / energy "
        "saved |"
    )
    print("| --- | --- | --- | --- | --- |")
    for key in _weeks(rows):
        effect, seed, season, week = key
        for ref, model in pairs:
            a, b = _of(rows, key, ref), _of(rows, key, model)
            if not a or not b:
                continue
            g = front_gap(a, b, x)
            gap = "no overlap" if g is None else f"{g['mean']:+.2f} ({g['min']:+.2f} … {g['max']:+.2f})"
            m0 = next((c for c in at_equal(b, a, x) if c["run"]["weight"] == 1e4), None)
            r0 = next((c for c in at_equal(a, b, x) if c["run"]["weight"] == 1e4), None)
            cell = lambda c: "-" if c is None else f"{_f(c['saved_Kh'])} / {_f(c['saved_energy'], '{:+.1f}')}"  # noqa: E731
            print(f"| {effect} s{seed}: {ref} → {model} | {season} {week} | {gap} | {cell(m0)} | {cell(r0)} |")


def plot(rows, pairs, path) -> None:
    """One panel per case and week: K·h against Σu² for every model, its Pareto front drawn, weights labelled."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = _weeks(rows)
    models = sorted({m for p in pairs for m in p}, key=lambda m: (m != "base", m))
    colors = dict(zip(models, ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple")))
    fig, axes = plt.subplots(len(keys), 2, figsize=(10, 3.2 * len(keys)), squeeze=False)
    for row, key in zip(axes, keys):
        for ax, x in zip(row, AXES):
            for m in models:
                runs = _of(rows, key, m)
                if not runs:
                    continue
                fr = pareto(runs, x)
                ax.plot([r[x] for r in fr], [r[KH] for r in fr], "-", color=colors[m], lw=1, label=m)
                ax.plot([r[x] for r in runs], [r[KH] for r in runs], "o", color=colors[m], ms=3)
                for r in runs:
                    ax.annotate(f"{r['weight']:g}", (r[x], r[KH]), fontsize=6, color=colors[m])
            ax.set_xlabel(f"{AXES[x]} [{'(kg/s)²' if x == 'energy_proxy' else 'kWh'}]", fontsize=7)
            ax.set_ylabel("K·h outside [20, 22] °C", fontsize=7)
            ax.set_title(f"{key[0]} s{key[1]} {key[2]} week {key[3]}", fontsize=7)
            ax.tick_params(labelsize=6)
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    print(f"front figure: {path}")


def _pairs(texts) -> list:
    out = []
    for t in texts:
        ref, _, model = t.partition(",")
        if not model:
            raise SystemExit(f"--pairs wants ref,model (model names hold colons), got {t!r}")
        out.append((ref, model))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=[])
    ap.add_argument("--seasons", nargs="+", default=["summer", "winter"])
    ap.add_argument("--horizon", type=int, default=12)
    ap.add_argument("--days", type=float, default=7.0)
    ap.add_argument("--weights", nargs="+", type=float, default=[1e4, 100.0, 30.0, 10.0, 3.0])
    ap.add_argument("--models", nargs="+", default=["base", "extended", "kept:zone_coupling"])
    ap.add_argument("--json", help="write every run's figures here (rewritten after each run)")
    ap.add_argument("--from-json", nargs="+", help="read runs from these files (bench_control_gain's too)")
    ap.add_argument(
        "--pairs",
        nargs="+",
        default=[
            "base,extended",
            "base,kept:zone_coupling",
            "extended,kept:zone_coupling",
            "base,refit:zone_coupling",
            "refit:zone_coupling,kept:zone_coupling",
            "without:zone_coupling,extended",
        ],
        help="ref,model pairs to compare (ref first; the model's gain is positive); pairs without runs are skipped",
    )
    ap.add_argument("--plot", help="draw the fronts (K·h against Σu² and against reheat) into this PNG")
    ap.add_argument(
        "--min-weight",
        type=float,
        default=0.0,
        help="leave out runs below this comfort weight (a weight where the MPC gives up comfort wholesale makes a "
        "knee that a straight line across does not describe)",
    )
    args = ap.parse_args(argv)
    if args.from_json:
        rows = [r for f in args.from_json for r in json.loads(Path(f).read_text(encoding="utf-8"))]
        rows = [r for r in rows if r["weight"] >= args.min_weight]
    else:
        from bench_control_gain import run_case

        print(f"plant FMU per dataset, MPC N={args.horizon}; load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        rows = []
        for case in args.cases:
            rows += run_case(case, args.seasons, args.horizon, args.days, args.models, args.weights, args.json)
    pairs = _pairs(args.pairs)
    print_fronts(rows, pairs)
    for x in AXES:
        summary_table(rows, pairs, x)
    if args.plot:
        plot(rows, pairs, args.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
