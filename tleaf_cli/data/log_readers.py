"""Event logs read: XES or CSV files into cases, events in time order, with what was skipped.

An event log (the process-mining field's data: pm4py, ProM, the BPI Challenges) is a set of
cases (traces), each a sequence of events with an activity and a timestamp. `LogReader` (the
dataset reader interface of data/case_readers.py; `read_log` in one call) reads `.xes`,
`.xes.gz`, `.csv` or `.csv.gz` into `Cases` (data/cases.py), split by its settings, with what it
skipped in their `SkipReport`; `event_logs.write_cases` writes them as the `cases` artifact
(docs/event_logs.md).

XES is read by a streaming parser (expat, the parser under ElementTree's iterparse, fed straight
from the gzip stream): memory holds the cases' activities and times, never the XML tree, and a
malformed line is named by its number. pm4py would load the whole log into memory and is a heavy
dependency for reading three attributes.

Bad input: a case with no events is skipped and counted; events out of time order are sorted
(stably: file order breaks ties) and their cases counted; an event without activity or timestamp,
or with a timestamp that is no ISO 8601 date, is skipped and counted with the first few places
(case id and line) kept for the report. An InputError naming the file and, where known, the line:
a malformed XML file, a truncated .gz, a case id or activity holding a NUL character, a CSV row
with more fields than its header.

One case id twice: in XES two `<trace>` elements with one id are two cases (as pm4py keeps them),
the later ones renamed `<id>#2`, `#3`, ... and counted as duplicate case ids, the first few named;
in CSV rows of one case spread over the file are one case (exports often interleave cases), and
the cases whose rows are not contiguous are counted.

Attributes (`LogSettings.attributes`, `case_attributes`): the named event attributes (XES: the
event's attribute of that key; CSV: the column) are kept as one value per event, None where an
event has none, following their events through lifecycle filtering and sorting; the named case
attributes as one value per case (XES: the trace's attribute; CSV: the first non-empty cell of
the case's rows). Values are kept as the log writes them (text). A name the log does not have at
all (no event, or no trace, holds it; no such CSV column) is an InputError naming it and some
that the log has.
"""

from __future__ import annotations

import csv
import gzip
import io
import itertools
import os
import zlib
from datetime import UTC, datetime
from pathlib import Path
from typing import IO
from xml.parsers import expat

from tleaf_cli.data.activity_names import activity_atoms
from tleaf_cli.data.case_readers import Progress
from tleaf_cli.data.cases import Case, Cases
from tleaf_cli.data.event_logs import split_cases, write_cases
from tleaf_cli.data.log_columns import attribute_column, cell, check_met, key_column
from tleaf_cli.data.skip_report import EXAMPLES, SkipReport
from tleaf_cli.errors import InputError
from tleaf_cli.settings.event_logs import (
    ACTIVITY_COLUMNS,
    CASE_COLUMNS,
    TIMESTAMP_COLUMNS,
    XES_ACTIVITY_KEY,
    XES_CASE_KEY,
    XES_TIMESTAMP_KEY,
    LogSettings,
)

LOG_SUFFIXES = (".xes", ".xes.gz", ".csv", ".csv.gz")
LIFECYCLE_KEY = "lifecycle:transition"
AUTO = "auto"  # the lifecycle setting's default: 'complete' events where the log has any
COMPLETE = "complete"
CHUNK = 1 << 20  # bytes of XML fed to the parser at a time
ROWS_PER_TICK = 4096  # CSV rows between two progress reports

# What a skip is counted as (SkipReport.skipped's keys).
NO_ACTIVITY = "events without activity"
NO_TIMESTAMP = "events without timestamp"
BAD_TIMESTAMP = "events with an unreadable timestamp"
NO_CASE_ID = "events without case id"
EMPTY_CASE = "cases without events"
LIFECYCLE = "events of another lifecycle transition"
DUPLICATE_SUFFIX = "#"  # XES: the second trace named c1 is case c1#2


class LogReader:
    """An XES or CSV event log as `Cases` (a `CaseReader`): `read` the log, `write` the `cases`
    artifact with the settings' split."""

    def __init__(self, path: str | os.PathLike, settings: LogSettings | None = None) -> None:
        self.path = Path(path)
        self.settings = settings or LogSettings()

    def read(self, progress: Progress | None = None) -> Cases:
        """The log's cases, split by the settings; InputError if it is unusable as a whole."""
        settings = self.settings
        settings.check()
        kind = log_format(self.path)
        if not self.path.is_file():
            raise InputError(f"{self.path}: no such file")
        reader = _read_xes if kind == "xes" else _read_csv
        tick = progress or (lambda done, total: None)
        try:
            cases = reader(self.path, settings, tick)
        except (EOFError, zlib.error, gzip.BadGzipFile) as e:
            raise InputError(f"{self.path}: truncated or damaged gzip file ({e})") from None
        except UnicodeDecodeError as e:
            raise InputError(
                f"{self.path}: not UTF-8 text ({e.reason} at byte {e.start})"
            ) from None
        if not cases.cases:
            raise InputError(f"{self.path}: no case with events ({cases.skips.text()} skipped)")
        size = self.path.stat().st_size
        tick(size, size)
        return cases

    def write(self, cases: Cases, out: str | os.PathLike) -> None:
        """The `cases` artifact of `cases`, split by the settings (event_logs.write_cases)."""
        write_cases(cases, out, self.settings)


def read_log(
    path: str | os.PathLike, settings: LogSettings | None = None, progress: Progress | None = None
) -> Cases:
    """Read an XES or CSV event log into cases (`LogReader.read`)."""
    return LogReader(path, settings).read(progress)


def log_format(path: str | os.PathLike) -> str:
    """'xes' or 'csv' by the file's name; InputError for any other."""
    name = str(path).lower()
    for suffix in LOG_SUFFIXES:
        if name.endswith(suffix):
            return suffix.split(".")[1]
    raise InputError(f"{path}: not an event log (expected {', '.join(LOG_SUFFIXES)})")


class _Counted:
    """A binary file read through, with how far: `tell()` of the file itself (for a .gz, the
    compressed bytes read), so progress is told against the file's size."""

    def __init__(self, path: Path, tick: Progress) -> None:
        self.raw = open(path, "rb")  # noqa: SIM115 (closed by close())
        self.size = path.stat().st_size
        self.tick = tick
        gz = path.name.lower().endswith(".gz")
        self.stream: IO[bytes] = gzip.GzipFile(fileobj=self.raw) if gz else self.raw

    def report(self) -> None:
        self.tick(min(self.raw.tell(), self.size), self.size)

    def close(self) -> None:
        self.stream.close()
        self.raw.close()


def _utc(text: str) -> datetime | None:
    """An ISO 8601 timestamp as a UTC datetime (no zone: UTC), or None if it is none."""
    try:
        stamp = datetime.fromisoformat(text.strip())
    except ValueError:
        return None
    return stamp.replace(tzinfo=UTC) if stamp.tzinfo is None else stamp.astimezone(UTC)


class _Builder:
    """Collects events per case (first-appearance order) and skips, into Cases."""

    def __init__(self, path: Path, keys: dict[str, str], settings: LogSettings) -> None:
        self.path = path
        self.keys = keys
        self.settings = settings
        self.skips = SkipReport()
        # None: keep every event; AUTO: decided in `finish`; else the transition kept
        self.lifecycle = None if settings.lifecycle == "all" else settings.lifecycle.lower()
        self.any_complete = False  # some event's transition is 'complete' (AUTO)
        # case -> activities, times, whether each event has a transition but not 'complete', and
        # each event's kept attribute values (settings.event_attributes, in order)
        self.events: dict[str, tuple[list[str], list[datetime], list[bool], list[tuple]]] = {}
        self.case_values: dict[str, list[str | None]] = {}  # case -> its kept case attributes
        self.values: dict[str, str] = {}  # each attribute value once, shared by its events
        self.seen: dict[str, str] = {}  # every case id met -> where it was first met
        self.names: dict[str, str] = {}  # each activity name once, shared by its events
        self.duplicates: list[str] = []  # XES: ids of traces met again (renamed)
        self.spread = 0  # CSV: cases whose rows are not contiguous in the file (merged)

    def event(
        self,
        case: str | None,
        activity: str | None,
        stamp: str | None,
        life: str | None,
        at: str,
        values: tuple[str | None, ...] = (),
    ) -> None:
        for what, name in (("case id", case), ("activity", activity)):
            if name and "\x00" in name:
                raise InputError(f"{self.path}: {at}: a NUL character in the {what} {name!r}")
        skips = self.skips
        phase = None if life is None else life.strip().lower()
        if self.lifecycle not in (None, AUTO) and phase is not None and phase != self.lifecycle:
            skips.skip(LIFECYCLE)
            return
        self.any_complete |= phase == COMPLETE
        if not case:
            skips.skip(NO_CASE_ID, at)
            return
        self.seen.setdefault(case, at)
        where = f"case {case}, {at}"
        if not activity:
            skips.skip(NO_ACTIVITY, where)
            return
        if not stamp:
            skips.skip(NO_TIMESTAMP, where)
            return
        time = _utc(stamp)
        if time is None:
            skips.skip(BAD_TIMESTAMP, f"{where}: '{stamp[:40]}'")
            return
        activities, times, other, kept = self.events.setdefault(case, ([], [], [], []))
        activities.append(self.names.setdefault(activity, activity))  # one str per name
        times.append(time)
        other.append(phase is not None and phase != COMPLETE)
        if values:
            values = tuple(None if v is None else self.values.setdefault(v, v) for v in values)
        kept.append(values)

    def case_attributes(self, case: str, values: tuple[str | None, ...]) -> None:
        """A case's kept case attributes: the first non-empty value of each is kept."""
        held = self.case_values.setdefault(case, [None] * len(values))
        for k, value in enumerate(values):
            if held[k] is None and value:
                held[k] = value

    def case(self, case: str | None, at: str) -> None:
        """A case met (XES: a trace, even one without events)."""
        if case:
            self.seen.setdefault(case, at)

    def trace_id(self, case: str) -> str:
        """An XES trace's case id: its own, or, for a trace whose id an earlier trace took,
        the first free `<id>#2`, `<id>#3`, ... (counted: one id twice is a data error, and
        merging two traces would interleave two runs of the process)."""
        if case not in self.seen:
            return case
        self.duplicates.append(case)
        n = 2
        while f"{case}{DUPLICATE_SUFFIX}{n}" in self.seen:
            n += 1
        return f"{case}{DUPLICATE_SUFFIX}{n}"

    def finish(self) -> Cases:
        skips = self.skips
        if self.lifecycle == AUTO and self.any_complete:  # a log with lifecycle: complete only
            for case, (activities, times, other, kept) in list(self.events.items()):
                if any(other):
                    skips.skip(LIFECYCLE, count=sum(other))
                    keep = [i for i, o in enumerate(other) if not o]
                    activities[:] = [activities[i] for i in keep]
                    times[:] = [times[i] for i in keep]
                    kept[:] = [kept[i] for i in keep]
                    if not keep:
                        del self.events[case]
        for case, at in self.seen.items():
            if case not in self.events:  # no event, or none kept
                skips.skip(EMPTY_CASE, f"case {case}, {at}")
        rows, reordered = [], 0
        for case, (activities, times, _, kept) in self.events.items():
            if any(b < a for a, b in itertools.pairwise(times)):
                reordered += 1
                order = sorted(range(len(times)), key=times.__getitem__)  # stable
                activities = [activities[i] for i in order]
                times = [times[i] for i in order]
                kept = [kept[i] for i in order]
            rows.append((case, tuple(activities), tuple(times), kept))
        self._repairs(reordered)
        atoms = activity_atoms(a for _, acts, _, _ in rows for a in acts)
        s = self.settings
        split_of = split_cases([c for c, _, _, _ in rows], s.split, s.split_order, s.seed)
        names, case_names = s.event_attributes, s.trace_attributes
        cases = [
            Case(
                c,
                acts,
                tuple(atoms[a] for a in acts),
                times,
                split_of[c],
                attributes={n: tuple(v[k] for v in kept) for k, n in enumerate(names)},
                case_attributes=dict(
                    zip(case_names, self.case_values.get(c, [None] * len(case_names)), strict=True)
                ),
            )
            for c, acts, times, kept in rows
        ]
        params = {
            "keys": self.keys,
            "reordered_cases": reordered,
            "duplicate_case_ids": {
                "count": len(self.duplicates),
                "examples": self.duplicates[:EXAMPLES],
            },
            "spread_cases": self.spread,
        }
        return Cases(cases, atoms, str(self.path), params, skips, [self.path], names, case_names)

    def _repairs(self, reordered: int) -> None:
        """What was repaired, as the phrases that lead the skip report's text."""
        repairs = self.skips.repairs
        if reordered:
            repairs.append(f"cases sorted by time: {reordered}")
        if self.duplicates:
            more = ", ..." if len(self.duplicates) > EXAMPLES else ""
            repairs.append(
                f"duplicate case ids (kept apart as <id>{DUPLICATE_SUFFIX}2, ...): "
                f"{len(self.duplicates)} ({', '.join(self.duplicates[:EXAMPLES])}{more})"
            )
        if self.spread:
            repairs.append(f"cases merged from rows spread over the file: {self.spread}")


def _read_xes(path: Path, settings: LogSettings, tick: Progress) -> Cases:
    keys = {
        "case": settings.case_key or XES_CASE_KEY,
        "activity": settings.activity_key or XES_ACTIVITY_KEY,
        "timestamp": settings.timestamp_key or XES_TIMESTAMP_KEY,
    }
    build = _Builder(path, keys, settings)
    names, case_names = settings.event_attributes, settings.trace_attributes
    met: set[str] = set()  # the event attributes met (where some were asked for)
    case_met: set[str] = set()  # the trace attributes met (where some were asked for)
    parser = expat.ParserCreate()
    stack: list[str] = []  # local tag names from the root down
    trace: dict[str, str] = {}
    events: list[tuple[dict[str, str], int]] = []  # a trace's events, its case id comes last
    event: dict[str, str] | None = None
    trace_line = 0

    def start(tag: str, attrs: dict[str, str]) -> None:
        nonlocal event, trace, events, trace_line
        local = tag.rsplit(":", 1)[-1]
        parent = stack[-1] if stack else None
        stack.append(local)
        if local == "trace" and parent == "log":
            trace, events, trace_line = {}, [], parser.CurrentLineNumber
        elif local == "event" and parent == "trace":
            event = {}
            events.append((event, parser.CurrentLineNumber))
        elif "key" in attrs and "value" in attrs:  # an attribute, of the element it is in
            if parent == "event" and event is not None and len(stack) >= 3:
                event.setdefault(attrs["key"], attrs["value"])
            elif parent == "trace" and len(stack) == 3:
                trace.setdefault(attrs["key"], attrs["value"])

    def end(tag: str) -> None:
        nonlocal event
        local = stack.pop()
        if local == "event" and stack and stack[-1] == "trace":
            event = None
        elif local == "trace" and stack == ["log"]:
            case = trace.get(keys["case"])
            if not case:
                for _, line in events:
                    build.skips.skip(NO_CASE_ID, f"trace at line {trace_line}, line {line}")
                return
            case = build.trace_id(case)
            build.case(case, f"line {trace_line}")
            if case_names:
                case_met.update(trace)
                build.case_attributes(case, tuple(trace.get(n) for n in case_names))
            for attrs, line in events:
                if names:
                    met.update(attrs)
                build.event(
                    case,
                    attrs.get(keys["activity"]),
                    attrs.get(keys["timestamp"]),
                    attrs.get(LIFECYCLE_KEY),
                    f"line {line}",
                    tuple(attrs.get(n) or None for n in names),
                )

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.buffer_text = True
    source = _Counted(path, tick)
    try:
        while chunk := source.stream.read(CHUNK):
            parser.Parse(chunk, False)
            source.report()
        parser.Parse(b"", True)
    except expat.ExpatError as e:
        raise InputError(
            f"{path}: line {e.lineno}: malformed XML ({expat.ErrorString(e.code)})"
        ) from None
    finally:
        source.close()
    check_met(path, names, met, "event")
    check_met(path, case_names, case_met, "trace")
    return build.finish()


def _read_csv(path: Path, settings: LogSettings, tick: Progress) -> Cases:
    source = _Counted(path, tick)
    try:
        text = io.TextIOWrapper(source.stream, encoding="utf-8-sig", newline="")
        return _read_csv_rows(path, csv.reader(text), settings, source)
    finally:
        source.close()


def _read_csv_rows(path: Path, rows, settings: LogSettings, source: _Counted) -> Cases:
    try:
        header = [h.strip() for h in next(rows)]
    except StopIteration:
        raise InputError(f"{path}: empty file (no header)") from None
    except csv.Error as e:
        raise InputError(f"{path}: line 1: {e}") from None
    try:
        keys = {
            "case": key_column(header, settings.case_key, CASE_COLUMNS, "case"),
            "activity": key_column(header, settings.activity_key, ACTIVITY_COLUMNS, "activity"),
            "timestamp": key_column(header, settings.timestamp_key, TIMESTAMP_COLUMNS, "timestamp"),
        }
    except InputError as e:
        raise InputError(f"{path}: {e}") from None
    build = _Builder(path, keys, settings)
    at = [header.index(keys[k]) for k in ("case", "activity", "timestamp")]
    columns = [attribute_column(path, header, n) for n in settings.event_attributes]
    case_columns = [attribute_column(path, header, n) for n in settings.trace_attributes]
    life = header.index(LIFECYCLE_KEY) if LIFECYCLE_KEY in header else None
    last, met, spread = None, set(), set()  # previous row's case; cases met; met again
    try:
        for number, row in enumerate(rows, 1):
            if number % ROWS_PER_TICK == 0:
                source.report()
            if not any(cell.strip() for cell in row):
                continue  # a blank line
            if len(row) > len(header):
                raise InputError(
                    f"{path}: line {rows.line_num}: {len(row)} fields where the header has "
                    f"{len(header)}"
                )
            case, activity, stamp = (row[i].strip() if i < len(row) else "" for i in at)
            if case and case != last:
                if case in met:
                    spread.add(case)
                met.add(case)
                last = case
            phase = row[life] if life is not None and life < len(row) else None
            values = tuple(cell(row, i) for i in columns)
            build.event(case, activity, stamp, phase, f"line {rows.line_num}", values)
            if case_columns and case:
                build.case_attributes(case, tuple(cell(row, i) for i in case_columns))
    except csv.Error as e:
        raise InputError(f"{path}: line {rows.line_num}: {e}") from None
    build.spread = len(spread)
    return build.finish()
