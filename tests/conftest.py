"""Shared fixtures: an isolated compile cache per test, and exhaustive trace sets."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest


@pytest.fixture(autouse=True)
def _isolated_cache(tmp_path_factory, monkeypatch) -> Path:
    """Every test gets its own compile cache, so no test sees another's (or the user's) cache."""
    cache = tmp_path_factory.mktemp("cache")
    monkeypatch.setenv("TLEAF_CACHE_DIR", str(cache))
    return cache


def all_traces(atoms, max_len: int, one_hot: bool = False) -> list[list[frozenset[str]]]:
    """Every non-empty trace up to max_len over the atoms (powerset or one-hot letters)."""
    if one_hot:
        letters = [frozenset()] + [frozenset({a}) for a in atoms]
    else:
        letters = [
            frozenset(c) for r in range(len(atoms) + 1) for c in itertools.combinations(atoms, r)
        ]
    return [list(t) for n in range(1, max_len + 1) for t in itertools.product(letters, repeat=n)]
