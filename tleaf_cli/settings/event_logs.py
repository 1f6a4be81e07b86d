"""Settings of `tleaf read-log`: which attributes (XES) or columns (CSV) of an event log hold the
case, the activity and the timestamp, which lifecycle events count, and how cases are split.
Pure Python: the command line builds read-log's options from this module.
"""

from __future__ import annotations

import math
from collections.abc import Callable
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


def attribute_names(setting_name: str) -> Callable[[str], tuple[str, ...]]:
    """The parser of a list of attribute names as written on the command line
    ("org:resource,amount"); a SettingError naming `setting_name` for an empty name."""

    def parse(text: str) -> tuple[str, ...]:
        parts = tuple(p.strip() for p in text.split(","))
        if not all(parts):
            raise SettingError(setting_name, f"takes names separated by commas, not '{text}'")
        return parts

    return parse


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
        "(the published protocols' exact splits: tleaf split-cases).",
        choices=SPLIT_ORDERS,
    )
    seed: int = setting(0, SEED_HELP)
    attributes: tuple[str, ...] | None = setting(
        None,
        "Event attributes (XES) or columns (CSV) to keep beside the activity, separated by "
        "commas (org:resource,...): one value per event, empty where an event has none.",
        auto="none",
        parse=attribute_names("attributes"),
    )
    case_attributes: tuple[str, ...] | None = setting(
        None,
        "Case attributes (XES: the trace's; CSV: columns, the first value in a case's rows) to "
        "keep, separated by commas.",
        auto="none",
        parse=attribute_names("case_attributes"),
    )

    @property
    def event_attributes(self) -> tuple[str, ...]:
        """The event attributes to keep (none when none were named)."""
        return self.attributes or ()

    @property
    def trace_attributes(self) -> tuple[str, ...]:
        """The case attributes to keep (none when none were named)."""
        return self.case_attributes or ()

    def check(self) -> None:
        check_values(self)
        split = self.split
        finite = len(split) == 3 and all(math.isfinite(x) and x >= 0 for x in split)
        if not finite or abs(sum(split) - 1) > 1e-6:
            shown = ",".join(str(x) for x in split)
            raise SettingError(
                "split", f"must be three non-negative fractions summing to 1, not {shown}"
            )
        for name in ("case_key", "activity_key", "timestamp_key", "lifecycle"):
            if getattr(self, name) == "":
                raise SettingError(name, "must not be empty")
        for name in ("attributes", "case_attributes"):
            chosen = getattr(self, name)
            if chosen is None:
                continue
            if not isinstance(chosen, tuple) or not all(isinstance(a, str) and a for a in chosen):
                raise SettingError(name, f"is a tuple of attribute names, not {chosen!r}")
            if len(set(chosen)) < len(chosen):
                raise SettingError(name, f"names an attribute twice: {','.join(chosen)}")


# split-cases: the protocols, and the orders k-fold cross-validation may take the cases in.
FOLD_PROTOCOLS = ("kfold", "thirds")
CASE_ORDERS = ("id", "file")


@dataclass(frozen=True)
class FoldSettings:
    """How `split-cases` splits a cases artifact anew: one fold of k-fold cross-validation over
    its case ids (Rama-Maneiro et al.'s protocol), or the first two thirds of its cases against
    the last (Tax et al.'s and Di Francescomarino et al.'s)."""

    protocol: str = setting(
        "kfold",
        "kfold: the cases --fold of --folds held out as test (scikit-learn's KFold, shuffled by "
        "--seed); thirds: the last third of the cases in file order test, as Tax et al.'s code "
        "counts it (2 * round((cases + 1) / 3) cases before it).",
        choices=FOLD_PROTOCOLS,
    )
    folds: int = setting(5, "Folds of the cross-validation (kfold).", min=2)
    fold: int | None = setting(
        None,
        "The fold whose cases are the test split: 0 to --folds minus 1, in KFold's order (kfold).",
        min=0,
        auto="required with kfold",
    )
    seed: int = setting(42, "KFold's random_state: the same seed gives the same folds (kfold).")
    val: float = setting(
        0.2,
        "Share of the training cases that is validation: the last ones, in --case-order (kfold) "
        "or file order (thirds).",
        min=0,
    )
    case_order: str = setting(
        "id",
        "The order KFold takes the cases in (kfold): id: by case id, as integers where every id "
        "is one (Rama-Maneiro et al.'s code sorts the ids); file: as the artifact holds them.",
        choices=CASE_ORDERS,
    )
    train_share: float = setting(
        1.0,
        "Keep only this share of the training cases (0 < F <= 1; at least one case), drawn by "
        "--share-seed; the others get the split 'unused', val and test stay as they are. For "
        "one --share-seed, a smaller share's cases are among a larger one's (a learning curve).",
    )
    share_seed: int = setting(
        0, "The draw of --train-share's cases: the same seed draws the same (nested) cases."
    )

    def check(self) -> None:
        check_values(self)
        if not 0 <= self.val < 1:
            raise SettingError("val", f"must be at least 0 and below 1, not {self.val}")
        share = self.train_share
        if isinstance(share, bool) or not isinstance(share, int | float) or not 0 < share <= 1:
            raise SettingError(
                "train_share", f"must be a share above 0 and at most 1, not {share!r}"
            )
        if self.protocol == "kfold":
            if self.fold is None:
                raise SettingError("fold", f"is required: 0 to {self.folds - 1}")
            if self.fold >= self.folds:
                raise SettingError(
                    "fold", f"must be 0 to {self.folds - 1} (folds {self.folds}), not {self.fold}"
                )
