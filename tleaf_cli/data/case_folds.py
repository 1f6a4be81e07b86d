"""A cases artifact split anew by the published next-activity and suffix-prediction protocols.

Two protocols (docs/event_logs.md#protocols):

- **kfold** (Rama-Maneiro, Vidal, Lama 2021): scikit-learn's `KFold(n_splits=folds,
  shuffle=True, random_state=seed)` over the cases; fold k's held-out cases are the test split,
  and of its training cases (in the order KFold was given them) the last `val` share is
  validation, `round(len * (1 - val))` train first. Their code gives KFold the case ids sorted
  (integer ids, the log's cases numbered by pandas), so `case_order="id"` sorts them, as integers
  where every id is one.
- **thirds** (Tax et al. 2017; Di Francescomarino et al. 2017): in file order, the first
  `2 * round((cases + 1) / 3)` cases train (their code counts one case more than the log holds,
  and rounds that third), the rest test; of the training cases the last `val` share is
  validation. (Their Keras code took the last 20 % of the training *prefixes* as validation, so
  one case can fall on both sides; here validation is whole cases.)

`split_anew` writes the result as a new cases artifact through the artifact's one writer
(`event_logs.write_case_table`): the same cases, activities, timestamps and activity -> atom map,
only `split` changed; its provenance holds the protocol's settings and the source artifact's own
parameters, its inputs the source's path and SHA-256. `train_share` below 1 keeps only a seeded
draw of the training cases (data/train_share.py), the others split `unused`.
"""

from __future__ import annotations

import os
from collections import Counter
from collections.abc import Sequence
from dataclasses import asdict, replace

import numpy as np

from tleaf_cli.data.artifacts import check_targets, describe_inputs
from tleaf_cli.data.event_logs import read_cases, write_case_table
from tleaf_cli.data.train_share import keep_train_share
from tleaf_cli.errors import SettingError
from tleaf_cli.settings.event_logs import FoldSettings


def id_order(ids: Sequence[str]) -> list[str]:
    """`ids` sorted: as integers where every id is a decimal integer, else as text."""
    if all(i.strip().lstrip("+-").isdigit() for i in ids):
        return sorted(ids, key=int)
    return sorted(ids)


def kfold_splits(
    ids: Sequence[str], folds: int, fold: int, seed: int, val: float
) -> dict[str, str]:
    """id -> train/val/test for fold `fold` of `KFold(folds, shuffle=True, random_state=seed)`
    over `ids` in the order given: the fold's held-out ids test, the last `val` share of its
    training ids (in the order given) val, the rest train."""
    from sklearn.model_selection import KFold

    if not 2 <= folds <= len(ids):
        raise SettingError("folds", f"must be 2 to the {len(ids)} cases, not {folds}")
    if not 0 <= fold < folds:
        raise SettingError("fold", f"must be 0 to {folds - 1}, not {fold}")
    splitter = KFold(n_splits=folds, shuffle=True, random_state=seed)
    train, test = list(splitter.split(np.arange(len(ids))))[fold]
    split_of = {ids[i]: "test" for i in test}
    split_of.update(_train_then_val([ids[i] for i in train], val))
    return split_of


def thirds_splits(ids: Sequence[str], val: float) -> dict[str, str]:
    """id -> train/val/test as Tax et al.'s code splits a log (in the order given): the first
    `2 * round((len(ids) + 1) / 3)` ids for training, the last `val` share of them val, the rest
    test."""
    per_third = round((len(ids) + 1) / 3)  # their case count is one more than the log's
    cut = min(2 * per_third, len(ids))
    split_of = {case: "test" for case in ids[cut:]}
    split_of.update(_train_then_val(list(ids[:cut]), val))
    return split_of


def _train_then_val(ids: list[str], val: float) -> dict[str, str]:
    """The first `round(len(ids) * (1 - val))` ids train, the rest val (as Rama-Maneiro et
    al.'s code rounds it)."""
    keep = round(len(ids) * (1 - val))
    return {case: "train" if rank < keep else "val" for rank, case in enumerate(ids)}


def splits_for(ids: Sequence[str], settings: FoldSettings) -> dict[str, str]:
    """id -> split under `settings` (ids in the artifact's order)."""
    settings.check()
    if settings.protocol == "thirds":
        return thirds_splits(ids, settings.val)
    ordered = id_order(ids) if settings.case_order == "id" else list(ids)
    assert settings.fold is not None  # check() refuses kfold without a fold
    return kfold_splits(ordered, settings.folds, settings.fold, settings.seed, settings.val)


def split_anew(
    cases_path: str | os.PathLike, out: str | os.PathLike, settings: FoldSettings
) -> Counter:
    """Write the cases of `cases_path` to `out` with the splits of `settings`, atomically; the
    number of cases per split. `out` may not be the input (refused before anything is read)."""
    settings.check()
    check_targets([cases_path], [out])
    source = read_cases(cases_path)
    ids = [case.case_id for case in source.cases]
    if settings.protocol == "kfold" and settings.folds > len(ids):
        raise SettingError(
            "folds", f"must be at most the {len(ids)} cases of {cases_path}, not {settings.folds}"
        )
    split_of = splits_for(ids, settings)
    if "train" not in split_of.values():
        raise SettingError("val", f"leaves no train case of the {len(ids)} in {cases_path}")
    split_of = keep_train_share(split_of, ids, settings.train_share, settings.share_seed)
    rows = [replace(case, split=split_of[case.case_id]) for case in source.cases]
    params = {**asdict(settings), "source": source.params}
    inputs = describe_inputs([cases_path])
    write_case_table(rows, source.activity_atoms, out, params, inputs)
    return Counter(split_of[c] for c in ids)
