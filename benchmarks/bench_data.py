"""Benchmark: load + prepare 51 weeks of 1-minute data (six zones, 21 VAV boxes).

Generates a synthetic Parquet file itself (no emulator needed), then times
``hvacfmu.data.prepare`` three times and prints the median.

    python3 benchmarks/bench_data.py [--weeks 51] [--csv]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from hvacfmu.building import building_from_dict
from hvacfmu.data import prepare

ZONES = ("NW", "W", "S", "E", "NE", "C")
BOXES_PER_ZONE = (3, 4, 4, 4, 3, 3)  # 21 boxes


def bench_building():
    zones, vavs = [], []
    for z, n in zip(ZONES, BOXES_PER_ZONE):
        zones.append({"name": z, "area": 300.0, "volume": 900.0, "adjacent": ["C"] if z != "C" else []})
        vavs += [{"name": f"VAV_{z}_{i + 1}", "zone": z, "m_min": 0.05, "m_max": 0.8} for i in range(n)]
    return building_from_dict(
        {
            "name": "bench floor",
            "latitude": 37.875,
            "longitude": -122.2587,
            "timezone": "America/Los_Angeles",
            "zones": zones,
            "vavs": vavs,
        }
    )


def synthetic_frame(building, weeks=51, seed=0):
    """1-minute synthetic measurements with offsets, a few gaps and Saturday excitation."""
    rng = np.random.default_rng(seed)
    start = pd.Timestamp("2024-09-02 00:00", tz=building.timezone)
    index = pd.date_range(start, periods=weeks * 7 * 1440, freq="1min")
    n = len(index)
    hours = (index.hour + index.minute / 60).to_numpy()
    day = np.arange(n) / 1440.0
    cols = {}
    t_out = 14 + 4 * np.cos(2 * np.pi * day / 365) + 5 * np.sin(2 * np.pi * (hours - 9) / 24) + rng.normal(0, 0.3, n)
    for z in building.zone_names:
        cols[f"T_{z}"] = 21.5 + 0.6 * np.sin(2 * np.pi * (hours - 14) / 24) + rng.normal(0, 0.05, n)
    for v in building.vav_names:
        cols[f"m_{v}"] = np.clip(0.2 + 0.1 * np.sin(2 * np.pi * hours / 24) + rng.normal(0, 0.02, n), 0.05, 0.8)
    cols["T_supply"] = 14 + rng.normal(0, 0.2, n)
    cols["T_out"] = t_out
    cols["ghi"] = np.clip(900 * np.sin(np.pi * (hours - 6) / 12), 0, None) * (hours > 6) * (hours < 18)
    sat = (index.day_of_week == 5) & (index.hour >= 10) & (index.hour < 14)
    cols["excitation"] = (sat & (np.arange(n) // (7 * 1440) % 3 == 0)).astype(float)
    frame = pd.DataFrame(cols, index=index)
    for _ in range(20):  # a few gaps
        a = int(rng.integers(0, n - 300))
        frame.iloc[a : a + int(rng.integers(5, 240)), int(rng.integers(0, frame.shape[1]))] = np.nan
    frame.index.name = "time"
    return frame.reset_index()


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--weeks", type=int, default=51)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--csv", action="store_true", help="also time the same data as CSV")
    args = parser.parse_args()
    building = bench_building()
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        frame = synthetic_frame(building, args.weeks)
        paths = [Path(tmp) / "measurements.parquet"]
        frame.to_parquet(paths[0], index=False)
        print(f"generated {len(frame)} rows x {frame.shape[1]} columns (Parquet) in {time.perf_counter() - t0:.1f} s")
        # the emulator's layout: ISO 8601 text with offsets in the time column
        paths.append(Path(tmp) / "measurements_isotext.parquet")
        frame.assign(time=pd.DatetimeIndex(frame["time"]).strftime("%Y-%m-%dT%H:%M:%S%z")).to_parquet(
            paths[1], index=False
        )
        if args.csv:
            paths.append(Path(tmp) / "measurements.csv")
            frame.to_csv(paths[-1], index=False)
        for path in paths:
            times = []
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    ds = prepare(path, building)
                times.append(time.perf_counter() - t0)
            print(
                f"prepare({path.name}, {args.weeks} weeks, {len(frame)} rows -> {len(ds.frame)} steps, "
                f"{len(ds.weeks)} weeks): median {statistics.median(times):.2f} s over {args.repeat} runs"
            )


if __name__ == "__main__":
    main()
