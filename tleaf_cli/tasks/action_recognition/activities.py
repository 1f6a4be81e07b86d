"""Labelled activity videos: one row per (video, step) with an action, an ingredient and a feature.

The format (docs/activities.md) is what `tleaf gen-activities` writes for its **synthetic** data
and what real data (e.g. Tasty Videos with per-segment ResNet features) is expected in: Parquet
with `video_id`, `step`, `action`, `ingredient`, `feature` (a list of numbers, the same length on
every row) and optionally `split` (train|val|test|unlabelled). Rows of a video are together, steps
consecutive. `read_activities` checks all of that and names the first offending row.

Each step's label is the atom `action_ingredient` of the knowledge base (docs/knowledge.md), so
names must make valid, unambiguous LTLf atoms: actions `[a-z][a-z0-9]*` (no `_`, so the atom
splits at its first `_`; not starting with `true`, `false` or `last`, which ltlf2dfa's grammar
reads as constants), ingredients `[a-z0-9_]+`. Pure numpy/pyarrow: no torch here.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from tleaf_cli.data.artifacts import PREFIX, read_artifact
from tleaf_cli.data.traces import SPLITS, assign_splits
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.base import atom

KIND = "activities"
SCHEMA_VERSION = 1
REQUIRED = ("video_id", "step", "action", "ingredient", "feature")
LABELS = ("action", "ingredient")  # optional with `labels=False`
NO_LABEL = -1  # a Video's index where a step has no label (read with `labels=False`)
# Videos whose labels training never reads: the logic loss (which needs none) may use them.
UNLABELLED = "unlabelled"
ACTIVITY_SPLITS = (*SPLITS, UNLABELLED)
# Used when a file has no split column: train, val, test fractions of the videos.
DEFAULT_FRACTIONS = (0.6, 0.2, 0.2)

_ACTION = re.compile(r"[a-z][a-z0-9]*")
_INGREDIENT = re.compile(r"[a-z0-9_]+")
_RESERVED = ("true", "false", "last")  # ltlf2dfa reads these prefixes as constants


def name_problem(name: str, role: str) -> str | None:
    """Why `name` cannot be an action / ingredient name (`role`), or None when it can."""
    pattern = _ACTION if role == "action" else _INGREDIENT
    if not pattern.fullmatch(name):
        allowed = "[a-z][a-z0-9]* (no '_')" if role == "action" else "[a-z0-9_]+"
        return f"{role} '{name}' is not a valid name: expected {allowed}"
    if role == "action" and name.startswith(_RESERVED):
        return f"action '{name}' starts with {'/'.join(_RESERVED)}, which LTLf reads as a constant"
    return None


@dataclass(frozen=True)
class Video:
    """One video: per-step class indices into the vocabularies, and features [T, D]."""

    video_id: str
    split: str
    actions: np.ndarray  # int64 [T], indices into Activities.actions
    ingredients: np.ndarray  # int64 [T], indices into Activities.ingredients
    features: np.ndarray  # float32 [T, D]
    first_step: int = 0  # the file's step number of the first step

    def __len__(self) -> int:
        return len(self.features)


@dataclass
class Activities:
    """A loaded activities file: videos in file order, sorted vocabularies, provenance params."""

    videos: list[Video]
    actions: tuple[str, ...]
    ingredients: tuple[str, ...]
    path: str
    params: dict[str, Any] = field(default_factory=dict)  # tleaf.params; {} for plain Parquet

    @property
    def feature_dim(self) -> int:
        return int(self.videos[0].features.shape[1])

    def atom(self, action: int | str, ingredient: int | str) -> str:
        """`action_ingredient`, from names or from vocabulary indices."""
        a = self.actions[action] if isinstance(action, int | np.integer) else action
        i = self.ingredients[ingredient] if isinstance(ingredient, int | np.integer) else ingredient
        return atom(a, i)

    def pairs(self, video: Video) -> list[tuple[str, str]]:
        """The labelled (action, ingredient) of each step."""
        return [
            (self.actions[a], self.ingredients[i])
            for a, i in zip(video.actions, video.ingredients, strict=True)
        ]

    def atoms(self, video: Video) -> list[str]:
        """The labelled atom of each step: the video as a one-hot trace."""
        return [atom(a, i) for a, i in self.pairs(video)]

    def split(self, name: str) -> list[Video]:
        return [v for v in self.videos if v.split == name]


def read_activities(
    path: str | os.PathLike,
    fractions: tuple[float, float, float] = DEFAULT_FRACTIONS,
    seed: int = 0,
    labels: bool = True,
) -> Activities:
    """Load and check an activities file; InputError naming the file and row when it is unusable.

    Without a `split` column, videos are assigned to train/val/test by `fractions`, by video
    (never one video in two splits), the same way for the same `seed`. With `labels=False`
    (new videos, features only: `tleaf predict`) the `action` and `ingredient` columns may be
    missing or have empty cells; a step without a label has index `NO_LABEL` (-1), and the
    vocabularies are those of the labels present (empty without any).
    """
    name = str(path)
    table, params = _read_table(Path(path))
    required = REQUIRED if labels else tuple(c for c in REQUIRED if c not in LABELS)
    missing = [c for c in required if c not in table.column_names]
    if missing:
        optional = "split" if labels else "action, ingredient, split"
        raise InputError(
            f"{name}: missing column(s) {', '.join(missing)}; expected "
            f"{', '.join(required)} and optionally {optional}"
        )
    if table.num_rows == 0:
        raise InputError(f"{name}: no rows")
    present = [c for c in (*required, "split") if c in table.column_names]
    for column in present:
        nulls = pc.is_null(table.column(column)).to_numpy(zero_copy_only=False)
        if nulls.any():
            raise InputError(f"{name}: row {int(nulls.argmax())}: {column} is empty")

    ids = _strings(table, "video_id", name, cast=True)
    steps = _steps(table, name)
    actions = _labels(table, "action", name)
    ingredients = _labels(table, "ingredient", name)
    features = _features(table.column("feature"), name)
    runs = _video_runs(ids, steps, name)
    _check_names(actions, "action", name)
    _check_names(ingredients, "ingredient", name)
    split_of = _splits(table, ids, runs, name, fractions, seed)

    action_vocab = tuple(sorted({a for a in actions if a is not None}))
    ingredient_vocab = tuple(sorted({i for i in ingredients if i is not None}))
    action_idx = _indices(actions, action_vocab)
    ingredient_idx = _indices(ingredients, ingredient_vocab)
    videos = [
        Video(
            video_id=ids[start],
            split=split_of[ids[start]],
            actions=action_idx[start:end],
            ingredients=ingredient_idx[start:end],
            features=features[start:end],
            first_step=int(steps[start]),
        )
        for start, end in runs
    ]
    return Activities(videos, action_vocab, ingredient_vocab, name, params)


def activities_table(
    video_ids: Sequence[str],
    steps: np.ndarray,
    actions: Sequence[str],
    ingredients: Sequence[str],
    features: np.ndarray,
    splits: Sequence[str],
) -> pa.Table:
    """The artifact's columns, one row per (video, step): features float32 [rows, D]."""
    features = np.ascontiguousarray(features, dtype=np.float32)
    dim = features.shape[1]
    return pa.table(
        {
            "video_id": pa.array(video_ids, pa.string()),
            "step": pa.array(steps, pa.int32()),
            "action": pa.array(actions, pa.string()),
            "ingredient": pa.array(ingredients, pa.string()),
            "feature": pa.FixedSizeListArray.from_arrays(pa.array(features.ravel()), dim),
            "split": pa.array(splits, pa.string()),
        }
    )


def _read_table(path: Path) -> tuple[pa.Table, dict[str, Any]]:
    """A tleaf `activities` artifact, or plain Parquet (real data) without tleaf metadata."""
    if not path.exists():
        raise InputError(f"{path}: no such file")
    try:
        meta = pq.read_schema(path).metadata or {}
    except (pa.ArrowException, OSError) as e:
        raise InputError(f"{path}: not a readable Parquet file ({e})") from None
    if f"{PREFIX}kind".encode() in meta:
        table, prov = read_artifact(path, KIND, SCHEMA_VERSION)
        return table, prov.params
    try:
        return pq.read_table(path), {}
    except (pa.ArrowException, OSError) as e:
        raise InputError(f"{path}: not a readable Parquet file ({e})") from None


def _strings(table: pa.Table, column: str, name: str, cast: bool = False) -> list[str]:
    col = table.column(column)
    if cast and (pa.types.is_integer(col.type) or pa.types.is_string(col.type)):
        col = col.cast(pa.string())
    if not (pa.types.is_string(col.type) or pa.types.is_large_string(col.type)):
        raise InputError(f"{name}: column {column} is {col.type}, expected strings")
    return col.to_pylist()


def _labels(table: pa.Table, column: str, name: str) -> list[str | None]:
    """A label column's values (None where a cell is empty), or None per row without it."""
    if column not in table.column_names:
        return [None] * table.num_rows
    col = table.column(column)
    if not (pa.types.is_string(col.type) or pa.types.is_large_string(col.type)) and not (
        pa.types.is_null(col.type)
    ):
        raise InputError(f"{name}: column {column} is {col.type}, expected strings")
    return col.to_pylist()


def _steps(table: pa.Table, name: str) -> np.ndarray:
    col = table.column("step")
    if not pa.types.is_integer(col.type):
        raise InputError(f"{name}: column step is {col.type}, expected integers")
    return col.to_numpy().astype(np.int64)


def _features(col: pa.ChunkedArray, name: str) -> np.ndarray:
    """float32 [rows, D]; the first row with another length or a non-finite value is named."""
    col = col.combine_chunks()
    kind = col.type
    if not (
        pa.types.is_list(kind) or pa.types.is_large_list(kind) or pa.types.is_fixed_size_list(kind)
    ) or not (pa.types.is_integer(kind.value_type) or pa.types.is_floating(kind.value_type)):
        raise InputError(f"{name}: column feature is {kind}, expected a list of numbers per row")
    lengths = pc.list_value_length(col).to_numpy(zero_copy_only=False)
    bad = np.flatnonzero(lengths != lengths[0])
    if len(bad):
        row = int(bad[0])
        raise InputError(
            f"{name}: row {row}: feature has {lengths[row]} values, expected {lengths[0]} "
            "(as on row 0)"
        )
    dim = int(lengths[0])
    if dim == 0:
        raise InputError(f"{name}: row 0: feature is empty")
    values = pc.list_flatten(col).to_numpy(zero_copy_only=False).astype(np.float32)
    features = values.reshape(len(col), dim)
    finite = np.isfinite(features).all(axis=1)
    if not finite.all():
        raise InputError(f"{name}: row {int(np.argmin(finite))}: feature has a NaN or infinity")
    return features


def _video_runs(ids: list[str], steps: np.ndarray, name: str) -> list[tuple[int, int]]:
    """(start, end) row ranges of the videos; rows of a video together, steps consecutive."""
    starts = [0] + [r for r in range(1, len(ids)) if ids[r] != ids[r - 1]]
    seen: dict[str, int] = {}
    for start in starts:
        if ids[start] in seen:
            raise InputError(
                f"{name}: row {start}: video '{ids[start]}' again after other videos "
                f"(its rows start on row {seen[ids[start]]}; rows of a video must be together)"
            )
        seen[ids[start]] = start
    is_start = np.zeros(len(ids), dtype=bool)
    is_start[starts] = True
    jumps = np.flatnonzero(~is_start[1:] & (np.diff(steps) != 1)) + 1
    if len(jumps):
        row = int(jumps[0])
        raise InputError(
            f"{name}: row {row}: video '{ids[row]}' step {steps[row]} follows step "
            f"{steps[row - 1]}; steps of a video must be consecutive (0, 1, 2, ...)"
        )
    return list(zip(starts, [*starts[1:], len(ids)], strict=True))


def _check_names(values: list[str | None], role: str, name: str) -> None:
    for value in dict.fromkeys(values):  # each distinct name once, in file order
        if value is None:  # no label (read with labels=False)
            continue
        problem = name_problem(value, role)
        if problem:
            raise InputError(f"{name}: row {values.index(value)}: {problem}")


def _splits(
    table: pa.Table,
    ids: list[str],
    runs: list[tuple[int, int]],
    name: str,
    fractions: tuple[float, float, float],
    seed: int,
) -> dict[str, str]:
    """video_id -> split: the file's column (checked), else assigned by video."""
    if "split" not in table.column_names:
        return assign_splits([ids[start] for start, _ in runs], fractions, seed)
    splits = _strings(table, "split", name)
    split_of: dict[str, str] = {}
    for start, end in runs:
        for row in range(start, end):
            if splits[row] not in ACTIVITY_SPLITS:
                raise InputError(
                    f"{name}: row {row}: split '{splits[row]}', "
                    f"expected one of {', '.join(ACTIVITY_SPLITS)}"
                )
            if splits[row] != splits[start]:
                raise InputError(
                    f"{name}: row {row}: video '{ids[row]}' is in split '{splits[row]}' here and "
                    f"'{splits[start]}' on row {start}; a video belongs to one split"
                )
        split_of[ids[start]] = splits[start]
    return split_of


def _indices(values: list[str | None], vocabulary: tuple[str, ...]) -> np.ndarray:
    index = {v: k for k, v in enumerate(vocabulary)}
    return np.fromiter(
        (NO_LABEL if v is None else index[v] for v in values), dtype=np.int64, count=len(values)
    )
