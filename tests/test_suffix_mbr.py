"""Suffix prediction by minimum Bayes risk (suffix_mbr.py): the choice is the draw with the
highest mean DL similarity to all the draws, checked against a brute force over the same draws;
where the model's most probable next activity is a loop, the greedy suffix runs to the length
cap and the MBR suffix does not; under the rules every choice is accepted."""

from __future__ import annotations

import numpy as np
import pytest

from tests.test_suffix_search import FORMULAS, Markov, accepted
from tleaf_cli.errors import ArgumentError
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.tasks.next_activity.similarity import dl_similarity
from tleaf_cli.tasks.next_activity.suffix_mbr import mbr_suffixes
from tleaf_cli.tasks.next_activity.suffix_sampling import sample_suffixes
from tleaf_cli.tasks.next_activity.suffix_search import SearchStats, predict_suffixes


@pytest.mark.parametrize("seed", range(4))
def test_the_choice_maximises_the_mean_similarity_to_the_draws(seed) -> None:
    model = Markov(3, seed, end_weight=0.6)
    prefixes = [(0,), (1, 2), (2,), (0, 0, 1)]
    s = 24
    chosen = mbr_suffixes(model, prefixes, 3, samples=s, max_length=8, seed=seed)
    # the same draws, by the sampler itself: prefix i's are rows i*s .. i*s+s-1
    draws = sample_suffixes(
        model, [p for p in prefixes for _ in range(s)], 3, temperature=1.0, max_length=8, seed=seed
    )
    for i, suffix in enumerate(chosen):
        mine = [d.activities for d in draws[i * s : (i + 1) * s]]
        expected = {c: np.mean([dl_similarity(c, d) for d in mine]) for c in set(mine)}
        best = max(expected.values())
        assert suffix.activities in expected
        assert expected[suffix.activities] == pytest.approx(best)


class Loop:
    """After any prefix: a 0.4, b 0.3, the end 0.3. Greedy picks a forever; a case really ends
    within a few events."""

    def __call__(self, rows):
        return np.log(np.tile([0.4, 0.3, 0.3], (len(rows), 1)))


def test_a_loop_the_greedy_suffix_runs_to_the_cap_and_mbr_does_not() -> None:
    greedy = predict_suffixes(Loop(), [(0,)], 2, beam_width=1, max_length=20)[0]
    assert len(greedy.activities) == 20
    stats = SearchStats()
    chosen = mbr_suffixes(Loop(), [(0,)], 2, samples=64, max_length=20, stats=stats)[0]
    assert len(chosen.activities) <= 4
    assert stats.branches >= 64 and stats.model_calls >= 1


@pytest.mark.parametrize("seed", range(4))
def test_under_the_rules_every_choice_is_accepted(seed) -> None:
    rng = np.random.default_rng(seed)
    vocabulary = ["a", "b", "c", "d"]
    picked = rng.choice(len(FORMULAS), size=2, replace=False)
    rules = RuleSet([FORMULAS[i] for i in picked], vocabulary)
    model = Markov(4, seed, end_weight=0.5)
    prefixes = [tuple(rng.integers(0, 4, size=int(rng.integers(1, 4))).tolist()) for _ in range(20)]
    stats = SearchStats()
    found = mbr_suffixes(model, prefixes, 4, rules=rules, samples=8, max_length=6, stats=stats)
    ok = accepted(rules, [p + f.activities for p, f in zip(prefixes, found, strict=True)])
    reachable = np.array([f.found for f in found])
    assert ok[reachable].all()
    assert stats.fallbacks == int((~reachable).sum())  # once per prefix, not per draw


def test_a_sample_count_below_one_is_refused() -> None:
    with pytest.raises(ArgumentError, match="samples"):
        mbr_suffixes(Loop(), [(0,)], 2, samples=0)
