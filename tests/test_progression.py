"""The in-process compile path: progression against MONA, and what makes it fast.

Both routes end in the canonical minimal DFA (`DFA.minimize` numbers the states of one language
the same way), so equal tables mean equal languages on non-empty traces: every comparison here is
language equality, not a sample of traces. tests/test_differential.py checks the default route
(now progression) against the direct LTLf evaluator as well.
"""

from __future__ import annotations

import itertools
import os
import random
import subprocess
import sys
import time

import numpy as np
import pytest

from tests.test_differential import OPERATORS, PATTERNS
from tleaf_cli.data.dfa_table import dfa_payload
from tleaf_cli.data.parallel import parallel_map
from tleaf_cli.data.random_formulas import random_formula
from tleaf_cli.logic import compile as compile_mod
from tleaf_cli.logic import dfa as dfa_mod
from tleaf_cli.logic import mona
from tleaf_cli.logic.alphabet import Alphabet
from tleaf_cli.logic.compile import compile_formula, compile_parsed
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.formulas import atoms, parse
from tleaf_cli.logic.grammar import read_formula
from tleaf_cli.logic.progression import Limits, TooLarge, progression_dfa

KINDS = ("powerset", "one-hot")


def _same_as_mona(text: str, kinds=KINDS) -> None:
    formula = parse(text)
    for kind in kinds:
        ours = progression_dfa(formula, Alphabet(atoms(formula), kind))
        reference = compile_parsed(formula, kind, engine="mona")
        assert ours == reference, f"{kind} DFA of {text!r}: progression differs from MONA"


@pytest.mark.parametrize("text", OPERATORS + sorted(PATTERNS.values()))
def test_every_operator_and_pattern_equals_mona(text: str) -> None:
    _same_as_mona(text)


@pytest.mark.slow
def test_thousands_of_random_formulas_equal_mona() -> None:
    """1,200 random formulas over 1-3 atoms (sizes up to 20, both alphabets) and 150 over 5-6
    atoms, whose top-level & and | take the product route."""
    rng = random.Random(17)
    texts = []
    for _ in range(1200):
        n = rng.choice([1, 2, 3, 3, 3])
        texts.append(random_formula(rng, "abc"[:n], rng.randint(2 * n - 1, 20)))
    assert len(set(texts)) > 1000
    for k, text in enumerate(texts):
        _same_as_mona(text, KINDS if k % 4 == 0 else ("powerset",))
    for _ in range(150):
        n = rng.choice([5, 6])
        parts = [random_formula(rng, rng.sample("abcdef"[:n], 2), 5) for _ in range(3)]
        text = f" {rng.choice(['&', '|'])} ".join(f"({p})" for p in parts)
        _same_as_mona(text, KINDS)


def test_pattern_conjunctions_over_eight_atoms_equal_mona() -> None:
    a = [f"a{i}" for i in range(1, 9)]
    mixed = [
        f"G({p} -> F({q}))" if k % 2 == 0 else f"((!({q}) U {p}) | G(!({q})))"
        for k, (p, q) in enumerate(itertools.pairwise(a))
    ]
    _same_as_mona(" & ".join(mixed))


def test_alphabet_larger_than_the_formula_and_folded_atoms() -> None:
    # `b & false` folds to false: b is gone from the NNF but still makes letters.
    _same_as_mona("a U (b & false)")
    formula = parse("F a")
    wide = progression_dfa(formula, Alphabet(("a", "b"), "powerset"))
    assert wide.alphabet.atoms == ("a", "b") and wide.accepts([{"b"}, {"a", "b"}])
    assert not wide.accepts([{"b"}])


def test_limits_raise_too_large_and_auto_falls_back_to_mona(monkeypatch) -> None:
    slow = "F(a & " + "X(" * 12 + "last" + ")" * 12 + ")"  # 2^12 states before the end
    with pytest.raises(TooLarge, match="limit of 2,000 states"):
        compile_formula(slow, engine="progression")
    calls = []
    real = mona.run_mona
    monkeypatch.setattr(mona, "run_mona", lambda *a, **k: calls.append(1) or real(*a, **k))
    dfa = compile_formula(slow)  # auto
    assert calls == [1] and dfa.num_states > 2_000
    compile_formula("G(a -> F b)")
    assert calls == [1]  # progression handled it, no MONA


def test_auto_routes_by_counted_work_not_by_the_clock(monkeypatch) -> None:
    """Under "auto" a formula goes to MONA past AUTO_WORK units of work in one construction: a
    count, the same on every run, machine and load, exactly at its boundary; a clock that runs
    an hour per reading changes no route."""
    formula = parse("G(F a <-> (F b <-> X(F c <-> X F d)))")  # one construction, DNFs blow up
    letters = Alphabet(atoms(formula), "powerset")
    counts = []
    for _ in range(2):
        limits = Limits()
        progression_dfa(formula, letters, limits)
        counts.append(limits.work_done)
    work = counts[0]
    assert counts == [work, work] and work > compile_mod.AUTO_WORK
    progression_dfa(formula, letters, Limits(max_direct_work=work))  # just enough
    with pytest.raises(TooLarge, match="units of work in one construction"):
        progression_dfa(formula, letters, Limits(max_direct_work=work - 1))
    now = [0.0]

    def hour_per_reading() -> float:
        now[0] += 3600.0
        return now[0]

    for clock in ("perf_counter", "monotonic", "time", "process_time", "thread_time"):
        monkeypatch.setattr(time, clock, hour_per_reading)
    assert compile_mod.by_progression(formula, "powerset", "auto") is None  # MONA's
    assert compile_mod.by_progression(formula, "powerset", "progression") is not None
    small = parse("G(a -> F b) & (!b U a)")
    assert compile_mod.by_progression(small, "powerset", "auto") is not None  # progression's


def test_unknown_engine_is_a_setting_error() -> None:
    from tleaf_cli.errors import SettingError

    with pytest.raises(SettingError, match="engine"):
        compile_formula("a", engine="fast")  # type: ignore[arg-type]


def test_compile_stage_engines_write_the_same_rows(tmp_path) -> None:
    from tleaf_cli.data import compile_dfas

    rng = random.Random(3)
    lines = [random_formula(rng, "abc", rng.randint(5, 15)) for _ in range(40)]
    lines += ["a & (b", "F(a & " + "X(" * 12 + "last" + ")" * 12 + ")"]
    src = tmp_path / "f.ltl"
    src.write_text("\n".join(lines) + "\n")
    rows = {}
    for engine in compile_mod.ENGINES:
        settings = compile_dfas.CompileSettings(cache_dir=None, engine=engine, jobs=2)
        rows[engine] = compile_dfas.compile_sources(compile_dfas.read_formulas(src), settings).rows
    assert rows["auto"] == rows["mona"]
    assert rows["progression"][:-1] == rows["mona"][:-1]
    assert "limit of 2,000 states" in rows["progression"][-1]["error"]


# ------------------------------------------------------------------------ minimisation
def _random_dfa(rng: np.random.Generator, atoms_max: int = 3) -> DFA:
    n = int(rng.integers(1, 40))
    alphabet = Alphabet(tuple("abcdefgh"[: int(rng.integers(0, atoms_max + 1))]))
    # Few distinct successors per row, so that states merge.
    base = rng.integers(0, n, size=(n, 1))
    noise = rng.integers(0, n, size=(n, alphabet.size))
    table = np.where(rng.random((n, alphabet.size)) < 0.8, base, noise)
    return DFA(alphabet, table, int(rng.integers(0, n)), rng.random(n) < rng.random())


def _two_variant_nonempty(dfa: DFA) -> DFA:
    """minimize_nonempty as first written: both choices minimised in full, the smaller kept."""
    table = np.vstack([dfa.table, dfa.table[dfa.initial][None, :]])
    variants = [
        DFA(dfa.alphabet, table, dfa.num_states, np.append(dfa.accepting, e)).minimize()
        for e in (False, True)
    ]
    return min(variants, key=lambda d: d.num_states)


def test_small_and_array_minimisation_agree(monkeypatch) -> None:
    rng = np.random.default_rng(0)
    for _ in range(500):
        dfa = _random_dfa(rng)
        monkeypatch.setattr(dfa_mod, "SMALL_TABLE", 10**9)
        small = (dfa.minimize(), dfa.minimize_nonempty())
        monkeypatch.setattr(dfa_mod, "SMALL_TABLE", -1)
        array = (dfa.minimize(), dfa.minimize_nonempty())
        assert small == array
        assert array[1] == _two_variant_nonempty(dfa)
        assert dfa.minimize().minimize_nonempty(minimal=True) == array[1]


def test_hashed_row_classes_are_exact_even_when_hashes_collide(monkeypatch) -> None:
    rng = np.random.default_rng(1)
    dfas = [_random_dfa(rng, atoms_max=7) for _ in range(60)]
    monkeypatch.setattr(dfa_mod, "SMALL_TABLE", -1)
    monkeypatch.setattr(dfa_mod, "HASHED_ROW_WIDTH", 10**9)
    exact = [d.minimize() for d in dfas]
    monkeypatch.setattr(dfa_mod, "HASHED_ROW_WIDTH", 0)
    assert [d.minimize() for d in dfas] == exact
    # Every row hashed alike: the grouping check fails and the exact route decides.
    monkeypatch.setattr(dfa_mod, "_row_weights", lambda width: np.zeros(width, np.uint64))
    assert [d.minimize() for d in dfas] == exact


def test_payload_guards_unchanged_for_a_product_dfa() -> None:
    """Guards are cut per table row and ISOP skips trivial calls: same texts and CNFs as one
    guard per edge from its letter vector."""
    from tleaf_cli.logic.guards import guard_for

    dfa = compile_formula("G(a -> F b) & ((!d U c) | G !d) & G(e -> X f)")
    payload = dfa_payload(dfa)
    expected = [(s, d, guard_for(mask, dfa.alphabet)) for s, d, mask in dfa.edges()]
    got = [(e["src"], e["dst"], e["guard"], e["cnf"]) for e in payload["edges"]]
    assert got == [(s, d, g.text, g.cnf) for s, d, g in expected]


# ----------------------------------------------------------------------------- parsing
def _shape(f) -> tuple:
    kids = getattr(f, "formulas", None) or ([f.f] if hasattr(f, "f") else [])
    return (type(f).__name__, str(f), tuple(_shape(k) for k in kids))


def test_fast_reader_builds_what_lark_builds_or_declines() -> None:
    from ltlf2dfa.parser.ltlf import LTLfParser

    lark = LTLfParser()
    tokens = ["a", "b", "x1", "y_2", "true", "false", "last", "True", "LAST", "trueish", "lasts",
              "!", "~", "X", "WX", "F", "G", "U", "R", "&", "&&", "|", "||", "->", "=>", "<->",
              "<=>", "(", ")", "(", ")", "Fa", "aX", "1", "W", "^"]  # fmt: skip
    rng = random.Random(5)
    decided = valid = 0
    for i in range(6000):
        if i % 2:
            text = "".join(rng.choice(tokens) + rng.choice(["", " "]) for _ in range(12))
        else:
            text = random_formula(rng, "abc", rng.randint(5, 15))
            text = text.replace("(", " ( ").replace(")", " ) ") if i % 4 == 0 else text
        try:
            expected = _shape(lark(text))
        except Exception:
            expected = None
        ours = read_formula(text)
        valid += expected is not None
        if ours is not None:
            decided += 1
            assert _shape(ours) == expected, text
    assert decided > 0.95 * valid  # it does take the common case
    assert read_formula("a -> b -> c") is not None and read_formula("TRUE") is None


def test_sympy_is_not_imported_and_to_dfa_still_works() -> None:
    code = (
        "import sys; import tleaf_cli.logic.compile as c; c.compile_formula('G(a -> F b)'); "
        "print('sympy' in sys.modules); "
        "from ltlf2dfa.parser.ltlf import LTLfParser; "
        "print('digraph' in LTLfParser()('F a').to_dfa())"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True,
        cwd=os.path.dirname(os.path.dirname(__file__)),
    ).stdout.split()  # fmt: skip
    assert out == ["False", "True"]


# ---------------------------------------------------------------------- shared work
def _pid_and_square(x: int) -> tuple[int, int]:
    return os.getpid(), x * x


def test_shared_work_keeps_order_and_this_process_works_too() -> None:
    items = [(k,) for k in range(2000)]
    results = list(parallel_map(_pid_and_square, items, jobs=2, share_work=True))
    assert [r[1] for r in results] == [k * k for k in range(2000)]
    assert os.getpid() in {r[0] for r in results}  # chunks no worker had started ran here
