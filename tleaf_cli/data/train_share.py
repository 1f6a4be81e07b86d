"""A share of a split's training cases, for a learning curve (`split-cases --train-share F`).

`keep_train_share` keeps a seeded draw of `F` of the training cases, at least one: the training
ids, in the order given, are permuted once by `numpy.random.default_rng(seed)` and the first
`max(1, round(F * n))` of that permutation stay `train`. The others get the split `unused`:
they stay in the artifact (its cases, activities and activity -> atom map are the source's), and
no stage reads that split (training reads train and val, mine-declare train and test, eval
test). Validation and test cases are left as they are. For one seed and one list of training
ids the permutation is the same whatever `F`, so a smaller share's cases are among a larger
share's: the points of a learning curve are nested.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from tleaf_cli.errors import SettingError

UNUSED = "unused"  # the split of the training cases a share leaves out


def train_share_size(train_cases: int, share: float) -> int:
    """How many of `train_cases` training cases a share keeps: `round(share * n)`, at least 1
    (none when there are none); SettingError for a share that is not above 0 and at most 1."""
    if (
        isinstance(share, bool)
        or not isinstance(share, int | float)
        or not math.isfinite(share)
        or not 0 < share <= 1
    ):
        raise SettingError("train_share", f"must be a share above 0 and at most 1, not {share!r}")
    if train_cases == 0:
        return 0
    return max(1, min(train_cases, round(share * train_cases)))


def keep_train_share(
    split_of: dict[str, str], ids: Sequence[str], share: float, seed: int
) -> dict[str, str]:
    """`split_of` (id -> split) with only a seeded draw of `share` of its training cases left
    `train`, the other training cases `unused`; `ids` gives the order the draw permutes (every
    id of `split_of`, e.g. the artifact's order). Share 1 returns the splits unchanged."""
    train = [case for case in ids if split_of[case] == "train"]
    keep = train_share_size(len(train), share)
    if keep == len(train):
        return dict(split_of)
    order = np.random.default_rng(seed).permutation(len(train))
    kept = {train[i] for i in order[:keep]}
    return {
        case: (UNUSED if split == "train" and case not in kept else split)
        for case, split in split_of.items()
    }
