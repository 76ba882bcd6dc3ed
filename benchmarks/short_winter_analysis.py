"""Why models lose on seven winter weeks: the measurements behind ``benchmarks/short_winter_s8.md``.

Run after ``bench_short_winter.py`` (reads its ``--out`` folder: the data, ``truth.json`` and the fitted models)::

    python3 benchmarks/short_winter_analysis.py oracle [--case c1 ...]     # what the data allow
    python3 benchmarks/short_winter_analysis.py gain-days [--case ...]      # physics step 2: week/workdays/shrunk/auto
    python3 benchmarks/short_winter_analysis.py segments [--case ...]       # physics step 1 with input gaps filled
    python3 benchmarks/short_winter_analysis.py minute --case c10           # the same plant at the 1-min export

``oracle``: the emulator's own plant (:class:`hvacfmu.emulator.Plant`, the true parameters) driven by the export's
15-minute inputs (airflow and ``Td_`` per box, each unit's supply air, outdoor air, ``ghi``), run continuously from the
data's start; from its state at each test window's midnight, 24-h open loop (i) with the true internal gains and (ii)
with the season's training-week time-of-week mean of the gains (all a model can know). Scored like ``evaluate`` on
the zones model's windows, next to the time-of-week mean.

``minute``: the same case exported every minute without outages (same seed, same building and weather), the true
plant with the true gains driven minute by minute: what the 15-minute samples lose.

``segments`` is an experiment, not the library's behaviour: it patches step 1's weekend-segment selection to use the
evaluation's input filling (gaps up to 2 h), which rejects a segment for a single missing step otherwise.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_short_winter import CASES, COMMON  # noqa: E402


def _load(folder: Path):
    import hvacfmu as hf

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return hf.prepare(folder / "data" / "measurements.parquet", folder / "data" / "building.toml")


def oracle(folder: Path) -> dict:
    """Per zone, mean over the test windows [K]: oracle with true / profile gains, zones model, time-of-week mean."""
    import hvacfmu as hf
    from hvacfmu.emulator import Plant

    truth = json.loads((folder / "data" / "truth.json").read_text(encoding="utf-8"))
    ds = _load(folder)
    f = ds.frame
    plant = Plant.from_truth(truth)
    t0 = pd.Timestamp(truth["start"]).tz_localize(truth["timezone"])
    if f.index[0] != t0:
        raise ValueError(f"data start {f.index[0]} is not the emulated start {t0}")
    fi = f.interpolate(limit_direction="both")  # the oracle needs every input; gaps are interpolated in time
    vavs, zones = plant.vavs, plant.zones
    M = fi[[f"m_{v}" for v in vavs]].to_numpy()
    TD = fi[[f"Td_{v}" for v in vavs]].to_numpy()
    TS = fi[[f"T_supply_{a}" for a in plant.ahus]].to_numpy()
    TO, GHI = fi["T_out"].to_numpy(), fi["ghi"].to_numpy()
    EXC = fi["excitation"].to_numpy() > 0.5
    Y = f[[f"T_{z}" for z in zones]].to_numpy()

    def run(pl, x, k0, k1, store=None):
        out = np.full((k1 - k0 + 1, len(zones)), np.nan)
        out[0] = pl.zone_temperatures(x)
        for i, k in enumerate(range(k0, k1)):
            irr = pl.facades_from_ghi(k * 900.0, 900.0, max(GHI[k], 0.0))
            x, out[i + 1] = pl.advance(
                x, k * 900.0, 900.0, M[k], TO[k], TS[k], irr, excitation=bool(EXC[k]), T_discharge=TD[k]
            )
            if store is not None:
                store[k + 1] = x
        return x, out

    x = plant.initial_state(np.nan_to_num(Y[0], nan=float(np.nanmean(Y[0]))))
    x, _ = run(plant, x, 0, 672)  # one week to warm the walls up
    states: dict = {}
    _, cont = run(plant, x, 0, len(f) - 1, store=states)
    # (ii) the gains any model can know: per season, the training weeks' time-of-week mean (one-minute slots)
    core = copy.copy(plant.core)
    idx = pd.date_range(t0, periods=len(core.Q_ig), freq="min")
    slot = (idx.day_of_week * 1440 + idx.hour * 60 + idx.minute).to_numpy()
    Qp, Tp = core.Q_ig.copy(), core.T_fl.copy()
    for season in {w.season for w in ds.weeks}:
        train = np.zeros(len(idx), bool)
        rows = np.zeros(len(idx), bool)
        for w in ds.weeks:
            if w.season == season:
                sel = (idx >= w.start) & (idx < w.end)
                rows |= sel
                train |= sel & w.train
        if train.any():
            Qp[rows] = pd.DataFrame(core.Q_ig[train]).groupby(slot[train]).mean().reindex(slot[rows]).to_numpy()
            Tp[rows] = pd.Series(core.T_fl[train]).groupby(slot[train]).mean().reindex(slot[rows]).to_numpy()
    core.Q_ig, core.T_fl = Qp, Tp
    profile = Plant(core, truth)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = hf.evaluate(hf.load_model(folder / "zones.json"), ds).scores[0]
    true_rms, prof_rms = [], []
    for s in sc.starts:
        k = f.index.get_loc(s)
        meas = Y[k + 1 : k + 97]
        for pl, acc in ((plant, true_rms), (profile, prof_rms)):
            _, o = run(pl, states[k], k, k + 96)
            acc.append(np.sqrt(np.nanmean(np.where(np.isfinite(meas), (o[1:] - meas) ** 2, np.nan), axis=0)))
    err = cont - Y
    return {
        "continuous_rms": float(np.sqrt(np.nanmean(err**2))),
        "zones": list(zones),
        "oracle_true": np.mean(true_rms, axis=0).tolist(),
        "oracle_profile": np.mean(prof_rms, axis=0).tolist(),
        "zones_model": np.nanmean(sc.rms, axis=0).tolist(),
        "time_of_week": np.nanmean(sc.baselines["time-of-week mean"], axis=0).tolist(),
    }


def _margins(res, names) -> dict:
    out = {}
    for name in names:
        zs = [z for z in res.verdict.zones if z.model == name]
        ss = [s for s in res.verdict.seasons if s.model == name]
        w = min(zs, key=lambda z: z.margin(z.time_of_week))
        out[name] = {
            "worst_zone": w.output,
            "worst_tow_percent": 100 * w.margin(w.time_of_week),
            "worst_season_tow_percent": min([100 * (1 - s.rms / s.time_of_week) for s in ss], default=float("nan")),
            "behind_tow": sum(not z.beats_time_of_week for z in zs),
            "zones": len(zs),
            "mean_rms": float(np.mean([z.rms for z in zs])),
        }
    return out


def gain_days(folder: Path) -> dict:
    """The fitted physics model with step 2 redone for each ``gain_days`` (step 1 unchanged)."""
    import hvacfmu as hf
    from hvacfmu.models.physics import refit_gains

    ds = _load(folder)
    base = hf.load_model(folder / "physics.json")
    models = {"week": base} | {g: refit_gains(base, ds, g) for g in ("workdays", "shrunk", "auto")}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = hf.evaluate(list(models.values()), ds, names=list(models))
    return _margins(res, models)


def segments(folder: Path) -> dict:
    """Physics refitted with step 1's weekend segments taken from the input-filled frame (experiment)."""
    import hvacfmu as hf
    from hvacfmu.data.windows import FILL_INPUTS_H, fill_inputs
    from hvacfmu.models.physics import identification as ident

    ds = _load(folder)
    original = ident._weekend_segments

    class Filled:
        def __init__(self, dataset):
            self._ds = dataset
            self.frame = fill_inputs(dataset.frame, dataset.building.zone_names, dataset.step, FILL_INPUTS_H).frame

        def __getattr__(self, name):
            return getattr(self._ds, name)

    ident._weekend_segments = lambda dataset, *a: original(Filled(dataset), *a)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            filled = hf.fit(ds, "physics", progress=False)
    finally:
        ident._weekend_segments = original
    base = hf.load_model(folder / "physics.json")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = hf.evaluate([base, filled], ds, names=["default", "filled"])
    out = _margins(res, ["default", "filled"])
    out["default"]["segments"] = base.meta.get("n_segments")
    out["filled"]["segments"] = filled.meta.get("n_segments")
    return out


def minute(folder: Path) -> dict:
    """RMS [K] per zone of the true plant, true gains, driven by the case's 1-minute export (no outages)."""
    import hvacfmu as hf
    from hvacfmu.emulator import Plant

    case = folder.name
    opts = {k: v for k, v in {**COMMON, **CASES[case]}.items() if k not in ("faults", "export_step")}
    paths = hf.generate(folder.parent / f"{case}-1min", export_step=60, **opts)
    truth = json.loads(Path(paths.truth).read_text(encoding="utf-8"))
    building = hf.load_building(paths.building)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f, _ = hf.load_measurements(paths.measurements, building)
    t0 = pd.Timestamp(truth["start"]).tz_localize(truth["timezone"])
    f = f.reindex(pd.date_range(t0, periods=int(truth["weeks"]) * 7 * 1440, freq="min")).interpolate(
        limit_direction="both"
    )
    plant = Plant.from_truth(truth)
    M = f[[f"m_{v}" for v in plant.vavs]].to_numpy()
    TD = f[[f"Td_{v}" for v in plant.vavs]].to_numpy()
    TS = f[[f"T_supply_{a}" for a in plant.ahus]].to_numpy()
    TO, GHI = f["T_out"].to_numpy(), f["ghi"].to_numpy()
    EXC = f["excitation"].to_numpy() > 0.5
    Y = f[[f"T_{z}" for z in plant.zones]].to_numpy()
    x = plant.initial_state(Y[0])
    T = np.empty_like(Y)
    T[0] = Y[0]
    for k in range(len(f) - 1):
        irr = plant.facades_from_ghi(k * 60.0, 60.0, max(GHI[k], 0.0))[0]
        x, T[k + 1] = plant.advance(
            x, k * 60.0, 60.0, M[k], TO[k], TS[k], irr, excitation=bool(EXC[k]), T_discharge=TD[k]
        )
    err = pd.DataFrame(T - Y, index=f.index, columns=list(plant.zones)).iloc[7 * 1440 :]  # after a week's warm-up
    ds = _load(folder)
    test = np.zeros(len(err), bool)
    for w in ds.test_weeks():
        test |= (err.index >= w.start) & (err.index < w.end) & (err.index.day_of_week < 5)
    return {
        "zones": list(plant.zones),
        "continuous_rms": float(np.sqrt(np.nanmean(err.to_numpy() ** 2))),
        "test_weekdays_rms": np.sqrt((err[test] ** 2).mean()).tolist(),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("oracle", "gain-days", "segments", "minute"))
    ap.add_argument("--case", action="append", choices=sorted(CASES))
    ap.add_argument("--out", default="/tmp/short-winter", help="bench_short_winter.py's result folder")
    args = ap.parse_args(argv)
    run = {"oracle": oracle, "gain-days": gain_days, "segments": segments, "minute": minute}[args.what]
    results = {}
    for case in args.case or list(CASES):
        r = run(Path(args.out) / case)
        results[case] = r
        if args.what == "oracle":
            cells = zip(r["zones"], r["oracle_true"], r["oracle_profile"], r["zones_model"], r["time_of_week"])
            print(
                f"{case}: continuous run {r['continuous_rms']:.3f} K; per zone: oracle true gains / profile gains / "
                "zones model / time-of-week mean [K]"
            )
            for z, a, b, c, t in cells:
                print(f"   {z:<4} {a:.3f} / {b:.3f} / {c:.3f} / {t:.3f}")
        elif args.what == "minute":
            print(
                f"{case}: 1-min export, true plant and gains: continuous {r['continuous_rms']:.3f} K; test weekdays "
                + ", ".join(f"{z} {e:.3f}" for z, e in zip(r["zones"], r["test_weekdays_rms"]))
                + " K"
            )
        else:
            for name, m in r.items():
                print(
                    f"{case} {name:<9} worst zone {m['worst_zone']:<5} {m['worst_tow_percent']:+7.1f} %, worst season "
                    f"{m['worst_season_tow_percent']:+7.1f} %, behind tow {m['behind_tow']}/{m['zones']}, "
                    f"mean RMS {m['mean_rms']:.3f} K" + (f", {m['segments']} segments" if "segments" in m else "")
                )
        sys.stdout.flush()
    (Path(args.out) / f"analysis-{args.what}.json").write_text(json.dumps(results, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
