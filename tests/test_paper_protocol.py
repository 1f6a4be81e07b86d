"""The authors' Table I data protocol (`--protocol paper`): checked against brute force."""

from __future__ import annotations

import itertools
import random
from collections import Counter

import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.paper_protocol import (
    accepting_paths,
    guard_cubes,
    paper_negative_words,
    paper_positive_words,
    paper_reason,
    rejected_within_budget,
    spot_formula,
    trimmed_states,
)
from tleaf_cli.data.random_formulas import syntax_tree_size
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.logic.formulas import parse

FORMULAS = [
    "F(a) & F(b)",
    "(a U b) | G(c)",
    "F(a & X(b)) | (b U c)",
    "X(a) | X(X(b))",
    "!(a) U (b & F(c))",
    "G(a) | F(b & c)",
]
runner = CliRunner()


def simple_paths(dfa) -> set[tuple[tuple[int, int], ...]]:
    """Every path from the initial state that repeats no state and whose last state, and only
    it, is accepting (the initial state excepted), by enumerating state sequences."""
    out = set()
    others = [s for s in range(dfa.num_states) if s != dfa.initial]
    for k in range(1, dfa.num_states):
        for seq in itertools.permutations(others, k):
            states = (dfa.initial, *seq)
            arcs = list(itertools.pairwise(states))
            if not all((dfa.table[s] == d).any() for s, d in arcs):
                continue
            if dfa.accepting[states[-1]] and not dfa.accepting[list(seq[:-1])].any():
                out.add(tuple(arcs))
    return out


@pytest.mark.parametrize("text", FORMULAS)
def test_paths_are_the_simple_accepting_first_paths(text):
    dfa = compile_formula(text)
    every = simple_paths(dfa)
    found = accepting_paths(dfa, limit=10_000)
    assert {tuple(p) for p in found} == every
    assert len(found) == len(every)  # each once
    capped = accepting_paths(dfa)
    assert capped == found[: min(10, len(found))]  # the first ten the search meets


@pytest.mark.parametrize("text", FORMULAS)
def test_positives_follow_their_paths_and_are_accepted(text):
    dfa = compile_formula(text)
    paths = accepting_paths(dfa)
    words = paper_positive_words(dfa, np.random.default_rng(0), paths)
    assert len(words) == 3 * len(paths)
    for k, word in enumerate(words):
        path = paths[k % len(paths)]
        assert len(word) == len(path)
        state = dfa.initial
        for letter, (src, dst) in zip(word.tolist(), path, strict=True):
            assert state == src and dfa.table[src, letter] == dst
            state = dst
        assert dfa.accepting[dfa.run(word)]


def test_a_letter_completes_one_cube_uniformly():
    """Guard a | b (cubes a, b): letters drawn are in the guard with the ISOP's weights."""
    dfa = compile_formula("F(a | b)")
    (path,) = accepting_paths(dfa)
    cubes = guard_cubes(dfa, *path[0])
    assert sorted(cubes) == [(1,), (2,)]
    words = paper_positive_words(dfa, np.random.default_rng(1), [path], repeats=4000)
    seen = Counter(int(w[0]) for w in words)
    # letters {a}=1, {b}=2, {a,b}=3: P = 1/4, 1/4, 1/2 (either cube, the other atom a coin)
    assert set(seen) == {1, 2, 3}
    assert abs(seen[3] / 4000 - 0.5) < 0.04 and abs(seen[1] / 4000 - 0.25) < 0.04


@pytest.mark.parametrize("text", FORMULAS)
def test_negatives_are_uniform_rejected_words_of_the_length(text):
    dfa = compile_formula(text)
    length = 2
    rejected = {
        w
        for w in itertools.product(range(dfa.alphabet.size), repeat=length)
        if not dfa.accepting[dfa.run(list(w))]
    }
    words = paper_negative_words(dfa, np.random.default_rng(2), [length] * 3000)
    drawn = Counter(tuple(w.tolist()) for w in words)
    assert set(drawn) <= rejected and all(len(w) == length for w in drawn)
    if rejected:
        assert len(drawn) == len(rejected)  # every rejected word turns up
        expected = 3000 / len(rejected)
        assert max(drawn.values()) < 2 * expected and min(drawn.values()) > expected / 2


def test_no_rejected_word_gives_none():
    dfa = compile_formula("F(a) | !(a)")  # every word is accepted
    assert paper_negative_words(dfa, np.random.default_rng(0), [1, 2]) == [None, None]


def test_rejection_budget_counts_letters_as_the_authors_do():
    """F a | X b over a path of length 1: a word is rejected with probability 1/2 (b does not
    matter at length 1: a rejected iff not a); over many draws the budget of 40 letters nearly
    always suffices; with a budget of 0 one accepted draw fails it."""
    dfa = compile_formula("F(a)")
    paths = [[(dfa.initial, int(dfa.table[dfa.initial, 1]))]]
    fails = sum(
        not rejected_within_budget(dfa, np.random.default_rng(k), paths, budget=0)
        for k in range(400)
    )
    assert abs(fails / 400 - 0.5) < 0.1  # fails iff the first draw is accepted
    assert all(rejected_within_budget(dfa, np.random.default_rng(k), paths) for k in range(50))
    valid = compile_formula("F(a) | !(a)")
    assert not rejected_within_budget(valid, np.random.default_rng(0), paths)


def test_trimmed_states_leave_out_the_dead_state():
    dfa = compile_formula("a U b")  # start, accept, dead
    assert dfa.num_states == 3 and trimmed_states(dfa) == 2


def test_filters():
    assert paper_reason(compile_formula("F(a)"), np.random.default_rng(0)) is not None
    dfa = compile_formula("F(a) & F(b) & F(c)")
    assert len(accepting_paths(dfa)) >= 5
    assert paper_reason(dfa, np.random.default_rng(0)) is None


def test_spot_formulas_have_the_size_and_operators():
    rng = random.Random(0)
    atoms = ["a", "b", "c"]
    for size in (1, 2, 3, 10, 20):
        for _ in range(200):
            text = spot_formula(rng, atoms, size)
            assert syntax_tree_size(parse(text)) == size, text
            assert not any(op in text for op in ("->", "<->", " R ", "WX"))
    leaves = Counter(spot_formula(rng, atoms, 1) for _ in range(5000))
    assert set(leaves) == {"a", "b", "c", "true", "false"}
    assert abs(leaves["true"] / 5000 - 0.2) < 0.03  # weight 1 of 3 + 1 + 1
    roots = Counter(spot_formula(rng, atoms, 3)[0] for _ in range(7000))
    # 4 unary of 7 operators start with their letter; a binary one with "("
    assert abs(roots["("] / 7000 - 3 / 7) < 0.03


def test_cli_paper_protocol_chain(tmp_path):
    ltl, dfas, traces = tmp_path / "f.ltl", tmp_path / "d.parquet", tmp_path / "t.parquet"
    args = ["gen-formulas", "--protocol", "paper", "--atoms", "3", "--size", "10", "-n", "3"]
    result = runner.invoke(app, [*args, "-o", str(ltl), "--no-cache", "-q"])
    assert result.exit_code == 0, result.output
    assert runner.invoke(app, ["compile-dfa", str(ltl), "-o", str(dfas), "-q"]).exit_code == 0
    result = runner.invoke(app, ["gen-traces", str(dfas), "--protocol", "paper", "-o", str(traces)])
    assert result.exit_code == 0, result.output
    table = pq.read_table(traces).to_pylist()
    by_formula = Counter(r["formula_id"] for r in table)
    assert len(by_formula) == 3 and all(n >= 30 for n in by_formula.values())  # 3 x >= 5 pairs
    for sat, neg in zip(table[::2], table[1::2], strict=True):
        assert sat["label"] and not neg["label"] and len(sat["trace"]) == len(neg["trace"])
    refused = runner.invoke(app, [*args, "--pairs", "3", "-o", str(tmp_path / "x.ltl")])
    assert refused.exit_code == 2 and "--pairs" in refused.output
    refused = runner.invoke(
        app, ["gen-traces", str(dfas), "--protocol", "paper", "--per-formula", "4"]
    )
    assert refused.exit_code == 2
