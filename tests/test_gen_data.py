"""`gen-formulas` and `gen-traces`: labels, balance, uniformity, hard negatives, splits, seeds."""

from __future__ import annotations

import itertools
import math
import random
from collections import Counter
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.dfa_table import read_dfas
from tleaf_cli.data.formula_files import read_formulas
from tleaf_cli.data.random_formulas import syntax_tree_size
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.logic.formulas import atoms, parse
from tleaf_cli.logic.sampling import WordSampler
from tleaf_cli.logic.semantics import satisfies

runner = CliRunner()


def tleaf(*args) -> object:
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def low(tmp_path_factory) -> dict[str, Path]:
    """A small low-tier chain: 30 formulas, compiled, 10 pairs each, with splits."""
    d = tmp_path_factory.mktemp("low")
    paths = {"ltl": d / "f.ltl", "dfas": d / "dfas.parquet", "traces": d / "traces.parquet"}
    assert tleaf("gen-formulas", "--tier", "low", "-n", 30, "-o", paths["ltl"]).exit_code == 0
    assert tleaf("compile-dfa", paths["ltl"], "-o", paths["dfas"]).exit_code == 0
    result = tleaf(
        "gen-traces",
        paths["dfas"],
        "-o",
        paths["traces"],
        "--per-formula",
        10,
        "--split",
        "0.6,0.2,0.2",
        "--seed",
        3,
    )
    assert result.exit_code == 0, result.output
    return paths


def _rows(path: Path) -> list[dict]:
    return pq.read_table(path).to_pylist()


def test_every_label_agrees_with_the_direct_evaluator(low) -> None:
    formulas = {r["formula_id"]: parse(r["formula"]) for r in read_dfas(low["dfas"]).rows}
    rows = _rows(low["traces"])
    assert len(rows) == 30 * 20
    for r in rows:
        assert len(r["trace"]) >= 1
        assert satisfies([set(x) for x in r["trace"]], formulas[r["formula_id"]]) == r["label"]


def test_labels_and_lengths_are_balanced_per_formula(low) -> None:
    by_formula: dict[str, dict[bool, Counter]] = {}
    for r in _rows(low["traces"]):
        by_formula.setdefault(r["formula_id"], {True: Counter(), False: Counter()})
        by_formula[r["formula_id"]][r["label"]][len(r["trace"])] += 1
    for fid, sides in by_formula.items():
        assert sides[True] == sides[False], fid  # same length histogram on both sides
        assert sum(sides[True].values()) == 10
        assert all(2 <= n <= 12 for n in sides[True])


def test_no_duplicate_traces_within_a_formula(low) -> None:
    seen = Counter((r["formula_id"], str(r["trace"])) for r in _rows(low["traces"]))
    assert max(seen.values()) == 1


def test_splits_are_by_formula(low) -> None:
    split_of: dict[str, set[str]] = {}
    for r in _rows(low["traces"]):
        split_of.setdefault(r["formula_id"], set()).add(r["split"])
    assert all(len(s) == 1 for s in split_of.values())
    counts = Counter(next(iter(s)) for s in split_of.values())
    assert counts == {"train": 18, "val": 6, "test": 6}


def test_hard_negatives_are_minimal_edits_of_their_satisfying_trace(low) -> None:
    rows = _rows(low["traces"])
    dfas = read_dfas(low["dfas"])
    hard = [(rows[i - 1], r) for i, r in enumerate(rows) if r["source"] == "hard"]
    assert len(hard) >= 30
    for sat, neg in hard[:60]:
        assert sat["label"] and not neg["label"] and sat["formula_id"] == neg["formula_id"]
        dfa = dfas.dfa(sat["formula_id"])
        diff = sum(a != b for a, b in zip(sat["trace"], neg["trace"], strict=True))
        assert diff >= 1
        if diff > 1:  # then no single change may be enough
            letters = [set(c) for k in range(4) for c in itertools.combinations("abc", k)]
            for pos, letter in itertools.product(range(len(sat["trace"])), letters):
                edited = [set(x) for x in sat["trace"]]
                edited[pos] = letter
                assert dfa.accepts(edited), "a one-step edit was rejected, so diff was not minimal"


def test_formulas_have_the_tier_shape_and_distinct_languages(low) -> None:
    sources = read_formulas(low["ltl"])
    assert len(sources) == 30 and sources[0].formula_id == "low-00000"
    dfas = []
    for s in sources:
        f = parse(s.text)
        assert len(atoms(f)) == 3 and syntax_tree_size(f) == 10
        dfas.append(compile_formula(s.text))
    for a, b in itertools.combinations(dfas, 2):
        assert a != b  # canonical minimal DFAs: equal tables would mean equal languages


@pytest.mark.parametrize("tier", ["moderate", "high"])
def test_other_tiers(tmp_path: Path, tier: str) -> None:
    out = tmp_path / "f.ltl"
    result = tleaf("gen-formulas", "--tier", tier, "-n", 8, "-o", out, "--seed", 1)
    assert result.exit_code == 0, result.output
    n_atoms, size = {"moderate": (3, 20), "high": (6, 20)}[tier]
    for s in read_formulas(out):
        f = parse(s.text)
        assert len(atoms(f)) == n_atoms and syntax_tree_size(f) == size
    assert "synthetic" in out.read_text().splitlines()[0].lower()


def test_rejects_formulas_that_teach_nothing(tmp_path: Path) -> None:
    from tleaf_cli.data.formula_gen import judge

    assert judge(compile_formula("a & !a"), 2, 12, False) == "unsatisfiable"
    assert judge(compile_formula("a | !a"), 2, 12, False) == "valid"
    assert judge(compile_formula("X X X X X X X X X X X X X a"), 2, 12, False) == (
        "too few traces at the trace lengths"
    )
    assert judge(compile_formula("G(a -> F b)"), 2, 12, False) is None
    # "G a" has one satisfying trace per length: 11 pairs at lengths 2..12, not 20.
    assert judge(compile_formula("G a"), 2, 12, False, pairs=11) is None
    assert judge(compile_formula("G a"), 2, 12, False, pairs=12) == (
        "too few traces at the trace lengths"
    )


def test_seeds_and_jobs(tmp_path: Path, low) -> None:
    base = ["gen-traces", low["dfas"], "--per-formula", 10, "--split", "0.6,0.2,0.2"]
    a, b = tmp_path / "a.parquet", tmp_path / "b.parquet"
    assert tleaf(*base, "-o", a, "--seed", 3, "--jobs", 2).exit_code == 0
    assert tleaf(*base, "-o", b, "--seed", 4).exit_code == 0
    assert pq.read_table(a).equals(pq.read_table(low["traces"]))  # jobs 2 == jobs 1, same seed
    assert not pq.read_table(b).equals(pq.read_table(a))
    f1, f2 = tmp_path / "1.ltl", tmp_path / "2.ltl"
    tleaf("gen-formulas", "--tier", "low", "-n", 10, "-o", f1, "--seed", 9)
    tleaf("gen-formulas", "--tier", "low", "-n", 10, "-o", f2, "--seed", 9, "--jobs", 2)
    assert f1.read_text() == f2.read_text()


def test_shortfall_is_reported_not_padded(tmp_path: Path) -> None:
    src = tmp_path / "f.ltl"
    src.write_text("G a\nG(a -> F b)\n")
    dfas, out = tmp_path / "d.parquet", tmp_path / "t.parquet"
    tleaf("compile-dfa", src, "-o", dfas)
    result = tleaf("gen-traces", dfas, "-o", out, "--per-formula", 20)
    assert result.exit_code == 1
    assert "L1" in result.output and "only 11 of 20" in result.output
    counts = Counter(r["formula_id"] for r in _rows(out))
    assert counts == {"L1": 22, "L2": 40}


def test_one_hot_traces(tmp_path: Path) -> None:
    src = tmp_path / "f.ltl"
    src.write_text("(!b U a) | G !b\nG(a -> F c)\n")
    dfas, out = tmp_path / "d.parquet", tmp_path / "t.parquet"
    tleaf("compile-dfa", src, "-o", dfas)
    assert tleaf("gen-traces", dfas, "-o", out, "--one-hot", "--per-formula", 8).exit_code == 0
    rows = _rows(out)
    assert rows and all(len(step) <= 1 for r in rows for step in r["trace"])


def test_once_each_traces_read_every_atom_once(tmp_path: Path) -> None:
    """--once-each: every trace holds each atom of its formula exactly once (plus "none" steps),
    labels agree with the evaluator, and hard negatives are a satisfying trace with two steps
    swapped."""
    src = tmp_path / "f.ltl"
    src.write_text("((!b U a) | G !b) & ((!c U b) | G !c) & ((!e U d) | G !e)\nG(a -> F c)\n")
    dfas, out = tmp_path / "d.parquet", tmp_path / "t.parquet"
    tleaf("compile-dfa", src, "-o", dfas, "--one-hot")
    result = tleaf(
        "gen-traces", dfas, "-o", out, "--once-each", "--per-formula", 6, "--max-none", 2
    )
    assert result.exit_code == 0, result.output
    rows = _rows(out)
    formulas = {f.formula_id: f.text for f in read_formulas(src)}
    assert Counter(r["label"] for r in rows) == {True: 12, False: 12}
    for r in rows:
        steps = [s[0] for s in r["trace"] if s]
        assert sorted(steps) == sorted(atoms(parse(formulas[r["formula_id"]])))
        assert len(r["trace"]) - len(steps) <= 2
        assert (
            satisfies([set(s) for s in r["trace"]], parse(formulas[r["formula_id"]]))
            == (r["label"])
        )
    satisfying = [r["trace"] for r in rows if r["label"]]
    for r in (r for r in rows if r["source"] == "hard"):
        assert any(
            sum(a != b for a, b in zip(r["trace"], s, strict=True)) == 2
            for s in satisfying
            if len(s) == len(r["trace"])
        )


@pytest.mark.parametrize("once_each", [True, False], ids=["once-each", "sampled"])
def test_a_formula_every_trace_satisfies_is_skipped_and_counted(
    tmp_path: Path, once_each: bool
) -> None:
    """kb-extract writes the rule set `true` for videos no rule applies to: no trace violates it,
    so it has no pairs. gen-traces says it is always true and skips it (exit 0), instead of
    reporting it as a formula short of pairs (exit 1); a tautology is the same language."""
    from tleaf_cli.data.traces import generate_traces
    from tleaf_cli.settings.data import TraceSettings

    src = tmp_path / "f.ltl"
    src.write_text("rs-empty: true\nrule: (!b U a) | G !b\ntaut: a | !a\n")
    dfas, out = tmp_path / "d.parquet", tmp_path / "t.parquet"
    assert tleaf("compile-dfa", src, "-o", dfas, "--one-hot").exit_code == 0
    flag = ["--once-each"] if once_each else ["--one-hot"]
    result = tleaf("gen-traces", dfas, "-o", out, *flag, "--per-formula", 4)
    assert result.exit_code == 0, result.output
    assert "2 always true skipped (every trace satisfies them" in result.output, result.output
    assert "rs-empty, taut" in result.output and "short of 4 pairs" in result.output
    assert {r["formula_id"] for r in _rows(out)} == {"rule"}
    settings = TraceSettings(per_formula=4, one_hot=True, once_each=once_each)
    report = generate_traces(dfas, tmp_path / "t2.parquet", settings)
    assert report.always_true == ["rs-empty", "taut"] and report.short == []


def _chi_square_critical(df: int, z: float = 3.09) -> float:
    """Wilson-Hilferty approximation of the chi-square quantile (z=3.09: p = 0.001)."""
    return df * (1 - 2 / (9 * df) + z * math.sqrt(2 / (9 * df))) ** 3


def _chi_square(samples: list[tuple], support: list[tuple]) -> float:
    counts = Counter(samples)
    expected = len(samples) / len(support)
    return sum((counts.get(w, 0) - expected) ** 2 / expected for w in support)


def test_satisfying_traces_are_uniform_among_accepted_words() -> None:
    """Chi-square on a DFA whose accepted words of length 4 can be enumerated."""
    dfa = compile_formula("(a U b) | G(a -> X c)")
    length = 4
    letters = range(dfa.alphabet.size)
    support = [w for w in itertools.product(letters, repeat=length) if dfa.accepting[dfa.run(w)]]
    sampler = WordSampler(dfa, length)
    assert sampler.counts(True)[length] == len(support)
    n = 40 * len(support)
    rng = np.random.default_rng(0)
    samples = [tuple(w) for w in sampler.sample(rng, length, True, n)]
    assert set(samples) <= set(support)
    critical = _chi_square_critical(len(support) - 1)
    assert _chi_square(samples, support) < critical
    # The test has teeth: a random walk over letters that can still reach acceptance is not
    # uniform over words, and fails it.
    walk = []
    completions, _ = sampler.accepting  # count[t, s] (unscaled at these lengths)
    pyrng = random.Random(0)
    for _ in range(n):
        s, w = dfa.initial, []
        for t in range(length):
            ok = [x for x in letters if completions[length - t - 1, dfa.table[s, x]] > 0]
            x = pyrng.choice(ok)
            w.append(x)
            s = dfa.table[s, x]
        walk.append(tuple(w))
    assert _chi_square(walk, support) > critical


def test_inspect_stats(low) -> None:
    dfas = tleaf("inspect", low["dfas"], "--stats")
    assert dfas.exit_code == 0 and "compiled 30, failed 0" in dfas.output
    traces = tleaf("inspect", low["traces"], "--stats")
    assert traces.exit_code == 0
    assert "label: False 300, True 300" in traces.output
    assert "split: test 120, train 360, val 120" in traces.output


def test_long_traces_over_large_alphabets_do_not_overflow() -> None:
    """64 letters, length 300: about 2**1800 words, far past float64; counts stay usable."""
    dfa = compile_formula("G(a -> F b) & F(c & d & e & f)")
    sampler = WordSampler(dfa, 300)
    assert np.isinf(sampler.counts(True)[300]) and np.isinf(sampler.counts(False)[300])
    words = sampler.sample(np.random.default_rng(0), 300, True, 5)
    assert all(dfa.accepting[dfa.run(w)] for w in words)
    hard = sampler.nearest_rejected(np.random.default_rng(0), words[0])
    assert not dfa.accepting[dfa.run(hard)]
