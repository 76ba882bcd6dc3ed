"""Reading and validating a measurements file (CSV or Parquet).

:func:`load_measurements` returns the data at their native resolution with a
tz-aware local index and canonical SI columns, or raises
:class:`~hvacfmu.errors.DataError` listing every problem found in the file.
Rows in messages are counted from 1 for the first data row (line 2 of a CSV
file with its header on line 1).
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pandas as pd

from ..building import ORIENTATIONS, Building, load_building
from ..errors import DataError, problems_message
from .plausibility import (
    check_airflow,
    check_airflow_constant,
    check_irradiance_level,
    check_outdoor,
    check_outdoor_frozen,
    check_outdoor_shoulder,
    check_outdoor_unit_mix,
    check_setpoint_like,
    check_stuck,
    check_zone_held,
    check_zone_spikes,
    clear_sky_ghi,
    identical_columns,
)
from .units import kind_of, normalize_unit, to_si

#: Plausible range of any air temperature [°C].
TEMPERATURE_RANGE = (-50.0, 80.0)
#: Negative airflow down to this value is sensor noise and is set to 0 [kg/s].
AIRFLOW_NOISE = 0.005
#: Negative irradiance down to this value is sensor noise and is set to 0 [W/m2].
IRRADIANCE_NOISE = 10.0
#: No irradiance at ground level exceeds this [W/m2].
IRRADIANCE_MAX = 1500.0
#: Number of example rows quoted per problem.
N_EXAMPLES = 3

_OFFSET_PATTERN = r"(?:[Zz]|[+-]\d{2}:?\d{2})\s*$"


@dataclasses.dataclass
class LoadReport:
    """What :func:`load_measurements` found in a file.

    Attributes
    ----------
    path : str
    rows : int
        Data rows in the file.
    start, end : pandas.Timestamp or None
        First and last timestamp (local time).
    native_step : float or None [s]
        Median spacing of the timestamps.
    column_steps : dict
        Canonical column -> median spacing of its non-missing samples [s].
    columns : dict
        Canonical column -> column name in the file (present columns only).
    units : dict
        Canonical column -> unit of the file (canonical spelling).
    unknown_columns : tuple of str
        File columns that map to no canonical quantity (ignored).
    has_offsets : bool
        True if the times carry UTC offsets (no daylight-saving ambiguity).
    masked : dict
        ``(canonical column, reason) -> samples`` set missing by a plausibility
        check (reasons ``"airflow spike"``, ``"stuck sensor"``).
    warnings : list of str
        Usable but noteworthy findings (unknown columns, clipped sensor noise ...).
    """

    path: str
    rows: int = 0
    start: pd.Timestamp | None = None
    end: pd.Timestamp | None = None
    native_step: float | None = None
    column_steps: dict = dataclasses.field(default_factory=dict)
    columns: dict = dataclasses.field(default_factory=dict)
    units: dict = dataclasses.field(default_factory=dict)
    unknown_columns: tuple = ()
    has_offsets: bool = False
    masked: dict = dataclasses.field(default_factory=dict)
    warnings: list = dataclasses.field(default_factory=list)


def as_building(building, timezone: str | None = None) -> Building:
    """A :class:`Building`, loading it if ``building`` is a path.

    ``timezone`` (optional) overrides the building's ``data_timezone``: the zone
    naive timestamps of the measurements are read in (e.g. ``"UTC"``).
    """
    if not isinstance(building, Building):
        building = load_building(building)
    if timezone is not None and timezone != building.data_timezone:
        building = dataclasses.replace(building, data_timezone=str(timezone))
    return building


def _fmt_time(t) -> str:
    return pd.Timestamp(t).isoformat()


class _Where:
    """Formats row positions (with their local times when known) for messages."""

    def __init__(self, local_times):
        self.local_times = local_times  # DatetimeIndex (may contain NaT) or None

    def rows(self, positions, values=None, limit=N_EXAMPLES) -> str:
        positions = np.asarray(positions)
        parts = []
        for p in positions[:limit]:
            s = f"row {int(p) + 1}"
            if self.local_times is not None and not pd.isna(self.local_times[p]):
                s += f" ({_fmt_time(self.local_times[p])})"
            if values is not None:
                v = values[p]
                s = f"{_fmt_value(v)} at {s}"
            parts.append(s)
        text = ", ".join(parts)
        if len(positions) > limit:
            text += f" and {len(positions) - limit} more"
        return text


def _fmt_value(v) -> str:
    if isinstance(v, (float, np.floating)):
        return f"{float(v):.6g}"
    return repr(v)


def _read(path: Path, problems: list, time_name: str = "time") -> pd.DataFrame | None:
    suffix = "".join(path.suffixes[-2:]).lower() if path.suffix.lower() == ".gz" else path.suffix.lower()
    if not path.exists():
        problems.append(f"{path}: file does not exist")
        return None
    try:
        if suffix in (".parquet", ".pq"):
            frame = pd.read_parquet(path)
            if isinstance(frame.index, pd.DatetimeIndex) and frame.index.name is None:
                frame.index.name = time_name
            if frame.index.name is not None:
                frame = frame.reset_index()
            return frame
        if suffix in (".csv", ".csv.gz", ".txt"):
            other = _not_text(path)
            if other:
                problems.append(other)
                return None
            enc = _encoding(path)
            sep = _sniff_separator(path, enc)
            preamble = _preamble(path, sep, enc)
            if preamble:
                problems.append(preamble)
                return None
            frame = pd.read_csv(
                path, sep=sep, dtype={time_name: str}, low_memory=False, encoding=enc, encoding_errors="replace"
            )
            header = _csv_header(path, sep, enc)
            if len(header) == frame.shape[1]:
                frame.columns = header  # the names as written: pandas renames a repeated name 'X' to 'X.1'
            if sep != "," and not frame.columns.duplicated().any():  # repeated names are reported by _load
                problems += _thousands_dots(path, sep, frame, time_name, enc)
            return frame
    except Exception as exc:  # noqa: BLE001 - any reader failure is reported as a data problem
        problems.append(f"{path.name}: cannot be read as {suffix[1:]}: {exc}{_reader_hint(str(exc))}")
        return None
    problems.append(f"{path.name}: unknown file type {suffix!r}; measurements must be .csv or .parquet")
    return None


def _opener(path: Path):
    """``open``, or ``gzip.open`` for a ``.gz`` file (the CSV readers' one rule)."""
    import gzip

    return gzip.open if path.suffix.lower() == ".gz" else open


def _not_text(path: Path) -> str | None:
    """A problem when a .csv file is empty or another format under that name (an Excel workbook, parquet)."""

    with _opener(path)(path, "rb") as f:
        head = f.read(8)
    if not head:
        return f"{path.name}: the file is empty (0 bytes): export the trend data again"
    kinds = {b"PK\x03\x04": "an Excel workbook (.xlsx) or another zip archive", b"PAR1": "a parquet file",
             b"\xd0\xcf\x11\xe0": "an old Excel workbook (.xls)"}  # fmt: skip
    kind = next((k for magic, k in kinds.items() if head.startswith(magic)), None)
    if kind is None:
        return None
    return (
        f"{path.name}: the file is {kind}, not text separated by commas: save the sheet as CSV (UTF-8) "
        "or give the file its own extension (.parquet is read)"
    )


def _reader_hint(error: str) -> str:
    """What a pandas tokenizer error means in a trend export (a row with more fields than the header)."""
    m = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", error)
    if not m:
        return ""
    want, line, got = map(int, m.groups())
    return (
        f" (line {line} holds {got} fields where the header has {want}: a value holding the separator unquoted "
        "(a thousands separator such as 1,006, a decimal comma, a status text with a comma) or a row of another "
        f"export with more columns; fix or delete line {line})"
    )


def _encoding(path: Path) -> str:
    """The text encoding of a CSV file: UTF-16 by its byte-order mark, else UTF-8 (BOM or not), else cp1252.

    Excel's "Unicode text" is UTF-16 with a BOM; older BMS tools write Windows-1252 ('°' as the single byte
    0xB0), which is not valid UTF-8. A file that decodes as UTF-8 is read as UTF-8; the five bytes cp1252
    leaves undefined are read as replacement characters (they only occur in names and texts).
    """
    import codecs

    with _opener(path)(path, "rb") as f:
        head = f.read(4)
        if head[:2] in (b"\xff\xfe", b"\xfe\xff"):
            return "utf-16"
        f.seek(0)
        decoder = codecs.getincrementaldecoder("utf-8-sig")(errors="strict")
        try:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                decoder.decode(chunk)
            decoder.decode(b"", final=True)
        except UnicodeDecodeError:
            return "cp1252"
    return "utf-8-sig"


_THOUSANDS_DOT = r"^\s*[-+]?[1-9]\d{0,2}(\.\d{3})+\s*$"


def _thousands_dots(path: Path, sep: str, frame: pd.DataFrame, time_name: str, enc: str = "utf-8-sig") -> list[str]:
    """Problems for '.' thousands separators among whole numbers (a European export: '1.006' is 1006, not 1.006).

    Read as numbers they would be a thousand times too small without a trace;
    only columns whose other values are all whole numbers are judged.
    """
    numeric = [c for c in frame.columns if c != time_name and pd.api.types.is_float_dtype(frame[c].dtype)]
    if not numeric:
        return []
    text = pd.read_csv(
        path, sep=sep, dtype=str, usecols=numeric, encoding=enc, encoding_errors="replace", low_memory=False
    )
    out = []
    for c in numeric:
        col = text[c].dropna().str.strip()
        dots = col.str.match(_THOUSANDS_DOT)
        if not dots.any() or col[~dots].str.contains(r"\.", regex=True).any():
            continue
        rows = np.flatnonzero(text[c].str.strip().str.match(_THOUSANDS_DOT).fillna(False).to_numpy())
        examples = ", ".join(f"{text[c].iloc[r]!r} at row {r + 1}" for r in rows[:3])
        out.append(
            f"{path.name}: column {str(c).strip()!r}: {len(rows)} value(s) such as {examples} among whole numbers: "
            "a '.' thousands separator ('1.006' = 1006), which would read a thousand times too small; export the "
            "numbers without thousands separators"
        )
    return out


def _csv_header(path: Path, sep: str, enc: str = "utf-8-sig") -> list[str]:
    """The header names of a CSV file as written (quotes removed), empty if unreadable."""
    import csv

    with _opener(path)(path, "rt", encoding=enc, errors="replace", newline="") as f:
        return next(csv.reader(f, delimiter=sep), [])


def _duplicate_names(names, label) -> list[str]:
    """Problems naming every column name that appears more than once (after trimming whitespace)."""
    names = [str(c).strip() for c in names]
    seen: dict[str, list[int]] = {}
    for i, c in enumerate(names):
        seen.setdefault(c, []).append(i + 1)
    return [
        f"{label}: column {c!r} appears {len(cols)} times in the header (columns {', '.join(map(str, cols))}); "
        "a reader cannot tell which one is the point: rename or drop the copies in the export"
        for c, cols in seen.items()
        if len(cols) > 1
    ]


def _head_lines(path: Path, enc: str, n: int) -> list[str]:

    with _opener(path)(path, "rt", encoding=enc, errors="replace") as f:
        return [line for _, line in zip(range(n), f)]


def _separator_of(line: str) -> tuple[str, int]:
    counts = {sep: line.count(sep) for sep in (",", ";", "\t")}
    best = max(counts, key=counts.get)
    return (best, counts[best]) if counts[best] > 0 else (",", 0)


def _sniff_separator(path: Path, enc: str = "utf-8-sig") -> str:
    """',' unless the header line is clearly separated by ';' or tabs (common in BMS exports).

    Lines above the header with no separator (a report title) are passed over, so that :func:`_preamble` can
    name them.
    """
    lines = _head_lines(path, enc, 30)
    return next((sep for sep, n in map(_separator_of, lines) if n > 0), ",")


def _preamble(path: Path, sep: str, enc: str) -> str | None:
    """A problem naming report lines above the header (title, site, period), or None.

    The header is the first of the file's first lines to hold as many separators as the line after it, where
    that count is the most common one; lines before it are a preamble that shifts every column.
    """
    import csv

    lines = [line.rstrip("\r\n") for line in _head_lines(path, enc, 30)]
    counts = [len(next(csv.reader([line], delimiter=sep), [])) for line in lines]
    if len(counts) < 3:
        return None
    common = max(set(counts), key=counts.count)
    if common < 2 or counts[0] == common:
        return None
    first = next((i for i in range(len(counts) - 1) if counts[i] == common == counts[i + 1]), None)
    if first is None or first == 0:
        return None
    shown = "; ".join(repr(x[:60]) for x in lines[:first][:3])
    return (
        f"{path.name}: lines 1-{first} above the header hold {', '.join(str(c) for c in counts[:first])} field(s) "
        f"where the rest of the file has {common} ({shown}): a report title or description above the column "
        f"names? the header looks like line {first + 1} ({lines[first][:60]!r}...); delete the lines above it"
    )


def _parse_times(col: pd.Series, tz: str, name: str, label: str, problems: list):
    """UTC nanoseconds (int64, NaT as the minimum int) and a validity mask."""
    n = len(col)
    values = col
    if isinstance(values.dtype, pd.DatetimeTZDtype):
        utc = pd.DatetimeIndex(values).tz_convert("UTC").as_unit("ns")
        ok = ~utc.isna()
        if not ok.all():
            problems.append(
                f"{label}: column {name!r}: {int((~ok).sum())} empty times at {_Where(None).rows(np.flatnonzero(~ok))}"
            )
        return utc.asi8, ok, True
    if pd.api.types.is_datetime64_dtype(values.dtype):
        naive = pd.DatetimeIndex(values).as_unit("ns")
        empty = np.asarray(naive.isna())
        if empty.any():
            problems.append(
                f"{label}: column {name!r}: {int(empty.sum())} empty times at {_Where(None).rows(np.flatnonzero(empty))}"
            )
        return _localize(naive, empty, tz, name, label, problems) + (False,)
    if pd.api.types.is_numeric_dtype(values.dtype) or pd.api.types.is_bool_dtype(values.dtype):
        problems.append(
            f"{label}: column {name!r} holds numbers ({values.dtype}); times must be ISO 8601 text "
            "(e.g. 2024-09-02T00:00:00-07:00) or timestamps"
        )
        return np.zeros(n, np.int64), np.zeros(n, bool), False
    text = values.astype("str").where(values.notna())
    empty = text.isna().to_numpy()
    stripped = text.str.strip()
    has_offset = _has_offset(stripped)
    if has_offset.any() and (~has_offset & ~empty).any():
        bad = np.flatnonzero(~has_offset & ~empty)
        problems.append(
            f"{label}: column {name!r} mixes times with and without UTC offset; "
            f"{len(bad)} without offset at {_Where(None).rows(bad, values=text.to_numpy())}"
        )
    utc = np.full(n, np.iinfo(np.int64).min, dtype=np.int64)
    ok = np.zeros(n, dtype=bool)
    unparsed = np.zeros(n, dtype=bool)
    if has_offset.any():
        sel = has_offset
        parsed = pd.to_datetime(stripped[sel], format="ISO8601", utc=True, errors="coerce")
        idx = pd.DatetimeIndex(parsed).as_unit("ns")
        good = ~idx.isna()
        where = np.flatnonzero(sel)
        utc[where[good]] = idx.asi8[good]
        ok[where[good]] = True
        unparsed[where[~good]] = True
    naive_sel = ~has_offset & ~empty
    if naive_sel.any():
        parsed = pd.to_datetime(stripped[naive_sel], format="ISO8601", errors="coerce")
        idx = pd.DatetimeIndex(parsed).as_unit("ns")
        where = np.flatnonzero(naive_sel)
        bad = idx.isna()
        unparsed[where[bad]] = True
        sub_utc, sub_ok = _localize(idx, bad, tz, name, label, problems, rows=where)
        utc[where[sub_ok]] = sub_utc[sub_ok]
        ok[where[sub_ok]] = True
    if unparsed.any():
        bad = np.flatnonzero(unparsed)
        problems.append(
            f"{label}: column {name!r}: {len(bad)} values are not ISO 8601 times, e.g. "
            f"{_Where(None).rows(bad, values=text.to_numpy())}{_time_format_hint(stripped.iloc[bad[:200]])}"
            + _summary_rows_hint(stripped, bad, n)
        )
    if empty.any():
        bad = np.flatnonzero(empty)
        problems.append(f"{label}: column {name!r}: {len(bad)} empty times at {_Where(None).rows(bad)}")
    return utc, ok, bool(has_offset.any() and not naive_sel.any())


def _summary_rows_hint(text: pd.Series, bad: np.ndarray, n: int) -> str:
    """A hint when the unparseable times are a few words in the last rows (a totals or average row)."""
    if not 0 < len(bad) <= 5 or bad[0] < n - 10 or not text.iloc[bad].str.contains(r"[A-Za-z]{3}", na=False).all():
        return ""
    return (
        f"; the last rows of the file hold words, not times ({', '.join(repr(x) for x in text.iloc[bad][:3])}): "
        "a summary row (total, average, min/max) that the report appends? delete it (its numbers are not readings)"
    )


def _time_format_hint(text: pd.Series) -> str:
    """What unparseable times look like (numbers, day/month order), as a fix appended to the problem."""
    num = pd.to_numeric(text, errors="coerce")
    if num.notna().mean() > 0.9:
        med = float(num.median())
        if 20_000 < med < 80_000:
            return (
                "; these are numbers like Excel serial dates (days since 1899-12-30): export the times as text "
                "such as 2024-09-02T00:00:00-07:00"
            )
        if 1e8 < med < 1e10 or 1e11 < med < 1e13:
            return "; these are numbers like Unix times (seconds or ms since 1970): export the times as ISO 8601 text"
        return "; these are numbers, not times"
    if text.str.match(r"^\s*\d{1,2}[/.-]\d{1,2}[/.-]\d{2,4}").mean() > 0.9:
        return (
            "; dates like 03/04/2025 are ambiguous (3 April or March 4?): export year-month-day "
            "(2025-04-03T00:00:00) so nothing depends on a locale"
        )
    return ""


def _has_offset(text: pd.Series) -> np.ndarray:
    """True where an ISO 8601 time string ends with a UTC offset or Z (vectorised with pyarrow)."""
    import pyarrow as pa
    import pyarrow.compute as pc

    try:
        arr = pa.array(text.to_numpy(dtype=object, na_value=None), type=pa.string())
        return np.asarray(pc.fill_null(pc.match_substring_regex(arr, _OFFSET_PATTERN), False))
    except (pa.ArrowException, TypeError):  # pragma: no cover - exotic content: slow path
        return text.str.contains(_OFFSET_PATTERN, regex=True, na=False).to_numpy()


def _localize(naive: pd.DatetimeIndex, unparsed, tz, name, label, problems, rows=None):
    """Naive local times -> UTC ns, resolving repeated autumn hours from the row order.

    A naive time in the hour repeated when daylight saving time ends is
    ambiguous. Each run of consecutive rows inside such an hour is resolved the
    way a logger writes it: wall-clock times increase, step back once (to the
    start of the repeated hour, or repeat a time for hourly data) and increase
    again; the rows before the step are daylight saving time, the rows after it
    standard time (the rule of pandas' ``tz_localize(ambiguous='infer')``,
    applied per run so that every unresolvable run is reported). A run without
    exactly one step back (the repeated hour logged once only, rows out of
    order, unordered duplicates) cannot be resolved and is a problem, as are
    naive times that do not exist (skipped when daylight saving time starts).
    """
    n = len(naive)
    rows = np.arange(n) if rows is None else rows
    amb = np.asarray(naive.tz_localize(tz, ambiguous="NaT", nonexistent="shift_forward").isna()) & ~unparsed
    as_dst = naive.tz_localize(tz, ambiguous=np.ones(n, dtype=bool), nonexistent="NaT")
    nonexistent = np.asarray(as_dst.isna()) & ~unparsed
    utc = np.full(n, np.iinfo(np.int64).min, dtype=np.int64)
    dst_utc = as_dst.tz_convert("UTC").as_unit("ns").asi8
    unresolved = np.zeros(n, dtype=bool)
    if amb.any():
        std_utc = naive.tz_localize(tz, ambiguous=np.zeros(n, dtype=bool), nonexistent="NaT").tz_convert("UTC")
        std_utc = std_utc.as_unit("ns").asi8
        local = naive.asi8
        pos = np.flatnonzero(amb)
        runs = np.split(pos, np.flatnonzero(np.diff(pos) != 1) + 1)
        bad_runs = []
        for run in runs:
            back = np.flatnonzero(np.diff(local[run]) <= 0)
            if len(back) != 1:
                unresolved[run] = True
                bad_runs.append((run, len(back)))
                continue
            switch = back[0] + 1
            utc[run[:switch]] = dst_utc[run[:switch]]
            utc[run[switch:]] = std_utc[run[switch:]]
        if bad_runs:
            why = "; ".join(
                f"{naive[run[0]]}..{naive[run[-1]]} (rows {int(rows[run[0]]) + 1}-{int(rows[run[-1]]) + 1}): "
                + ("the repeated hour appears once only" if steps == 0 else f"times step back {steps} times, not once")
                for run, steps in bad_runs[:N_EXAMPLES]
            )
            more = f" and {len(bad_runs) - N_EXAMPLES} more" if len(bad_runs) > N_EXAMPLES else ""
            first = bad_runs[0][0][0]
            example = naive[first].isoformat()
            offsets = [_fmt_offset(int(x) - int(local[first])) for x in (dst_utc[first], std_utc[first])]
            problems.append(
                f"{label}: column {name!r}: {int(unresolved.sum())} naive local times are ambiguous (repeated when "
                f"daylight saving time ends in {tz}) and their order does not tell which occurrence they are: "
                f"{why}{more}; a file in time order must list the repeated hour twice, first in daylight "
                f"saving time then in standard time; otherwise write times with their UTC offset "
                f"(e.g. {example}{offsets[0]} for the first occurrence, {example}{offsets[1]} for the second)"
                + (_clock_never_changes_hint(tz, naive[bad_runs[0][0][0]]) if any(k == 0 for _, k in bad_runs) else "")
            )
    if nonexistent.any():
        problems.append(
            f"{label}: column {name!r}: {int(nonexistent.sum())} naive local times do not exist (skipped when "
            f"daylight saving time starts in {tz}): {_naive_rows(naive, rows, nonexistent)}; "
            "write times with their UTC offset (if the export inserted rows for the skipped hour, delete them)"
            + _clock_never_changes_hint(tz, naive[np.flatnonzero(nonexistent)[0]], "the hour that local clocks skip")
        )
    ok = ~(unresolved | nonexistent | unparsed)
    plain = ok & ~amb
    utc[plain] = dst_utc[plain]
    return utc, ok


def _clock_never_changes_hint(tz: str, when: pd.Timestamp, what: str = "that hour once") -> str:
    """The fix when the repeated hour appears once only: the export's clock may never change (UTC, standard time).

    A logger on UTC or on standard time all year writes that hour once; read on the wall clock of ``tz`` its
    times are then an hour (or the UTC offset) off, so the zone is named with its ``Etc/GMT`` equivalent.
    """
    std = pd.Timestamp(when).tz_localize(tz, ambiguous=False, nonexistent="shift_backward").utcoffset()
    if "skip" in what:  # a time the clocks skip lies in daylight saving time's first hour: standard time is before
        std = (pd.Timestamp(when) - pd.Timedelta(hours=2)).tz_localize(tz, ambiguous=False).utcoffset()
    hours = -int(std.total_seconds() // 3600) if std is not None else 0
    fixed = f"Etc/GMT{hours:+d}" if hours and std is not None and std.total_seconds() % 3600 == 0 else None
    alt = (
        f' or, for standard time all year, data_timezone = "{fixed}" (UTC{_fmt_offset(-int(std.total_seconds() * 1e9))})'
        if fixed
        else ""
    )
    return (
        f". If the export's clock never changes (a server on UTC or on standard time all year writes {what}), "
        f'declare its zone: data_timezone = "UTC"{alt} in the building file, or --timezone'
    )


def _fmt_offset(ns: int) -> str:
    """UTC offset text such as '-07:00' from an offset UTC - local [ns] (sign flipped to ISO 8601)."""
    minutes = -ns // 60_000_000_000
    sign = "+" if minutes >= 0 else "-"
    return f"{sign}{abs(minutes) // 60:02d}:{abs(minutes) % 60:02d}"


def _naive_rows(naive, rows, mask, limit=N_EXAMPLES) -> str:
    """'2024-11-03 01:00:00 at row 5, ...' for the masked naive times."""
    pos = np.flatnonzero(mask)
    text = ", ".join(f"{naive[i]} at row {int(rows[i]) + 1}" for i in pos[:limit])
    if len(pos) > limit:
        text += f" and {len(pos) - limit} more"
    return text


def _numeric(series: pd.Series):
    """Float array of a column and the positions of non-numeric entries."""
    dtype = series.dtype
    if pd.api.types.is_bool_dtype(dtype):
        return series.astype(float).to_numpy(), np.zeros(0, dtype=np.int64)
    if pd.api.types.is_numeric_dtype(dtype):
        return series.to_numpy(dtype=float, na_value=np.nan), np.zeros(0, dtype=np.int64)
    as_num = pd.to_numeric(series, errors="coerce")
    values = as_num.to_numpy(dtype=float, na_value=np.nan)
    present = series.notna().to_numpy().copy()
    if series.dtype == object or pd.api.types.is_string_dtype(dtype):
        text = series.astype("str").str.strip().str.lower()
        blank = text.isin(["", "nan", "na", "n/a", "null", "none", "-nan", "#n/a", "#na", "n.a.", "--", "-"]).to_numpy()
        present &= ~blank
    bad = np.flatnonzero(present & np.isnan(values))
    return values, bad


def _median_step(t_ns: np.ndarray, max_samples: int = 20_000) -> float | None:
    """Median spacing [s] of increasing times [ns]; estimated on an even subsample of long series."""
    if len(t_ns) < 2:
        return None
    d = np.diff(t_ns)
    if len(d) > max_samples:
        d = d[:: len(d) // max_samples]
    d = d[d > 0]
    if not len(d):
        return None
    return float(np.median(d)) / 1e9


#: A column whose samples are spaced more coarsely than the file is "coarse" (interpolated to the model
#: step) only if at least this share of its sample spacings equal its median spacing; otherwise it is
#: a sparse column at the file's resolution (its missing steps stay missing).
REGULAR_SHARE = 0.8


def _column_step(t_ns: np.ndarray, report: LoadReport, desc: str, n_rows: int) -> float | None:
    """Native spacing [s] of one column's valid samples (see :data:`REGULAR_SHARE`)."""
    step = _median_step(t_ns) or report.native_step
    native = report.native_step
    if not step or not native or step <= 1.5 * native:
        return step
    d = np.diff(t_ns) / 1e9
    regular = float(np.mean(np.abs(d - step) <= 0.01 * step)) if len(d) else 0.0
    if regular >= REGULAR_SHARE:
        return step
    report.warnings.append(
        f"{desc}: values in only {100 * len(t_ns) / max(n_rows, 1):.1f} % of the rows, at irregular times "
        f"(median spacing {step:g} s, the file's {native:g} s): kept at the file's resolution, not interpolated"
    )
    return native


def load_measurements(path, building, timezone: str | None = None) -> tuple[pd.DataFrame, LoadReport]:
    """Read, validate and convert a measurements file.

    Parameters
    ----------
    path : str or Path
        CSV (``.csv``, ``.csv.gz``) or Parquet (``.parquet``) file with one row
        per timestamp. The ``time`` column holds ISO 8601 times with UTC offset
        (naive times are wall-clock times of the data's clock zone,
        ``building.clock_timezone``: ``data_timezone`` or else ``timezone``; the
        hour repeated when daylight saving time ends is resolved from the row
        order, see :func:`_localize`) or, in Parquet, timestamps.
    building : Building or path
        Gives the expected columns, the column mapping
        (:meth:`Building.column_for`) and the units (:meth:`Building.unit_for`).
    timezone : str, optional
        Zone of naive timestamps (e.g. ``"UTC"``), overriding the building's
        ``data_timezone``. The returned index is always in ``building.timezone``.

    Returns
    -------
    frame : pandas.DataFrame
        Native resolution; index: tz-aware ``DatetimeIndex`` in the building's
        time zone named ``time``; columns: canonical names in SI units
        (``T_*`` and ``Td_*`` [°C], ``m_*`` [kg/s], ``rh_*`` [0..1],
        ``ghi``/``I_*`` [W/m²], ``excitation`` 0/1) present in the file; NaN
        where values are missing. A single declared air handler without its
        ``T_supply_<ahu>`` column takes the ``T_supply`` column.
    report : LoadReport

    Raises
    ------
    DataError
        Listing every problem found: missing columns, non-numeric values,
        unparseable, duplicate or non-increasing times, naive times that do
        not exist or whose daylight-saving ambiguity the row order cannot
        resolve, physically impossible values and implausible units.
    """
    building = as_building(building, timezone)
    frame, report, problems = _load(Path(path), building)
    if problems:
        raise DataError(problems_message(f"Cannot use measurements {path}", problems))
    return frame, report


def _load(path: Path, building: Building):
    """Worker of :func:`load_measurements`: (frame or None, report, problems)."""
    problems: list[str] = []
    report = LoadReport(path=str(path))
    time_name = building.column_for("time")
    raw = _read(path, problems, time_name)
    if raw is None:
        return None, report, problems
    label = path.name
    raw = _drop_empty_unnamed(raw)
    raw = _drop_cut_last_row(raw, path, label, report)
    report.rows = n = len(raw)
    if n == 0:
        problems.append(f"{label}: no data rows")
    duplicates = _duplicate_names(raw.columns, label)
    if duplicates:
        return None, report, problems + duplicates
    raw.columns = [str(c).strip() for c in raw.columns]
    present = _map_columns(raw, building, label, time_name, problems, report)
    header_rows = _header_rows(raw, present, time_name, label)
    if header_rows:
        return None, report, problems + header_rows
    utc, ok, local = _load_times(raw, building, label, time_name, problems, report)
    ctx = _Column(label, building, _Where(local), problems, report, utc, ok, local, n)
    out = {}
    for canonical, name in present.items():
        si = _column_values(ctx, canonical, name, raw[name])
        if si is not None:
            out[canonical] = si
    problems += identical_columns(out, present, ctx.where.rows, label)
    if problems or utc is None:
        return None, report, problems
    order = [c for c in building.expected_columns() if c in out]
    index = pd.DatetimeIndex(utc.view("M8[ns]")).tz_localize("UTC").tz_convert(building.timezone)
    index.name = "time"
    frame = _frame_from_columns(out, order, index)
    return frame, report, problems


#: A row with text (not a number, not a spelling of "missing") in at least this share of the value columns is
#: a header row (units, descriptions, a second header of concatenated exports), named once instead of per column.
HEADER_ROW_SHARE = 0.5


def _header_rows(raw, present: dict, time_name: str, label: str) -> list[str]:
    """One problem naming the rows that hold text in most value columns (a units row under the header), if any.

    Only columns read as text are parsed here (a units row makes every column text); the file's other checks run
    once the rows are gone, so that one row does not yield a non-numeric problem per column.
    """
    names = [n for c, n in present.items() if c != "time" and n in raw.columns]
    text_cols = [n for n in names if not pd.api.types.is_numeric_dtype(raw[n].dtype)]
    if len(names) < 2 or len(text_cols) < HEADER_ROW_SHARE * len(names):
        return []
    count = np.zeros(len(raw), dtype=int)
    first: dict[int, list] = {}
    for n in text_cols:
        _, bad = _numeric(raw[n])
        count[bad] += 1
        for r in bad[:50]:
            first.setdefault(int(r), []).append(n)
    rows = np.flatnonzero(count >= HEADER_ROW_SHARE * len(names))
    if not len(rows) or len(rows) > max(3, 0.01 * len(raw)):  # text in most rows: a format, named per column
        return []
    r0 = int(rows[0])
    seen: dict[str, str] = {}
    for n in first.get(r0, []):
        seen.setdefault(str(raw[n].iloc[r0]).strip(), n)  # one example per distinct text ('°F', 'CFM', '%')
    examples = ", ".join(f"{t!r} in {n!r}" for t, n in list(seen.items())[:3])
    tcell = raw[time_name].iloc[r0] if time_name in raw.columns else None
    tdesc = "an empty time" if tcell is None or pd.isna(tcell) or not str(tcell).strip() else f"time {str(tcell)!r}"
    if len(rows) == 1:
        which = f"row {r0 + 1} holds"
    else:
        which = (
            f"{len(rows)} rows ({', '.join(str(int(r) + 1) for r in rows[:5])}{' ...' if len(rows) > 5 else ''}) hold"
        )
    return [
        f"{label}: {which} text instead of readings in {int(count[r0])} of the {len(names)} value "
        f"columns (row {r0 + 1}: {examples}; {tdesc}): a units or description row under the header, or the header of another "
        "export pasted in? a reader takes the first line as the only header: delete those rows (the rest of the "
        "file is checked once they are gone)"
    ]


def _map_columns(raw, building, label, time_name, problems, report) -> dict:
    """Canonical column -> file column of the columns present; missing required ones are problems."""
    expected = building.expected_columns()
    present = {}
    for canonical, required in expected.items():
        name = building.column_for(canonical)
        if name in raw.columns:
            present[canonical] = name
        elif (
            len(building.ahus) == 1
            and canonical == building.ahus[0].supply_column
            and (building.column_for("T_supply") in raw.columns)
        ):
            present[canonical] = building.column_for("T_supply")  # the single unit's plain T_supply column
        elif required:
            mapped = f" (mapped from {canonical})" if name != canonical else ""
            near = _with_unit(raw.columns, name)
            hint = (
                f": the file has {near!r}, the name with a unit appended; map it in the building's [columns] "
                f'table ({canonical} = "{near}") or export the header without units (declare them in [units])'
                if near
                else ""
            )
            problems.append(f"{label}: missing required column {name!r}{mapped}{hint}")
    if (
        building.ahus
        and "T_supply" in present
        and "T_supply" not in building.columns
        and any(present.get(c) == present["T_supply"] for c in building.supply_columns())
    ):
        del present["T_supply"]  # the file's T_supply is a unit's own column; the primary supply is derived
    used = set(present.values()) | {time_name}
    unknown = tuple(c for c in raw.columns if c not in used and not c.startswith("Unnamed: "))
    report.unknown_columns = unknown
    report.columns = dict(present)
    n_missing = sum(1 for c, req in expected.items() if req and c not in present)
    if n_missing and unknown:  # a hint, appended to the last missing-column problem
        problems[-1] += (
            f" (the file has {len(unknown)} column(s) that map to nothing: "
            f"{', '.join(repr(c) for c in unknown[:8])}{' ...' if len(unknown) > 8 else ''}; "
            'map them to canonical names in the building\'s [columns] table, e.g. T_NW = "RM4-NW ZN-T")'
        )
    if unknown:
        report.warnings.append(
            f"{label}: {len(unknown)} unknown column(s) ignored: {', '.join(repr(c) for c in unknown[:10])}"
            + (" ..." if len(unknown) > 10 else "")
        )
    facades = [o for o in ORIENTATIONS if f"I_{o}" in present]
    if facades and len(facades) < 4 and "ghi" not in present:
        missing = [o for o in ORIENTATIONS if o not in facades]
        problems.append(
            f"{label}: facade irradiance given for {', '.join(facades)} but not for {', '.join(missing)}, "
            "and no 'ghi' column to compute them from"
        )
    return present


def _drop_empty_unnamed(raw):
    """The frame without columns that have no name and no value (a separator at the end of every line)."""
    keep = [
        i
        for i, c in enumerate(raw.columns)
        if not ((str(c).strip() == "" or str(c).startswith("Unnamed: ")) and raw.iloc[:, i].isna().all())
    ]
    return raw if len(keep) == raw.shape[1] else raw.iloc[:, keep]


def _drop_cut_last_row(raw, path: Path, label: str, report):
    """The frame without its last row when the file ends in the middle of that row (copied while being written).

    Its last field may be a number cut short ('48' of '484'), so the row is dropped with a warning.
    """
    if path.suffix.lower() not in (".csv", ".txt") or len(raw) < 2:
        return raw
    with open(path, "rb") as f:
        f.seek(max(0, path.stat().st_size - 65536))
        tail = f.read()
    if tail.endswith((b"\n", b"\r")) or b"\x00" in tail[-4:]:
        return raw  # a complete last line (UTF-16 ends in a NUL byte; its lines are judged by the reader)
    import csv

    line = tail.rsplit(b"\n", 1)[-1].decode("utf-8", errors="replace")
    filled = len(next(csv.reader([line], delimiter=_sniff_separator(path)), []))
    if filled >= raw.shape[1]:
        return raw  # every field present: the last line lacks only its line break
    report.warnings.append(
        f"{label}: row {len(raw)} (the last) ends the file after {filled} of its {raw.shape[1]} fields without a "
        "line break: a file copied while the export was written? the row is dropped (its last value may be cut "
        "short); export the file again to keep it"
    )
    return raw.iloc[:-1]


def _split_date_time(raw) -> tuple[str, str] | None:
    """The names of a dates-only column and the times-of-day column after it (Excel's split), or None."""
    cols = list(raw.columns[:3])
    for a, b in zip(cols, cols[1:]):
        da = raw[a].dropna().astype(str).head(200).str.strip()
        db = raw[b].dropna().astype(str).head(200).str.strip()
        if len(da) and len(db):
            dates = da.str.fullmatch(r"\d{4}-\d{1,2}-\d{1,2}|\d{1,2}[/.]\d{1,2}[/.]\d{2,4}").mean()
            times = db.str.fullmatch(r"\d{1,2}:\d{2}(:\d{2}(\.\d+)?)?(\s*[AaPp][Mm])?").mean()
            if dates > 0.9 and times > 0.9:
                return str(a), str(b)
    return None


def _utc_marked_local(text, back_rows, tz) -> str:
    """A hint when times marked UTC step back where ``tz``'s clocks go back: local wall-clock times with a 'Z'."""
    rows = [r for r in back_rows if isinstance(text[r], str)]
    if not rows or not all(str(text[r]).strip().endswith(("Z", "+00:00")) for r in rows):
        return ""
    naive = pd.to_datetime(
        [str(text[r]).strip().removesuffix("Z").removesuffix("+00:00") for r in rows], format="ISO8601", errors="coerce"
    )
    try:
        repeated = pd.DatetimeIndex(naive).tz_localize(tz, ambiguous="NaT", nonexistent="NaT").isna()
    except (TypeError, ValueError):  # pragma: no cover - an unusual time zone
        return ""
    if not repeated.all() or pd.DatetimeIndex(naive).isna().any():
        return ""
    return (
        f"; the times are marked UTC ('Z' or +00:00) but step back in the hour that {tz}'s clocks repeat when "
        f"daylight saving time ends ({naive[0]:%Y-%m-%d %H:%M}): local wall-clock times written with a 'Z'? drop "
        "the 'Z' so that they are read in the building's time zone, or export true UTC times"
    )


def _repeated_rows(raw, rows, previous) -> int:
    """How many of ``rows`` hold exactly the values of the row at ``previous`` (same position) in every column."""
    a = raw.iloc[rows].reset_index(drop=True)
    b = raw.iloc[previous].reset_index(drop=True)
    same = (a == b) | (a.isna() & b.isna())
    return int(same.all(axis=1).sum())


_UNIT_SUFFIX = re.compile(r"^(.*?)\s*(\([^()]*\)|\[[^\[\]]*\])\s*$")


def _with_unit(columns, name: str) -> str | None:
    """The file column that is ``name`` with a unit in brackets appended ('T_NW (°F)', 'T_NW [degF]'), or None."""
    for c in map(str, columns):
        m = _UNIT_SUFFIX.match(c)
        if m and m.group(1).strip().lower() == name.strip().lower():
            return c
    return None


def _load_times(raw, building, label, time_name, problems, report):
    """(UTC ns, valid mask, local DatetimeIndex) of the time column, or (None, None, None) without one."""
    if time_name not in raw.columns:
        mapped = " (mapped from time)" if time_name != "time" else ""
        first = str(raw.columns[0]) if len(raw.columns) else None
        hint = (
            f" (the file's first column is {first!r}: if it holds the times, map it in the building's [columns] "
            f'table: time = "{first}")'
            if first is not None and first != time_name
            else ""
        )
        split = _split_date_time(raw)
        if split:
            hint = (
                f" (the file splits each time over columns {split[0]!r} (dates, e.g. {raw[split[0]].iloc[0]!r}) and "
                f"{split[1]!r} (times of day, e.g. {raw[split[1]].iloc[0]!r}): join them into one column of times "
                "such as 2025-03-03T00:00:00 named time, or mapped in the building's [columns] table)"
            )
        problems.append(f"{label}: missing time column {time_name!r}{mapped}{hint}")
        return None, None, None
    n_before, amb = len(problems), []
    utc, ok, has_offsets = _parse_times(raw[time_name], building.clock_timezone, time_name, label, problems)
    report.has_offsets = has_offsets
    local = pd.DatetimeIndex(np.where(ok, utc, np.iinfo(np.int64).min).view("M8[ns]"))
    local = local.tz_localize("UTC").tz_convert(building.timezone)
    valid_pos = np.flatnonzero(ok)
    tv = utc[valid_pos]
    if len(tv) > 1:
        d = np.diff(tv)
        where = _Where(local)
        dup = valid_pos[1:][d == 0]
        if len(dup):
            same = _repeated_rows(raw, dup, valid_pos[:-1][d == 0])
            hint = (
                f"; {same} of them repeat the row before them exactly (every column): a logger re-sending records? "
                "drop the repeated rows"
                if same
                else ""
            )
            problems.append(
                f"{label}: column {time_name!r}: {len(dup)} duplicate timestamps at {where.rows(dup)}{hint}"
            )
        back = np.flatnonzero(d < 0)
        if len(back) > 1 or len(dup):
            # the repeated autumn hour of naive local times is resolved from the row order: with the order broken
            # elsewhere, its messages only confuse; the order is the problem to fix first
            amb = [p for p in problems[n_before:] if "naive local times are ambiguous" in p]
            problems[:] = [p for p in problems if p not in amb]
        if len(back) > 1 and len(back) >= 0.9 * len(d):
            problems.append(
                f"{label}: column {time_name!r}: the rows run newest first (times go backwards at {len(back)} of "
                f"{len(d)} steps, from {_fmt_time(local[valid_pos[0]])} at row 1 to "
                f"{_fmt_time(local[valid_pos[-1]])} at row {valid_pos[-1] + 1}): sort the file oldest first"
                + (" (the repeated autumn hour then reads in order)" if amb else "")
            )
        elif len(back):
            parts = ", ".join(
                f"row {valid_pos[i + 1] + 1} ({_fmt_time(local[valid_pos[i + 1]])}) after row {valid_pos[i] + 1} "
                f"({_fmt_time(local[valid_pos[i]])})"
                for i in back[:N_EXAMPLES]
            )
            more = f" and {len(back) - N_EXAMPLES} more" if len(back) > N_EXAMPLES else ""
            problems.append(
                f"{label}: column {time_name!r}: times go backwards at {len(back)} place(s): {parts}{more}; "
                "rows must be sorted by time"
                + _utc_marked_local(raw[time_name].to_numpy(), valid_pos[back + 1], building.timezone)
                + (
                    f" (at {len(back)} places the rows are in no time order, e.g. merged from a database "
                    "without sorting: sort the file by time"
                    + (", the first occurrence of the repeated autumn hour before the second" if amb else "")
                    + ")"
                    if len(back) > 1
                    else ""
                )
            )
        if not len(back):
            problems += _stray_rows(tv, valid_pos, local, label, time_name)
    if len(tv):
        report.start, report.end = local[valid_pos[0]], local[valid_pos[-1]]
        report.native_step = _median_step(tv)
        report.warnings += _coarse_stretches(tv, valid_pos, local, report.native_step, label, time_name)
    return utc, ok, local


#: Stretches of rows spaced at least this multiple of the file's spacing, lasting this long [h], are named.
COARSE_FACTOR, COARSE_HOURS = 1.9, 6.0


def _coarse_stretches(tv, valid_pos, local, native, label, time_name) -> list[str]:
    """A warning for stretches logged at a coarser interval than the file (a 5-min export with 15-min days).

    Steps there hold fewer samples than the file's spacing promises and stay
    missing (the 50 % rule of :func:`hvacfmu.data.resample.resample`); gaps (one
    long jump) are not stretches.
    """
    if not native or len(tv) < 3:
        return []
    d = np.round(np.diff(tv) / 1e9)
    coarse = d >= COARSE_FACTOR * native
    if not coarse.any():
        return []
    starts = np.flatnonzero(np.diff(np.concatenate(([np.nan], d))) != 0)  # runs of one spacing: diffs a..b-1
    stops = np.concatenate((starts[1:], [len(d)]))
    found = [
        (int(a), int(b), float(d[a]))
        for a, b in zip(starts, stops)
        if coarse[a] and b - a >= 3 and d[a] * (b - a) >= COARSE_HOURS * 3600
    ]
    if not found:
        return []
    a, b, spacing = found[0]
    days = sum(d[x:y].sum() for x, y, _ in found) / 86400
    more = f" and {len(found) - 1} more stretch(es)" if len(found) > 1 else ""
    return [
        f"{label}: column {time_name!r}: rows {valid_pos[a] + 1}-{valid_pos[b] + 1} ({_fmt_time(local[valid_pos[a]])} .. "
        f"{_fmt_time(local[valid_pos[b]])}) are {spacing:g} s apart, not the file's {native:g} s{more}, {days:.1f} "
        f"days in all: model steps there hold fewer than half the samples expected at {native:g} s and stay missing; "
        "export the file at one interval"
    ]


#: A jump of the times longer than this [days] ...
STRAY_GAP_DAYS = 30.0
#: ... that cuts off at most this share of the rows leaves stray rows (a logger clock reset, a typo in a year).
STRAY_SHARE = 0.01


def _stray_rows(tv, valid_pos, local, label, time_name) -> list[str]:
    """Problems for a few rows months or years away from the rest (1970 after a logger reset, a wrong year).

    Two campaigns concatenated in one file (both sides large) are legitimate and
    pass; a side of at most :data:`STRAY_SHARE` of the rows beyond a jump of
    :data:`STRAY_GAP_DAYS` would stretch the span, the weeks and the coverage.
    """
    d = np.diff(tv)
    n = len(tv)
    out = []
    for i in np.flatnonzero(d > STRAY_GAP_DAYS * 86400e9):
        left, right = i + 1, n - i - 1
        if min(left, right) > STRAY_SHARE * n:
            continue
        a, b = (0, i) if left <= right else (i + 1, n - 1)
        where = "before" if left <= right else "after"
        other = i + 1 if left <= right else i
        out.append(
            f"{label}: column {time_name!r}: {min(left, right)} row(s) {valid_pos[a] + 1}-{valid_pos[b] + 1} "
            f"({_fmt_time(local[valid_pos[a]])} .. {_fmt_time(local[valid_pos[b]])}) lie {d[i] / 86400e9:.0f} days "
            f"{where} the rest of the file (row {valid_pos[other] + 1}, {_fmt_time(local[valid_pos[other]])}): a logger "
            "clock reset or a wrong year? correct or drop those rows"
        )
    return out


@dataclasses.dataclass
class _Column:
    """What checking one column needs to know about the file."""

    label: str
    building: Building
    where: _Where
    problems: list
    report: LoadReport
    utc: np.ndarray | None
    ok: np.ndarray | None
    local: pd.DatetimeIndex | None
    n: int

    def rows(self, positions, values):
        return self.where.rows(positions, values=values)


def _column_values(ctx: _Column, canonical: str, name: str, column: pd.Series):
    """One column converted to SI and checked (problems, warnings and masks recorded in ``ctx``), or None."""
    label, problems, report = ctx.label, ctx.problems, ctx.report
    desc = f"column {name!r}" + (f" ({canonical})" if name != canonical else "")
    kind = kind_of(canonical)
    try:
        unit = normalize_unit(ctx.building.unit_for(canonical), kind)
    except ValueError as exc:
        problems.append(f"{label}: {desc}: {exc} (declared in the building's [units])")
        return None
    report.units[canonical] = unit
    values, bad = _numeric(column)
    if len(bad):
        problems.append(_non_numeric_message(f"{label}: {desc}", bad, column, ctx))
    infinite = np.flatnonzero(np.isinf(values))
    if len(infinite):
        problems.append(
            f"{label}: {desc}: {len(infinite)} infinite value(s), e.g. {ctx.rows(infinite, values)}; "
            "a missing value must be an empty cell"
        )
        values = np.where(np.isinf(values), np.nan, values)
    finite = values[np.isfinite(values)]
    if not len(finite):
        if len(bad):
            return None  # every value is non-numeric: reported above
        if ctx.building.expected_columns().get(canonical, False) and ctx.n:
            problems.append(f"{label}: {desc}: no values at all (every row is empty)")
        elif ctx.n:
            report.warnings.append(f"{label}: optional {desc} has no values at all: ignored")
            del report.units[canonical]
            report.columns.pop(canonical, None)
        return None
    si = _checked_si(ctx, canonical, desc, kind, unit, values, finite)
    kept = int(np.isfinite(si).sum())
    si = check_stuck(canonical, si, ctx.utc, f"{label}: {desc}", ctx.rows, report.warnings, ok=ctx.ok)
    if kept > np.isfinite(si).sum():
        report.masked[(canonical, "stuck sensor")] = kept - int(np.isfinite(si).sum())
    if canonical == "T_out":
        before = int(np.isfinite(si).sum())
        si = check_outdoor_frozen(si, ctx.local, ctx.ok, f"{label}: {desc}", ctx.rows, report.warnings)
        if before > np.isfinite(si).sum():
            report.masked[(canonical, "frozen sensor")] = before - int(np.isfinite(si).sum())
    if canonical in {f"T_{z}" for z in ctx.building.zone_names}:
        check_setpoint_like(si, ctx.utc, ctx.ok, f"{label}: {desc}", report.warnings)
        check_zone_held(si, ctx.utc, ctx.ok, f"{label}: {desc}", ctx.rows, report.warnings)
    elif kind == "airflow":
        box = next((v for v in ctx.building.vavs if f"m_{v.name}" == canonical), None)
        check_airflow_constant(si, ctx.utc, ctx.ok, box, f"{label}: {desc}", report.warnings)
    if ctx.utc is not None:
        sel = np.isfinite(si) & ctx.ok
        report.column_steps[canonical] = _column_step(ctx.utc[sel], report, f"{label}: {desc}", ctx.n)
    return si


_DECIMAL_COMMA = r"^\s*[-+]?\d+,\d+\s*$"


def _non_numeric_message(desc: str, bad, column: pd.Series, ctx: _Column) -> str:
    """The problem of non-numeric cells; a decimal comma (a European export) is named with its fix."""
    text = column.iloc[bad[:1000]].astype("str")
    comma = float(text.str.match(_DECIMAL_COMMA).mean())
    if comma >= 0.5:
        thousands = bool(text.str.match(r"^\s*[-+]?\d{1,3}(,\d{3})+\s*$").all())
        what = "a thousands separator (or a decimal comma)" if thousands else "a decimal comma"
        return (
            f"{desc}: {len(bad)} value(s) written with a comma, e.g. {ctx.rows(bad, column.to_numpy())}: {what}; "
            "numbers must be written plainly with a decimal point (1006, 21.5): export the file without thousands "
            "separators and with '.' as the decimal separator (the column separator may stay ';')"
        )
    return (
        f"{desc}: {len(bad)} non-numeric value(s), e.g. {ctx.rows(bad, column.to_numpy())}; a reading must be a "
        "number and a missing one an empty cell (status texts such as 'Offline' or 'Fault' are not readings: "
        "blank them)"
    )


def _checked_si(ctx: _Column, canonical, desc, kind, unit, values, finite):
    """Values converted to SI and checked by the rules of their physical kind."""
    label, problems, report, where = ctx.label, ctx.problems, ctx.report, ctx.where
    si = to_si(values, unit)
    if kind == "temperature":
        n_before = len(problems)
        si = _check_temperature(canonical, desc, label, unit, values, finite, si, where, problems)
        if canonical == "T_out" and len(problems) == n_before:
            check_outdoor(si, unit, ctx.local, ctx.building.latitude, f"{label}: {desc}", problems)
        if canonical == "T_out" and len(problems) == n_before:
            zone_unit = _zone_temperature_unit(ctx.building)
            lat = ctx.building.latitude
            check_outdoor_unit_mix(values, unit, zone_unit, ctx.local, lat, f"{label}: {desc}", report.warnings)
            check_outdoor_shoulder(values, unit, si, ctx.local, lat, f"{label}: {desc}", report.warnings)
        if canonical in {f"T_{z}" for z in ctx.building.zone_names} and len(problems) == n_before:
            kept = int(np.isfinite(si).sum())
            si = check_zone_spikes(si, ctx.utc, ctx.ok, f"{label}: {desc}", ctx.rows, problems, report.warnings)
            if kept > np.isfinite(si).sum():
                report.masked[(canonical, "temperature spike")] = kept - int(np.isfinite(si).sum())
    elif kind == "airflow":
        box = next((v for v in ctx.building.vavs if f"m_{v.name}" == canonical), None)
        kept = int(np.isfinite(si).sum())
        si = _check_airflow(canonical, desc, label, unit, finite, si, box, where, problems, report)
        if kept > np.isfinite(si).sum():
            report.masked[(canonical, "airflow spike")] = kept - int(np.isfinite(si).sum())
    elif kind == "irradiance":
        n_before = len(problems)
        b = ctx.building
        sky = None
        if ctx.utc is not None and ctx.ok is not None and ctx.ok.any():
            t = ctx.utc[ctx.ok]
            sky = float(np.max(clear_sky_ghi(t[:: max(1, len(t) // 20_000)], b.latitude, b.longitude), initial=0.0))
        si = _check_irradiance(desc, label, unit, si, where, problems, report, report.start, report.end, sky)
        if canonical == "ghi" and len(problems) == n_before:
            check_irradiance_level(
                si, ctx.utc, ctx.ok, b.latitude, b.longitude, f"{label}: {desc}", unit, report.warnings
            )
    elif kind == "fraction":
        si = _check_fraction(desc, label, unit, finite, si, where, problems, report)
    elif kind == "speed":
        si = _check_wind(desc, label, unit, si, where, problems, report)
    else:
        flag_bad = np.flatnonzero(np.isfinite(si) & (si != 0) & (si != 1))
        if len(flag_bad):
            problems.append(
                f"{label}: {desc}: {len(flag_bad)} value(s) other than 0 or 1, e.g. {where.rows(flag_bad, values=si)}"
            )
    return si


def _zone_temperature_unit(building: Building) -> str | None:
    """The declared unit of the zone temperatures, when all zones share one (else None)."""
    try:
        units = {normalize_unit(building.unit_for(f"T_{z}"), "temperature") for z in building.zone_names}
    except ValueError:
        return None
    return units.pop() if len(units) == 1 else None


def _frame_from_columns(columns: dict, order: list, index) -> pd.DataFrame:
    """DataFrame from equal-length float arrays without a transposing copy (pandas keeps (k, n) blocks)."""
    if not order:
        return pd.DataFrame(index=index)
    block = np.stack([np.asarray(columns[c], dtype=float) for c in order])  # (k, n), C order
    return pd.DataFrame(block.T, index=index, columns=order, copy=False)


def _sample(x: np.ndarray, n: int = 50_000) -> np.ndarray:
    """An even subsample of at most about ``n`` values (for medians and percentiles of long series)."""
    return x[:: max(1, len(x) // n)]


_ERROR_CODES = {99.0, 999.0, 9999.0, 99999.0, 999999.0, 32767.0, 32768.0, 65535.0}


def _error_code_hint(si_values, unit) -> str:
    """'; -999 looks like an error code ...' when the impossible values are one or two codes such as -999 or 32767."""
    from .units import from_si

    raw = np.round(np.asarray(from_si(np.asarray(si_values, dtype=float), unit)), 6)
    codes = np.unique(raw)
    if not len(codes) or len(codes) > 2 or not all(abs(float(c)) in _ERROR_CODES for c in codes):
        return ""
    shown = " and ".join(f"{float(c):g}" for c in codes)
    return (
        f"; {shown} {'looks' if len(codes) == 1 else 'look'} like an error code of the export, not a reading: a "
        "missing value must be an empty cell (export missing values empty, or blank those cells)"
    )


def _large_temperature_guess(med: float) -> str:
    """What a temperature column whose median is above 200 (in degC or degF) is likely written in."""
    kelvin = 220 <= med <= 340  # -53..67 °C
    tenths_c = 5 <= med / 10 <= 40
    tenths_f = 40 <= med / 10 <= 105
    guesses = ["K"] if kelvin else []
    guesses += ["tenths of a degree C (divide by 10)"] if tenths_c else []
    guesses += ["tenths of a degree F (divide by 10)"] if tenths_f else []
    return ", or ".join(guesses) if guesses else "another unit or scale (check the export's point definition)"


def _check_temperature(canonical, desc, label, unit, raw_values, finite, si, where, problems):
    med = float(np.median(_sample(finite)))
    indoor = canonical != "T_out"
    guess = None
    if unit in ("degC", "degF") and med > 200:
        guess = _large_temperature_guess(med)
    elif unit == "degC" and med > 45:
        guess = "degF"
    elif unit == "degF" and indoor and med < 40:
        guess = "degC"
    elif unit == "K" and med < 150:
        guess = "degC or degF"
    if guess is not None:
        problems.append(
            f"{label}: {desc}: declared {unit} but the median is {med:.4g}, which cannot be an air temperature in "
            f"{unit}; the data look like {guess}: declare the unit in the building's [units] table"
        )
        return si
    lo, hi = TEMPERATURE_RANGE
    bad = np.flatnonzero((si < lo) | (si > hi))
    if len(bad):
        problems.append(
            f"{label}: {desc}: {len(bad)} value(s) outside {lo:g}..{hi:g} °C (after conversion from {unit}), "
            f"e.g. {where.rows(bad, values=si)}{_error_code_hint(si[bad], unit)}"
        )
    return si


def _check_airflow(canonical, desc, label, unit, finite, si, box, where, problems, report):
    """Negative airflow (noise clipped, else refused), then :func:`plausibility.check_airflow` against the box."""
    if box is not None:
        si = check_airflow(
            si, unit, box, f"{label}: {desc}", lambda p, v: where.rows(p, values=v), problems, report.warnings
        )
    neg = si < 0
    bad = np.flatnonzero(si < -AIRFLOW_NOISE)
    if len(bad):
        problems.append(
            f"{label}: {desc}: {len(bad)} negative airflow value(s) (below -{AIRFLOW_NOISE:g} kg/s), "
            f"e.g. {where.rows(bad, values=si)}{_error_code_hint(si[bad], unit)}"
        )
    elif neg.any():
        report.warnings.append(
            f"{label}: {desc}: {int(neg.sum())} slightly negative airflow value(s) (sensor noise) set to 0"
        )
        si = np.where(neg, 0.0, si)
    return si


#: A reheat command this far outside 0..1 is sensor noise and is clipped [1].
FRACTION_NOISE = 0.02


def _check_fraction(desc, label, unit, finite, si, where, problems, report):
    """A reheat command/valve position must lie in 0..1 (after conversion from %)."""
    top = float(np.max(finite))
    if unit == "1" and 1.5 < top <= 100.5 and float(np.min(finite)) >= -0.5:
        problems.append(
            f"{label}: {desc}: values reach {top:.4g} (declared as a fraction 0..1); the data look like percent: "
            'declare the unit in the building\'s [units] table, e.g. "rh_*" = "%"'
        )
        return si
    if unit == "%" and 0 < top <= 1.0 and float(np.mean((finite > 0) & (finite < 1))) > 0.01:
        report.warnings.append(
            f"{label}: {desc}: declared % but its largest value is {top:.3g}, so the reheat never exceeds {top:.3g} %; "
            'the data look like a fraction 0..1: declare "1" for the column in the building\'s [units] table'
        )
    bad = np.flatnonzero((si < -FRACTION_NOISE) | (si > 1 + FRACTION_NOISE))
    if len(bad):
        problems.append(
            f"{label}: {desc}: {len(bad)} value(s) outside 0..1 (after conversion from {unit}), "
            f"e.g. {where.rows(bad, values=si)}"
        )
        return si
    out = (si < 0) | (si > 1)
    if out.any():
        report.warnings.append(f"{label}: {desc}: {int(out.sum())} value(s) slightly outside 0..1 clipped")
        si = np.clip(si, 0.0, 1.0)
    return si


#: Negative wind speed down to this value is sensor noise and is set to 0 [m/s].
WIND_NOISE = 0.2
#: No wind speed measured at a building site (10-min mean or gust) exceeds this [m/s].
WIND_MAX = 60.0


def _zero_noise(si, label, desc, report):
    """Slightly negative values (sensor noise, within the column's tolerance) set to 0, with a warning."""
    neg = si < 0
    if neg.any():
        si = np.where(neg, 0.0, si)
        report.warnings.append(f"{label}: {desc}: {int(neg.sum())} slightly negative value(s) (sensor noise) set to 0")
    return si


def _check_wind(desc, label, unit, si, where, problems, report):
    """A wind speed must lie in 0..:data:`WIND_MAX` m/s (after conversion from ``unit``)."""
    bad = np.flatnonzero(si < -WIND_NOISE)
    if len(bad):
        problems.append(
            f"{label}: {desc}: {len(bad)} negative wind speed value(s) (below -{WIND_NOISE:g} m/s), "
            f"e.g. {where.rows(bad, values=si)}{_error_code_hint(si[bad], unit)}; a speed is never negative "
            "(a wind direction or a signed component is not a speed: map the site's wind speed column)"
        )
    high = np.flatnonzero(si > WIND_MAX)
    if len(high):
        problems.append(
            f"{label}: {desc}: {len(high)} value(s) above {WIND_MAX:g} m/s (after conversion from {unit}), faster "
            f"than any wind at a building site: is the unit right (declare km/h, mph or kn in the building's [units]) "
            f"or is it a direction in degrees?, e.g. {where.rows(high, values=si)}{_error_code_hint(si[high], unit)}"
        )
    return si if len(bad) else _zero_noise(si, label, desc, report)


#: Below this clear-sky peak [W/m²] over the span (polar night) low irradiance is not judged.
DAYLIGHT_MIN = 50.0


def _check_irradiance(desc, label, unit, si, where, problems, report, start=None, end=None, clear_peak=None):
    peak = float(np.nanmax(si))
    day = start is not None and end is not None and (end - start) >= pd.Timedelta(days=1)
    day = day and (clear_peak is None or clear_peak >= DAYLIGHT_MIN)  # the sun rises at all (no polar night)
    if day and peak < 0.5:
        problems.append(
            f"{label}: {desc}: the largest value over {(end - start).days} day(s) is {peak:.3g} W/m² (declared {unit}): "
            "no daylight at all, a dead or disconnected sensor; fix the sensor or drop the column (the models then "
            "have no solar input)"
        )
        return si
    if day and 0 < peak < 5:
        problems.append(
            f"{label}: {desc}: the largest value over {(end - start).days} day(s) is {peak:.3g} W/m² (declared {unit}); "
            "irradiance this low cannot be right, the data look like kW/m²: declare the unit in the building's [units]"
        )
        return si
    bad = np.flatnonzero(si < -IRRADIANCE_NOISE)
    if len(bad):
        problems.append(
            f"{label}: {desc}: {len(bad)} negative irradiance value(s) (below -{IRRADIANCE_NOISE:g} W/m²), "
            f"e.g. {where.rows(bad, values=si)}{_error_code_hint(si[bad], unit)}"
        )
    high = np.flatnonzero(si > IRRADIANCE_MAX)
    if len(high):
        problems.append(
            f"{label}: {desc}: {len(high)} value(s) above {IRRADIANCE_MAX:g} W/m², more than any irradiance at "
            f"ground level (is the unit W/m²?), e.g. {where.rows(high, values=si)}{_error_code_hint(si[high], unit)}"
        )
    return si if len(bad) else _zero_noise(si, label, desc, report)
