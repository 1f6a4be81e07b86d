"""Suffix prediction by temperature sampling (suffix_sampling.py): under the rules every drawn
continuation is accepted; without them the first token's frequencies follow the tempered model;
the draws repeat with the seed."""

from __future__ import annotations

import numpy as np
import pytest

from tests.test_suffix_search import FORMULAS, Markov, accepted
from tleaf_cli.errors import ArgumentError
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.tasks.next_activity.suffix_sampling import sample_suffixes
from tleaf_cli.tasks.next_activity.suffix_search import SearchStats


@pytest.mark.parametrize("seed", range(6))
def test_every_continuation_drawn_under_the_rules_is_accepted(seed) -> None:
    rng = np.random.default_rng(seed)
    vocabulary = ["a", "b", "c", "d"]
    picked = rng.choice(len(FORMULAS), size=2, replace=False)
    rules = RuleSet([FORMULAS[i] for i in picked], vocabulary)
    model = Markov(len(vocabulary), seed, end_weight=0.5)
    prefixes = [tuple(rng.integers(0, 4, size=int(rng.integers(1, 4))).tolist()) for _ in range(40)]
    stats = SearchStats()
    found = sample_suffixes(model, prefixes, 4, rules=rules, max_length=6, seed=seed, stats=stats)
    ok = accepted(rules, [p + s.activities for p, s in zip(prefixes, found, strict=True)])
    reachable = [s.found for s in found]
    assert all(ok[reachable]) and all(s.satisfied for s in found if s.found)
    assert stats.fallbacks == len(found) - sum(reachable)
    assert all(len(s.activities) <= 6 for s in found)


def test_the_first_token_follows_the_tempered_model() -> None:
    model = Markov(3, seed=4)
    prefix = (0,)
    draws = sample_suffixes(model, [prefix] * 4000, 3, temperature=0.5, max_length=5, seed=1)
    first = np.array([s.activities[0] if s.activities else 3 for s in draws])
    p = np.exp(model.next(prefix) / 0.5)
    p /= p.sum()
    seen = np.bincount(first, minlength=4) / len(first)
    assert np.abs(seen - p).max() < 0.03, (seen, p)


def test_the_draws_repeat_with_the_seed_and_refuse_a_bad_temperature() -> None:
    model = Markov(3, seed=2)
    one = sample_suffixes(model, [(0,), (1, 2)], 3, seed=7)
    assert one == sample_suffixes(model, [(0,), (1, 2)], 3, seed=7)
    for bad in (0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ArgumentError, match="temperature"):
            sample_suffixes(model, [(0,)], 3, temperature=bad)
