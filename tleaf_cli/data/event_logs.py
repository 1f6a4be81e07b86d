"""Event logs as artifacts: the `cases` Parquet artifact, written from a read log and read back.

`write_cases` writes `Cases` (data/cases.py; a log read by `log_readers.read_log`) as one row per
case (docs/event_logs.md):

    case_id     string
    activities  list<string>             the activities' own names, in time order
    atoms       list<string>             each activity as a formula atom (data/activity_names.py)
    timestamps  list<timestamp[us, UTC]>
    split       string                   train | val | test

with the usual provenance (data/artifacts.py), the counts of what was skipped, and the map
activity -> atom under the key `tleaf.activity_atoms`; and, for each event attribute kept
(`read-log --attributes`), a column `event:<attribute>` (list<string>, one value per event, null
where the event has none), for each case attribute kept a column `case:<attribute>` (string),
their names in order under `tleaf.attributes` (`{"event": [...], "case": [...]}`). Artifacts
written before attributes existed have neither and read as cases without attributes.
`read_cases` reads it back as `Cases`. Nothing is written until the whole log is read, and then
atomically.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Sequence
from dataclasses import asdict, replace
from typing import Any

import pyarrow as pa

from tleaf_cli.data.artifacts import PREFIX, describe_inputs, read_artifact, write_artifact
from tleaf_cli.data.cases import Case, Cases, source_path
from tleaf_cli.data.skip_report import SkipReport
from tleaf_cli.data.traces import assign_splits, splits_in_order
from tleaf_cli.errors import InputError
from tleaf_cli.settings.event_logs import LogSettings

__all__ = ["Case", "Cases", "iter_sequences", "read_cases", "write_case_table", "write_cases"]

KIND = "cases"
SCHEMA_VERSION = 1
ATOMS_KEY = f"{PREFIX}activity_atoms"
ATTRIBUTES_KEY = f"{PREFIX}attributes"
EVENT_PREFIX = "event:"  # an event attribute's column: event:org:resource
CASE_PREFIX = "case:"  # a case attribute's column
TIMESTAMP_TYPE = pa.timestamp("us", tz="UTC")
_COLUMNS = ("case_id", "activities", "atoms", "timestamps", "split")


def split_cases(ids: list[str], fractions: tuple[float, float, float], order: str, seed: int):
    """case id -> train/val/test: by `fractions`, of cases drawn by `seed` (order 'random') or
    the first cases of the file first (order 'file')."""
    if order == "random":
        return assign_splits(ids, fractions, seed)
    return splits_in_order(ids, fractions)


def cases_table(cases: Sequence[Case]) -> pa.Table:
    """The artifact's columns, one row per case in the order given: the fixed ones, then each
    kept event attribute's and case attribute's (the first case's names: every case keeps the
    same ones)."""
    events, kept = attribute_names(cases)
    return pa.table(
        {
            "case_id": pa.array([c.case_id for c in cases], pa.string()),
            "activities": pa.array([c.activities for c in cases], pa.list_(pa.string())),
            "atoms": pa.array([c.atoms for c in cases], pa.list_(pa.string())),
            "timestamps": pa.array([c.timestamps for c in cases], pa.list_(TIMESTAMP_TYPE)),
            "split": pa.array([c.split for c in cases], pa.string()),
            **{
                EVENT_PREFIX + name: pa.array(
                    [c.attributes[name] for c in cases], pa.list_(pa.string())
                )
                for name in events
            },
            **{
                CASE_PREFIX + name: pa.array([c.case_attributes[name] for c in cases], pa.string())
                for name in kept
            },
        }
    )


def attribute_names(cases: Sequence[Case]) -> tuple[list[str], list[str]]:
    """The event and the case attributes the cases keep (the first case's: all keep the same)."""
    if not cases:
        return [], []
    return list(cases[0].attributes), list(cases[0].case_attributes)


def write_cases(cases: Cases, out: str | os.PathLike, settings: LogSettings) -> dict[str, str]:
    """Write a read log's `cases` as the `cases` artifact atomically, split by `settings` (the
    split the reader gave them, when it read with the same settings); the activity -> atom map."""
    settings.check()
    ids = [c.case_id for c in cases.cases]
    split_of = split_cases(ids, settings.split, settings.split_order, settings.seed)
    rows = [
        c if c.split == split_of[c.case_id] else replace(c, split=split_of[c.case_id])
        for c in cases.cases
    ]
    params = {
        **asdict(settings),
        **cases.params,
        **cases.skips.params(),
        "events": cases.events,
    }
    inputs = describe_inputs(cases.inputs or [cases.path])
    write_case_table(rows, cases.activity_atoms, out, params, inputs)
    return cases.activity_atoms


def write_case_table(
    cases: Sequence[Case],
    atoms: dict[str, str],
    out: str | os.PathLike,
    params: dict[str, Any],
    inputs: list[dict[str, str]],
) -> None:
    """Write cases with their splits, their activity -> atom map and provenance as the `cases`
    artifact, atomically: the one writer of the artifact, for a log read (`write_cases`) and for
    a cases artifact split anew (data/case_folds.py)."""
    table = cases_table(cases)
    events, kept = attribute_names(cases)
    meta = {ATOMS_KEY.encode(): json.dumps(atoms).encode()}
    if events or kept:
        meta[ATTRIBUTES_KEY.encode()] = json.dumps({"event": events, "case": kept}).encode()
    table = table.replace_schema_metadata(meta)
    write_artifact(table, out, kind=KIND, schema=SCHEMA_VERSION, params=params, inputs=inputs)


def read_cases(path: str | os.PathLike) -> Cases:
    """A `cases` artifact as `Cases`: `.cases` the cases (file order), `.activity_atoms` its
    activity -> atom map, `.params` its provenance's parameters, `.skips` what reading the log
    skipped. ArgumentTypeError when `path` is not a path, InputError for another artifact."""
    table, prov = read_artifact(source_path(path, "a cases artifact"), KIND, SCHEMA_VERSION)
    meta = table.schema.metadata or {}
    try:
        atoms = json.loads(meta[ATOMS_KEY.encode()])
    except (KeyError, ValueError):
        raise InputError(f"{path}: no activity -> atom map in its metadata") from None
    try:
        kept = json.loads(meta.get(ATTRIBUTES_KEY.encode(), b"{}"))
        events, case_names = list(kept.get("event", [])), list(kept.get("case", []))
        event_values = [table.column(EVENT_PREFIX + n).to_pylist() for n in events]
        case_values = [table.column(CASE_PREFIX + n).to_pylist() for n in case_names]
    except (ValueError, AttributeError, KeyError) as e:
        raise InputError(f"{path}: its attributes do not match its columns ({e})") from None
    columns = {name: table.column(name).to_pylist() for name in _COLUMNS}
    cases = [
        Case(
            case,
            tuple(acts),
            tuple(ats),
            tuple(times),
            split,
            attributes={n: tuple(v[k]) for n, v in zip(events, event_values, strict=True)},
            case_attributes={n: v[k] for n, v in zip(case_names, case_values, strict=True)},
        )
        for k, (case, acts, ats, times, split) in enumerate(zip(*columns.values(), strict=True))
    ]
    return Cases(
        cases,
        atoms,
        str(path),
        prov.params,
        SkipReport.from_params(prov.params),
        attribute_names=tuple(events),
        case_attribute_names=tuple(case_names),
    )


def iter_sequences(cases: Cases, split: str | None = None) -> Iterator[tuple[str, ...]]:
    """Each case's atoms, in file order (of one split, if given): the log as atom sequences."""
    for case in cases.cases:
        if split is None or case.split == split:
            yield case.atoms
