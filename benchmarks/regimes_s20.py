"""Two regimes, one set of coefficients (session 20): the memory check's candidates selected three ways.

Issue 13 p.8 on the EnergyPlus mid-rise apartments (``memory_s19.py``'s bed). The fit's memory check
(:mod:`hvacfmu.models.memory`) builds four candidates and scores them by blocked week cross-validation on the
training weeks. Each candidate is also scored on the held-out windows (per flat and season, against persistence and
the time-of-week mean), and the held-out tables of these selections and switches are put side by side:

- ``fit`` (main before session 19, ``memory=False``);
- ``mean`` (session 19's default rule: the lowest cross-validated RMS, seasons weighed alike);
- ``no_season_worse`` (option ``memory_select="no_season_worse"``: not worse than the fit in any season beyond one
  standard error of the paired week difference);
- ``season_switch`` (not a model the package can ship: per season the candidate the week cross-validation ranks
  first in that season, ``meta["memory"]["season_best"]``; its held-out table is assembled from the candidates'
  tables, exact because every scored 24-h window lies in one season's label and would run that season's set);
- ``unit_switch`` (:class:`UnitSwitched`, simulated: per zone and step the fit's equation where the zone's unit
  runs, the slow refinement's elsewhere) and ``window_switch`` (per zone and window the slow refinement's RMS where
  the unit runs in at most :data:`FLOATING_SHARE` of the window's steps, else the fit's): neither can be shipped.

Counted: zone-seasons behind persistence / behind the time-of-week mean; mean over the flats per season and year.

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/regimes_s20.py --out DIR apartments [--split-seed 1]
    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/regimes_s20.py --out DIR energyplus --dirs EXPORT_DIR ...
    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/regimes_s20.py --out DIR emulator --seeds 0 1

``energyplus`` / ``emulator``: the default fit (is the check run at all?) and, forced (``memory=True``), the same
three selections, for information.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from hvacfmu.models.base import ZoneModel

sys.path.insert(0, str(Path(__file__).resolve().parent))

RULES = ("fit", "mean", "no_season_worse", "season_switch", "unit_switch", "window_switch")


class UnitSwitched(ZoneModel):
    """Not a model the package can ship (no matrix form, ``regimes_s20.md``): each zone's next temperature from
    ``held``'s equation (the memoryless fit) in a step where the zone's unit runs (its measured airflow above
    :func:`hvacfmu.models.causes.held_setpoint.running_threshold` of its training airflows, a cycling unit's floor),
    else from ``floating``'s (the slow refinement). The regime is read from the model's own input, never from the
    temperature it predicts. Each state's gain profile follows its own equation."""

    def __init__(self, held, floating, prep_train_u):
        from hvacfmu.models.causes.held_setpoint import running_threshold

        self.held, self.floating = held, floating
        self.kind, self.step, self.outputs, self.gains = held.kind, held.step, held.outputs, held.gains
        self.meta: dict = {}
        zu = self._zone_u(prep_train_u)
        self.u_on = np.array(
            [running_threshold(float(np.nanquantile(zu[:, i], 0.99)), 0.0) for i in range(zu.shape[1])]
        )
        self.nx = len(held.outputs)
        self.inputs, self.disturbances, self.holidays = held.inputs, held.disturbances, held.holidays

    @property
    def n_states(self) -> int:
        return self.nx

    def to_dict(self):
        raise NotImplementedError("a benchmark's regime-switched model has no file form")

    @classmethod
    def from_dict(cls, d):
        raise NotImplementedError("a benchmark's regime-switched model has no file form")

    def _zone_u(self, u):
        u = np.asarray(u, float)
        hm = self.held.heat_map if self.held.heat_map is not None else self.held.input_map
        hm = np.asarray(hm, float)
        return u @ hm.T if u.shape[-1] == hm.shape[1] else u

    def signals(self, frame):
        return self.held.signals(frame)

    def measured_outputs(self, frame):
        return self.held.measured_outputs(frame)

    def initial_state(self, frame, k0):
        return self.held.initial_state(frame, k0)

    def output(self, x):
        return np.asarray(x)

    def gains_at(self, index, season):
        return np.concatenate([self.held.gains_at(index, season), self.floating.gains_at(index, season)], axis=-1)

    def step_state(self, x, u, v, q):
        nx = self.nx
        xh = self.held.step_state(x, u, v, q[..., :nx])
        xf = self.floating.step_state(x, u, v, q[..., nx:])
        on = np.nan_to_num(self._zone_u(u)) > self.u_on
        return np.where(on, xh, xf)


class SeasonSwitched(ZoneModel):
    """Not a model the package can ship (``regimes_s20.md`` section 3): the coefficients of ``by_season[s]`` in the
    windows of season ``s``. The season travels as a last column of the gain term (``gains_at`` knows the season,
    ``step_state`` does not); used to check that the composed ``season_switch`` table is what a simulation gives."""

    def __init__(self, by_season: dict):
        first = next(iter(by_season.values()))
        self.by_season = by_season
        self.names = list(by_season)
        self.kind, self.step, self.outputs, self.gains = first.kind, first.step, first.outputs, first.gains
        self.inputs, self.disturbances, self.holidays = first.inputs, first.disturbances, first.holidays
        self.meta: dict = {}
        self.first = first

    @property
    def n_states(self) -> int:
        return len(self.outputs)

    def to_dict(self):
        raise NotImplementedError("a benchmark's season-switched model has no file form")

    @classmethod
    def from_dict(cls, d):
        raise NotImplementedError("a benchmark's season-switched model has no file form")

    def signals(self, frame):
        return self.first.signals(frame)

    def measured_outputs(self, frame):
        return self.first.measured_outputs(frame)

    def initial_state(self, frame, k0):
        return self.first.initial_state(frame, k0)

    def output(self, x):
        return np.asarray(x)

    def gains_at(self, index, season):
        q = self.by_season[season].gains_at(index, season)
        return np.concatenate([q, np.full(q.shape[:-1] + (1,), float(self.names.index(season)))], axis=-1)

    def step_state(self, x, u, v, q):
        which = q[..., -1]
        out = None
        for i, s in enumerate(self.names):
            sel = which == i
            if not np.any(sel):
                continue
            xs = np.asarray(self.by_season[s].step_state(x, u, v, q[..., :-1]))
            out = xs if out is None else np.where(sel[..., None], xs, out)
        return out


def _fit_capturing(ds, kind, **opts):
    """``fit(ds, kind, **opts)`` and the memory check's candidate models (empty if the check did not run)."""
    from hvacfmu.fitting import fit
    from hvacfmu.models import memory

    seen: dict = {}
    orig = memory.memory_candidates

    def wrap(*a, **k):
        out = orig(*a, **k)
        seen.update(out[0])
        return out

    memory.memory_candidates = wrap
    try:
        t0 = time.process_time()
        m = fit(ds, kind, progress=False, **opts)
        cpu = time.process_time() - t0
    finally:
        memory.memory_candidates = orig
    return m, dict(seen), cpu


def _compose(scores: dict, pick: dict) -> dict:
    """A held-out table whose season ``s`` comes from candidate ``pick[s]`` (``all``: window-weighted)."""
    import numpy as np

    first = scores[next(iter(pick.values()))]
    rows = {}
    seasons = [s for s in first["seasons"] if s != "all"]
    for s in seasons:
        rows[s] = dict(scores[pick[s]]["seasons"][s])
    w = np.array([rows[s]["windows"] for s in seasons], float)
    allrow = dict(first["seasons"]["all"])
    allrow["model"] = (np.array([rows[s]["model"] for s in seasons]).T @ w / w.sum()).tolist()
    rows["all"] = allrow
    return {"outputs": first["outputs"], "seasons": rows}


#: a zone floats in a window when its unit runs in at most this share of the window's steps (``apartments_s18.md``'s
#: floating regime of the wind re-test, declared there before any score was read)
FLOATING_SHARE = 0.10


def _window_switch(res, ds, sw) -> dict:
    """Per window and zone, the slow refinement's RMS where the zone floats in the window (its unit runs in at most
    :data:`FLOATING_SHARE` of the steps, from the measured airflows), the fit's elsewhere; per season the mean."""
    sc = {s.name: s for s in res.scores}
    fit, slow = sc["fit"], sc["slow_cross_fitted"]
    idx = ds.frame.index
    u = np.asarray(sw.held.signals(ds.frame)[0], float)
    on = np.nan_to_num(sw._zone_u(u)) > sw.u_on
    N = 96  # the evaluation's 24-h horizon at 15 min
    k0 = idx.get_indexer(fit.starts)
    share = np.stack([on[k : k + N].mean(axis=0) for k in k0])  # (W, ny)
    if share.shape[1] != fit.rms.shape[1]:
        share = np.broadcast_to(share.mean(axis=1, keepdims=True), fit.rms.shape)
    floating = share <= FLOATING_SHARE
    rms = np.where(floating, slow.rms, fit.rms)
    seasons = np.asarray(fit.seasons, dtype=object)
    rows = {}
    for s in [*dict.fromkeys(fit.seasons), "all"]:
        sel = np.ones(len(seasons), bool) if s == "all" else seasons == s
        rows[s] = {
            "windows": int(sel.sum()),
            "model": np.nanmean(rms[sel], axis=0).tolist(),
            "persistence": np.nanmean(fit.baselines["persistence"][sel], axis=0).tolist(),
            "time_of_week": np.nanmean(fit.baselines["time-of-week mean"][sel], axis=0).tolist(),
            "floating_share": float(np.mean(floating[sel])),
        }
    return {"outputs": list(fit.outputs), "seasons": rows}


def _summary(per: dict) -> dict:
    """Zone-seasons behind persistence / time-of-week; per season the mean over outputs of model and baselines."""
    import numpy as np

    bp = bt = n = 0
    means = {}
    for s, row in per["seasons"].items():
        m = np.asarray(row["model"], float)
        p = np.asarray(row["persistence"], float)
        t = np.asarray(row["time_of_week"], float)
        if len(per["outputs"]) == 1:  # lumped: against the floor's baselines
            p, t = np.array([np.nanmean(p)]), np.array([np.nanmean(t)])
        means[s] = {"model": float(np.mean(m)), "persistence": float(np.mean(p)), "time_of_week": float(np.mean(t))}
        if s == "all":
            continue
        n += m.size
        bp += int(np.sum(m > p))
        bt += int(np.sum(m > t))
    return {"cells": n, "behind_persistence": bp, "behind_time_of_week": bt, "means": means}


def _selections(ds, kind, opts, tag, out: Path) -> dict:
    from energyplus_unseen5_run import _per_zone_season

    from hvacfmu.evaluation import evaluate
    from hvacfmu.models.memory import select_candidate

    m, cands, cpu = _fit_capturing(ds, kind, **opts)
    mem = m.meta.get("memory") or {}
    rec: dict = {"kind": kind, "fit_cpu_s": cpu, "checked": bool(mem.get("checked")), "memory": mem}
    print(f"{tag} {kind}: fit CPU {cpu:.1f} s, check run: {rec['checked']} ({mem.get('reason', mem.get('why'))})")
    if not rec["checked"]:
        return rec
    cv = mem["week_cv"]
    picks = {
        "fit": "fit",
        "mean": select_candidate(cv, "mean")[0],
        "no_season_worse": select_candidate(cv, "no_season_worse")[0],
    }
    models = dict(cands)
    if "slow_cross_fitted" in cands:
        from hvacfmu.models.datadriven import _options, _Prepared

        prep = _Prepared(ds, _options({}))
        u_tr = np.asarray(cands["fit"].signals(prep.frame)[0], float)[prep.train]
        models["unit_switch"] = UnitSwitched(cands["fit"], cands["slow_cross_fitted"], u_tr)
        print(f"  unit_switch: running thresholds {np.round(models['unit_switch'].u_on, 5).tolist()} kg/s")
    best = mem.get("season_best") or {}
    if best:
        models["season_switch_sim"] = SeasonSwitched({s: cands[best.get(s, "fit")] for s in cands["fit"].gains})
    res = evaluate(list(models.values()), ds, names=list(models))
    scores = _per_zone_season(res)
    seasons = [s for s in scores["fit"]["seasons"] if s != "all"]
    best = mem.get("season_best") or {}
    tables = {r: scores[p] for r, p in picks.items()}
    tables["season_switch"] = _compose(scores, {s: best.get(s, "fit") for s in seasons})
    if "season_switch_sim" in scores:
        tables["season_switch_sim"] = scores.pop("season_switch_sim")
    if "unit_switch" in scores:
        tables["unit_switch"] = scores.pop("unit_switch")
        tables["window_switch"] = _window_switch(res, ds, models["unit_switch"])
        print(
            "  window_switch: zone-windows floating per season "
            + " ".join(f"{k[:2]} {r['floating_share']:.2f}" for k, r in tables["window_switch"]["seasons"].items())
        )
    rec.update(
        picks=picks, season_best=best, candidate_scores=scores, summaries={r: _summary(t) for r, t in tables.items()}
    )
    rec["candidate_summaries"] = {c: _summary(sc) for c, sc in scores.items()}
    worse = (mem.get("selection") or {}).get("worse_seasons")
    if worse is None:
        worse = select_candidate(cv, "no_season_worse")[1]["worse_seasons"]
    rec["worse_seasons"] = worse
    print(
        "  week CV per season: "
        + "; ".join(f"{c} " + " ".join(f"{s[:2]} {v:.3f}" for s, v in cv[c]["season_rms"].items()) for c in cv)
    )
    print(f"  worse than the fit beyond 1 SE: {worse}; season_best {best}; picks {picks}")
    for r, sm in rec["summaries"].items():
        line = " ".join(f"{s[:2]} {v['model']:.3f}" for s, v in sm["means"].items())
        print(
            f"  {r:>16}: behind pers. {sm['behind_persistence']}/{sm['cells']}, ToW {sm['behind_time_of_week']}/{sm['cells']}; {line}"
        )
    base = rec["summaries"]["fit"]["means"]
    print(
        "  baselines: "
        + " ".join(f"{s[:2]} p {v['persistence']:.3f} t {v['time_of_week']:.3f}" for s, v in base.items())
    )
    return rec


def apartments(out: Path, split_seed: int = 0) -> None:
    from held_zones_s14 import _paths

    from hvacfmu.data import prepare

    tag = "apartments" if split_seed == 0 else f"apartments_split{split_seed}"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        paths = _paths("wind")
        ds = prepare(paths.measurements, paths.building, seed=split_seed)
        recs = {k: _selections(ds, k, {"memory": "auto"}, tag, out) for k in ("zones", "lumped")}
    (out / f"{tag}.json").write_text(json.dumps(recs, indent=1, default=str))


def _default_and_forced(ds, tag, out: Path) -> None:
    recs = {}
    for k in ("zones", "lumped"):
        recs[f"{k}_default"] = _selections(ds, k, {}, tag, out)
        recs[f"{k}_forced"] = _selections(ds, k, {"memory": True}, tag + " forced", out)
    (out / f"{tag}.json").write_text(json.dumps(recs, indent=1, default=str))


def energyplus(out: Path, dirs) -> None:
    from hvacfmu.data import prepare

    for d in dirs:
        d = Path(d)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds = prepare(d / "measurements.parquet", d / "building.toml")
            _default_and_forced(ds, d.name, out)


def emulator(out: Path, seeds) -> None:
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset

    for seed in seeds:
        p = cached_dataset(weeks=8, seed=seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds = prepare(p.measurements, p.building)
            _default_and_forced(ds, f"default_seed{seed}", out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["apartments", "energyplus", "emulator"])
    ap.add_argument("--dirs", nargs="*", default=[])
    ap.add_argument("--split-seed", type=int, default=0)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.what == "apartments":
        apartments(out, args.split_seed)
    elif args.what == "energyplus":
        energyplus(out, args.dirs)
    else:
        emulator(out, args.seeds)


if __name__ == "__main__":
    main()
