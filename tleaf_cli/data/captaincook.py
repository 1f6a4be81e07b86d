"""CaptainCook4D's recordings (people cooking recipes, every step annotated) as a `recordings`
artifact: one row per recording, its steps in time order.

Read from the annotation files as the dataset ships them (github.com/CaptainCook4D/annotations,
`annotation_json/`):

- `complete_step_annotations.json` (required): {recording_id: {activity_id, activity_name,
  person_id, environment, steps: [{step_id, start_time, end_time, description, has_errors}]}};
- `error_annotations.json` (optional): [{recording_id, is_error, step_annotations: [{step_id,
  errors: [{tag, description}]}]}], which gives each step's error categories (the tags:
  Preparation Error, Measurement Error, Order Error, Timing Error, Technique Error, Temperature
  Error, Missing Step, Other) and the recording's `is_error`;
- `activity_idx_step_idx.json` (optional): {activity_id: [step ids]}: a step id outside its
  recipe's list is unknown;
- a split file (`data_splits/recordings_data_split_combined.json`, given separately):
  {split: [recording ids]}; a recording in no split gets split "none".

A step annotated with negative times (-1: the person skipped it) is not in the order: its id is
kept in `skipped_step_ids`. A step without numeric times, with an unknown or non-integer step id,
or a recording without steps or recipe is skipped and counted (the first few named), as are the
split file's ids that no recording has. Steps are sorted by start time (ties keep file order).
"""

from __future__ import annotations

import os
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pyarrow as pa

from tleaf_cli.data.activity_names import activity_atom
from tleaf_cli.data.artifacts import describe_inputs, read_artifact, read_json_file, write_artifact
from tleaf_cli.errors import InputError

KIND = "recordings"
SCHEMA_VERSION = 1
STEPS_FILE = "complete_step_annotations.json"
ERRORS_FILE = "error_annotations.json"
RECIPE_STEPS_FILE = "activity_idx_step_idx.json"
NO_SPLIT = "none"
EXAMPLES = 5


def step_atom(description: str) -> str:
    """A step's atom: its description's words, lower case, joined by _ (`activity_atom`), so
    "Coat -Coat a 6-oz. ramekin cup" and "Coat-Coat a 6-oz. ramekin cup" meet; task graphs
    (knowledge/task_graphs.py) name their steps the same way."""
    return activity_atom(description)


def recipe_key(activity_name: str) -> str:
    """The recipe's short name, as its task graph file is named: "Microwave Egg Sandwich" ->
    "microwaveeggsandwich"."""
    return re.sub(r"[^a-z0-9]", "", activity_name.lower())


@dataclass
class RecordingsReport:
    """What `read_recordings` read: the rows, and what it skipped, by kind, with examples."""

    folder: str
    rows: list[dict[str, Any]] = field(default_factory=list)
    skipped: Counter[str] = field(default_factory=Counter)
    examples: dict[str, list[str]] = field(default_factory=dict)
    inputs: list[Path] = field(default_factory=list)

    def skip(self, kind: str, where: str) -> None:
        self.skipped[kind] += 1
        shown = self.examples.setdefault(kind, [])
        if len(shown) < EXAMPLES:
            shown.append(where)

    def skip_text(self) -> str:
        if not self.skipped:
            return "nothing"
        return "; ".join(
            f"{n} {kind} (e.g. {', '.join(self.examples[kind])})"
            for kind, n in sorted(self.skipped.items())
        )

    def split_counts(self) -> dict[str, int]:
        return dict(sorted(Counter(r["split"] for r in self.rows).items()))


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


def read_recordings(
    folder: str | os.PathLike, splits: str | os.PathLike | None = None
) -> RecordingsReport:
    """The recordings of the annotation folder `folder` (see the module docstring)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: not a folder (the dataset's annotation_json/)")
    report = RecordingsReport(str(folder))
    steps_path = folder / STEPS_FILE
    data = read_json_file(steps_path)
    if not isinstance(data, dict):
        raise InputError(f"{steps_path}: expected an object {{recording_id: recording}}")
    report.inputs.append(steps_path)
    tags: dict[tuple[str, int], list[str]] = {}
    is_error: dict[str, bool] = {}
    if (folder / ERRORS_FILE).exists():
        tags, is_error = _step_errors(folder / ERRORS_FILE, read_json_file(folder / ERRORS_FILE))
        report.inputs.append(folder / ERRORS_FILE)
    known: dict[str, set[int]] | None = None
    if (folder / RECIPE_STEPS_FILE).exists():
        recipe_steps = read_json_file(folder / RECIPE_STEPS_FILE)
        if not isinstance(recipe_steps, dict):
            raise InputError(f"{folder / RECIPE_STEPS_FILE}: expected {{activity_id: [step ids]}}")
        known = {str(k): {int(s) for s in v} for k, v in recipe_steps.items()}
        report.inputs.append(folder / RECIPE_STEPS_FILE)
    split_of: dict[str, str] = {}
    if splits is not None:
        split_of = read_splits(splits)
        report.inputs.append(Path(splits))
    for key, rec in data.items():
        row = _recording(str(key), rec, known, tags, is_error, report)
        if row is not None:
            row["split"] = split_of.get(row["recording_id"], NO_SPLIT)
            report.rows.append(row)
    read = {r["recording_id"] for r in report.rows}
    for rid in split_of:
        if rid not in read:
            report.skip("split ids without a recording", rid)
    return report


def _recording(
    key: str,
    rec: Any,
    known: dict[str, set[int]] | None,
    tags: dict[tuple[str, int], list[str]],
    is_error: dict[str, bool],
    report: RecordingsReport,
) -> dict[str, Any] | None:
    if not isinstance(rec, dict) or not isinstance(rec.get("steps"), list) or not rec["steps"]:
        report.skip("recordings without steps", key)
        return None
    rid = str(rec.get("recording_id", key))
    name = rec.get("activity_name")
    if not isinstance(name, str) or not recipe_key(name) or "activity_id" not in rec:
        report.skip("recordings without recipe", rid)
        return None
    allowed = known.get(str(rec["activity_id"])) if known is not None else None
    done: list[tuple[float, float, int, str, bool]] = []
    skipped_ids: list[int] = []
    for k, step in enumerate(rec["steps"]):
        where = f"{rid} step {k}"
        sid = step.get("step_id") if isinstance(step, dict) else None
        if not isinstance(sid, int) or isinstance(sid, bool):
            report.skip("steps without an integer step_id", where)
            continue
        if allowed is not None and sid not in allowed:
            report.skip("steps with an unknown step_id", f"{where} (id {sid})")
            continue
        start, end = _number(step.get("start_time")), _number(step.get("end_time"))
        if start is None or end is None:
            report.skip("steps without times", f"{where} (id {sid})")
            continue
        if start < 0 or end < 0:
            skipped_ids.append(sid)
            continue
        done.append(
            (start, end, sid, str(step.get("description", "")), bool(step.get("has_errors")))
        )
    done.sort(key=lambda s: s[0])  # stable: ties keep file order
    step_tags = [sorted(set(tags.get((rid, sid), []))) for _, _, sid, _, _ in done]
    all_tags = {t for (r, _), ts in tags.items() if r == rid for t in ts}
    flags = [err or bool(ts) for (*_, err), ts in zip(done, step_tags, strict=True)]
    return {
        "recording_id": rid,
        "activity_id": int(rec["activity_id"]),
        "activity_name": name,
        "recipe": recipe_key(name),
        "step_ids": [s[2] for s in done],
        "step_descriptions": [s[3] for s in done],
        "atoms": [step_atom(s[3]) for s in done],
        "start_s": [s[0] for s in done],
        "end_s": [s[1] for s in done],
        "step_has_error": flags,
        "step_error_categories": step_tags,
        "skipped_step_ids": skipped_ids,
        "has_errors": is_error.get(rid, any(flags) or bool(all_tags)),
        "error_categories": sorted(all_tags),
    }


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


def write_recordings(report: RecordingsReport, out: str | os.PathLike) -> None:
    """Write the `recordings` artifact atomically, with what was skipped in its provenance."""
    if not report.rows:
        raise InputError(f"{report.folder}: no recordings to write ({report.skip_text()})")
    table = pa.table({c: pa.array([r[c] for r in report.rows], t) for c, t in _TYPES.items()})
    params = {
        "folder": report.folder,
        "skipped": dict(report.skipped),
        "skipped_examples": report.examples,
        "splits": report.split_counts(),
    }
    inputs = describe_inputs(report.inputs)
    write_artifact(table, out, kind=KIND, schema=SCHEMA_VERSION, params=params, inputs=inputs)


def load_recordings(path: str | os.PathLike) -> list[dict[str, Any]]:
    """A `recordings` artifact's rows, as dicts of the columns, in file order."""
    table, _ = read_artifact(path, KIND, SCHEMA_VERSION)
    return table.to_pylist()
