"""Settings of `tleaf read-log`: which attributes (XES) or columns (CSV) of an event log hold the
case, the activity and the timestamp, which lifecycle events count, and how cases are split.
Pure Python: the command line builds read-log's options from this module.
"""

from __future__ import annotations

from dataclasses import dataclass

from tleaf_cli.errors import SettingError
from tleaf_cli.settings import check_values, setting
from tleaf_cli.settings.data import SEED_HELP, fractions

SPLIT_ORDERS = ("random", "file")

# The header names tried, in this order, for a CSV log's columns when none is given: the XES keys
# as pm4py writes them, then the names of the published next-activity benchmarks' CSVs.
CASE_COLUMNS = ("case:concept:name", "CaseID", "Case ID", "case_id", "case")
ACTIVITY_COLUMNS = ("concept:name", "ActivityID", "Activity", "activity")
TIMESTAMP_COLUMNS = ("time:timestamp", "CompleteTimestamp", "Complete Timestamp", "timestamp")
# The XES attributes read by default: the case id on the trace, activity and time on the event.
XES_CASE_KEY = "concept:name"
XES_ACTIVITY_KEY = "concept:name"
XES_TIMESTAMP_KEY = "time:timestamp"


@dataclass(frozen=True)
class LogSettings:
    """How `read_log` reads an event log and splits its cases."""

    case_key: str | None = setting(
        None,
        "The trace attribute (XES) or column (CSV) holding the case id.",
        auto=f"XES: {XES_CASE_KEY}; CSV: the first of {', '.join(CASE_COLUMNS)} in the header",
    )
    activity_key: str | None = setting(
        None,
        "The event attribute (XES) or column (CSV) holding the activity.",
        auto=f"XES: {XES_ACTIVITY_KEY}; CSV: the first of {', '.join(ACTIVITY_COLUMNS)}",
    )
    timestamp_key: str | None = setting(
        None,
        "The event attribute (XES) or column (CSV) holding the timestamp (ISO 8601; "
        "without a zone read as UTC).",
        auto=f"XES: {XES_TIMESTAMP_KEY}; CSV: the first of {', '.join(TIMESTAMP_COLUMNS)}",
    )
    lifecycle: str = setting(
        "auto",
        "Which events count by their lifecycle:transition (events without one always do): "
        "auto: only 'complete' ones if any event of the log is 'complete', else all (logs that "
        "keep a status there); all: every event; another value: only events of that transition.",
    )
    split: tuple[float, float, float] = setting(
        (0.8, 0.1, 0.1),
        "train,val,test fractions of the cases.",
        parse=fractions,
    )
    split_order: str = setting(
        "random",
        "random: cases drawn by --seed; file: the first fractions of cases in file order "
        "(the protocol of suffix-prediction papers: the first 2/3 train).",
        choices=SPLIT_ORDERS,
    )
    seed: int = setting(0, SEED_HELP)

    def check(self) -> None:
        check_values(self)
        if len(self.split) != 3 or min(self.split) < 0 or abs(sum(self.split) - 1) > 1e-6:
            raise SettingError(
                "split", f"must be three non-negative fractions summing to 1, not {self.split}"
            )
        for name in ("case_key", "activity_key", "timestamp_key", "lifecycle"):
            if getattr(self, name) == "":
                raise SettingError(name, "must not be empty")
