"""Diagnose named emulator datasets and compare their reports before/after a change (session 15, speed).

``run OUTDIR CASE...`` writes ``report.to_dict()`` of each case as JSON to OUTDIR and appends its process CPU
seconds to ``OUTDIR/times.tsv``; ``diff DIR_A DIR_B`` compares the JSON files of two such directories: byte
for byte, else number by number (the largest relative difference and every non-numeric difference).
Run it once with PYTHONPATH at the old tree and once at the new one (benchmarks/diagnosis_speed_s15.md).

Cases: ``EFFECT@SEED`` (16 weeks, default layout, as ``tests/test_diagnosis.py::test_emulator_effect_is_found``;
``@0`` is the clean dataset), ``batN`` (battery case N of ``bench_diagnosis_battery.make_cases(48, 2026)``, 16
weeks, core9 at ``max_terms=20`` as ``test_battery_slice``), ``w51`` (the 51-week dataset of bench_diagnosis.py).
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import sys
import time
from pathlib import Path


def _dataset(case: str):
    from hvacfmu.data import prepare
    from hvacfmu.emulator import cached_dataset

    if case.startswith("bat"):
        path = Path(__file__).resolve().parent / "bench_diagnosis_battery.py"
        spec = importlib.util.spec_from_file_location("bench_diagnosis_battery", path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        c = mod.make_cases(48, 2026)[int(case[3:])]
        paths = cached_dataset(weeks=16, seed=c["seed"], effects=c["effects"], layout=c["layout"])
        opts = {"max_terms": 20} if c["layout"] == "core9" else {}
        return prepare(paths.measurements, paths.building, step=c["step"]), opts
    if case == "w51":
        paths = cached_dataset(weeks=51, seed=0)
        return prepare(paths.measurements, paths.building), {}
    effect, seed = case.rsplit("@", 1)
    paths = cached_dataset(weeks=16, seed=int(seed), effects=[effect] if effect else [])
    return prepare(paths.measurements, paths.building), {}


def run(out: Path, cases) -> None:
    import hvacfmu
    from hvacfmu.diagnosis import diagnose

    print("hvacfmu from", hvacfmu.__file__, file=sys.stderr)
    out.mkdir(parents=True, exist_ok=True)
    for case in cases:
        ds, opts = _dataset(case)
        c0, t0 = time.process_time(), time.perf_counter()
        rep = diagnose(ds, progress=False, **opts)
        cpu, wall = time.process_time() - c0, time.perf_counter() - t0
        name = case.replace(":", "_").replace("=", "").replace("@", "_")
        (out / f"{name}.json").write_text(json.dumps(rep.to_dict(), indent=1, sort_keys=True, default=str))
        line = f"{case}\tcpu {cpu:.2f}\twall {wall:.2f}\tload {os.getloadavg()[0]:.1f}\t{rep.causes}"
        print(line, flush=True)
        with open(out / "times.tsv", "a") as f:
            f.write(line + "\n")


def _walk(a, b, path, out):
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            out.append((path, "keys", sorted(set(a) ^ set(b))))
            return
        for k in a:
            _walk(a[k], b[k], f"{path}.{k}", out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append((path, "len", (len(a), len(b))))
            return
        for i, (x, y) in enumerate(zip(a, b)):
            _walk(x, y, f"{path}[{i}]", out)
    elif isinstance(a, float) and isinstance(b, float):
        if a != b and not (math.isnan(a) and math.isnan(b)):
            out.append((path, "rel", abs(a - b) / max(abs(a), abs(b), 1e-300)))
    elif type(a) is not type(b) or a != b:
        out.append((path, "value", (a, b)))


def diff(a_dir: Path, b_dir: Path) -> int:
    bad = 0
    for f in sorted(b_dir.glob("*.json")):
        g = a_dir / f.name
        if not g.exists():
            print(f"{f.name}: not in {a_dir}")
            bad += 1
            continue
        if g.read_text() == f.read_text():
            print(f"{f.name}: identical (bytes)")
            continue
        out: list = []
        _walk(json.loads(g.read_text()), json.loads(f.read_text()), "", out)
        rel = max((d for _, k, d in out if k == "rel"), default=0.0)
        other = [o for o in out if o[1] != "rel"]
        print(f"{f.name}: {len(out)} differences, largest relative {rel:.3g}, non-numeric {len(other)}")
        for o in other[:10]:
            print("   ", o)
        bad += bool(other) or rel > 1e-10
    return bad


if __name__ == "__main__":
    if len(sys.argv) >= 3 and sys.argv[1] == "run":
        run(Path(sys.argv[2]), sys.argv[3:])
    elif len(sys.argv) == 4 and sys.argv[1] == "diff":
        sys.exit(diff(Path(sys.argv[2]), Path(sys.argv[3])))
    else:
        sys.exit(__doc__)
