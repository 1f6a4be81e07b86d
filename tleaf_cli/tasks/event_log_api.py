"""The event-log side of the public Python API (`import tleaf_cli as tl`): a log, a Declare or
LTLf knowledge base, and the conformance of every case to every rule, as the commands
`read-log`, and `check-cases` compute them, without files in between.

    cases = tl.read_log("helpdesk.xes.gz", attributes=["org:resource"])   # or a DataFrame
    rules = tl.read_rules("kb.decl", cases)        # its names matched to the log's exactly
    table = tl.check_cases(cases, rules)           # one row per case and rule
    run = tl.load_run("run/", rules="kb.decl")     # a next-activity run (train-task's folder)
    frame = run.predict(cases)                     # tleaf predict's rows, as a DataFrame

`read_log` takes a log file (XES or CSV), a cases artifact, or a pandas DataFrame with pm4py's
column names (`case:concept:name`, `concept:name`, `time:timestamp`, attributes beside them), as
pm4py's `read_xes` returns it. Every argument is checked as the rest of `tl.*` checks them: a
wrong type or value raises `ArgumentTypeError` / `ArgumentError` naming the argument; a file
that cannot be read raises `InputError` naming it.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from tleaf_cli.arguments import given
from tleaf_cli.data.cases import Cases
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.data.log_readers import read_log as read_log_file
from tleaf_cli.errors import ArgumentError, ArgumentTypeError, TleafError
from tleaf_cli.settings.event_logs import LogSettings
from tleaf_cli.settings.next_activity import PredictSettings, prefix_lengths
from tleaf_cli.tasks.case_checks import CaseRule, read_case_rules
from tleaf_cli.tasks.case_checks import check_cases as check_all
from tleaf_cli.tasks.next_activity.evaluate import check_same_log
from tleaf_cli.tasks.next_activity.predict import Predictor
from tleaf_cli.tasks.next_activity.predictions import (
    predict_pairs,
    predictions_table,
    running_prefixes,
)

PM4PY_COLUMNS = ("case:concept:name", "concept:name", "time:timestamp")


def read_log(
    source: str | os.PathLike | Any,
    attributes: Sequence[str] = (),
    case_attributes: Sequence[str] = (),
) -> Cases:
    """The cases of an event log: a path to an XES or CSV log or to a cases artifact
    (`tleaf read-log`'s), or a pandas DataFrame with pm4py's column names. `attributes`: event
    attributes to keep (a rule's MP-Declare conditions read them); `case_attributes`: case
    attributes to keep (a log file's only). Every case is in the "train" split of a log read
    here: split a log with `tleaf read-log` for training."""
    attributes = _names(attributes, "attributes")
    case_attributes = _names(case_attributes, "case_attributes")
    settings = LogSettings(
        attributes=attributes or None,
        case_attributes=case_attributes or None,
        split=(1.0, 0.0, 0.0),
        split_order="file",
    )
    if isinstance(source, str | os.PathLike):
        if str(source).endswith(".parquet"):
            return read_cases(source)
        return read_log_file(source, settings)
    if type(source).__name__ == "DataFrame" and hasattr(source, "to_csv"):
        return _read_frame(source, settings)
    raise ArgumentTypeError(
        "source",
        "expected the path of an XES or CSV log or of a cases artifact, or a pandas "
        f"DataFrame with pm4py's columns {', '.join(PM4PY_COLUMNS)}, not {given(source)}",
    )


def read_rules(path: str | os.PathLike, cases: Cases | None = None) -> list[CaseRule]:
    """The rules of a knowledge base (`.ltl`, `.decl` with MP-Declare conditions, or a formula
    table), each with its name, formula, atoms and conditions; a `.decl`'s activity names
    matched exactly to those of `cases` (`read_log`'s), so that each reads that log's atom."""
    if not isinstance(path, str | os.PathLike):
        raise ArgumentTypeError("path", f"expected the path of a rule file, not {given(path)}")
    if cases is not None and not isinstance(cases, Cases):
        raise ArgumentTypeError("cases", f"expected tl.read_log's cases, not {given(cases)}")
    return read_case_rules(path, None if cases is None else cases.activity_atoms)


def check_cases(cases: Cases, rules: Sequence[CaseRule]) -> Any:
    """Every case of `cases` against every rule of `rules` (`tl.read_rules`), exactly: a pandas
    DataFrame with one row per case and rule, `case_id`, `rule`, `satisfied`, in the cases'
    order and the rules' (as `tleaf check-cases` writes them)."""
    if not isinstance(cases, Cases):
        raise ArgumentTypeError("cases", f"expected tl.read_log's cases, not {given(cases)}")
    if isinstance(rules, str | bytes) or not isinstance(rules, Sequence):
        raise ArgumentTypeError("rules", f"expected tl.read_rules' rules, not {given(rules)}")
    if not rules or not all(isinstance(r, CaseRule) for r in rules):
        raise ArgumentError("rules", "expected one or more rules of tl.read_rules")
    import pandas as pd

    checks = check_all(cases, rules)
    n_rules = len(rules)
    return pd.DataFrame(
        {
            "case_id": [c for c in checks.case_ids for _ in range(n_rules)],
            "rule": [r.name for _ in checks.case_ids for r in rules],
            "satisfied": checks.satisfied.ravel(),
        }
    )


class Run:
    """A trained next-activity run, ready to predict for running cases (`tl.load_run`)."""

    def __init__(self, run_dir: str | os.PathLike, predictor: Predictor) -> None:
        self.path = os.fspath(run_dir)
        self.predictor = predictor

    @property
    def rule_names(self) -> tuple[str, ...]:
        """The rules it watches, in the order of the `rules` column."""
        return self.predictor.rule_names

    def predict(
        self, cases: Cases, prefix_lengths: str | None = None, split: str | None = None
    ) -> Any:
        """`tleaf predict`'s rows for `cases` (`tl.read_log`'s) as a pandas DataFrame, its
        columns docs/monitoring.md's: every case as running, or with `prefix_lengths` ("1-4")
        each case replayed cut at those lengths; `split`: only that split's cases."""
        if not isinstance(cases, Cases):
            raise ArgumentTypeError("cases", f"expected tl.read_log's cases, not {given(cases)}")
        lengths = None
        if prefix_lengths is not None:
            if not isinstance(prefix_lengths, str):
                raise ArgumentTypeError(
                    "prefix_lengths", f"expected text such as '1-4', not {given(prefix_lengths)}"
                )
            lengths = _parsed_lengths(prefix_lengths)
        check_same_log(cases, self.predictor.encoder, self.path)
        chosen = [c for c in cases.cases if split is None or c.split == split]
        if not chosen:
            raise ArgumentError("split", f"no case in the split {split!r}")
        pairs = running_prefixes(chosen, lengths)
        if not pairs:
            raise ArgumentError("prefix_lengths", f"no case reaches the lengths {prefix_lengths}")
        predictions = predict_pairs(self.predictor, pairs)
        return predictions_table(pairs, predictions, replayed=lengths is not None).to_pandas()


def load_run(
    run_dir: str | os.PathLike,
    rules: str | os.PathLike | None = None,
    rule_names: Sequence[str] = (),
    **settings: Any,
) -> Run:
    """A next-activity run folder (`tleaf train-task next-activity`'s) and the rules it watches
    (`rules`, a `.ltl` or `.decl`; default: the run's own knowledge base), with `tleaf
    predict`'s settings as keywords (way="beam", samples=200, top_k=3, ...: PredictSettings)."""
    if not isinstance(run_dir, str | os.PathLike):
        raise ArgumentTypeError("run_dir", f"expected a run folder's path, not {given(run_dir)}")
    if rules is not None and not isinstance(rules, str | os.PathLike):
        raise ArgumentTypeError("rules", f"expected a rule file's path, not {given(rules)}")
    names = _names(rule_names, "rule_names")
    try:
        chosen = PredictSettings(**settings)
    except TypeError as e:
        raise ArgumentError("settings", str(e)) from None
    return Run(run_dir, Predictor.load(run_dir, chosen, rules, names))


def _parsed_lengths(text: str) -> tuple[int, ...]:
    try:
        return prefix_lengths(text)
    except TleafError as e:  # the settings' own error, said as this argument's
        raise ArgumentError("prefix_lengths", str(e)) from None


def _names(value: object, argument: str) -> tuple[str, ...]:
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise ArgumentTypeError(argument, f"expected a list of names, not {given(value)}")
    if not all(isinstance(v, str) and v for v in value):
        raise ArgumentError(argument, f"expected non-empty names, got {list(value)!r}")
    return tuple(value)


def _read_frame(frame: Any, settings: LogSettings) -> Cases:
    """A pm4py-style DataFrame through the CSV reader, so it is read exactly as a log file."""
    missing = [c for c in PM4PY_COLUMNS if c not in frame.columns]
    if missing:
        raise ArgumentError(
            "source",
            f"the DataFrame has no column {missing[0]!r} (pm4py's names: "
            f"{', '.join(PM4PY_COLUMNS)}; it has: {', '.join(map(str, frame.columns[:8]))})",
        )
    with tempfile.TemporaryDirectory(prefix="tleaf-log-") as folder:
        path = Path(folder) / "log.csv"
        frame.to_csv(path, index=False, date_format="%Y-%m-%dT%H:%M:%S.%f%z")
        cases = read_log_file(path, settings)
    cases.path = "<DataFrame>"
    return cases
