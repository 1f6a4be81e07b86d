"""Event logs as artifacts: the `cases` Parquet artifact, written from a read log and read back.

`write_cases` writes a `log_readers.LogReport` (a log read by `read_log`) as one row per case
(docs/event_logs.md):

    case_id     string
    activities  list<string>             the activities' own names, in time order
    atoms       list<string>             each activity as a formula atom (data/activity_names.py)
    timestamps  list<timestamp[us, UTC]>
    split       string                   train | val | test

with the usual provenance (data/artifacts.py), the counts of what was skipped, and the map
activity -> atom under the key `tleaf.activity_atoms`. `read_cases` reads it back. Nothing is
written until the whole log is read, and then atomically.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field
from datetime import datetime
from typing import Any

import pyarrow as pa

from tleaf_cli.data.activity_names import activity_atoms
from tleaf_cli.data.artifacts import PREFIX, describe_inputs, read_artifact, write_artifact
from tleaf_cli.data.log_readers import EXAMPLES, LogReport
from tleaf_cli.data.traces import assign_splits, splits_in_order
from tleaf_cli.errors import InputError
from tleaf_cli.settings.event_logs import LogSettings

KIND = "cases"
SCHEMA_VERSION = 1
ATOMS_KEY = f"{PREFIX}activity_atoms"
TIMESTAMP_TYPE = pa.timestamp("us", tz="UTC")
# A case as written: id, activities, timestamps (µs since 1970 UTC, or UTC datetimes)
Row = tuple[str, Sequence[str], Sequence[int] | Sequence[datetime]]


@dataclass(frozen=True)
class Case:
    """One case: its activities in time order, their UTC timestamps, atoms and split."""

    case_id: str
    activities: tuple[str, ...]
    atoms: tuple[str, ...]
    timestamps: tuple[datetime, ...]
    split: str

    def __len__(self) -> int:
        return len(self.activities)


@dataclass
class Cases:
    """A read `cases` artifact: the cases in file order, the activity -> atom map, params."""

    cases: list[Case]
    activity_atoms: dict[str, str]
    path: str
    params: dict[str, Any] = field(default_factory=dict)


# ---- splitting and writing


def split_cases(ids: list[str], fractions: tuple[float, float, float], order: str, seed: int):
    """case id -> train/val/test: by `fractions`, of cases drawn by `seed` (order 'random') or
    the first cases of the file first (order 'file')."""
    if order == "random":
        return assign_splits(ids, fractions, seed)
    return splits_in_order(ids, fractions)


def cases_table(rows: list[Row], split_of: dict[str, str], atoms: dict[str, str]) -> pa.Table:
    """The artifact's columns, one row per case in the order given."""
    return pa.table(
        {
            "case_id": pa.array([c for c, _, _ in rows], pa.string()),
            "activities": pa.array([a for _, a, _ in rows], pa.list_(pa.string())),
            "atoms": pa.array([[atoms[x] for x in a] for _, a, _ in rows], pa.list_(pa.string())),
            "timestamps": pa.array([t for _, _, t in rows], pa.list_(TIMESTAMP_TYPE)),
            "split": pa.array([split_of[c] for c, _, _ in rows], pa.string()),
        }
    )


def write_cases(report: LogReport, out: str | os.PathLike, settings: LogSettings) -> dict[str, str]:
    """Split the cases and write the `cases` artifact atomically; the activity -> atom map."""
    ids = [c for c, _, _ in report.cases]
    split_of = split_cases(ids, settings.split, settings.split_order, settings.seed)
    atoms = activity_atoms(a for _, acts, _ in report.cases for a in acts)
    params = {
        **asdict(settings),
        "keys": report.keys,
        "skipped": report.skipped,
        "skipped_examples": report.examples,
        "reordered_cases": report.reordered,
        "duplicate_case_ids": {
            "count": len(report.duplicates),
            "examples": report.duplicates[:EXAMPLES],
        },
        "spread_cases": report.spread,
        "events": report.events,
    }
    write_case_rows(report.cases, split_of, atoms, out, params, describe_inputs([report.path]))
    return atoms


def write_case_rows(
    rows: list[Row],
    split_of: dict[str, str],
    atoms: dict[str, str],
    out: str | os.PathLike,
    params: dict[str, Any],
    inputs: list[dict[str, str]],
) -> None:
    """Write cases (id, activities, timestamps) with their splits, their activity -> atom map and
    provenance as the `cases` artifact, atomically: the one writer of the artifact, for a log
    read (`write_cases`) and for a cases artifact split anew (data/case_folds.py)."""
    table = cases_table(rows, split_of, atoms)
    table = table.replace_schema_metadata({ATOMS_KEY.encode(): json.dumps(atoms).encode()})
    write_artifact(table, out, kind=KIND, schema=SCHEMA_VERSION, params=params, inputs=inputs)


def read_cases(path: str | os.PathLike) -> Cases:
    """A `cases` artifact's rows as Cases (file order), with its activity -> atom map."""
    table, prov = read_artifact(path, KIND, SCHEMA_VERSION)
    meta = table.schema.metadata or {}
    try:
        atoms = json.loads(meta[ATOMS_KEY.encode()])
    except (KeyError, ValueError):
        raise InputError(f"{path}: no activity -> atom map in its metadata") from None
    columns = {name: table.column(name).to_pylist() for name in _COLUMNS}
    cases = [
        Case(case, tuple(acts), tuple(ats), tuple(times), split)
        for case, acts, ats, times, split in zip(*columns.values(), strict=True)
    ]
    return Cases(cases, atoms, str(path), prov.params)


_COLUMNS = ("case_id", "activities", "atoms", "timestamps", "split")


def iter_sequences(cases: Cases, split: str | None = None) -> Iterator[tuple[str, ...]]:
    """Each case's atoms, in file order (of one split, if given): the log as atom sequences."""
    for case in cases.cases:
        if split is None or case.split == split:
            yield case.atoms
