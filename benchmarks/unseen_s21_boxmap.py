"""Session 21: the box-in-another-zone check (`hvacfmu.data.boxmap.check_box_zones`) with and without the
concentration rule (`ZONE_CONCENTRATION`), on the same evidence: clean false alarms and random box swaps.

    PYTHONPATH=. python3 benchmarks/unseen_s21_boxmap.py 'GLOB' [DIR ...] > out.jsonl

GLOB: export folders (session 16's EnergyPlus 1.9 caches: '/tmp/s1*/cache*/energyplus-v1.9-*', 4 weeks from
12 January), one per prototype; DIR: further export folders (the session 21 large hotel). Three random swaps of two
boxes' zones per building (seed 0); buildings above 60 boxes are skipped. Results in benchmarks/unseen_s21.md (fix 8).
"""

from __future__ import annotations

import copy
import glob
import json
import sys
import warnings

import numpy as np
import tomllib

import hvacfmu as hf
from hvacfmu.building import building_from_dict
from hvacfmu.data import boxmap
from hvacfmu.errors import BuildingError


def flags(ev, b, concentration: bool) -> list:
    """(box, other zone, its share of the box's evidence) of the boxes the rule flags."""
    out = []
    for v in ev.boxes:
        if v not in ev.zone_t:
            continue
        alt, _ = ev.zone_t[v]
        z0 = b.vav(v).zone
        own, other = ev.zone[v][z0], ev.zone[v][alt]
        if other - own < boxmap.ZONE_MARGIN or other < boxmap.ZONE_SHARE * (own + other):
            continue
        share = other / max(sum(ev.zone[v].values()), 1e-9)
        if concentration and share < boxmap.ZONE_CONCENTRATION:
            continue
        out.append((v, alt, round(share, 2)))
    return out


def main(argv: list) -> None:
    warnings.simplefilter("ignore")
    todo, seen = [], set()
    for d in sorted(glob.glob(argv[0])) + argv[1:]:
        key = d.rstrip("/").split("/")[-1]
        key = key.split("energyplus-v1.9-")[-1].rsplit("-", 1)[0] if "energyplus-v" in key else key
        if key not in seen:
            seen.add(key)
            todo.append((key, d))
    rng = np.random.default_rng(0)
    for key, d in todo:
        try:
            ds = hf.data.prepare(f"{d}/measurements.parquet", f"{d}/building.toml")
        except Exception as e:  # noqa: BLE001 - a refused export is a row, not the end of the run
            print(json.dumps({"case": key, "error": str(e)[:80]}), flush=True)
            continue
        raw = tomllib.loads(open(f"{d}/building.toml").read())
        b = ds.building
        ev = boxmap.box_zone_evidence(ds.frame, b)
        if ev is None or len(b.vav_names) > 60:
            print(
                json.dumps({"case": key, "skipped": "no evidence or > 60 boxes", "boxes": len(b.vav_names)}), flush=True
            )
            continue
        row = {
            "case": key,
            "boxes": len(b.vav_names),
            "clean_s16": flags(ev, b, False),
            "clean_s21": flags(ev, b, True),
        }
        row["swaps"] = []
        vavs = raw["vavs"]
        for _ in range(3):
            i, j = rng.choice(len(vavs), 2, replace=False)
            if vavs[i]["zone"] == vavs[j]["zone"]:
                continue
            dd = copy.deepcopy(raw)
            a, c = dd["vavs"][i], dd["vavs"][j]
            a["zone"], c["zone"] = c["zone"], a["zone"]
            try:
                bb = building_from_dict(dd)
            except BuildingError:  # the swap itself refused (a 10 kg/s lobby box in a 300 m3 shop)
                continue
            e2 = boxmap.box_zone_evidence(ds.frame, bb)
            if e2 is None:
                continue
            names = {a["name"], c["name"]}
            row["swaps"].append(
                {
                    "pair": sorted(names),
                    "s16": [f for f in flags(e2, bb, False) if f[0] in names],
                    "s21": [f for f in flags(e2, bb, True) if f[0] in names],
                }
            )
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
