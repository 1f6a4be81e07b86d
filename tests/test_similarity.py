"""The suffix Damerau-Levenshtein measure against an independent implementation and by hand."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from tleaf_cli.tasks.next_activity.similarity import (
    damerau_levenshtein,
    dl_similarity,
    trace_dl_similarity,
)


def unrestricted_dl(a: tuple[int, ...], b: tuple[int, ...]) -> int:
    """The unrestricted Damerau-Levenshtein distance as the shortest path over edit operations
    (breadth-first search from `a` to `b`): an independent definition, not a dynamic programme.
    Intermediate strings never need symbols outside those of a and b, nor more than
    |a| + |b| of them, so the search is finite."""
    symbols = sorted(set(a) | set(b))
    limit = len(a) + len(b)
    seen = {a}
    frontier = [a]
    for distance in itertools.count():
        if b in seen:
            return distance
        following = []
        for s in frontier:
            for t in _edits(s, symbols, limit):
                if t not in seen:
                    seen.add(t)
                    following.append(t)
        frontier = following


def _edits(s: tuple[int, ...], symbols: list[int], limit: int):
    for i in range(len(s)):
        yield s[:i] + s[i + 1 :]  # deletion
        for x in symbols:
            if x != s[i]:
                yield (*s[:i], x, *s[i + 1 :])  # substitution
        if i + 1 < len(s) and s[i] != s[i + 1]:
            yield (*s[:i], s[i + 1], s[i], *s[i + 2 :])  # adjacent transposition
    if len(s) < limit:
        for i in range(len(s) + 1):
            for x in symbols:
                yield (*s[:i], x, *s[i:])  # insertion


def test_distance_matches_shortest_edit_path_on_random_tuples():
    rng = np.random.default_rng(0)
    for _ in range(150):
        a = tuple(int(x) for x in rng.integers(0, 3, rng.integers(0, 5)))
        b = tuple(int(x) for x in rng.integers(0, 3, rng.integers(0, 5)))
        assert damerau_levenshtein(a, b) == unrestricted_dl(a, b), (a, b)


def test_unrestricted_not_optimal_string_alignment():
    # "CA" -> "AC" -> "ABC": 2 edits, a transposed pair edited further; OSA says 3
    assert damerau_levenshtein((2, 0), (0, 1, 2)) == 2
    assert unrestricted_dl((2, 0), (0, 1, 2)) == 2


@pytest.mark.parametrize(
    ("a", "b", "distance", "similarity"),
    [
        ((), (), 0, 1.0),
        ((), (1, 2), 2, 0.0),
        ((3,), (), 1, 0.0),
        ((1, 2), (2, 1), 1, 0.5),  # a transposition counts 1
        ((1, 2, 3), (1, 2, 3), 0, 1.0),
        ((1, 2, 3, 4), (1, 2, 4), 1, 0.75),
        ((0, 1), (2, 3), 2, 0.0),
    ],
)
def test_edge_cases(a, b, distance, similarity):
    assert damerau_levenshtein(a, b) == distance
    assert damerau_levenshtein(b, a) == distance
    assert dl_similarity(a, b) == pytest.approx(similarity)


def test_similarity_is_one_minus_normalised_distance():
    rng = np.random.default_rng(1)
    for _ in range(100):
        a = tuple(int(x) for x in rng.integers(0, 3, rng.integers(1, 6)))
        b = tuple(int(x) for x in rng.integers(0, 3, rng.integers(0, 5)))
        expected = 1 - unrestricted_dl(a, b) / max(len(a), len(b))
        assert dl_similarity(a, b) == pytest.approx(expected)
        assert 0.0 <= dl_similarity(a, b) <= 1.0


def test_accepts_lists_and_numpy_arrays():
    assert damerau_levenshtein([1, 2, 3], np.array([1, 3, 2])) == 1


def test_trace_similarity_counts_the_prefix_and_the_end():
    # suffix-only: nothing shared; whole trace: prefix (3) and end shared of 5 symbols
    assert dl_similarity([4], [5]) == 0.0
    assert trace_dl_similarity([1, 2, 3], [4], [5]) == pytest.approx(1 - 1 / 5)
    # a predicted suffix that stops early: one deletion over max(3 + 0 + 1, 3 + 1 + 1)
    assert trace_dl_similarity([1, 2, 3], [], [4]) == pytest.approx(1 - 1 / 5)
    assert trace_dl_similarity([], [], []) == 1.0
