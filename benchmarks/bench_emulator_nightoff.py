"""Night-off emulator schedule: diagnosis (clean / off-hours heater) and fit + evaluate, two layouts.

Runs, one process at a time, for each layout (sdh, row4): ``generate`` 8 winter weeks (cold climate, from
2025-11-03) with ``--schedule night-off``, clean and with ``off_hours_heater``; ``diagnose`` on each (findings
compared with truth.json); ``fit`` lumped/zones + ``evaluate`` on the clean data; the same clean data with the
default ``always-on`` schedule for comparison (case ``always_on``). Writes one JSON line per
run to ``benchmarks/emulator_nightoff_s13_results.jsonl``.

    OMP_NUM_THREADS=1 nice -n 10 python3 benchmarks/bench_emulator_nightoff.py [workdir [layouts [cases]]]
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

HEATER = {"sdh": "off_hours_heater:zone=W,power=2500,below=5", "row4": "off_hours_heater:zone=R1,power=2500,below=5"}
OUT = Path(__file__).with_name("emulator_nightoff_s13_results.jsonl")


def run(args: list[str]) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "hvacfmu", *args], check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main(work: Path) -> None:
    from hvacfmu.diagnosis.truth import compare_with_truth

    layouts = sys.argv[2].split(",") if len(sys.argv) > 2 else ["sdh", "row4"]
    cases = sys.argv[3].split(",") if len(sys.argv) > 3 else ["clean", "heater", "always_on"]
    seeds = [int(s) for s in sys.argv[4].split(",")] if len(sys.argv) > 4 else [0]
    for seed, layout, case in ((s, lay, c) for s in seeds for lay in layouts for c in cases):
        d = work / f"{layout}-{case}" if seed == 0 else work / f"{layout}-{case}-s{seed}"
        gen = ["generate", str(d), "--weeks", "8", "--seed", str(seed), "--climate", "cold", "--start", "2025-11-03"]
        gen += ["--layout", layout, "--schedule", "always-on" if case == "always_on" else "night-off"]
        if case == "heater":
            gen += ["--effect", HEATER[layout]]
        rec = {"layout": layout, "case": case, "seed": seed, "generate_s": round(run(gen), 1)}
        data, bld = str(d / "measurements.parquet"), str(d / "building.toml")
        rec["diagnose_s"] = round(run(["diagnose", data, "-b", bld, "--json", str(d / "diagnosis.json")]), 1)
        rep = json.loads((d / "diagnosis.json").read_text())
        truth = json.loads((d / "truth.json").read_text())
        cmp = compare_with_truth(rep, truth)
        rec["findings"] = [
            {
                "cause": f["cause"],
                "location": f["location"],
                "reason": f.get("reason"),
                **{k: (f.get("parameters") or {}).get(k, {}).get("value") for k in ("u_min", "T_threshold")},
            }
            for f in rep["findings"]
        ]
        rec["found"] = [e["name"] for e in cmp["found"]]
        rec["missed"] = [e["name"] for e in cmp["missed"]]
        rec["unsupported"] = cmp["unsupported"]
        if case != "heater" and seed == 0:
            for kind in ("lumped", "zones"):
                model = str(d / f"{kind}.json")
                rec[f"fit_{kind}_s"] = round(run(["fit", data, "-b", bld, "-m", kind, "-o", model]), 1)
                ev = d / f"eval_{kind}.json"
                rec[f"evaluate_{kind}_s"] = round(run(["evaluate", data, "-b", bld, "-m", model, "--json", str(ev)]), 1)
                rec[f"evaluate_{kind}"] = json.loads(ev.read_text())
        with OUT.open("a", encoding="utf-8") as fh:
            fh.write(json.dumps(rec) + "\n")
        print(seed, layout, case, rec["found"], rec["missed"], [f["cause"] for f in rec["findings"]], flush=True)


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/nightoff_bench"))
