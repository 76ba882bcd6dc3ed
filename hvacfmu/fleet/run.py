"""Run the per-building pipeline over a fleet with Dask (``dask.distributed``)."""

from __future__ import annotations

import dataclasses
import logging
import os
import sys
import time
from pathlib import Path

import pandas as pd

from ..errors import HvacfmuError
from .manifest import BuildingSpec, read_fleet
from .task import DEFAULT_KINDS, run_building, stage_list

log = logging.getLogger("hvacfmu.fleet")

#: Memory limit of one local worker (the 51-week six-zone building peaks well below it).
DEFAULT_WORKER_MEMORY = "3GiB"


@dataclasses.dataclass
class FleetResult:
    """Outcome of :func:`fleet`.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per building and zone (and model): status, failed stage and error, RMS by season, baselines,
        verdict against persistence, ASHRAE Guideline 14 NMBE / CV(RMSE), findings, FMU paths.
    buildings : list of dict
        The per-building results as returned by :func:`~hvacfmu.fleet.task.run_building`.
    seconds : float
        Wall time of the run [s].
    n_workers : int
    out : Path
    """

    table: pd.DataFrame
    buildings: list
    seconds: float
    n_workers: int
    out: Path

    @property
    def failed(self) -> list:
        """Names of the buildings whose pipeline failed."""
        return [b["name"] for b in self.buildings if b["status"] != "ok"]

    def to_pandas(self) -> pd.DataFrame:
        return self.table

    def summary(self) -> str:
        n = len(self.buildings)
        cached = sum(bool(b.get("cached")) for b in self.buildings)
        lines = [
            f"fleet: {n} buildings in {self.seconds:.1f} s on {self.n_workers} worker(s) "
            f"({n - len(self.failed)} ok, {len(self.failed)} failed, {cached} from cache)"
        ]
        for b in self.buildings:
            if b["status"] != "ok":
                lines.append(f"!! {b['name']}: {b['failed_stage']} failed: {b['error'].splitlines()[0]}")
        t = self.table
        if "verdict" in t and len(t):
            losing = t[t["verdict"].astype(str).str.startswith("WORSE")]
            lines.append(f"zones worse than persistence: {len(losing)} of {len(t)} (building, model, zone) rows")
        lines += _season_lines(t)
        return "\n".join(lines)


def _season_lines(t: pd.DataFrame, shown: int = 12) -> list[str]:
    """How many (building, model, zone) rows lose to persistence / the time-of-week mean in some season, and which."""
    lines = []
    for col, what in (
        ("seasons_worse_than_persistence", "persistence"),
        ("seasons_worse_than_time_of_week", "the time-of-week mean"),
    ):
        if col not in t or not len(t):
            continue
        rows = t[t[col].fillna("").astype(str) != ""]
        cases = "; ".join(f"{r.building} {r.model} {r.zone}: {r[col]}" for _, r in rows.head(shown).iterrows())
        more = f" and {len(rows) - shown} more" if len(rows) > shown else ""
        flag = "!! " if len(rows) and col.endswith("persistence") else ""
        listed = f" ({cases}{more})" if len(rows) else ""
        lines.append(f"{flag}zones worse than {what} in a season: {len(rows)} of {len(t)} rows{listed}")
    return lines


def fleet(
    source,
    stages=("check", "fit", "evaluate"),
    out="hvacfmu-fleet",
    *,
    scheduler=None,
    n_workers=None,
    kinds=DEFAULT_KINDS,
    step: float = 900.0,
    horizon: int = 96,
    progress=None,
    report=True,
) -> FleetResult:
    """Run the pipeline over every building of ``source`` on a Dask cluster.

    Parameters
    ----------
    source : path
        Folder of building folders, a folder with ``fleet.json``, or a manifest (``.json``/``.csv``).
    stages : str or sequence of str
        Subset of ``check, fit, evaluate, diagnose, export``.
    out : path
        Output folder: ``fleet.parquet``, ``fleet.csv``, ``report.html`` and per-building results.
    scheduler : str, optional
        Address of a running Dask scheduler (e.g. ``tcp://10.0.0.5:8786``); default a ``LocalCluster``.
    n_workers : int, optional
        Local workers (default: the machine's cores, one thread each).
    kinds : sequence of str
        Model kinds to fit.
    step : float [s]
    horizon : int [steps]
    progress : bool, optional
        Progress bar (default: when stderr is a terminal; otherwise a log line per building).
    report : bool
        Write the HTML report page with figures.

    Returns
    -------
    FleetResult
    """
    specs = read_fleet(source)
    stages = stage_list(stages)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    options = {"kinds": list(kinds), "step": float(step), "horizon": int(horizon)}
    t0 = time.perf_counter()
    results, n = _run_on_dask(specs, stages, out, options, scheduler, n_workers, progress)
    table = fleet_table(results)
    result = FleetResult(table, results, time.perf_counter() - t0, n, out)
    _write_table(table, out)
    if report:
        from .report import write_report

        write_report(result, out / "report.html")
    return result


def _run_on_dask(specs: list[BuildingSpec], stages, out, options, scheduler, n_workers, progress):
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError as exc:  # pragma: no cover - dask is a dependency
        raise HvacfmuError(
            f"the fleet command needs dask.distributed ({exc}); pip install 'dask[distributed]'"
        ) from None
    cluster = None
    if scheduler:
        client = Client(scheduler, timeout="30s")
    else:
        n_workers = int(n_workers or min(len(specs), os.cpu_count() or 1))
        cluster = LocalCluster(
            n_workers=n_workers,
            threads_per_worker=1,
            processes=True,
            memory_limit=DEFAULT_WORKER_MEMORY,
            dashboard_address=None,
        )
        client = Client(cluster)
    try:
        n = len(client.scheduler_info().get("workers", {})) or (n_workers or 1)
        futures = {
            client.submit(run_building, s, stages, str(out), options, key=f"building-{i}-{s.name}", pure=False): s
            for i, s in enumerate(specs)
        }
        results = {}
        bar = _progress(len(specs), progress)
        for fut in as_completed(list(futures)):
            try:
                r = fut.result()
            except Exception as exc:  # noqa: BLE001 - a lost worker (e.g. killed for memory) fails one building
                r = _lost(futures[fut], exc)
            results[r["name"]] = r
            bar(r)
        return [results[s.name] for s in specs], n
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _lost(spec: BuildingSpec, exc: Exception) -> dict:
    return {
        "name": spec.name,
        "key": None,
        "status": "failed",
        "failed_stage": "worker",
        "error": f"the Dask task failed ({type(exc).__name__}: {exc}); a worker over its memory limit "
        f"({DEFAULT_WORKER_MEMORY}) is restarted and its task reported here",
        "seconds": {},
        "zones": [],
        "findings": [],
        "fmus": {},
        "notes": [],
        "cached": False,
    }


def _progress(total: int, progress):
    tty = sys.stderr.isatty() if progress is None else bool(progress)
    done = [0]
    if tty:
        from tqdm.auto import tqdm

        bar = tqdm(total=total, desc="fleet", unit="building", file=sys.stderr)

        def update(r):
            bar.update(1)
            if done[0] + 1 == total:
                bar.close()
            done[0] += 1

        return update

    def line(r):
        done[0] += 1
        state = "cached" if r.get("cached") else ("ok" if r["status"] == "ok" else f"FAILED at {r['failed_stage']}")
        print(f"fleet: {done[0]}/{total} {r['name']}: {state}", file=sys.stderr, flush=True)

    return line


def fleet_table(results: list) -> pd.DataFrame:
    """One row per building, model and zone (one row per building when it has no zone scores)."""
    rows = []
    for r in results:
        base = {
            "building": r["name"],
            "status": r["status"],
            "failed_stage": r["failed_stage"],
            "error": r["error"],
            "peak_rss_mb": r.get("peak_rss_mb"),
            "seconds": sum(r.get("seconds", {}).values()),
        }
        findings = r.get("findings", [])
        base["findings"] = "; ".join(f"{f['cause']} {f['location']}" for f in findings)
        base["n_findings"] = len(findings)
        for kind, path in r.get("fmus", {}).items():
            base[f"fmu_{kind}"] = path
        zones = r.get("zones") or [{}]
        for z in zones:
            row = dict(base)
            row.update(z)
            zone_findings = [f for f in findings if z.get("zone") and f'"{z.get("zone")}"' in f["location"]]
            row["zone_findings"] = "; ".join(
                f"{f['cause']} ({f['gain_percent']:+.1f} %)" if f.get("gain_percent") is not None else f["cause"]
                for f in zone_findings
            )
            rows.append(row)
    return pd.DataFrame(rows)


def _write_table(table: pd.DataFrame, out: Path) -> None:
    table.to_csv(out / "fleet.csv", index=False)
    table.to_parquet(out / "fleet.parquet", index=False)
