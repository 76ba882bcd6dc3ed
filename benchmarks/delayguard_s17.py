"""A loop cycling at twice the data's step is not a delay: delay evidence per zone at the base structure.

Per zone (Model A refitted by within least squares, no extension term): the one-step delay pick, its ΔBIC plain
and given the zone's temperature history, the same given the history with the airflow low-passed
(``delay_given_history(..., True)``, the gate of session 17), the residual's correlation with past and future
airflow by lag, the lag-1/2 autocorrelation of the airflow's step changes, and the fit with the undelayed and the
delayed airflow both free. ``benchmarks/delayguard_s17.md``.

Run (JSON lines to ``/tmp/delayguard_<kind>.jsonl``; cached emulator data in ``$HVACFMU_CACHE``)::

    python3 benchmarks/delayguard_s17.py quad4 4,7,8,14,20,26,0,1,2,3
    python3 benchmarks/delayguard_s17.py default 14,18,26,32,38
    python3 benchmarks/delayguard_s17.py ell5 /path/to/cold1      # a directory from unseen_layout_s17.py
"""

import json
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from hvacfmu.data import prepare
from hvacfmu.diagnosis.design import Within, bounded_ls, fit_structure, make_signals, zone_design
from hvacfmu.diagnosis.selection import DEFAULT_OPTIONS, _gate, delay_given_history, ess_factor, lag1, score_candidate
from hvacfmu.fitting import fit
from hvacfmu.models.causes import Candidate
from hvacfmu.models.causes.actuation_delay import delay_evidence, temperature_history
from hvacfmu.models.causes.signals import max_delay, shifted
from hvacfmu.models.extended import ActuationDelay


def both_fit(sig, W, z, d):
    H = temperature_history(sig.Y[:, z], sig.step)
    keep = np.isfinite(H[W.rows]).all(axis=1)
    rows = W.rows[keep]
    Wh = Within(sig.group, rows)
    target = np.vstack([sig.Y[1:], np.full((1, sig.nz), np.nan)])
    D = zone_design(sig, z, [])
    ud = np.nan_to_num(shifted(sig.U[:, z], d), nan=float(np.nanmean(sig.U[:, z])))
    out = {}
    for withH in (False, True):
        X = np.column_stack([D.X, ud] + ([H] if withH else []))
        k = H.shape[1] if withH else 0
        lo = np.r_[D.lower, -np.inf, [-np.inf] * k]
        hi = np.r_[D.upper, np.inf, [np.inf] * k]
        lo[D.names.index("b")] = -np.inf
        hi[D.names.index("b")] = np.inf
        ls = bounded_ls(Wh(X), Wh(target[:, z] - D.offset), lo, hi, dof_extra=Wh.n_groups)
        se = np.sqrt(np.diag(ls.cov))
        ib = D.names.index("b")
        idl = len(D.names)
        out["H" if withH else "noH"] = {
            "b_now": float(ls.theta[ib]),
            "b_now_t": float(ls.theta[ib] / se[ib]),
            "b_del": float(ls.theta[idl]),
            "b_del_t": float(ls.theta[idl] / se[idl]),
        }
    return out


def table(ds, truth):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        base = fit(ds, "zones", progress=False, use_solar=False, heat="airflow", open_loop=False)
    sig = make_signals(ds, base)
    rows = sig.rows("train")
    W = Within(sig.group, rows)
    cur = fit_structure(sig, [], rows)
    cur_rss = [ls.rss for ls in cur.zone_ls]
    factors = [ess_factor(lag1(cur.resid[:, z])) for z in range(sig.nz)]
    out = []
    for zi, z in enumerate(sig.zones):
        c = Candidate(
            "actuation_delay", {"zone": z}, [ActuationDelay(zone=z, delay=d) for d in range(1, max_delay(sig.step) + 1)]
        )
        score_candidate(sig, W, [], cur_rss, factors, c, None)
        c.evidence.update(delay_evidence(sig, W, cur.resid[:, zi], sig.U[:, zi]))
        _gate(c, dict(DEFAULT_OPTIONS))
        u = W(np.nan_to_num(sig.U[:, zi], nan=float(np.nanmean(sig.U[:, zi]))))
        acf = [float(np.corrcoef(u[:-l], u[l:])[0, 1]) for l in (1, 2, 3, 4)]
        du = np.diff(u)
        acfd = [float(np.corrcoef(du[:-l], du[l:])[0, 1]) for l in (1, 2)]
        ev = c.evidence
        out.append(
            {
                "zone": z,
                "true": truth.get(z),
                "d": int(c.term.delay),
                "dbic": c.test["delta_bic"],
                "hist_dbic": ev["history"].get("delta_bic"),
                "status": c.status,
                "hist_lowpass_dbic": delay_given_history(sig, W, [], c.term, True).get("delta_bic"),
                "past": {k: round(v, 3) for k, v in ev["xcorr_resid_airflow_by_lag"].items()},
                "fut": {k: round(v, 3) for k, v in ev["xcorr_resid_future_airflow_by_lag"].items()},
                "u_acf": [round(a, 3) for a in acf],
                "du_acf": [round(a, 3) for a in acfd],
                "both": both_fit(sig, W, zi, int(c.term.delay)),
            }
        )
    return out


def battery(i, layouts=None):
    from bench_diagnosis_battery import make_cases

    from hvacfmu.emulator import cached_dataset

    if layouts:
        case = make_cases(32, 2026, layouts=["quad4"], n_clean=4, n_pair=4, step=900.0)[i]
    else:
        case = make_cases(48, 2026)[i]
    paths = cached_dataset(weeks=16, seed=case["seed"], effects=case["effects"], layout=case["layout"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(paths.measurements, paths.building, step=case["step"])
    truth = {
        e["zone"]: float(e["minutes"]) * 60 / case["step"]
        for e in json.loads(paths.truth.read_text())["effects"]
        if e["name"] == "actuation_delay"
    }
    return {"source": f"{'quad4' if layouts else 'default'} {i}", "effects": case["effects"], "zones": table(ds, truth)}


def ell5(name):
    d = Path(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(d / "measurements.parquet", d / "building.toml")
    return {"source": f"ell5 {name}", "zones": table(ds, {})}


if __name__ == "__main__":
    kind, ids = sys.argv[1], sys.argv[2].split(",")
    for i in ids:
        r = ell5(i) if kind == "ell5" else battery(int(i), layouts=(kind == "quad4"))
        with open(f"/tmp/delayguard_{kind}.jsonl", "a") as fh:
            fh.write(json.dumps(r) + "\n")
        print(r["source"], "done", flush=True)
