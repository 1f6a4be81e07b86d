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
    ARC_SHAPES,
    Arc,
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
from tleaf_cli.data.traces import paper_traces
from tleaf_cli.errors import SettingError
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.sampling import WordSampler

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
    it, is accepting (none if the initial state is), by enumerating state sequences."""
    out = set()
    if dfa.accepting[dfa.initial]:
        return out
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
    assert {tuple((a.src, a.dst) for a in p) for p in found} == every
    assert len(found) == len(every)  # each once
    capped = accepting_paths(dfa)
    assert capped == found[: min(10, len(found))]  # the first ten the search meets


def accepting_first_words(dfa) -> set[tuple[int, ...]]:
    """Every word whose run repeats no state and reaches an accepting state at its last letter
    only, by enumerating every word up to the number of states (a longer run repeats one)."""
    out = set()
    for length in range(1, dfa.num_states):
        for word in itertools.product(range(dfa.alphabet.size), repeat=length):
            states = [dfa.initial]
            for letter in word:
                states.append(int(dfa.table[states[-1], letter]))
            simple = len(set(states)) == len(states)
            if simple and dfa.accepting[states[-1]] and not dfa.accepting[states[:-1]].any():
                out.add(word)
    return out


def states_of(dfa, word) -> tuple[int, ...]:
    states = [dfa.initial]
    for letter in word:
        states.append(int(dfa.table[states[-1], letter]))
    return tuple(states)


def letters_of(cube, atoms: int) -> set[int]:
    """Every letter (powerset index) inside a cube."""
    return {
        x for x in range(1 << atoms) if all((x >> (abs(lit) - 1) & 1) == (lit > 0) for lit in cube)
    }


@pytest.mark.parametrize("shape", ARC_SHAPES)
@pytest.mark.parametrize("text", FORMULAS)
def test_path_count_per_arc_shape_is_the_exhaustive_count(text, shape):
    """letter: one path per accepting-first word; guard: one per state sequence of such
    words; cube: one per such sequence and choice of one ISOP cube on each of its arcs.
    Each path's cubes hold exactly the letters the brute force finds on its arcs."""
    dfa = compile_formula(text)
    n = len(dfa.atoms)
    words = accepting_first_words(dfa)
    sequences = {states_of(dfa, w) for w in words}
    found = accepting_paths(dfa, limit=10**6, shape=shape)
    assert len({tuple(p) for p in found}) == len(found)  # each once
    assert {(dfa.initial, *(a.dst for a in p)) for p in found} == sequences
    for path in found:
        for arc in path:
            on_arc = set(np.flatnonzero(dfa.table[arc.src] == arc.dst).tolist())
            inside = [letters_of(c, n) for c in arc.cubes]
            assert all(cube <= on_arc for cube in inside)
            if shape == "guard":
                assert set().union(*inside) == on_arc
            else:
                assert len(arc.cubes) == 1
    if shape == "letter":
        spelled = {tuple(min(letters_of(a.cubes[0], n)) for a in p) for p in found}
        assert all(len(letters_of(a.cubes[0], n)) == 1 for p in found for a in p)
        assert spelled == words and len(found) == len(words)
    elif shape == "guard":
        assert len(found) == len(sequences)
    else:
        per_sequence = [
            np.prod([len(guard_cubes(dfa, s, d)) for s, d in itertools.pairwise(seq)])
            for seq in sequences
        ]
        assert len(found) == sum(per_sequence)
    capped = accepting_paths(dfa, shape=shape)
    assert capped == found[: min(10, len(found))]


def test_shapes_differ_where_a_guard_has_several_cubes_and_letters():
    """F(a | b) over a, b: one guard a | b, two cubes, three letters into the accepting state."""
    dfa = compile_formula("F(a | b)")
    counts = {s: len(accepting_paths(dfa, limit=100, shape=s)) for s in ARC_SHAPES}
    assert counts == {"guard": 1, "cube": 2, "letter": 3}


def test_an_accepting_initial_state_gives_no_path():
    """G(a) | F(b) accepts the empty trace; the authors' search stops at the empty path, so
    there is none here, though accepting-first words exist past the initial state."""
    dfa = compile_formula("G(a) | F(b)")
    assert dfa.accepting[dfa.initial]
    assert accepting_first_words(dfa) == set()  # the brute force agrees: the start accepts
    for shape in ARC_SHAPES:
        assert accepting_paths(dfa, shape=shape) == []
    assert paper_reason(dfa, np.random.default_rng(0)) == "fewer than 5 accepting paths"


def test_an_unknown_shape_is_refused():
    with pytest.raises(SettingError, match="paper_arcs"):
        accepting_paths(compile_formula("F(a)"), shape="edge")


@pytest.mark.parametrize("text", FORMULAS)
def test_letter_shape_positives_are_their_paths_letters(text):
    dfa = compile_formula(text)
    paths = accepting_paths(dfa, shape="letter")
    words = paper_positive_words(dfa, np.random.default_rng(0), paths, repeats=2)
    for k, word in enumerate(words):
        letters = [min(letters_of(a.cubes[0], len(dfa.atoms))) for a in paths[k % len(paths)]]
        assert word.tolist() == letters


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
        for letter, arc in zip(word.tolist(), path, strict=True):
            assert state == arc.src and dfa.table[arc.src, letter] == arc.dst
            state = arc.dst
        assert dfa.accepting[dfa.run(word)]


def test_a_letter_completes_one_cube_uniformly():
    """Guard a | b (cubes a, b): letters drawn are in the guard with the ISOP's weights."""
    dfa = compile_formula("F(a | b)")
    (path,) = accepting_paths(dfa)
    cubes = guard_cubes(dfa, path[0].src, path[0].dst)
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
    paths = [[Arc(dfa.initial, int(dfa.table[dfa.initial, 1]), ((1,),))]]
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


def test_cli_paper_arcs(tmp_path):
    """--paper-arcs reaches both commands and the formula file's header; it needs --protocol
    paper."""
    ltl, dfas, traces = tmp_path / "f.ltl", tmp_path / "d.parquet", tmp_path / "t.parquet"
    args = ["gen-formulas", "--protocol", "paper", "--paper-arcs", "letter", "-n", "3"]
    result = runner.invoke(app, [*args, "-o", str(ltl), "--no-cache", "-q"])
    assert result.exit_code == 0, result.output
    assert '"paper_arcs": "letter"' in ltl.read_text()
    assert runner.invoke(app, ["compile-dfa", str(ltl), "-o", str(dfas), "-q"]).exit_code == 0
    paper = ["gen-traces", str(dfas), "--protocol", "paper", "-o", str(traces)]
    assert runner.invoke(app, [*paper, "--paper-arcs", "letter"]).exit_code == 0
    rows = Counter(r["formula_id"] for r in pq.read_table(traces).to_pylist())
    texts = dict(line.split(": ", 1) for line in ltl.read_text().splitlines()[2:])
    for fid, text in texts.items():  # 3 draws of each letter path, each with its negative
        assert rows[fid] == 6 * len(accepting_paths(compile_formula(text), shape="letter"))
    for command in (
        ["gen-formulas", "--paper-arcs", "letter", "-o", str(tmp_path / "x.ltl")],
        ["gen-traces", str(dfas), "--paper-arcs", "cube", "-o", str(tmp_path / "x.parquet")],
    ):
        refused = runner.invoke(app, command)
        assert refused.exit_code == 2 and "--paper-arcs" in refused.output


@pytest.mark.parametrize("text", [FORMULAS[0], FORMULAS[2], FORMULAS[4]])
def test_paper_hard_swaps_a_share_of_negatives_for_nearest_rejected_words(text):
    """--paper-hard: the authors' positives kept, a share of their negatives replaced by a
    rejected word one letter away where one exists (the nearest, as tleaf's hard negatives);
    0 draws exactly the authors' traces."""
    dfa = compile_formula(text)
    plain = paper_traces(dfa, np.random.default_rng(5), "guard")
    again = paper_traces(dfa, np.random.default_rng(5), "guard", 0.0)
    assert [w.tolist() for w in plain.words] == [w.tolist() for w in again.words]
    assert plain.words and set(plain.sources) == {"uniform"}
    mixed = paper_traces(dfa, np.random.default_rng(5), "guard", 1.0)
    positives = mixed.words[::2]
    assert [w.tolist() for w in positives] == [w.tolist() for w in plain.words[::2]]
    sampler = WordSampler(dfa, max(len(w) for w in positives))
    for sat, neg, source in zip(positives, mixed.words[1::2], mixed.sources[1::2], strict=True):
        assert source == "hard" and len(neg) == len(sat) and not dfa.accepting[dfa.run(neg)]
        changed = int((neg != sat).sum())
        fewest = min(
            sum(a != b for a, b in zip(word, sat.tolist(), strict=True))
            for word in itertools.product(sampler.letters.tolist(), repeat=len(sat))
            if not dfa.accepting[dfa.run(word)]
        )
        assert changed == fewest
    half = paper_traces(dfa, np.random.default_rng(5), "guard", 0.5).sources[1::2]
    assert 0 < half.count("hard") < len(half)


def test_paper_hard_needs_the_paper_protocol(tmp_path):
    ltl, dfas = tmp_path / "f.ltl", tmp_path / "d.parquet"
    ltl.write_text("f0: F(a) & F(b)\n")
    assert runner.invoke(app, ["compile-dfa", str(ltl), "-o", str(dfas), "-q"]).exit_code == 0
    refused = runner.invoke(app, ["gen-traces", str(dfas), "--paper-hard", "0.5"])
    assert refused.exit_code == 2 and "--paper-hard" in refused.output
    out = tmp_path / "t.parquet"
    args = ["gen-traces", str(dfas), "--protocol", "paper", "--paper-hard", "1", "-o", str(out)]
    assert runner.invoke(app, [*args, "-q"]).exit_code == 0
    rows = pq.read_table(out).to_pylist()
    assert {r["source"] for r in rows if not r["label"]} == {"hard"}
