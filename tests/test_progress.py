"""hvacfmu.progress: a bar on a terminal, plain log lines otherwise (issue 17 p.7)."""

from __future__ import annotations

import io
import logging
import subprocess
import sys

import pytest

import hvacfmu.progress as hp
from hvacfmu.progress import Progress, is_terminal, progress


class FakeTerminal(io.StringIO):
    def isatty(self):
        return True


@pytest.fixture
def fast_logging(monkeypatch):
    monkeypatch.setattr(hp, "LOG_INTERVAL", 0.0)


def test_not_a_terminal_gives_plain_log_lines(caplog, fast_logging):
    stream = io.StringIO()
    with caplog.at_level(logging.INFO, logger="hvacfmu.progress"):
        items = list(progress(range(20), desc="work", unit="week", stream=stream))
    assert items == list(range(20))
    assert stream.getvalue() == ""  # nothing written to the stream itself
    lines = [r.getMessage() for r in caplog.records]
    assert lines[0] == "work: 2/20 week (10 %)" and "work: 20/20 week (100 %)" in lines
    assert lines[-1].startswith("work: done, 20 week in ")
    assert len(lines) == 11 and not any("\r" in x for x in lines)


def test_terminal_gets_a_bar_that_leaves_nothing_in_the_log(caplog):
    stream = FakeTerminal()
    assert is_terminal(stream) and not is_terminal(io.StringIO())
    with (
        caplog.at_level(logging.INFO, logger="hvacfmu.progress"),
        Progress(total=3, desc="data", unit="stage", stream=stream) as bar,
    ):
        for note in ("gaps", "resampling", "weeks"):
            bar.update(note=note)
    assert "\r" in stream.getvalue() and "data" in stream.getvalue()
    assert not caplog.records


def test_disabled_shows_nothing(caplog, fast_logging):
    stream = FakeTerminal()
    with caplog.at_level(logging.INFO, logger="hvacfmu.progress"):
        assert sum(progress(range(5), desc="x", enabled=False, stream=stream)) == 10
    assert stream.getvalue() == "" and not caplog.records


def test_short_work_logs_nothing(caplog):
    with caplog.at_level(logging.INFO, logger="hvacfmu.progress"):
        list(progress(range(100), desc="quick", stream=io.StringIO()))
    assert not caplog.records  # under LOG_INTERVAL: no lines at all


def test_cli_check_progress_in_a_pipe_is_plain(tmp_path, monkeypatch):
    """``hvacfmu check`` with stderr to a pipe: log lines only, no bar debris."""
    from conftest import SMALL_BUILDING
    from test_data import make_measurements, write

    from hvacfmu.building import building_from_dict

    b = building_from_dict(SMALL_BUILDING)
    path = write(make_measurements(b, periods=3 * 1440), tmp_path / "m.csv")
    code = (
        "import hvacfmu.progress as p, sys; p.LOG_INTERVAL = 0.0; from hvacfmu.cli import main; "
        f"sys.exit(main(['check', {str(path)!r}, '-b', {str(b.save(tmp_path / 'b.toml'))!r}]))"
    )
    r = subprocess.run([sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=120)
    assert "\r" not in r.stderr and "Traceback" not in r.stderr
    assert "INFO hvacfmu.progress: data m.csv: 4/4 stage (100 %)" in r.stderr
    assert r.stdout.startswith("Measurements:") and "Coverage on the model step" in r.stdout
