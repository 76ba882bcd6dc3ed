"""The fleet: many buildings on Dask, one failing building never stops the others, reruns resume."""

from __future__ import annotations

import json
import shutil

import pandas as pd
import pytest

from hvacfmu.errors import DataError
from hvacfmu.fleet import read_fleet, run_building
from hvacfmu.fleet.run import fleet_table


@pytest.fixture(scope="module")
def small_fleet(tmp_path_factory):
    """A manifest of two 4-week emulator buildings (two layouts) and one with broken data."""
    from hvacfmu.emulator import cached_dataset

    root = tmp_path_factory.mktemp("fleet")
    entries = []
    for name, opts in (("sdh", {"seed": 0}), ("row", {"seed": 1, "layout": "row4"})):
        p = cached_dataset(weeks=4, **opts)
        entries.append({"name": name, "measurements": str(p.measurements), "building": str(p.building)})
    bad = root / "bad"
    bad.mkdir()
    p = cached_dataset(weeks=4, seed=0)
    shutil.copy(p.building, bad / "building.toml")
    frame = pd.read_parquet(p.measurements)
    frame.iloc[:, 1:3] = float("nan")  # two whole columns missing: check must refuse, naming them
    frame.to_parquet(bad / "measurements.parquet")
    entries.append({"name": "bad", "measurements": "bad/measurements.parquet", "building": "bad/building.toml"})
    manifest = root / "fleet.json"
    manifest.write_text(json.dumps({"buildings": entries}))
    return manifest


def test_manifest_errors_name_entry_and_file(tmp_path):
    m = tmp_path / "m.json"
    m.write_text(json.dumps([{"name": "x", "measurements": "nope.parquet", "building": "nope.toml"}]))
    with pytest.raises(DataError, match=r"entry 0 \(x\): missing measurements .*nope.parquet"):
        read_fleet(m)
    with pytest.raises(DataError, match="does not exist"):
        read_fleet(tmp_path / "absent")
    (tmp_path / "empty").mkdir()
    with pytest.raises(DataError, match="no building found"):
        read_fleet(tmp_path / "empty")


def test_one_building_pipeline_and_cache(small_fleet, tmp_path):
    specs = read_fleet(small_fleet)
    row = next(s for s in specs if s.name == "row")
    r = run_building(row, "check,evaluate", tmp_path, {"kinds": ["zones"]})
    assert r["status"] == "ok", r["error"]
    assert r["cached"] is False
    assert set(r["seconds"]) == {"check", "fit", "evaluate"}  # evaluate implies fit
    zones = {z["zone"] for z in r["zones"]}
    assert zones == {"R1", "R2", "R3", "R4"} or len(zones) == 4
    for z in r["zones"]:
        assert z["rms_all"] > 0 and z["persistence_all"] > 0
        assert z["verdict"]
    again = run_building(row, "check,evaluate", tmp_path, {"kinds": ["zones"]})
    assert again["cached"] is True and again["zones"] == r["zones"]
    # other options are another result
    other = run_building(row, "check,evaluate", tmp_path, {"kinds": ["lumped"]})
    assert other["cached"] is False and other["key"] != r["key"]


def test_failure_is_recorded_not_raised(small_fleet, tmp_path):
    bad = next(s for s in read_fleet(small_fleet) if s.name == "bad")
    r = run_building(bad, "check,fit", tmp_path, {"kinds": ["zones"]})
    assert r["status"] == "failed" and r["failed_stage"] == "check"
    assert "check refused" in r["error"]
    table = fleet_table([r])
    assert table.loc[0, "status"] == "failed" and table.loc[0, "failed_stage"] == "check"


@pytest.mark.slow
def test_fleet_on_local_dask_cluster(small_fleet, tmp_path):
    from hvacfmu.fleet import fleet

    out = tmp_path / "out"
    res = fleet(small_fleet, stages="check,fit,evaluate,export", out=out, n_workers=2, kinds=("zones",), progress=False)
    assert res.failed == ["bad"]
    t = pd.read_parquet(out / "fleet.parquet")
    assert set(t["building"]) == {"sdh", "row", "bad"}
    ok = t[t["status"] == "ok"]
    assert len(ok) == 6 + 4  # one row per zone of each building
    assert ok["rms_all"].gt(0).all() and ok["fmu_zones"].str.endswith(".fmu").all()
    assert (out / "fleet.csv").exists() and "Portfolio report" in (out / "report.html").read_text()
    again = fleet(
        small_fleet, stages="check,fit,evaluate,export", out=out, n_workers=2, kinds=("zones",), progress=False
    )
    assert all(b.get("cached") for b in again.buildings if b["status"] == "ok")


@pytest.mark.slow
def test_cli_fleet_subprocess(small_fleet, tmp_path):
    import subprocess
    import sys

    out = tmp_path / "cli"
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "hvacfmu",
            "-q",
            "fleet",
            str(small_fleet),
            "--stages",
            "check",
            "--out",
            str(out),
            "--workers",
            "1",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert p.returncode == 1, p.stderr  # one building fails its check
    assert "bad: check failed" in p.stdout
    assert "Traceback" not in p.stderr
    assert (out / "fleet.parquet").exists()


def test_a_season_lost_to_persistence_shows_in_the_table_and_summary(tmp_path):
    """A model that beats persistence over all windows but loses in one season: the fleet row's verdict is
    the all-windows one, so the table must carry both baselines per season and the seasons lost, and the
    summary must count and name them (before, only ``persistence_all`` was kept: the loss was invisible)."""
    from types import SimpleNamespace

    from hvacfmu.fleet.run import FleetResult
    from hvacfmu.fleet.task import _zone_rows

    def table(values):  # Table I: rows seasons + all, columns outputs
        return pd.DataFrame({"R1": values}, index=["fall", "winter", "all"])

    tables = {
        "model": table([0.20, 0.90, 0.40]),
        "persistence": table([1.00, 0.80, 0.93]),
        "time-of-week mean": table([0.15, 1.20, 0.50]),
    }
    score = SimpleNamespace(outputs=("R1",), table=lambda which, order: tables[which])
    ev = SimpleNamespace(verdict=None, season_order=("fall", "winter"), score=lambda name: score)
    rows = _zone_rows(ev, ["zones"])
    assert rows[0]["verdict"] == "beats persistence"  # over all windows
    assert rows[0]["persistence_winter"] == 0.80 and rows[0]["time_of_week_fall"] == 0.15
    assert rows[0]["seasons_worse_than_persistence"] == "winter"
    assert rows[0]["seasons_worse_than_time_of_week"] == "fall"
    result = {"name": "b1", "status": "ok", "failed_stage": None, "error": None, "zones": rows}
    t = fleet_table([result])
    text = FleetResult(t, [result], 1.0, 1, tmp_path).summary()
    assert "!! zones worse than persistence in a season: 1 of 1 rows (b1 zones R1: winter)" in text
    assert "zones worse than the time-of-week mean in a season: 1 of 1 rows (b1 zones R1: fall)" in text
