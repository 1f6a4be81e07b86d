"""The DFA type: minimality, completeness, canonical form, products, the stored form."""

from __future__ import annotations

import functools
import itertools
import random

import numpy as np
import pytest

from tests.conftest import all_traces
from tleaf_cli.data.random_formulas import random_formula
from tleaf_cli.errors import InputError
from tleaf_cli.logic import conjunction
from tleaf_cli.logic.alphabet import Alphabet, LetterError
from tleaf_cli.logic.checker import check
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.logic.conjunction import conjoin_nonempty
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


# Formulas without atoms: letter 0 is then their every letter, and not a self-loop for most.
ATOMLESS = ("last", "!last", "X true", "X X true", "X(last)", "WX false", "true", "false")


def _folded(dfas: list[DFA]) -> DFA:
    """The reference `conjoin_nonempty` must equal: pairwise products, then minimize_nonempty."""
    return functools.reduce(lambda x, y: x.product(y), dfas).minimize_nonempty()


def _unminimised(dfa: DFA) -> DFA:
    """The same language with every state doubled (the copies alternate), so not minimal."""
    n, table = dfa.num_states, dfa.table
    doubled = np.vstack([table + n, table])  # copy 0 steps into copy 1 and back
    return DFA(dfa.alphabet, doubled, dfa.initial, np.concatenate([dfa.accepting] * 2))


def _random_groups(rng: random.Random) -> list[DFA]:
    """1-4 one-hot DFAs over disjoint atoms, as `rule_set._conjunction` gets its groups: each the
    product (minimal, the empty word included) of 1-3 random formulas over its own atoms (X, WX,
    U, ... included), or of atomless formulas; now and then one not minimal."""
    names = iter("abcdefghijklmn")
    groups = []
    for _ in range(rng.randint(1, 4)):
        atoms = [next(names) for _ in range(rng.randint(0, 3))]
        texts = []
        for _ in range(rng.randint(1, 3)):
            if not atoms or rng.random() < 0.15:
                texts.append(rng.choice(ATOMLESS))
                continue
            some = rng.sample(atoms, rng.randint(1, len(atoms)))
            texts.append(random_formula(rng, some, rng.randint(2 * len(some), 2 * len(some) + 5)))
        # one group's formulas with their atoms, whatever atoms the others have
        dfa = functools.reduce(DFA.product, [compile_formula(t, "one-hot") for t in texts])
        groups.append(_unminimised(dfa) if rng.random() < 0.1 else dfa)
    return groups


def test_conjoin_nonempty_equals_the_pairwise_products() -> None:
    rng = random.Random(5)
    for case in range(150):
        groups = _random_groups(rng)
        expected = _folded(groups)
        assert conjoin_nonempty(groups) == expected, case
        rng.shuffle(groups)
        assert conjoin_nonempty(groups) == expected, case  # the order does not matter


@pytest.mark.parametrize(
    "texts",
    [
        ["G !a", "G !b", "G !c", "G !d", "G !e", "G !f", "G !g", "G !h", "G !i", "G !j", "G !k"],
        ["G !a", "G !b", "X X true", "F c", "F d"],
        ["F a", "F b", "F c", "F d", "F e", "F f", "F g", "F h", "F i", "F j"],  # 1024 states
        ["G !a", "false"],
        ["last"],
        ["a U b"],
    ],
)
def test_conjoin_nonempty_sinks_and_large_products(texts: list[str]) -> None:
    """Rejecting sinks collapse to one state ("G !x" each, or all with "false"); a product past
    SMALL_TABLE entries ("F x" each: 2**10 states) takes the pairwise route: the same DFA."""
    dfas = [compile_formula(t, "one-hot") for t in texts]
    assert conjoin_nonempty(dfas) == _folded(dfas)


def test_conjoin_nonempty_keeps_conjunctions_by_structure() -> None:
    """Rules over other atoms whose names sort into the same letters reuse the kept table; names
    that sort into another layout ("a" before "y", "z") are conjoined anew: either way the same
    DFA as folding, and the returned table is a copy (changing it changes nothing kept)."""
    one_hot = functools.partial(compile_formula, alphabet="one-hot")
    first = [one_hot("a U b"), one_hot("G(c -> X !c)")]
    renamed = [one_hot("p U q"), one_hot("G(r -> X !r)")]  # p < q < r: as a < b < c
    permuted = [one_hot("y U z"), one_hot("G(a -> X !a)")]  # a < y < z: other letters
    conjunction._CONJUNCTIONS.clear()
    conjoined = [conjoin_nonempty(dfas) for dfas in (first, renamed, permuted)]
    assert len(conjunction._CONJUNCTIONS) == 2  # `renamed` was a repeat
    for dfas, got in zip((first, renamed, permuted), conjoined, strict=True):
        assert got == _folded(dfas)
    conjoined[0].table[:] = 0
    assert conjoin_nonempty(renamed) == _folded(renamed)


def test_conjoin_nonempty_rejects_shared_atoms_and_powersets() -> None:
    with pytest.raises(InputError, match="atom a is in two"):
        conjoin_nonempty([compile_formula("F a", "one-hot"), compile_formula("G !a", "one-hot")])
    with pytest.raises(InputError, match="one-hot"):
        conjoin_nonempty([compile_formula("F a")])
    with pytest.raises(InputError, match="at least one"):
        conjoin_nonempty([])


@pytest.mark.parametrize("mode", ["and", "or", "xor"])
def test_small_products_on_lists_equal_the_array_products(mode, monkeypatch) -> None:
    """`DFA.product` below SMALL_TABLE entries walks lists (`small_tables.product_table`): the
    same minimal DFA as the array walk, on random formulas over overlapping atoms, on both
    alphabets."""
    from tleaf_cli.logic import dfa as dfa_module

    rng = random.Random(11)
    pairs = []
    for _ in range(40):
        kind = rng.choice(["one-hot", "powerset"])
        atoms = [["a", "b"], ["b", "c"], ["a", "c"], ["c"]]
        left, right = rng.sample(atoms, 2)
        pairs.append(
            tuple(
                compile_formula(random_formula(rng, side, rng.randint(2 * len(side), 7)), kind)
                for side in (left, right)
            )
        )
    small = [a.product(b, mode) for a, b in pairs]
    monkeypatch.setattr(dfa_module, "SMALL_TABLE", 0)  # every product through arrays
    arrays = [a.product(b, mode) for a, b in pairs]
    assert small == arrays
    assert any(d.num_states > 2 for d in small)  # not only trivial products
