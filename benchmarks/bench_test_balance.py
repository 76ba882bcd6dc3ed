"""How pytest-xdist's ``load`` scheduler would share a test run between workers, from measured per-test costs.

Usage::

    HVACFMU_TEST_CPU=cost.tsv python3 -m pytest -q -n 2 ...          # per-test costs (tests/conftest.py)
    python3 -m pytest --collect-only -q [-m "not slow"] | grep :: > order.txt
    python3 benchmarks/bench_test_balance.py cost.tsv order.txt [--wall] [--workers 2] [--first test_x.py,...]

Replays ``xdist.scheduler.LoadScheduling`` (pytest-xdist 3.x: an initial chunk of a quarter of each worker's
share, refills up to half of the pending share when a worker's queue runs low, nothing moves once sent) on the
costs of ``cost.tsv`` (CPU seconds, or ``--wall`` seconds) in the order of ``order.txt`` (``--first`` moves whole
modules to the front, as ``tests/conftest.py``'s ``RUN_FIRST``) and prints when each worker would end. A worker
that ends much later than the other is the tail to fix: a long module sent late in a big chunk.
"""

from __future__ import annotations

import argparse
import heapq


def read_costs(path: str, wall: bool = False) -> dict[str, float]:
    costs: dict[str, float] = {}
    with open(path, encoding="utf-8") as f:
        for line in f:
            r = line.rstrip("\n").split("\t")
            if len(r) < 5 or r[4].startswith("<"):
                continue
            costs[r[4]] = costs.get(r[4], 0.0) + (float(r[3] or 0) if wall else float(r[1]) + float(r[2]))
    return costs


def simulate(order: list[str], cost, workers: int = 2, startup: float = 8.0, ran: dict | None = None) -> list[float]:
    """End time of each worker [s] under xdist's ``load`` scheduling (``startup``: collection per worker);
    ``ran`` (if given) gets test index -> worker."""
    pending = list(range(len(order)))
    queues: list[list[int]] = [[] for _ in range(workers)]
    chunk = max(len(order) // workers // 4, 2)
    for q in queues:
        q += pending[:chunk]
        del pending[:chunk]
    end = [startup] * workers
    events = [(startup + cost(order[q[0]]), n, q[0]) for n, q in enumerate(queues) if q]
    heapq.heapify(events)
    while events:
        t, n, i = heapq.heappop(events)
        end[n], duration = t, cost(order[i])
        queues[n].remove(i)
        if ran is not None:
            ran[i] = n
        if pending:
            low, high = max(2, len(pending) // workers // 4), max(2, len(pending) // workers // 2)
            if len(queues[n]) < low and not (duration >= 0.1 and len(queues[n]) >= 2):
                k = high - len(queues[n])
                queues[n] += pending[:k]
                del pending[:k]
        if queues[n]:
            heapq.heappush(events, (t + cost(order[queues[n][0]]), n, queues[n][0]))
    return end


def simulate_loadfile(order: list[str], cost, workers: int = 2, startup: float = 8.0) -> tuple[list[float], dict]:
    """End time of each worker [s] under ``--dist loadfile --no-loadscope-reorder`` (pytest-xdist 3.x
    ``LoadFileScheduling``: whole files in collection order, one to each worker at the start, the next file to a
    worker once it has at most 2 tests of its files pending) and which worker ran each file."""
    units: list[list[int]] = []
    for i, nodeid in enumerate(order):
        if not units or order[units[-1][0]].split("::")[0] != nodeid.split("::")[0]:
            units.append([])
        units[-1].append(i)
    queues: list[list[int]] = [[] for _ in range(workers)]
    where: dict[str, int] = {}

    def assign(n: int) -> None:
        if units:
            unit = units.pop(0)
            where[order[unit[0]].split("::")[0]] = n
            queues[n].extend(unit)

    for n in range(workers):
        assign(n)
    for n in range(workers):
        if len(queues[n]) <= 2:
            assign(n)
    end = [startup] * workers
    events = [(startup + cost(order[q[0]]), n) for n, q in enumerate(queues) if q]
    heapq.heapify(events)
    while events:
        t, n = heapq.heappop(events)
        end[n] = t
        queues[n].pop(0)
        if len(queues[n]) <= 2:
            assign(n)
        if queues[n]:
            heapq.heappush(events, (t + cost(order[queues[n][0]]), n))
    return end, where


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("costs")
    ap.add_argument("order")
    ap.add_argument("--wall", action="store_true", help="wall seconds instead of CPU seconds")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--first", default="", help="comma-separated module file names moved to the front, in order")
    ap.add_argument("--dist", choices=("load", "loadfile"), default="load", help="xdist mode to replay")
    args = ap.parse_args()
    costs = read_costs(args.costs, args.wall)
    with open(args.order, encoding="utf-8") as f:
        order = [line.strip() for line in f if "::" in line]
    first = {name: i for i, name in enumerate(filter(None, args.first.split(",")))}
    order.sort(key=lambda nodeid: first.get(nodeid.split("::")[0].rsplit("/", 1)[-1], len(first)))
    missing = [o for o in order if o not in costs]
    total = sum(costs.get(o, 0.1) for o in order)
    if args.dist == "loadfile":
        end, _ = simulate_loadfile(order, lambda o: costs.get(o, 0.1), args.workers)
    else:
        ran: dict[int, int] = {}
        end = simulate(order, lambda o: costs.get(o, 0.1), args.workers, ran=ran)
        split: dict[str, set] = {}
        for i, n in ran.items():
            split.setdefault(order[i].split("::")[0], set()).add(n)
        split = {m: w for m, w in split.items() if len(w) > 1}
        # a module run on both workers builds its module fixtures and per-worker caches twice
        print(f"modules on more than one worker: {len(split)}: " + ", ".join(m.rsplit("/", 1)[-1] for m in split))
    print(f"{len(order)} tests, {len(missing)} without a measured cost (0.1 s), total {total:.0f} s")
    print("workers end at " + ", ".join(f"{t:.0f} s" for t in end) + f" (ideal {total / args.workers + 8:.0f} s)")


if __name__ == "__main__":
    main()
