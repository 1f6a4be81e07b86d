"""rule_parts: a knowledge base's conjunction as several DFAs of bounded size, checked against
the one-DFA conjunction (RuleSet) by brute force over every short word."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from tleaf_cli.errors import ArgumentError
from tleaf_cli.rule_set import RuleSet, rule_parts

VOCABULARY = ["a", "b", "c", "d", "e"]
FORMULAS = [
    "(!b U a) | G !b",  # precedence(a, b)
    "(!c U a) | G !c",
    "(!d U b) | G !d",
    "(!e U c) | G !e",
    "G(a -> F d)",  # response(a, d)
    "G(b -> F e)",
    "F a",
    "G !(c & X c)",
]


def accepted(rule_set: RuleSet, word: tuple[int, ...]) -> bool:
    dfa = rule_set.dfa
    return bool(dfa.accepting[dfa.run(rule_set.letters(np.array(word)))])


def test_parts_accept_exactly_the_conjunctions_words_and_stay_small():
    whole = RuleSet(FORMULAS, VOCABULARY)
    parts = rule_parts(FORMULAS, VOCABULARY, max_states=6)
    assert len(parts) > 1 and whole.dfa.num_states > 6
    assert all(p.dfa.num_states <= 6 or len(p.formulas) == 1 for p in parts)
    assert sorted(f for p in parts for f in p.formulas) == sorted(FORMULAS)
    for n in range(1, 6):
        for word in itertools.product(range(len(VOCABULARY)), repeat=n):
            assert all(accepted(p, word) for p in parts) == accepted(whole, word), word


def test_a_conjunction_that_fits_is_one_part_the_same_dfa():
    whole = RuleSet(FORMULAS, VOCABULARY)
    [part] = rule_parts(FORMULAS, VOCABULARY, max_states=10_000)
    assert np.array_equal(part.dfa.table, whole.dfa.table)
    assert np.array_equal(part.dfa.accepting, whole.dfa.accepting)
    assert part.dfa.initial == whole.dfa.initial and part.dfa.atoms == whole.dfa.atoms


@pytest.mark.parametrize("max_states", [1, 2.5, True])
def test_max_states_must_be_an_int_of_two_or_more(max_states):
    with pytest.raises(ArgumentError, match="max_states"):
        rule_parts(FORMULAS, VOCABULARY, max_states=max_states)
