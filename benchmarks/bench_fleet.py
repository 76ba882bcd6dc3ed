"""Fleet throughput on the local Dask cluster: 1, 2, 4 and 8 buildings, scaling, 1,000-building estimate.

    python3 benchmarks/bench_fleet.py [--weeks 13] [--workers 2] [--stages check,fit,evaluate]
                                      [--peak-51]   # also the peak memory of the 51-week six-zone building

Buildings are emulator buildings of varied layouts and seeds (generated once into the cache). Each size runs
in a fresh output folder (no result cache) on one LocalCluster. Printed: wall time, throughput
[buildings/min], scaling efficiency (throughput per worker relative to one building on one worker) and the
per-task peak resident memory.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

LAYOUTS = ("sdh", "row4", "core9")


def make_manifest(n: int, weeks: int, folder: Path) -> Path:
    from hvacfmu.emulator import cached_dataset

    entries = []
    for i in range(n):
        p = cached_dataset(weeks=weeks, seed=i, layout=LAYOUTS[i % len(LAYOUTS)])
        entries.append({"name": f"b{i}", "measurements": str(p.measurements), "building": str(p.building)})
    path = folder / f"fleet_{n}.json"
    path.write_text(json.dumps(entries))
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--weeks", type=int, default=13)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--stages", default="check,fit,evaluate")
    ap.add_argument("--sizes", default="1,2,4,8")
    ap.add_argument("--peak-51", action="store_true", help="also run the 51-week six-zone building alone")
    args = ap.parse_args()
    from hvacfmu.fleet import fleet

    tmp = Path(tempfile.mkdtemp(prefix="bench-fleet-"))
    sizes = [int(s) for s in args.sizes.split(",")]
    print(f"generating up to {max(sizes)} buildings of {args.weeks} weeks (cached after the first run) ...")
    rows = []
    for n in sizes:
        manifest = make_manifest(n, args.weeks, tmp)
        out = tmp / f"out_{n}"
        t0 = time.perf_counter()
        res = fleet(
            manifest,
            stages=args.stages,
            out=out,
            n_workers=min(args.workers, n),
            kinds=("zones",),
            progress=False,
            report=False,
        )
        wall = time.perf_counter() - t0
        busy = sum(sum(b["seconds"].values()) for b in res.buildings)
        peak = max(b.get("peak_rss_mb") or 0 for b in res.buildings)
        rows.append((n, min(args.workers, n), wall, 60 * n / wall, busy / n, peak, len(res.failed)))
        shutil.rmtree(out, ignore_errors=True)
    base = rows[0][3] / rows[0][1]
    print(f"\nstages {args.stages}, {args.weeks}-week buildings, LocalCluster, 1 thread per worker")
    print(
        f"{'n':>3} {'workers':>7} {'wall [s]':>9} {'bldg/min':>9} {'task [s]':>9} {'efficiency':>10} "
        f"{'peak RSS [MB]':>13} {'failed':>6}"
    )
    for n, w, wall, thr, task, peak, failed in rows:
        print(f"{n:>3} {w:>7} {wall:>9.1f} {thr:>9.2f} {task:>9.1f} {thr / w / base:>10.2f} {peak:>13.0f} {failed:>6}")
    n, w, wall, thr, task, *_ = rows[-1]
    per_worker = thr / w
    for cluster in (2, 32, 128):
        print(
            f"estimate: 1,000 buildings on {cluster} single-thread workers: "
            f"{1000 / (per_worker * cluster):.0f} min (at {per_worker:.2f} buildings/min per worker, "
            f"the {n}-building efficiency; scheduler overhead per task is ~ms)"
        )
    if args.peak_51:
        from hvacfmu.emulator import cached_dataset

        p = cached_dataset(weeks=51, seed=0)
        m = tmp / "peak.json"
        m.write_text(json.dumps([{"name": "sdh51", "measurements": str(p.measurements), "building": str(p.building)}]))
        res = fleet(
            m,
            stages="check,fit,evaluate,diagnose,export",
            out=tmp / "peak",
            n_workers=1,
            kinds=("lumped", "zones", "physics"),
            progress=False,
            report=False,
        )
        b = res.buildings[0]
        print(
            f"\n51-week six-zone building, all stages, kinds lumped/zones/physics: status {b['status']}, "
            f"{sum(b['seconds'].values()):.1f} s, peak RSS of the worker process {b['peak_rss_mb']:.0f} MB"
        )
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
