"""Declare mining (knowledge/declare.py) against LTLf semantics: every template's counts, checked
on the sequences, equal what tleaf's reference evaluator says of the template's formula."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tleaf_cli.data.formula_files import parse_ltl_text
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.declare import (
    TEMPLATES,
    Constraint,
    declare_text,
    holding_shares,
    measure_declare,
    mine_declare,
)
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.semantics import satisfies

ATOMS = ("a", "b", "c", "d")
logs = st.lists(st.lists(st.sampled_from(ATOMS), min_size=1, max_size=7), min_size=1, max_size=12)


def one_hot(case: list[str]) -> list[set[str]]:
    return [{x} for x in case]


@settings(max_examples=60, deadline=None)
@given(logs)
def test_measured_counts_are_the_formulas_counts(cases) -> None:
    """Support and activation of every constraint equal the semantic counts of its formulas,
    over all of ATOMS (so absent activities and vacuous cases are covered)."""
    for m in measure_declare(cases, activities=ATOMS):
        c = m.constraint
        formula = parse(c.formula)
        sat = [satisfies(one_hot(case), formula) for case in cases]
        assert m.satisfied == sum(sat), (c, cases)
        assert [c.holds(case) for case in cases] == sat, c
        if c.activation is not None:
            act = [satisfies(one_hot(case), parse(c.activation)) for case in cases]
            assert m.activated == sum(act), c
            assert [c.activated(case) for case in cases] == act, c
            ok = sum(s and a for s, a in zip(sat, act, strict=True))
            assert m.confidence == pytest.approx(ok / m.activated if m.activated else 1.0)


@settings(max_examples=40, deadline=None)
@given(logs, st.sampled_from((0.0, 0.5, 0.8, 1.0)), st.sampled_from((0.0, 0.7, 1.0)))
def test_mined_rules_pass_the_thresholds_and_none_is_implied_by_another(cases, sup, conf) -> None:
    mined = mine_declare(cases, min_support=sup, min_confidence=conf)
    kept = {m.constraint for m in mined}
    for m in mined:
        formula = parse(m.constraint.formula)
        assert m.support >= sup and m.confidence >= conf
        assert m.support == sum(satisfies(one_hot(c), formula) for c in cases) / len(cases)
        if m.constraint.activation is not None:
            assert m.activated >= 1  # never kept on vacuous satisfaction alone
    for c in kept:
        a, *b = c.activities
        if c.template in ("response", "precedence"):
            assert Constraint("succession", (a, *b)) not in kept
        if c.template == "existence":
            assert not {Constraint(t, (a,)) for t in ("init", "end", "exactly_once")} & kept


@settings(max_examples=30, deadline=None)
@given(logs)
def test_dropped_rules_are_implied_on_every_case(cases) -> None:
    """What redundancy drops holds on every case where the rule that drops it holds: the
    conjunction of the mined rules means the same with or without it."""
    everything = {m.constraint for m in mine_declare(cases, min_support=0, min_confidence=0)}
    candidates = {
        m.constraint
        for m in measure_declare(cases)
        if m.activated >= 1
        or m.constraint.template in ("existence", "absence", "exactly_once", "init", "end")
    }
    dropped = candidates - everything
    universe = [list(x) for x in {tuple(c) for c in cases}] + [["a", "b"], ["b"], ["c", "a"]]
    for c in dropped:
        assert any(all(k.holds(case) <= c.holds(case) for case in universe) for k in everything), c


def test_a_log_with_a_clear_process_gives_its_rules() -> None:
    cases = [["register", "check", "decide", "notify"]] * 8 + [["register", "decide", "notify"]] * 2
    names = {m.constraint.name for m in mine_declare(cases, min_support=0.9, min_confidence=0.9)}
    assert "init.register" in names and "end.notify" in names
    assert "succession.check.decide" not in names  # decide without check in 2 cases: precedence
    assert "chain_response.check.decide" in names
    assert "response.check.decide" not in names  # implied by the chain response
    assert "existence.register" not in names  # implied by init.register
    assert "response.register.notify" not in names  # implied by end.notify


def test_the_file_reads_back_with_each_rule_named_and_measured() -> None:
    cases = [["a", "b"], ["a", "c", "b"], ["a"]]
    mined = mine_declare(cases, min_support=0.6, min_confidence=0.6)
    text = declare_text(mined, ["mined from 3 cases"])
    rules = parse_ltl_text(text)
    assert [r.formula_id for r in rules] == [m.constraint.name for m in mined]
    assert all(r.problem is None for r in rules)
    rule_lines = [x for x in text.splitlines() if not x.startswith("#")]
    for line, m in zip(rule_lines, mined, strict=True):
        assert f"support {m.support:.4f}" in line


def test_holding_shares_on_other_cases() -> None:
    rule = Constraint("response", ("a", "b"))
    assert holding_shares([rule], [["a", "b"], ["b", "a"], ["c"], ["a"]]) == [0.5]


def test_bad_inputs_are_errors() -> None:
    with pytest.raises(InputError, match="no cases"):
        mine_declare([])
    with pytest.raises(InputError, match="at least one event"):
        mine_declare([["a"], []])
    with pytest.raises(InputError, match="unknown Declare template 'respond'"):
        mine_declare([["a"]], templates=["respond"])
    assert set(TEMPLATES) >= {"existence", "succession", "not_coexistence"}
