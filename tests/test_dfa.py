"""The DFA type: minimality, completeness, canonical form, products, the stored form."""

from __future__ import annotations

import itertools
import random

import numpy as np
import pytest

from tests.conftest import all_traces
from tleaf_cli.data.random_formulas import random_formula
from tleaf_cli.logic.alphabet import Alphabet, LetterError
from tleaf_cli.logic.checker import check
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.guards import cnf_holds


def _formulas(n: int, seed: int = 11) -> list[str]:
    rng = random.Random(seed)
    return [random_formula(rng, ["a", "b", "c"], rng.randint(5, 14)) for _ in range(n)]


def _distinguishable_pairs(dfa: DFA) -> set[tuple[int, int]]:
    """Table-filling (Myhill-Nerode), written independently of DFA.minimize."""
    n, table, acc = dfa.num_states, dfa.table.tolist(), dfa.accepting.tolist()
    marked = {(p, q) for p in range(n) for q in range(p + 1, n) if acc[p] != acc[q]}
    changed = True
    while changed:
        changed = False
        for p, q in itertools.combinations(range(n), 2):
            if (p, q) in marked:
                continue
            for x in range(dfa.alphabet.size):
                a, b = sorted((table[p][x], table[q][x]))
                if a != b and (a, b) in marked:
                    marked.add((p, q))
                    changed = True
                    break
    return marked


@pytest.mark.parametrize("kind", ["powerset", "one-hot"])
def test_compiled_dfas_are_minimal_complete_and_reachable(kind: str) -> None:
    for text in [*_formulas(40), "G(a -> F b)", "a U b", "last", "WX a"]:
        dfa = compile_formula(text, kind)
        n = dfa.num_states
        # complete: one successor per (state, letter), inside the states
        assert dfa.table.shape == (n, dfa.alphabet.size)
        assert dfa.table.min() >= 0 and dfa.table.max() < n
        # guards out of each state cover every letter exactly once
        for src in range(n):
            cover = np.zeros(dfa.alphabet.size, dtype=int)
            for s, _, guard in dfa.guarded_edges():
                if s == src:
                    cover += cnf_holds(guard.cnf, dfa.alphabet)
            assert (cover == 1).all(), (text, src)
        # minimal: every state reachable and every pair of states distinguishable
        assert len(dfa._reachable()) == n
        assert len(_distinguishable_pairs(dfa)) == n * (n - 1) // 2, text


def test_minimal_on_nonempty_traces_uses_the_empty_word_freely() -> None:
    # "G a" needs 3 states if the empty trace must be rejected, 2 if it may be accepted.
    assert compile_formula("G a").num_states == 2
    # "a" (first letter has a): init, sink, accept-all; the empty word changes nothing.
    assert compile_formula("a").num_states == 3


def test_same_language_gives_identical_tables() -> None:
    pairs = [
        ("G(a -> F b)", "!F(a & !F b)"),
        ("a U b", "b | (a & X(a U b))"),
        ("F a", "!G !a"),
        ("a R b", "!(!a U !b)"),
    ]
    for x, y in pairs:
        assert compile_formula(x) == compile_formula(y), (x, y)
    assert compile_formula("F a") != compile_formula("G a")


def test_product_is_conjunction_and_disjunction() -> None:
    traces = all_traces(["a", "b", "c"], 4)
    for f, g in [("G(a -> F b)", "F c"), ("a U b", "G !c"), ("X a", "WX b")]:
        df, dg = compile_formula(f), compile_formula(g)
        both = compile_formula(f"({f}) & ({g})")
        either = compile_formula(f"({f}) | ({g})")
        assert (check(df.intersect(dg), traces) == check(both, traces)).all()
        assert (check(df.product(dg, "or"), traces) == check(either, traces)).all()
        assert df.intersect(dg).atoms == both.atoms


def test_complement_and_equivalence() -> None:
    traces = all_traces(["a", "b"], 4)
    d = compile_formula("a U b")
    assert (check(d.complement(), traces) == ~check(d, traces)).all()
    assert d.equivalent(compile_formula("b | (a & X(a U b))"))
    assert not d.equivalent(compile_formula("a R b"))


def test_one_hot_product_over_union_of_atoms() -> None:
    d = compile_formula("G(a -> F b)", "one-hot").intersect(compile_formula("G !c", "one-hot"))
    assert d.atoms == ("a", "b", "c") and d.alphabet.kind == "one-hot"
    assert d.accepts([{"a"}, {"b"}]) and not d.accepts([{"a"}, {"c"}, {"b"}])
    with pytest.raises(ValueError, match="powerset and a one-hot"):
        compile_formula("a").intersect(compile_formula("b", "one-hot"))


def test_accepts_rejects_empty_traces_and_non_one_hot_letters() -> None:
    d = compile_formula("F a", "one-hot")
    assert d.accepts([{"zzz"}, {"a"}])  # atoms outside the DFA are another domain atom
    with pytest.raises(ValueError, match="non-empty"):
        d.accepts([])
    two = compile_formula("F(a | b)", "one-hot")
    with pytest.raises(LetterError, match="not one-hot"):
        two.accepts([{"a", "b"}])


def test_from_guards_rejects_incomplete_and_overlapping_edges() -> None:
    alphabet = Alphabet(("a",))
    with pytest.raises(ValueError, match="not complete"):
        DFA.from_guards(alphabet, 1, 0, [0], [(0, 0, [[1]])])
    with pytest.raises(ValueError, match="not deterministic"):
        DFA.from_guards(alphabet, 1, 0, [0], [(0, 0, [[1]]), (0, 0, [])])


def test_powerset_alphabet_is_bounded() -> None:
    atoms = tuple(sorted(f"p{i:02d}" for i in range(17)))
    with pytest.raises(LetterError, match="one-hot"):
        Alphabet(atoms, "powerset")
    assert Alphabet(atoms, "one-hot").size == 18
