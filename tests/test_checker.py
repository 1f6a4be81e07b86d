"""The batched checker agrees with running each trace through its DFA one step at a time."""

from __future__ import annotations

import random

import numpy as np

from tleaf_cli.data.random_formulas import random_formula
from tleaf_cli.logic.checker import PackedDFAs
from tleaf_cli.logic.compile import compile_formula


def test_many_dfas_many_traces_match_step_by_step_runs() -> None:
    rng = random.Random(3)
    dfas = [
        compile_formula(random_formula(rng, ["a", "b", "c"], rng.randint(5, 12)), kind)
        for kind in ("powerset", "one-hot")
        for _ in range(15)
    ]
    packed = PackedDFAs(dfas)
    gen = np.random.default_rng(3)
    n, width = 3000, 9
    which = gen.integers(0, len(dfas), n)
    lengths = gen.integers(1, width + 1, n)
    letters = np.full((n, width), -1, dtype=np.int32)
    for i in range(n):
        size = dfas[which[i]].alphabet.size
        letters[i, : lengths[i]] = gen.integers(0, size, lengths[i])
    got = packed.check(which, letters, lengths)
    expected = [
        bool(dfas[k].accepting[dfas[k].run(letters[i, : lengths[i]])]) for i, k in enumerate(which)
    ]
    assert got.tolist() == expected
    assert 0 < got.sum() < n  # a meaningful mix, not all one label


def test_traces_as_atom_sets_per_dfa_alphabet() -> None:
    d1, d2 = compile_formula("G(a -> F b)"), compile_formula("F(c & last)", "one-hot")
    packed = PackedDFAs([d1, d2])
    traces = [[{"a"}, {"b"}], [{"a"}], [{"a"}, {"c"}], [{"c"}, {"a"}], [{"b", "a"}]]
    which = [0, 0, 1, 1, 0]
    got = packed.check_traces(which, traces)
    assert got.tolist() == [True, False, True, False, True]
    assert got.tolist() == [[d1, d2][k].accepts(t) for k, t in zip(which, traces, strict=True)]
