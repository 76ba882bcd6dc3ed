"""Progress of long work: a bar on a terminal, plain log lines otherwise.

On a terminal (the stream's ``isatty()``) progress is a tqdm bar that leaves
nothing behind. When the output is a file, a pipe or a CI log, it is a few
plain ``logging`` lines (logger ``hvacfmu.progress``, level INFO) — one when
10 % more of the work is done and at least :data:`LOG_INTERVAL` seconds passed
since the last line, and one at the end — never carriage returns or bar debris.

Usage::

    from hvacfmu.progress import Progress, progress

    for week in progress(weeks, desc="fitting", unit="week", enabled=show):
        ...

    with Progress(total=4, desc="data", unit="stage", enabled=show) as bar:
        bar.update(note="reading")   # one stage done, the next one named
"""

from __future__ import annotations

import logging
import sys
import time

#: Smallest time [s] between two log lines when the output is not a terminal.
LOG_INTERVAL = 2.0

LOGGER = logging.getLogger("hvacfmu.progress")


def is_terminal(stream=None) -> bool:
    """True if ``stream`` (default ``sys.stderr``) is an interactive terminal."""
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # closed or not a file
        return False


class Progress:
    """Progress of ``total`` units of work (see the module docstring).

    Parameters
    ----------
    total : int or None
        Units of work (None: unknown; log lines then count units only).
    desc : str
        What is being done, e.g. ``"data"``.
    unit : str
        Name of one unit, e.g. ``"step"``.
    enabled : bool
        False shows nothing (``--quiet``).
    stream : file, optional
        Where a terminal bar goes (default ``sys.stderr``).
    """

    def __init__(self, total=None, desc="", unit="it", enabled=True, stream=None):
        self.total, self.desc, self.unit = total, desc, unit
        self.enabled = bool(enabled)
        self.n = 0
        self.start = time.monotonic()
        self._last_log = self.start
        self._last_share = 0
        self._bar = None
        if self.enabled and is_terminal(stream):
            from tqdm.auto import tqdm

            self._bar = tqdm(total=total, desc=desc, unit=unit, leave=False, file=stream or sys.stderr)

    def update(self, n: int = 1, note: str | None = None) -> None:
        """Count ``n`` more units done; ``note`` names what comes next (shown on the bar)."""
        self.n += n
        if not self.enabled:
            return
        if self._bar is not None:
            if note:
                self._bar.set_postfix_str(note, refresh=False)
            self._bar.update(n)
            return
        now = time.monotonic()
        share = self.n / self.total if self.total else 0.0
        tenth = int(10 * share + 1e-9)  # a line per tenth of the work at most
        if now - self._last_log >= LOG_INTERVAL and (not self.total or tenth > self._last_share):
            of = f"/{self.total}" if self.total else ""
            pct = f" ({100 * share:.0f} %)" if self.total else ""
            LOGGER.info("%s: %d%s %s%s%s", self.desc, self.n, of, self.unit, pct, f", {note}" if note else "")
            self._last_log, self._last_share = now, tenth

    def close(self) -> None:
        """End the bar, or log one closing line if the work took :data:`LOG_INTERVAL` or longer."""
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.close()
            self._bar = None
            return
        elapsed = time.monotonic() - self.start
        if elapsed >= LOG_INTERVAL:
            LOGGER.info("%s: done, %d %s in %.1f s", self.desc, self.n, self.unit, elapsed)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def progress(iterable, total=None, desc="", unit="it", enabled=True, stream=None):
    """Iterate over ``iterable`` showing :class:`Progress` (``total`` defaults to ``len(iterable)``)."""
    if total is None:
        try:
            total = len(iterable)
        except TypeError:
            total = None
    with Progress(total, desc=desc, unit=unit, enabled=enabled, stream=stream) as bar:
        for item in iterable:
            yield item
            bar.update()
