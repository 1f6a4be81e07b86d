"""Compiled DFAs against the direct LTLf evaluator on every trace up to length 4.

The evaluator (logic/semantics.py) shares no code with the MONA route, so agreement on all
4,680 traces over three atoms is strong evidence that parsing, MONA's output, the table, the
minimisation and the guards are all right.
"""

from __future__ import annotations

import random

import numpy as np
import pytest

from tests.conftest import all_traces
from tleaf_cli.data.dfa_table import dfa_from_row, dfa_payload, make_row
from tleaf_cli.data.random_formulas import random_formula
from tleaf_cli.logic.checker import check
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.semantics import satisfies

ATOMS = ["a", "b", "c"]
POWERSET = all_traces(ATOMS, 4)
ONE_HOT = all_traces(ATOMS, 4, one_hot=True)

# Every operator of the grammar, in every spelling, and the n-ary groupings kept from ltlf2dfa.
OPERATORS = [
    "a",
    "!a",
    "~a",
    "a & b",
    "a && b",
    "a | b",
    "a || b",
    "a -> b",
    "a => b",
    "a <-> b",
    "a <=> b",
    "X a",
    "WX a",
    "F a",
    "G a",
    "a U b",
    "a R b",
    "true",
    "false",
    "last",
    "TRUE | a",
    "X(a)",
    "G(a)",
    "F(last)",
    "!last",
    "X true",
    "WX false",
    "G F a",
    "F G a",
    "a -> b -> c",
    "a U b U c",
    "a R b R c",
    "a <-> b <-> c",
    "a & b & c | !a",
    "X X a",
    "WX WX a",
    "a U (X b)",
    "!(a U b) R c",
    "G(a & !a)",
    "F true",
    "G true",
]

# Common specification patterns (Declare / Dwyer), over a, b, c.
PATTERNS = {
    "existence": "F a",
    "absence": "G !a",
    "init": "a",
    "response": "G(a -> F b)",
    "precedence": "(!b U a) | G !b",
    "succession": "G(a -> F b) & ((!b U a) | G !b)",
    "chain_response": "G(a -> X b)",
    "chain_precedence": "G(X b -> a)",
    "alternate_response": "G(a -> X(!a U b))",
    "responded_existence": "F a -> F b",
    "coexistence": "(F a -> F b) & (F b -> F a)",
    "not_coexistence": "!(F a & F b)",
    "not_succession": "G(a -> !F b)",
    "not_chain_succession": "G(a -> !X b)",
    "exclusive_choice": "(F a | F b) & !(F a & F b)",
    "bounded_response": "G(a -> (b | X b | X X b))",
    "until_then": "(a U b) & F c",
    "end": "F(c & last)",
}


def _random_formulas(n: int, seed: int = 2021, n_atoms: int = 3) -> list[str]:
    """n formulas over exactly n_atoms of a, b, c, syntax-tree sizes 2*n_atoms-1 .. 14."""
    rng = random.Random(seed)
    atoms = ATOMS[:n_atoms]
    return [random_formula(rng, atoms, rng.randint(2 * n_atoms - 1, 14)) for _ in range(n)]


def _agree(text: str) -> None:
    formula = parse(text)
    for kind, traces in (("powerset", POWERSET), ("one-hot", ONE_HOT)):
        dfa = compile_formula(text, kind)
        expected = np.array([satisfies(t, formula) for t in traces])
        got = check(dfa, traces)
        bad = np.flatnonzero(got != expected)
        assert len(bad) == 0, (
            f"{kind} DFA of {text!r} disagrees on {len(bad)} traces, e.g. "
            f"{[sorted(x) for x in traces[bad[0]]]}: expected {expected[bad[0]]}"
        )
        # The stored form (guards as CNF) rebuilds exactly the same table.
        row = make_row("f", text, dfa_payload(dfa), None)
        assert dfa_from_row(row) == dfa


@pytest.mark.parametrize("text", OPERATORS)
def test_every_operator(text: str) -> None:
    _agree(text)


@pytest.mark.parametrize("name", sorted(PATTERNS))
def test_specification_patterns(name: str) -> None:
    _agree(PATTERNS[name])


@pytest.mark.slow
def test_random_three_atom_formulas() -> None:
    """At least 200 distinct random formulas over exactly three atoms: no mismatch anywhere."""
    formulas = _random_formulas(210)
    assert len(set(formulas)) >= 200
    for text in formulas:
        _agree(text)


@pytest.mark.slow
def test_random_one_and_two_atom_formulas() -> None:
    for text in _random_formulas(30, seed=5, n_atoms=1) + _random_formulas(30, seed=6, n_atoms=2):
        _agree(text)


def test_one_hot_dfa_agrees_with_powerset_dfa_on_one_hot_traces() -> None:
    for text in _random_formulas(60, seed=7) + list(PATTERNS.values()):
        powerset = compile_formula(text, "powerset")
        one_hot = compile_formula(text, "one-hot")
        assert (check(powerset, ONE_HOT) == check(one_hot, ONE_HOT)).all(), text
        assert one_hot.num_states <= powerset.num_states, text
