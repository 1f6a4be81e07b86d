"""splits_in_order / assign_splits: how ids (formulas, cases) are split train / val / test."""

from __future__ import annotations

from collections import Counter

import pytest

from tleaf_cli.data.traces import assign_splits, splits_in_order


@pytest.mark.parametrize("n", [3, 4, 7, 9])
def test_every_split_with_a_fraction_gets_an_id_where_there_are_enough(n):
    counts = Counter(assign_splits([f"f{i}" for i in range(n)], (0.8, 0.1, 0.1), seed=0).values())
    assert counts["val"] >= 1 and counts["test"] >= 1 and sum(counts.values()) == n


def test_large_sets_split_by_rounding_their_fractions_in_order():
    ids = [f"c{i}" for i in range(1000)]
    split = splits_in_order(ids, (0.7, 0.1, 0.2))
    assert [split[i] for i in ("c0", "c699", "c700", "c799", "c800", "c999")] == [
        "train", "train", "val", "val", "test", "test"
    ]  # fmt: skip


def test_a_zero_fraction_stays_empty_and_too_few_ids_go_first_to_train():
    assert set(splits_in_order(["a", "b", "c"], (1.0, 0.0, 0.0)).values()) == {"train"}
    assert set(splits_in_order(["a", "b"], (0.8, 0.1, 0.1)).values()) == {"train"}
