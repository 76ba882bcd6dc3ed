"""``check`` never says OK while a warning needs action (issue 13): the final line and the exit code.

The emulator's naive-UTC export (two weeks, 15-minute trend log) read as local time because the
building file's ``data_timezone = "UTC"`` line is removed: ``check`` names the 7-hour offset, marks it
``!``, and the final line reads ``OK WITH 1 WARNING THAT NEEDS ACTION (see above: clock offset)`` with
exit code 3; declared UTC, the same data give exit code 0 and no such line.
"""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import pandas as pd
import pytest

from hvacfmu.data import check
from hvacfmu.data.check import EXIT_ATTENTION, EXIT_NOT_USABLE, EXIT_OK
from hvacfmu.errors import HvacfmuWarning

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def naive_utc(tmp_path_factory):
    """(measurements, building declared UTC, building without data_timezone) of the naive-UTC export."""
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(weeks=2, seed=0, clock="naive-utc", export_step=900)
    text = Path(paths.building).read_text()
    assert 'data_timezone = "UTC"' in text
    local = tmp_path_factory.mktemp("clock") / "building_local.toml"
    local.write_text("".join(line for line in text.splitlines(True) if not line.startswith("data_timezone")))
    return Path(paths.measurements), Path(paths.building), local


def _check(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return check(*args, **kwargs)


def _cli(*args):
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run(
        [sys.executable, "-m", "hvacfmu.cli", "-q", "check", *map(str, args)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )


def test_clock_offset_is_not_a_clean_bill(naive_utc):
    data, declared, local = naive_utc
    report = _check(data, local)
    assert report.ok and report.exit_code == EXIT_ATTENTION == 3
    (clock,) = report.attention
    assert "clock: the data look 7 h late" in clock and clock in report.warnings
    text = str(report)
    last = text.splitlines()[-1]
    assert last.startswith("OK WITH 1 WARNING THAT NEEDS ACTION (see above: clock offset)"), last
    assert "OK:" not in text and "exit code 3" in last
    assert f"  ! {clock}" in text and "1 needs action (!)" in text
    fine = _check(data, declared)
    assert fine.ok and fine.attention == [] and fine.exit_code == EXIT_OK
    assert str(fine).splitlines()[-1].startswith("OK"), str(fine)[-300:]
    assert "NEED" not in str(fine)


def test_cli_exit_codes(naive_utc, cli):
    data, declared, local = naive_utc
    r = _cli(data, "-b", local)
    assert r.returncode == 3, r.stdout[-2000:] + r.stderr[-2000:]
    assert r.stdout.rstrip().splitlines()[-1].startswith("OK WITH 1 WARNING THAT NEEDS ACTION")
    r = cli("-q", "check", data, "-b", local, "--timezone", "UTC")  # in-process
    assert r.returncode == 0 and "NEED" not in r.stdout, r.stdout[-2000:]
    assert EXIT_NOT_USABLE == 1  # 'NOT USABLE' exits 1 (tests/test_data.py::test_check_cli)


def test_unknown_columns_need_action_and_notes_do_not(naive_utc, tmp_path):
    data, declared, _ = naive_utc
    frame = pd.read_parquet(data)
    frame["Discharge_Temp_NW_1"] = 30.0  # a point the building file does not map: maybe the Td the models need
    extra = tmp_path / "extra.parquet"
    frame.to_parquet(extra)
    report = _check(extra, declared)
    assert report.exit_code == EXIT_ATTENTION and len(report.attention) == 1
    assert "unknown column(s) ignored: 'Discharge_Temp_NW_1'" in report.attention[0]
    assert "(see above: unknown columns ignored)" in str(report).splitlines()[-1]
    # informational notes (no excitation column, ...) leave the bill clean but say they exist
    assert "excitation" in frame.columns
    plain = tmp_path / "no_excitation.parquet"
    frame.drop(columns=["excitation", "Discharge_Temp_NW_1"]).to_parquet(plain)
    report = _check(plain, declared)
    n = len(report.warnings)
    assert n >= 1 and report.attention == [] and report.exit_code == EXIT_OK
    assert any("no 'excitation' column" in w for w in report.warnings)
    assert str(report).splitlines()[-1] == (
        f"OK with {n} note{'s' if n != 1 else ''} (see above): the data can be used for fitting"
    )
