"""Event logs read: XES or CSV files into cases, events in time order, with what was skipped.

An event log (the process-mining field's data: pm4py, ProM, the BPI Challenges) is a set of
cases (traces), each a sequence of events with an activity and a timestamp. `read_log` reads
`.xes`, `.xes.gz`, `.csv` or `.csv.gz` into a `LogReport`; `event_logs.write_cases` writes it as
the `cases` artifact (docs/event_logs.md).

XES is read by a streaming parser (expat, the parser under ElementTree's iterparse, fed straight
from the gzip stream): memory holds the cases' activities and times, never the XML tree, and a
malformed line is named by its number. pm4py would load the whole log into memory and is a heavy
dependency for reading three attributes.

Bad input: a case with no events is skipped and counted; events out of time order are sorted
(stably: file order breaks ties) and their cases counted; an event without activity or timestamp,
or with a timestamp that is no ISO 8601 date, is skipped and counted with the first few places
(case id and line) kept for the report; a malformed XML file or a truncated .gz is an InputError
naming the file and, where known, the line.

One case id twice: in XES two `<trace>` elements with one id are two cases (as pm4py keeps them),
the later ones renamed `<id>#2`, `#3`, ... and counted as duplicate case ids, the first few named;
in CSV rows of one case spread over the file are one case (exports often interleave cases), and
the cases whose rows are not contiguous are counted.
"""

from __future__ import annotations

import csv
import gzip
import itertools
import os
import zlib
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from xml.parsers import expat

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
EXAMPLES = 5  # places kept per kind of skip, for the report
_EPOCH = datetime(1970, 1, 1, tzinfo=UTC)

# What a skip or a repair is counted as (LogReport.skipped's keys).
NO_ACTIVITY = "events without activity"
NO_TIMESTAMP = "events without timestamp"
BAD_TIMESTAMP = "events with an unreadable timestamp"
NO_CASE_ID = "events without case id"
EMPTY_CASE = "cases without events"
LIFECYCLE = "events of another lifecycle transition"
DUPLICATE_SUFFIX = "#"  # XES: the second trace named c1 is case c1#2


@dataclass
class LogReport:
    """What reading a log found: its cases (file order, events sorted by time) and what was
    skipped (kind -> count, and the first few places: 'case 17, line 230')."""

    path: str
    keys: dict[str, str]  # case / activity / timestamp -> the attribute or column read
    cases: list[tuple[str, list[str], list[int]]]  # case id, activities, µs since 1970 UTC
    skipped: dict[str, int] = field(default_factory=dict)
    examples: dict[str, list[str]] = field(default_factory=dict)
    reordered: int = 0  # cases whose events were not in time order in the file (sorted)
    duplicates: list[str] = field(default_factory=list)  # XES: ids of traces met again (renamed)
    spread: int = 0  # CSV: cases whose rows are not contiguous in the file (merged)

    @property
    def events(self) -> int:
        return sum(len(a) for _, a, _ in self.cases)

    def skip(self, kind: str, where: str) -> None:
        self.skipped[kind] = self.skipped.get(kind, 0) + 1
        places = self.examples.setdefault(kind, [])
        if len(places) < EXAMPLES:
            places.append(where)

    def skip_text(self) -> str:
        """What was skipped or repaired, in one phrase: 'cases sorted by time: 2, events without
        timestamp: 3 (case 7, line 12; ...)', or 'none'."""
        parts = [f"cases sorted by time: {self.reordered}"] if self.reordered else []
        if self.duplicates:
            more = ", ..." if len(self.duplicates) > EXAMPLES else ""
            parts.append(
                f"duplicate case ids (kept apart as <id>{DUPLICATE_SUFFIX}2, ...): "
                f"{len(self.duplicates)} ({', '.join(self.duplicates[:EXAMPLES])}{more})"
            )
        if self.spread:
            parts.append(f"cases merged from rows spread over the file: {self.spread}")
        for kind, count in self.skipped.items():
            places = self.examples.get(kind, [])
            more = "; ..." if count > len(places) else ""
            parts.append(f"{kind}: {count}" + (f" ({'; '.join(places)}{more})" if places else ""))
        return ", ".join(parts) or "none"


# ---- reading


def log_format(path: str | os.PathLike) -> str:
    """'xes' or 'csv' by the file's name; InputError for any other."""
    name = str(path).lower()
    for suffix in LOG_SUFFIXES:
        if name.endswith(suffix):
            return suffix.split(".")[1]
    raise InputError(f"{path}: not an event log (expected {', '.join(LOG_SUFFIXES)})")


def read_log(path: str | os.PathLike, settings: LogSettings | None = None) -> LogReport:
    """Read an XES or CSV event log into cases; InputError if it is unusable as a whole."""
    settings = settings or LogSettings()
    settings.check()
    kind = log_format(path)
    if not Path(path).is_file():
        raise InputError(f"{path}: no such file")
    reader = _read_xes if kind == "xes" else _read_csv
    try:
        report = reader(Path(path), settings)
    except (EOFError, zlib.error, gzip.BadGzipFile) as e:
        raise InputError(f"{path}: truncated or damaged gzip file ({e})") from None
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: not UTF-8 text ({e.reason} at byte {e.start})") from None
    if not report.cases:
        raise InputError(f"{path}: no case with events ({report.skip_text()} skipped)")
    return report


def _open(path: Path, mode: str):
    gz = path.name.lower().endswith(".gz")
    if mode == "rb":
        return gzip.open(path, "rb") if gz else open(path, "rb")
    return (gzip.open if gz else open)(path, "rt", encoding="utf-8-sig", newline="")


def _micros(text: str) -> int | None:
    """µs since 1970 UTC of an ISO 8601 timestamp (no zone: UTC), or None if it is none."""
    try:
        stamp = datetime.fromisoformat(text.strip())
    except ValueError:
        return None
    if stamp.tzinfo is None:
        stamp = stamp.replace(tzinfo=UTC)
    delta = stamp - _EPOCH
    return (delta.days * 86_400 + delta.seconds) * 1_000_000 + delta.microseconds


class _Builder:
    """Collects events per case (first-appearance order) and skips into a LogReport."""

    def __init__(self, path: Path, keys: dict[str, str], lifecycle: str) -> None:
        self.report = LogReport(str(path), keys, [])
        # None: keep every event; AUTO: decided in `finish`; else the transition kept
        self.lifecycle = None if lifecycle == "all" else lifecycle.lower()
        self.any_complete = False  # some event's transition is 'complete' (AUTO)
        # case -> activities, µs times, and whether each event has a transition but not 'complete'
        self.events: dict[str, tuple[list[str], list[int], list[bool]]] = {}
        self.seen: dict[str, str] = {}  # every case id met -> where it was first met
        self.names: dict[str, str] = {}  # each activity name once, shared by its events

    def event(
        self, case: str | None, activity: str | None, stamp: str | None, life: str | None, at: str
    ) -> None:
        report = self.report
        phase = None if life is None else life.strip().lower()
        if self.lifecycle not in (None, AUTO) and phase is not None and phase != self.lifecycle:
            report.skipped[LIFECYCLE] = report.skipped.get(LIFECYCLE, 0) + 1
            return
        self.any_complete |= phase == COMPLETE
        if not case:
            report.skip(NO_CASE_ID, at)
            return
        self.seen.setdefault(case, at)
        where = f"case {case}, {at}"
        if not activity:
            report.skip(NO_ACTIVITY, where)
            return
        if not stamp:
            report.skip(NO_TIMESTAMP, where)
            return
        micros = _micros(stamp)
        if micros is None:
            report.skip(BAD_TIMESTAMP, f"{where}: '{stamp[:40]}'")
            return
        activities, times, other = self.events.setdefault(case, ([], [], []))
        activities.append(self.names.setdefault(activity, activity))  # one str per name
        times.append(micros)
        other.append(phase is not None and phase != COMPLETE)

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
        self.report.duplicates.append(case)
        n = 2
        while f"{case}{DUPLICATE_SUFFIX}{n}" in self.seen:
            n += 1
        return f"{case}{DUPLICATE_SUFFIX}{n}"

    def finish(self) -> LogReport:
        report = self.report
        if self.lifecycle == AUTO and self.any_complete:  # a log with lifecycle: complete only
            for case, (activities, times, other) in list(self.events.items()):
                if any(other):
                    report.skipped[LIFECYCLE] = report.skipped.get(LIFECYCLE, 0) + sum(other)
                    keep = [i for i, o in enumerate(other) if not o]
                    activities[:] = [activities[i] for i in keep]
                    times[:] = [times[i] for i in keep]
                    if not keep:
                        del self.events[case]
        for case, at in self.seen.items():
            if case not in self.events:  # no event, or none kept
                report.skip(EMPTY_CASE, f"case {case}, {at}")
        for case, (activities, times, _) in self.events.items():
            if any(b < a for a, b in itertools.pairwise(times)):
                report.reordered += 1
                order = sorted(range(len(times)), key=times.__getitem__)  # stable
                activities = [activities[i] for i in order]
                times = [times[i] for i in order]
            report.cases.append((case, activities, times))
        return report


def _read_xes(path: Path, settings: LogSettings) -> LogReport:
    keys = {
        "case": settings.case_key or XES_CASE_KEY,
        "activity": settings.activity_key or XES_ACTIVITY_KEY,
        "timestamp": settings.timestamp_key or XES_TIMESTAMP_KEY,
    }
    build = _Builder(path, keys, settings.lifecycle)
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
                    build.report.skip(NO_CASE_ID, f"trace at line {trace_line}, line {line}")
                return
            case = build.trace_id(case)
            build.case(case, f"line {trace_line}")
            for attrs, line in events:
                build.event(
                    case,
                    attrs.get(keys["activity"]),
                    attrs.get(keys["timestamp"]),
                    attrs.get(LIFECYCLE_KEY),
                    f"line {line}",
                )

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.buffer_text = True
    with _open(path, "rb") as fh:
        try:
            parser.ParseFile(fh)
        except expat.ExpatError as e:
            raise InputError(
                f"{path}: line {e.lineno}: malformed XML ({expat.ErrorString(e.code)})"
            ) from None
    return build.finish()


def _column(header: list[str], given: str | None, candidates: tuple[str, ...], what: str) -> str:
    """The column holding `what`: the given name, else the first candidate in the header."""
    if given is not None:
        if given not in header:
            raise InputError(f"no column '{given}' for the {what} (columns: {', '.join(header)})")
        return given
    lowered = {h.lower(): h for h in header}
    for name in candidates:
        if name.lower() in lowered:
            return lowered[name.lower()]
    raise InputError(
        f"no {what} column: none of {', '.join(candidates)} in the header "
        f"({', '.join(header)}); name it with the {what} key setting"
    )


def _read_csv(path: Path, settings: LogSettings) -> LogReport:
    with _open(path, "rt") as fh:
        rows = csv.reader(fh)
        try:
            header = [h.strip() for h in next(rows)]
        except StopIteration:
            raise InputError(f"{path}: empty file (no header)") from None
        except csv.Error as e:
            raise InputError(f"{path}: line 1: {e}") from None
        try:
            keys = {
                "case": _column(header, settings.case_key, CASE_COLUMNS, "case"),
                "activity": _column(header, settings.activity_key, ACTIVITY_COLUMNS, "activity"),
                "timestamp": _column(
                    header, settings.timestamp_key, TIMESTAMP_COLUMNS, "timestamp"
                ),
            }
        except InputError as e:
            raise InputError(f"{path}: {e}") from None
        build = _Builder(path, keys, settings.lifecycle)
        at = [header.index(keys[k]) for k in ("case", "activity", "timestamp")]
        life = header.index(LIFECYCLE_KEY) if LIFECYCLE_KEY in header else None
        last, met, spread = None, set(), set()  # previous row's case; cases met; met again
        try:
            for row in rows:
                if not any(cell.strip() for cell in row):
                    continue  # a blank line
                case, activity, stamp = (row[i].strip() if i < len(row) else "" for i in at)
                if case and case != last:
                    if case in met:
                        spread.add(case)
                    met.add(case)
                    last = case
                phase = row[life] if life is not None and life < len(row) else None
                build.event(case, activity, stamp, phase, f"line {rows.line_num}")
        except csv.Error as e:
            raise InputError(f"{path}: line {rows.line_num}: {e}") from None
    build.report.spread = len(spread)
    return build.finish()
