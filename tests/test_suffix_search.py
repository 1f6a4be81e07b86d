"""Suffix search under the rules, against brute force over every continuation."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import tleaf_cli as tl
from tleaf_cli.errors import ArgumentError, ArgumentTypeError
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.tasks.next_activity.suffix_search import SearchStats, Suffix, predict_suffixes

FORMULAS = [
    "F a",
    "G(a -> F b)",
    "!b U a",
    "G !c",
    "F(a & X b)",
    "G(b -> X c)",
    "F c",
    "G(c -> !F a)",
]


class Markov:
    """A next-token model: log-probabilities of the activities and the end by the last activity
    and whether the sequence's length is even (so the search is not a fixed-point walk); every
    call and its sequences recorded."""

    def __init__(self, num_activities: int, seed: int, end_weight: float = 1.0) -> None:
        rng = np.random.default_rng(seed)
        weights = np.ones(num_activities + 1)
        weights[-1] = end_weight
        self.table = np.log(rng.dirichlet(weights, size=(num_activities, 2)))
        self.calls: list[list[tuple[int, ...]]] = []

    def __call__(self, rows):
        self.calls.append([tuple(r) for r in rows])
        return np.array([self.table[r[-1], len(r) % 2] for r in rows])

    def next(self, sequence: tuple[int, ...]) -> np.ndarray:
        return self.table[sequence[-1], len(sequence) % 2]


def traces_of(sequences, vocabulary, atoms):
    """Sequences of activity indices as traces of atom sets (an activity outside the formulas'
    atoms is the empty letter): independent of RuleSet.letters."""
    return [[{vocabulary[i]} & set(atoms) for i in s] for s in sequences]


def accepted(rules: RuleSet, sequences) -> np.ndarray:
    return tl.check(rules.dfa, traces_of(sequences, rules.vocabulary, rules.atoms))


def brute_force(model: Markov, prefix, num_activities, max_length, rules):
    """(best score, continuation) over all continuations, and the best accepted one (None when
    none is accepted), by enumeration."""
    scored = []
    for length in range(max_length + 1):
        for suffix in itertools.product(range(num_activities), repeat=length):
            sequence = tuple(prefix)
            score = 0.0
            for a in suffix:
                score += model.next(sequence)[a]
                sequence += (a,)
            score += model.next(sequence)[num_activities]
            scored.append((score, suffix))
    ok = accepted(rules, [tuple(prefix) + s for _, s in scored])
    best = max(scored, key=lambda x: x[0])
    best_accepted = max((x for x, k in zip(scored, ok, strict=True) if k), default=None)
    return best, best_accepted


def random_case(seed: int):
    rng = np.random.default_rng(seed)
    vocabulary = ["a", "b", "c", "d"][: int(rng.integers(3, 5))]
    picked = rng.choice(len(FORMULAS), size=int(rng.integers(1, 3)), replace=False)
    rules = RuleSet([FORMULAS[i] for i in picked], vocabulary)
    prefixes = [
        tuple(int(x) for x in rng.integers(0, len(vocabulary), int(rng.integers(1, 4))))
        for _ in range(4)
    ]
    return rules, prefixes, Markov(len(vocabulary), seed)


@pytest.mark.parametrize("seed", range(30))
def test_wide_beam_is_the_most_probable_accepted_continuation(seed):
    rules, prefixes, model = random_case(seed)
    v, max_length = len(rules.vocabulary), 3
    out = predict_suffixes(
        model, prefixes, v, rules=rules, beam_width=10_000, max_length=max_length
    )
    for prefix, suffix in zip(prefixes, out, strict=True):
        best, best_accepted = brute_force(model, prefix, v, max_length, rules)
        assert suffix.found == (best_accepted is not None)
        assert len(suffix.activities) <= max_length
        assert suffix.satisfied == bool(accepted(rules, [prefix + suffix.activities])[0])
        expected = best_accepted if suffix.found else best
        assert suffix.log_prob == pytest.approx(expected[0])
        assert suffix.activities == expected[1]
        if suffix.found:
            assert suffix.satisfied


@pytest.mark.parametrize("seed", range(20))
def test_parts_of_the_rules_search_as_their_conjunction_with_a_wide_beam(seed):
    """One DFA per formula (rule_parts' parts) instead of their product: pruning by the parts'
    distances is sound, so an exhaustive beam finds the same continuations."""
    rng = np.random.default_rng(500 + seed)
    vocabulary = ["a", "b", "c", "d"][: int(rng.integers(3, 5))]
    picked = [FORMULAS[i] for i in rng.choice(len(FORMULAS), size=3, replace=False)]
    whole = RuleSet(picked, vocabulary)
    parts = [RuleSet(f, vocabulary) for f in picked]
    prefixes = [tuple(int(x) for x in rng.integers(0, len(vocabulary), 2)) for _ in range(4)]
    model = Markov(len(vocabulary), seed)
    kwargs = dict(beam_width=10_000, max_length=3)
    one = predict_suffixes(model, prefixes, len(vocabulary), rules=whole, **kwargs)
    split = predict_suffixes(model, prefixes, len(vocabulary), rules=parts, **kwargs)
    assert split == one


@pytest.mark.parametrize("seed", range(30))
@pytest.mark.parametrize("beam_width", [1, 2])
def test_narrow_beam_found_exactly_when_an_accepted_continuation_exists(seed, beam_width):
    rules, prefixes, model = random_case(100 + seed)
    v, max_length = len(rules.vocabulary), 3
    out = predict_suffixes(
        model, prefixes, v, rules=rules, beam_width=beam_width, max_length=max_length
    )
    for prefix, suffix in zip(prefixes, out, strict=True):
        _, best_accepted = brute_force(model, prefix, v, max_length, rules)
        assert suffix.found == (best_accepted is not None)
        if suffix.found:  # accepted, and its score is that of its tokens
            assert accepted(rules, [prefix + suffix.activities])[0]
            assert suffix.log_prob <= best_accepted[0] + 1e-9
            assert suffix.log_prob == pytest.approx(score_of(model, prefix, suffix, v))
        else:
            assert not suffix.satisfied


def score_of(model: Markov, prefix, suffix: Suffix, v: int) -> float:
    sequence, score = tuple(prefix), 0.0
    for a in suffix.activities:
        score += model.next(sequence)[a]
        sequence += (a,)
    return score + model.next(sequence)[v]


@pytest.mark.parametrize("seed", range(10))
def test_the_model_never_sees_a_dead_branch(seed):
    # "G !c" and "G(b -> X c)" with a model that likes c: most extensions are dead
    vocabulary = ["a", "b", "c", "d"]
    rules = RuleSet(["G !c", "F a"], vocabulary) if seed % 2 else RuleSet("G !b", vocabulary)
    model = Markov(4, seed)
    model.table[:, :, 2] = np.log(0.7)  # not normalised; a score is all the search needs
    rng = np.random.default_rng(seed)
    prefixes = [(int(rng.choice([0, 3])),) for _ in range(6)]
    stats = SearchStats()
    out = predict_suffixes(model, prefixes, 4, rules=rules, beam_width=3, max_length=6, stats=stats)
    assert all(s.found for s in out) and stats.fallbacks == 0
    assert stats.pruned > 0
    live = rules.dfa.live()
    atoms = list(rules.atoms)
    for rows in model.calls:
        for row in rows:
            letters = [atoms.index(vocabulary[i]) + 1 if vocabulary[i] in atoms else 0 for i in row]
            assert live[rules.dfa.run(letters)], row


@pytest.mark.parametrize("seed", range(20))
def test_beam_one_without_rules_is_greedy_argmax(seed):
    rng = np.random.default_rng(seed)
    v, max_length = int(rng.integers(3, 6)), 8
    model = Markov(v, seed, end_weight=0.3)
    prefixes = [
        tuple(int(x) for x in rng.integers(0, v, int(rng.integers(1, 5)))) for _ in range(5)
    ]
    out = predict_suffixes(model, prefixes, v, beam_width=1, max_length=max_length)
    for prefix, suffix in zip(prefixes, out, strict=True):
        sequence, score = tuple(prefix), 0.0
        for _ in range(max_length):
            token = int(np.argmax(model.next(sequence)))
            score += model.next(sequence)[token]
            if token == v:
                break
            sequence += (token,)
        else:  # the budget spent: the case ends there
            score += model.next(sequence)[v]
        assert suffix.activities == sequence[len(prefix) :]
        assert suffix.log_prob == pytest.approx(score)
        assert suffix.satisfied is None and suffix.found


def test_one_call_per_step_with_every_branch():
    v, beam_width, max_length, n = 4, 3, 5, 20
    model = Markov(v, 0)
    model.table[:, :, v] = -50.0  # the end is never chosen before the budget is spent
    rng = np.random.default_rng(0)
    prefixes = [tuple(int(x) for x in rng.integers(0, v, 2)) for _ in range(n)]
    stats = SearchStats()
    predict_suffixes(model, prefixes, v, beam_width=beam_width, max_length=max_length, stats=stats)
    assert len(model.calls) == max_length + 1 == stats.model_calls
    assert [len(rows) for rows in model.calls] == [n] + [n * beam_width] * max_length
    assert stats.branches == sum(len(rows) for rows in model.calls)
    # every row is a prefix of the batch plus a continuation one step longer than the last call's
    for step, rows in enumerate(model.calls):
        assert all(len(r) == 2 + step for r in rows)
        assert {r[:2] for r in rows} == set(prefixes)


def test_stops_once_the_best_branch_is_finished():
    v = 3
    model = Markov(v, 1, end_weight=50.0)  # the end is by far the most probable token
    out = predict_suffixes(model, [(0,), (1,)], v, beam_width=4, max_length=30)
    assert len(model.calls) < 30
    assert all(s.found for s in out)


def test_a_dead_prefix_falls_back_to_the_unconstrained_answer():
    vocabulary = ["a", "b", "c"]
    rules = RuleSet("G !c", vocabulary)
    model = Markov(3, 4)
    stats = SearchStats()
    [dead, alive] = predict_suffixes(model, [(2, 0), (0,)], 3, rules=rules, stats=stats)
    [free] = predict_suffixes(Markov(3, 4), [(2, 0)], 3)
    assert not dead.found and dead.satisfied is False
    assert (dead.activities, dead.log_prob) == (free.activities, free.log_prob)
    assert alive.found and alive.satisfied and stats.fallbacks == 1
    # the constrained search never sent the dead prefix to the model
    assert all(row[:2] != (2, 0) for row in model.calls[0])


def test_an_unmeetable_budget_is_not_found():
    # "F c" after (a,) needs one more activity: with max_length 0 nothing is accepted
    rules = RuleSet("F c", ["a", "b", "c"])
    [short] = predict_suffixes(Markov(3, 0), [(0,)], 3, rules=rules, max_length=0)
    [enough] = predict_suffixes(Markov(3, 0), [(0,)], 3, rules=rules, max_length=1)
    assert not short.found and short.activities == ()
    assert enough.found and enough.activities == (2,)


def test_no_prefixes_no_calls():
    model = Markov(3, 0)
    assert predict_suffixes(model, [], 3) == []
    assert model.calls == []


@pytest.mark.parametrize(
    ("change", "error", "argument"),
    [
        ({"prefixes": [()]}, ArgumentError, "prefixes[0]"),
        ({"prefixes": [(0, 3)]}, ArgumentError, "prefixes[0]"),
        ({"prefixes": [(0.5,)]}, ArgumentTypeError, "prefixes[0]"),
        ({"prefixes": "ab"}, ArgumentTypeError, "prefixes"),
        ({"beam_width": 0}, ArgumentError, "beam_width"),
        ({"max_length": -1}, ArgumentError, "max_length"),
        ({"num_activities": 4}, ArgumentError, "next_log_probs"),  # model gives 3 + 1 columns
        ({"rules": RuleSet("F a", ["a", "b", "c", "d"])}, ArgumentError, "rules"),
        ({"rules": "F a"}, ArgumentTypeError, "rules"),
        (
            {"next_log_probs": lambda rows: np.full((len(rows), 4), np.nan)},
            ArgumentError,
            "next_log_probs",
        ),
        ({"next_log_probs": lambda rows: np.ones((len(rows), 4))}, ArgumentError, "next_log_probs"),
        ({"next_log_probs": None}, ArgumentTypeError, "next_log_probs"),
    ],
)
def test_arguments_that_cannot_be_used(change, error, argument):
    kwargs = {"next_log_probs": Markov(3, 0), "prefixes": [(0,)], "num_activities": 3} | change
    with pytest.raises(error) as raised:
        predict_suffixes(**kwargs)
    assert raised.value.argument == argument
