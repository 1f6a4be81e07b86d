"""CaptainCook4D's recordings (people cooking recipes, every step annotated) as `Cases` of
`Recording`s, and as a `recordings` artifact: one row per recording, its steps in time order.

Read by `CaptainCookReader` (the dataset reader interface of data/case_readers.py) from the
annotation files as the dataset ships them (github.com/CaptainCook4D/annotations,
`annotation_json/`):

- `complete_step_annotations.json` (required): {recording_id: {activity_id, activity_name,
  person_id, environment, steps: [{step_id, start_time, end_time, description, has_errors}]}};
- `error_annotations.json`: [{recording_id, is_error, step_annotations: [{step_id,
  errors: [{tag, description}]}]}], which gives each step's error categories (the tags:
  Preparation Error, Measurement Error, Order Error, Timing Error, Technique Error, Temperature
  Error, Missing Step, Other) and the recording's `is_error`;
- `activity_idx_step_idx.json`: {activity_id: [step ids]}: the recipes, and each one's steps;
- a split file (`data_splits/recordings_data_split_combined.json`, given separately):
  {split: [recording ids]}; a recording in no split gets split "none".

The last two annotation files are read where they are: a folder without one is still read, but
the file is named in `Cases.params["missing_files"]` (and read-recordings warns): without
error_annotations.json every recording's error categories are empty and `has_errors` comes from
the steps' own flags; without activity_idx_step_idx.json no step id or activity id is checked.

A recording is a `Case` whose activities are its steps' descriptions, atoms the steps' atoms
(`step_atom`, as the task graphs' rules name them) and timestamps the steps' start times; a
recording has no wall-clock time, so these are its seconds from the video's start counted from
1970-01-01 UTC (time gaps read true). A step annotated with negative times (-1: the person
skipped it) is not in the order: its id is kept in `skipped_step_ids`. A step without numeric
times, with an unknown or non-integer step id, a recording without steps or recipe, or of an
activity_id that is not one of the recipes is skipped and counted (the first few named), as are
the split file's ids that no recording has. Steps are sorted by start time (ties keep file
order).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, fields
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pyarrow as pa

from tleaf_cli.data.activity_names import activity_atom
from tleaf_cli.data.artifacts import describe_inputs, read_artifact, read_json_file, write_artifact
from tleaf_cli.data.case_readers import Progress
from tleaf_cli.data.cases import Case, Cases, source_path
from tleaf_cli.data.skip_report import SkipReport
from tleaf_cli.errors import InputError

KIND = "recordings"
SCHEMA_VERSION = 1
STEPS_FILE = "complete_step_annotations.json"
ERRORS_FILE = "error_annotations.json"
RECIPE_STEPS_FILE = "activity_idx_step_idx.json"
NO_SPLIT = "none"
_START = datetime(1970, 1, 1, tzinfo=UTC)  # a recording's second 0, as a timestamp


def step_atom(description: str) -> str:
    """A step's atom: its description's words, lower case, joined by _ (`activity_atom`), so
    "Coat -Coat a 6-oz. ramekin cup" and "Coat-Coat a 6-oz. ramekin cup" meet; task graphs
    (knowledge/task_graphs.py) name their steps the same way."""
    return activity_atom(description)


def recipe_key(activity_name: str) -> str:
    """The recipe's short name, as its task graph file is named: "Microwave Egg Sandwich" ->
    "microwaveeggsandwich"."""
    return re.sub(r"[^a-z0-9]", "", activity_name.lower())


@dataclass(frozen=True)
class Recording(Case):
    """One recording: a `Case` of its steps (activities: their descriptions), and its own
    fields, each a column of the `recordings` artifact (docs/procedures.md)."""

    activity_id: int
    activity_name: str
    recipe: str
    step_ids: tuple[int, ...]
    start_s: tuple[float, ...]
    end_s: tuple[float, ...]
    step_has_error: tuple[bool, ...]
    step_error_categories: tuple[tuple[str, ...], ...]
    skipped_step_ids: tuple[int, ...]
    has_errors: bool
    error_categories: tuple[str, ...]

    @property
    def recording_id(self) -> str:
        return self.case_id

    @property
    def step_descriptions(self) -> tuple[str, ...]:
        return self.activities

    @classmethod
    def of(cls, **columns: Any) -> Recording:
        """A recording from the artifact's columns (`recording_id`, `step_descriptions`, ...;
        timestamps from `start_s`)."""
        columns = dict(columns)
        steps = tuple(columns.pop("step_descriptions"))
        start = tuple(float(s) for s in columns.pop("start_s"))
        return cls(
            case_id=str(columns.pop("recording_id")),
            activities=steps,
            atoms=tuple(columns.pop("atoms")),
            timestamps=tuple(_START + timedelta(seconds=s) for s in start),
            split=columns.pop("split"),
            start_s=start,
            step_error_categories=tuple(tuple(c) for c in columns.pop("step_error_categories")),
            **{k: tuple(v) if isinstance(v, list) else v for k, v in columns.items()},
        )

    def row(self) -> dict[str, Any]:
        """The artifact's columns of this recording (lists, as the artifact's rows read)."""
        own = {f.name: getattr(self, f.name) for f in fields(self)}
        own.update(recording_id=self.case_id, step_descriptions=self.activities)
        return {c: _listed(own[c]) for c in _TYPES}


def _listed(value: Any) -> Any:
    """Tuples (nested too) as lists."""
    return [_listed(v) for v in value] if isinstance(value, tuple) else value


_TYPES = {
    "recording_id": pa.string(),
    "activity_id": pa.int64(),
    "activity_name": pa.string(),
    "recipe": pa.string(),
    "step_ids": pa.list_(pa.int64()),
    "step_descriptions": pa.list_(pa.string()),
    "atoms": pa.list_(pa.string()),
    "start_s": pa.list_(pa.float64()),
    "end_s": pa.list_(pa.float64()),
    "step_has_error": pa.list_(pa.bool_()),
    "step_error_categories": pa.list_(pa.list_(pa.string())),
    "skipped_step_ids": pa.list_(pa.int64()),
    "has_errors": pa.bool_(),
    "error_categories": pa.list_(pa.string()),
    "split": pa.string(),
}


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float) or value != value:
        return None
    return float(value)


def read_splits(path: str | os.PathLike) -> dict[str, str]:
    """recording id -> split from a {split: [ids]} file; InputError for an id in two splits."""
    path = Path(path)
    data = read_json_file(path)
    if not isinstance(data, dict) or not all(isinstance(v, list) for v in data.values()):
        raise InputError(f"{path}: expected an object {{split: [recording ids]}}")
    split_of: dict[str, str] = {}
    for split, ids in data.items():
        for rid in map(str, ids):
            if split_of.get(rid, split) != split:
                raise InputError(f"{path}: recording {rid} is in '{split_of[rid]}' and '{split}'")
            split_of[rid] = split
    return split_of


def _step_errors(path: Path, data: Any) -> tuple[dict[tuple[str, int], list[str]], dict[str, bool]]:
    """(recording, step id) -> error tags, and recording -> is_error, from error_annotations."""
    if not isinstance(data, list):
        raise InputError(f"{path}: expected a list of recordings")
    tags: dict[tuple[str, int], list[str]] = {}
    is_error: dict[str, bool] = {}
    for k, rec in enumerate(data):
        if not isinstance(rec, dict) or "recording_id" not in rec:
            raise InputError(f"{path}: entry {k} has no recording_id")
        rid = str(rec["recording_id"])
        if "is_error" in rec:
            is_error[rid] = bool(rec["is_error"])
        for step in rec.get("step_annotations") or []:
            if isinstance(step, dict) and isinstance(step.get("step_id"), int):
                found = [str(e.get("tag")) for e in step.get("errors") or [] if isinstance(e, dict)]
                tags.setdefault((rid, step["step_id"]), []).extend(found)
    return tags, is_error


def _recipe_steps(path: Path) -> dict[str, set[int]]:
    """activity id -> its step ids, from activity_idx_step_idx.json."""
    data = read_json_file(path)
    try:
        return {str(k): {int(s) for s in v} for k, v in data.items()}
    except (AttributeError, TypeError, ValueError):
        raise InputError(f"{path}: expected {{activity_id: [step ids]}}") from None


@dataclass
class _Annotations:
    """What the optional annotation files say (empty where a file is missing)."""

    tags: dict[tuple[str, int], list[str]]
    is_error: dict[str, bool]
    known: dict[str, set[int]] | None  # activity id -> step ids; None: not checked


class CaptainCookReader:
    """CaptainCook4D's annotation folder as `Cases` of `Recording`s (a `CaseReader`): `read`
    the folder (and the split file, if given), `write` the `recordings` artifact."""

    def __init__(self, folder: str | os.PathLike, splits: str | os.PathLike | None = None) -> None:
        self.folder = Path(source_path(folder, "CaptainCook4D's annotation folder"))
        self.splits = None if splits is None else Path(splits)

    def read(self, progress: Progress | None = None) -> Cases[Recording]:
        """The folder's recordings (see the module docstring); progress by recording."""
        folder = self.folder
        if not folder.is_dir():
            raise InputError(f"{folder}: not a folder (the dataset's annotation_json/)")
        steps_path = folder / STEPS_FILE
        data = read_json_file(steps_path)
        if not isinstance(data, dict):
            raise InputError(f"{steps_path}: expected an object {{recording_id: recording}}")
        inputs, missing = [steps_path], []
        notes = _Annotations({}, {}, None)
        if (folder / ERRORS_FILE).exists():
            notes.tags, notes.is_error = _step_errors(
                folder / ERRORS_FILE, read_json_file(folder / ERRORS_FILE)
            )
            inputs.append(folder / ERRORS_FILE)
        else:
            missing.append(ERRORS_FILE)
        if (folder / RECIPE_STEPS_FILE).exists():
            notes.known = _recipe_steps(folder / RECIPE_STEPS_FILE)
            inputs.append(folder / RECIPE_STEPS_FILE)
        else:
            missing.append(RECIPE_STEPS_FILE)
        split_of: dict[str, str] = {}
        if self.splits is not None:
            split_of = read_splits(self.splits)
            inputs.append(self.splits)
        skips = SkipReport()
        recordings: list[Recording] = []
        for k, (key, rec) in enumerate(data.items()):
            found = _recording(str(key), rec, notes, split_of, skips)
            if found is not None:
                recordings.append(found)
            if progress is not None:
                progress(k + 1, len(data))
        read = {r.case_id for r in recordings}
        for rid in split_of:
            if rid not in read:
                skips.skip("split ids without a recording", rid)
        atoms = {a: t for r in recordings for a, t in zip(r.activities, r.atoms, strict=True)}
        params = {"folder": str(folder), "missing_files": missing}
        return Cases(recordings, atoms, str(folder), params, skips, inputs)

    def write(self, cases: Cases[Recording], out: str | os.PathLike) -> None:
        """The `recordings` artifact of `cases` (`write_recordings`)."""
        write_recordings(cases, out)


def read_recordings(
    folder: str | os.PathLike, splits: str | os.PathLike | None = None
) -> Cases[Recording]:
    """The recordings of the annotation folder `folder` (`CaptainCookReader.read`)."""
    return CaptainCookReader(folder, splits).read()


def _recording(
    key: str, rec: Any, notes: _Annotations, split_of: dict[str, str], skips: SkipReport
) -> Recording | None:
    if not isinstance(rec, dict) or not isinstance(rec.get("steps"), list) or not rec["steps"]:
        skips.skip("recordings without steps", key)
        return None
    rid = str(rec.get("recording_id", key))
    name = rec.get("activity_name")
    if not isinstance(name, str) or not recipe_key(name) or "activity_id" not in rec:
        skips.skip("recordings without recipe", rid)
        return None
    activity = rec["activity_id"]
    if not _whole(activity) or (notes.known is not None and str(activity) not in notes.known):
        skips.skip("recordings with an unknown activity_id", f"{rid} (activity_id {activity!r})")
        return None
    allowed = notes.known.get(str(activity)) if notes.known is not None else None
    done: list[tuple[float, float, int, str, bool]] = []
    skipped_ids: list[int] = []
    for k, step in enumerate(rec["steps"]):
        where = f"{rid} step {k}"
        sid = step.get("step_id") if isinstance(step, dict) else None
        if not _whole(sid):
            skips.skip("steps without an integer step_id", where)
            continue
        if allowed is not None and sid not in allowed:
            skips.skip("steps with an unknown step_id", f"{where} (id {sid})")
            continue
        start, end = _number(step.get("start_time")), _number(step.get("end_time"))
        if start is None or end is None:
            skips.skip("steps without times", f"{where} (id {sid})")
            continue
        if start < 0 or end < 0:
            skipped_ids.append(sid)
            continue
        done.append(
            (start, end, sid, str(step.get("description", "")), bool(step.get("has_errors")))
        )
    done.sort(key=lambda s: s[0])  # stable: ties keep file order
    step_tags = [sorted(set(notes.tags.get((rid, sid), []))) for _, _, sid, _, _ in done]
    all_tags = {t for (r, _), ts in notes.tags.items() if r == rid for t in ts}
    flags = [err or bool(ts) for (*_, err), ts in zip(done, step_tags, strict=True)]
    return Recording.of(
        recording_id=rid,
        activity_id=int(activity),
        activity_name=name,
        recipe=recipe_key(name),
        step_ids=[s[2] for s in done],
        step_descriptions=[s[3] for s in done],
        atoms=[step_atom(s[3]) for s in done],
        start_s=[s[0] for s in done],
        end_s=[s[1] for s in done],
        step_has_error=flags,
        step_error_categories=step_tags,
        skipped_step_ids=skipped_ids,
        has_errors=notes.is_error.get(rid, any(flags) or bool(all_tags)),
        error_categories=sorted(all_tags),
        split=split_of.get(rid, NO_SPLIT),
    )


def _whole(value: Any) -> bool:
    """An integer, not a bool (JSON's true is no id)."""
    return isinstance(value, int) and not isinstance(value, bool)


def write_recordings(cases: Cases[Recording], out: str | os.PathLike) -> None:
    """Write the `recordings` artifact atomically, with what was skipped and which annotation
    files were missing in its provenance."""
    if not cases.cases:
        raise InputError(f"{cases.path}: no recordings to write ({cases.skips.text()} skipped)")
    rows = [r.row() for r in cases.cases]
    table = pa.table({c: pa.array([r[c] for r in rows], t) for c, t in _TYPES.items()})
    params = {
        "folder": cases.path,
        **cases.skips.params(),
        "splits": cases.split_counts(),
        "missing_files": list(cases.params.get("missing_files", [])),
    }
    inputs = describe_inputs(cases.inputs)
    write_artifact(table, out, kind=KIND, schema=SCHEMA_VERSION, params=params, inputs=inputs)


def load_recordings(path: str | os.PathLike) -> Cases[Recording]:
    """A `recordings` artifact as `Cases` of `Recording`s, in file order."""
    table, prov = read_artifact(source_path(path, "a recordings artifact"), KIND, SCHEMA_VERSION)
    recordings = [Recording.of(**row) for row in table.to_pylist()]
    atoms = {a: t for r in recordings for a, t in zip(r.activities, r.atoms, strict=True)}
    return Cases(recordings, atoms, str(path), prov.params, SkipReport.from_params(prov.params))
