"""The protocol of `tleaf predict RUN --follow`: events as JSON lines in, one JSON line out per
event (docs/monitoring.md, "Live stream"), apart from what is predicted (stream.py).

An event is `{"case": ..., "activity": ..., "timestamp": ISO 8601, "attributes": {...}, "end":
bool}` (`event_fields` reads it). A bad event raises a `BadEvent` whose `reason` is one of
`REASONS`, and changes nothing: `run_stream` reports it, counts it (`StreamSummary`) and goes
on. `read_lines` reads stdin or follows a growing file (like `tail -f`).
"""

from __future__ import annotations

import json
import os
import queue
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

from tleaf_cli.errors import InputError

if TYPE_CHECKING:
    from tleaf_cli.tasks.next_activity.stream import StreamMonitor

MALFORMED = "malformed JSON"
MISSING = "missing field"
BAD_FIELD = "bad field"
OUT_OF_ORDER = "timestamp before the case's previous event"
CLOSED = "case already ended"
NOT_OPEN = "end mark for a case not open"
REASONS = (MALFORMED, MISSING, BAD_FIELD, OUT_OF_ORDER, CLOSED, NOT_OPEN)
UNKNOWN_ACTIVITY = "unknown activity"  # not skipped: the case goes on without a prediction
ENDED = "the case ended"  # the reason of an end mark's line: no next event to predict
CASE_SCOPE = "case:"  # an attribute named case:<name> is a case attribute


class BadEvent(InputError):
    """An input line that is not a usable event (`reason`: one of `REASONS`); nothing changed."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


def first_line(e: Exception) -> str:
    return str(e).splitlines()[0] if str(e) else type(e).__name__


def event_fields(event: Mapping) -> tuple[str, str | None, datetime | None, dict, bool]:
    """(case id, activity or None for an end mark alone, UTC time, attributes, end) of an
    event; BadEvent for a field missing or of the wrong kind."""
    if "case" not in event:
        raise BadEvent(MISSING, "no 'case'")
    case_id = event["case"]
    if isinstance(case_id, bool) or not isinstance(case_id, str | int) or case_id == "":
        raise BadEvent(BAD_FIELD, f"'case' must be a non-empty string, not {case_id!r}")
    case_id = str(case_id)
    end = event.get("end", False)
    if end is None:
        end = False
    if not isinstance(end, bool):
        raise BadEvent(BAD_FIELD, f"'end' must be true or false, not {end!r}")
    activity = event.get("activity")
    if activity is None:
        if end:  # the mark alone: its other fields are not read
            return case_id, None, None, {}, True
        raise BadEvent(MISSING, f"case {case_id!r}: no 'activity'")
    if not isinstance(activity, str) or not activity:
        raise BadEvent(BAD_FIELD, f"'activity' must be a non-empty string, not {activity!r}")
    if "timestamp" not in event or event["timestamp"] is None:
        raise BadEvent(MISSING, f"case {case_id!r}: no 'timestamp'")
    text = event["timestamp"]
    try:
        if not isinstance(text, str):
            raise ValueError
        stamp = datetime.fromisoformat(text.strip())
    except ValueError:
        raise BadEvent(BAD_FIELD, f"'timestamp' is no ISO 8601 time: {text!r}") from None
    stamp = stamp.replace(tzinfo=UTC) if stamp.tzinfo is None else stamp.astimezone(UTC)
    raw = event.get("attributes") or {}
    if not isinstance(raw, dict):
        raise BadEvent(BAD_FIELD, f"'attributes' must be an object, not {raw!r}")
    attributes: dict[str, str | None] = {}
    for name, value in raw.items():
        if value is None or isinstance(value, str):
            attributes[name] = value
        elif isinstance(value, bool):
            attributes[name] = "true" if value else "false"
        elif isinstance(value, int | float):
            attributes[name] = str(value)
        else:
            raise BadEvent(BAD_FIELD, f"attribute {name!r}: a value, not {value!r}")
    return case_id, activity, stamp, attributes, end


# -------------------------------------------------------------------- the loop
@dataclass
class StreamSummary:
    """What a stream did: lines read (blank ones not counted), output lines, the lines skipped
    by reason, events with an activity the run never saw (not skipped), cases ended, cases
    still open, whether it was interrupted, seconds."""

    lines: int = 0
    written: int = 0
    skipped: Counter = field(default_factory=Counter)
    unknown_activity: int = 0
    ended: int = 0
    open: int = 0
    interrupted: bool = False
    seconds: float = 0.0

    def as_dict(self) -> dict:
        return {
            "lines": self.lines,
            "written": self.written,
            "skipped": sum(self.skipped.values()),
            "skipped_by_reason": dict(sorted(self.skipped.items())),
            "unknown_activity": self.unknown_activity,
            "ended": self.ended,
            "open": self.open,
            "interrupted": self.interrupted,
            "seconds": round(self.seconds, 3),
        }

    def line(self) -> str:
        """The one-line account at the end of a stream."""
        skipped = sum(self.skipped.values())
        reasons = ", ".join(f"{n} {r}" for r, n in sorted(self.skipped.items()))
        return (
            f"{self.lines} lines read, {self.written} predictions written"
            + (f", {skipped} skipped ({reasons})" if skipped else ", none skipped")
            + (
                f", {self.unknown_activity} events with an activity the run never saw "
                "(verdicts only)"
                if self.unknown_activity
                else ""
            )
            + f"; {self.ended} cases ended, {self.open} still open"
            + (" (interrupted)" if self.interrupted else "")
        )


def run_stream(
    monitor: StreamMonitor,
    lines: Iterable[str | bytes],
    write: Callable[[str], None],
    report: Callable[[str], None],
) -> StreamSummary:
    """Feed every line to `monitor`, `write` each output line (JSON, no newline), `report` each
    skipped line and each event of an activity the run never saw (one line naming the input
    line's number and why); stops at the end of `lines` or at an interrupt (Ctrl-C)."""
    summary = StreamSummary()
    start = time.perf_counter()
    try:
        for number, text in enumerate(lines, 1):
            if not text.strip():
                continue
            summary.lines += 1
            try:
                out = monitor.feed_line(text, number)
            except BadEvent as e:
                summary.skipped[e.reason] += 1
                report(f"line {number}: skipped, {e.reason}: {e}")
                continue
            write(json.dumps(out, ensure_ascii=False))
            summary.written += 1
            summary.ended += bool(out["ended"])
            if not monitor.knows(out["activity"]):
                summary.unknown_activity += 1
                report(
                    f"line {number}: {UNKNOWN_ACTIVITY} {out['activity']!r}: the run never saw "
                    f"it; case {out['case_id']!r} goes on with verdicts only, no prediction"
                )
    except KeyboardInterrupt:
        summary.interrupted = True
    summary.open = len(monitor.open)
    summary.seconds = time.perf_counter() - start
    return summary


def read_lines(
    source: str | os.PathLike,
    follow: bool = True,
    until_idle: float | None = None,
    poll: float = 0.05,
) -> Iterator[bytes]:
    """The lines of `source`: `-` is stdin, read to its end (or until no line came for
    `until_idle` seconds); a file is read to its end and, with `follow`, kept being read as it
    grows (a line counted once its newline is written) until `until_idle` seconds pass with
    nothing new (None: until interrupted). A file that shrinks is read again from its start."""
    if os.fspath(source) == "-":
        yield from _stdin_lines(until_idle)
        return
    with open(source, "rb") as f:
        pending = b""
        idle_since = time.monotonic()
        while True:
            chunk = f.readline()
            if chunk:
                pending += chunk
                if pending.endswith(b"\n"):
                    yield pending
                    pending = b""
                idle_since = time.monotonic()
                continue
            if not follow or (
                until_idle is not None and time.monotonic() - idle_since >= until_idle
            ):
                break
            if os.fstat(f.fileno()).st_size < f.tell():  # truncated: start again
                f.seek(0)
                pending = b""
            time.sleep(poll)
        if pending:
            yield pending


def _stdin_lines(until_idle: float | None) -> Iterator[bytes]:
    stream = getattr(sys.stdin, "buffer", sys.stdin)
    done = "" if stream is sys.stdin else b""  # readline's answer at the end
    if until_idle is None:
        yield from iter(stream.readline, done)
        return
    lines: queue.Queue = queue.Queue()

    def pump() -> None:
        for line in iter(stream.readline, done):
            lines.put(line)
        lines.put(None)

    threading.Thread(target=pump, daemon=True).start()
    while True:
        try:
            line = lines.get(timeout=until_idle)
        except queue.Empty:
            return
        if line is None:
            return
        yield line


def summary_path(out: str | os.PathLike) -> Path:
    """The summary JSON written beside a stream's output file: predictions.jsonl ->
    predictions.summary.json."""
    out = Path(out)
    return out.with_name(f"{out.stem}.summary.json")
