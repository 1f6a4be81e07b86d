"""Each Declare template defined once: the miner's direct check and counts of every template of
knowledge/templates.py equal what the template's LTLf formula says (logic/semantics.py on one-hot
traces), and every implication the miner prunes by holds on every case."""

from __future__ import annotations

import itertools
from functools import cache

from hypothesis import given, settings
from hypothesis import strategies as st

from tleaf_cli.knowledge.declare import ALL_TEMPLATES, measure_declare, mine_declare
from tleaf_cli.knowledge.declare_constraints import CaseView, Constraint, activating
from tleaf_cli.knowledge.declare_implied import implying, redundant, stronger
from tleaf_cli.knowledge.templates import TEMPLATES
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.semantics import satisfies
from tleaf_cli.settings.declare import DECLARE_TEMPLATES

ATOMS = ("a", "b", "c", "d")
logs = st.lists(st.lists(st.sampled_from(ATOMS), min_size=1, max_size=7), min_size=1, max_size=10)
# every case of up to 5 steps over three activities
UNIVERSE = [t for n in range(1, 6) for t in itertools.product(ATOMS[:3], repeat=n)]


@cache
def _formula(text: str):
    return parse(text)


def _holds(formula: str, case) -> bool:
    return satisfies([{x} for x in case], _formula(formula))


def _every_constraint(atoms=ATOMS) -> list[Constraint]:
    out = []
    for key, t in TEMPLATES.items():
        pairs = [(x,) for x in atoms] if t.arity == 1 else itertools.permutations(atoms, 2)
        out += [Constraint(key, p) for p in pairs]
    return out


def test_every_template_is_checked_and_written_as_its_formula() -> None:
    """A constraint's formula is its template's (templates.py), parentheses aside; its direct
    check says what the formula says on every case of up to 5 steps."""
    for c in _every_constraint(ATOMS[:3]):
        assert _formula(c.formula) == parse(c.declare.ltlf(*c.activities)), c
    views = [CaseView.of(case) for case in UNIVERSE]
    for c in _every_constraint(ATOMS[:2]):  # a, b: every case says something of both
        got = [c.holds_on(v) for v in views]
        assert got == [_holds(c.formula, case) for case in UNIVERSE], c


@settings(max_examples=40, deadline=None)
@given(logs)
def test_every_templates_counts_are_its_formulas(cases) -> None:
    """For every template (all 24), the miner's counts on random logs (over all of ATOMS, so
    absent activities and vacuous cases are covered) are the formula's: satisfied cases,
    activated cases (and every case that does not activate it satisfies it), confidence."""
    for m in measure_declare(cases, templates=DECLARE_TEMPLATES, activities=ATOMS):
        c = m.constraint
        sat = [_holds(c.formula, case) for case in cases]
        assert [c.holds(case) for case in cases] == sat, c
        assert m.satisfied == sum(sat), (c, cases)
        if c.activation is None:
            assert m.activated == m.cases and m.confidence == m.support
            continue
        act = [_holds(c.activation, case) for case in cases]
        assert [c.activated(case) for case in cases] == act, c
        assert m.activated == sum(act), c
        assert all(s for s, a in zip(sat, act, strict=True) if not a), c  # vacuous: satisfied
        ok = sum(s and a for s, a in zip(sat, act, strict=True))
        assert m.confidence == (ok / m.activated if m.activated else 1.0)


def test_activation_is_the_templates_and_both_where_declare_has_both() -> None:
    """templates.py's activating argument; both for the co-existences (symmetric) and the
    successions (a b without an a breaks them)."""
    both = {k for k in TEMPLATES if activating(k) == (0, 1)}
    assert both == {
        "co_existence", "not_co_existence", "succession", "alternate_succession",
        "chain_succession",
    }  # fmt: skip
    for key, t in TEMPLATES.items():
        if t.activation is None:
            assert activating(key) == ()  # unary, choice, exclusive choice: every case
        elif key not in both:
            assert activating(key) == (t.activation,)


@settings(max_examples=40, deadline=None)
@given(logs)
def test_each_stated_implication_holds_on_every_case(cases) -> None:
    """Every `stronger` implication (declare_implied's docstring): the implied rule holds on
    every case the implying rule holds on, by the formulas, on random logs and on every case of
    up to 5 steps (by the checks, equal to the formulas above)."""
    for c in _every_constraint(ATOMS[:3]):
        for s in stronger(c):
            for case in cases:
                assert _holds(s.formula, case) <= _holds(c.formula, case), (s, c, case)
    views = [CaseView.of(case) for case in UNIVERSE]
    for c in _every_constraint(ATOMS[:3]):
        for s in implying(c):
            assert all(s.holds_on(v) <= c.holds_on(v) for v in views), (s, c)
        assert c not in implying(c)  # no rule drops itself (nor two rules each other)


def test_todays_pruning_is_kept() -> None:
    """On the ten default templates the implications are those tleaf pruned by before."""
    a, b = "a", "b"
    expected = {
        Constraint("existence", (a,)): {("init", (a,)), ("end", (a,)), ("exactly", (a,))},
        Constraint("response", (a, b)): {
            ("succession", (a, b)), ("chain_response", (a, b)), ("end", (b,)),
        },
        Constraint("precedence", (a, b)): {("succession", (a, b)), ("init", (a,))},
        Constraint("not_co_existence", (a, b)): {("absence", (a,)), ("absence", (b,))},
    }  # fmt: skip
    from tleaf_cli.knowledge.declare import DEFAULT_TEMPLATES

    for c in _every_constraint((a, b)):
        if c.template in DEFAULT_TEMPLATES and c.activities in {(a,), (a, b)}:
            within = {(s.template, s.activities) for s in implying(c)}
            within = {x for x in within if x[0] in DEFAULT_TEMPLATES}
            assert within == expected.get(c, set()), c


@settings(max_examples=60, deadline=None)
@given(logs, st.sampled_from((0.0, 0.3, 0.6, 0.9)), st.sampled_from((0.0, 0.5, 0.9)))
def test_all_templates_mined_none_implied_by_another(cases, sup, conf) -> None:
    """With every template: the kept rules pass the thresholds, none is implied by another kept
    one, and every rule that passed but was dropped is implied by a kept one."""
    mined = mine_declare(cases, min_support=sup, min_confidence=conf, templates=ALL_TEMPLATES)
    kept = {m.constraint for m in mined}
    assert not redundant(kept)
    passed = {
        m.constraint
        for m in measure_declare(cases, ALL_TEMPLATES)
        if m.support >= sup and m.confidence >= conf
        and (m.activated >= 1 or m.constraint.activation is None)
    }  # fmt: skip
    assert kept <= passed
    assert all(implying(c) & kept for c in passed - kept)
    assert {m.constraint.template for m in mined} <= set(ALL_TEMPLATES)
