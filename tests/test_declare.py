"""Declare mining (knowledge/declare.py) against LTLf semantics: every template's counts, checked
on the sequences, equal what tleaf's reference evaluator says of the template's formula."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tleaf_cli.data.formula_files import parse_ltl_text
from tleaf_cli.errors import ArgumentError, InputError, SettingError
from tleaf_cli.knowledge.declare import (
    ALL_TEMPLATES,
    DEFAULT_TEMPLATES,
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
            assert not {Constraint(t, (a,)) for t in ("init", "end", "exactly")} & kept


@settings(max_examples=150, deadline=None)
@given(logs, st.sampled_from((0.0, 0.3, 0.6, 0.9)), st.sampled_from((0.0, 0.5, 0.9)))
@example([["c"], ["c", "a", "c"], ["b", "a", "c"], ["b", "c", "a", "b"], ["a", "a"], ["c"]], 0.3, 0)
def test_dropped_rules_are_implied_on_every_case(cases, sup, conf) -> None:
    """Each rule that passed the thresholds but was dropped is implied, on every case (every
    sequence of up to 4 steps), by one rule that was kept: the conjunction of the mined rules
    means the same with or without it."""
    kept = {m.constraint for m in mine_declare(cases, min_support=sup, min_confidence=conf)}
    passed = {
        m.constraint
        for m in measure_declare(cases)
        if m.support >= sup
        and m.confidence >= conf
        and (m.activated >= 1 or m.constraint.activation is None)
    }
    assert kept <= passed
    universe = [list(t) for n in range(1, 5) for t in itertools.product(ATOMS, repeat=n)]
    for c in passed - kept:
        assert any(all(k.holds(case) <= c.holds(case) for case in universe) for k in kept), c


@settings(max_examples=80, deadline=None)
@given(logs, st.sampled_from((0.3, 0.6, 0.9, 1.0)))
def test_joint_support_keeps_the_conjunction_on_that_share(cases, joint) -> None:
    """With min_joint_support the kept rules' conjunction holds on at least that share of the
    cases, the rules are a subset of those mined without it, and every left-out rule would break
    the share if added to the rules of higher support kept before it (greedy by support)."""
    every = mine_declare(cases, min_support=0.5, min_confidence=0.5)
    kept = mine_declare(cases, min_support=0.5, min_confidence=0.5, min_joint_support=joint)
    assert [m.constraint for m in kept] == [m.constraint for m in every if m in kept]
    holding = [all(m.constraint.holds(c) for m in kept) for c in cases]
    assert sum(holding) >= joint * len(cases)
    chosen = {m.constraint for m in kept}
    order = sorted(every, key=lambda m: -m.support)
    for i, m in enumerate(order):
        if m.constraint in chosen:
            continue
        before = [o.constraint for o in order[:i] if o.constraint in chosen] + [m.constraint]
        assert sum(all(r.holds(c) for r in before) for c in cases) < joint * len(cases)


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
    other = Constraint("existence", ("a",))
    cases = [["a", "b"], ["b", "a"], ["c"], ["a"]]
    assert holding_shares([rule], cases) == ([0.5], 0.5)
    assert holding_shares([rule, other], cases) == ([0.5, 0.75], 0.25)  # only ["a", "b"]


def test_bad_inputs_are_errors() -> None:
    with pytest.raises(InputError, match="no cases"):
        mine_declare([])
    with pytest.raises(InputError, match="at least one event"):
        mine_declare([["a"], []])
    with pytest.raises(ArgumentError, match="templates: unknown Declare template 'respond'"):
        mine_declare([["a"]], templates=["respond"])
    with pytest.raises(ArgumentError, match=r"min_joint_support: .* 0 to 1, not 1\.5"):
        mine_declare([["a"]], min_joint_support=1.5)
    with pytest.raises(ArgumentError, match="templates: names 'exactly_once' twice"):
        mine_declare([["a"]], templates=["exactly", "exactly_once"])  # the old name of exactly


@pytest.mark.parametrize(
    ("call", "argument", "expected"),
    [
        (lambda: mine_declare("abc"), "cases", "sequence of cases"),
        (lambda: mine_declare(["abc"]), r"cases\[0\]", "the string 'abc'"),
        (lambda: mine_declare([["a", 3]]), r"cases\[0\]\[1\]", "must be an activity"),
        (lambda: mine_declare([["a"]], templates="init"), "templates", "the string 'init'"),
        (lambda: mine_declare([["a"]], templates=("init", "init")), "templates", "'init' twice"),
        (lambda: mine_declare([["a"]], min_activated=float("nan")), "min_activated", "int"),
        (lambda: mine_declare([["a"]], min_activated=-1), "min_activated", "at least 0"),
        (lambda: mine_declare([["a"]], min_support=float("nan")), "min_support", "not nan"),
        (lambda: mine_declare([["a"]], min_confidence="high"), "min_confidence", "number"),
        (lambda: mine_declare([["a"]], activities="ab"), "activities", "the string 'ab'"),
        (lambda: holding_shares([], "ab"), "cases", "sequence of cases"),
    ],
)
def test_wrong_arguments_are_refused_by_name(call, argument, expected) -> None:
    """A call that would mine from the letters of a string, measure a template twice or drop
    every relational rule on a NaN threshold raises an ArgumentError naming the argument."""
    with pytest.raises(ArgumentError, match=rf"^{argument}: .*{expected}"):
        call()


def test_a_template_named_twice_is_refused_before_any_work(tmp_path, chain_cli) -> None:
    """`--templates init,init,end` would write `init.x` twice, a file no later stage reads."""
    from tleaf_cli.settings.declare import DeclareSettings, templates

    with pytest.raises(SettingError, match=r"templates: .*'init' twice"):
        templates("init,init,end")
    with pytest.raises(SettingError, match=r"templates: .*'init' twice"):
        DeclareSettings(templates=("init", "init")).check()
    with pytest.raises(SettingError, match=r"templates: .*the string 'init'"):
        DeclareSettings(templates="init").check()  # type: ignore[arg-type]
    cases = _cases_artifact(tmp_path)
    out = tmp_path / "kb.ltl"
    bad = chain_cli("mine-declare", cases, "-o", out, "--templates", "init,init,end")
    assert bad.exit_code == 2 and "--templates" in bad.output and "twice" in bad.output
    assert not out.exists()


# ---- a log's knowledge, and the commands


def _cases_artifact(tmp_path):
    """A cases artifact of 30 cases, the first 20 train (file order), the last 10 test."""
    from tleaf_cli.data.event_logs import write_cases
    from tleaf_cli.data.log_readers import read_log
    from tleaf_cli.settings.event_logs import LogSettings

    rows = ["CaseID,ActivityID,CompleteTimestamp"]
    for case in range(30):
        acts = ["Open ticket", "Assign", "Resolve", "Close"]
        if case % 10 == 9:
            acts = ["Open ticket", "Resolve", "Close"]  # no assignment: 2 of 20 train, 1 of 10 test
        rows += [f"{case},{a},2020-01-01 00:{case:02d}:{k:02d}" for k, a in enumerate(acts)]
    log = tmp_path / "log.csv"
    log.write_text("\n".join(rows) + "\n")
    settings = LogSettings(split=(2 / 3, 0.0, 1 / 3), split_order="file")
    write_cases(read_log(log, settings), tmp_path / "cases.parquet", settings)
    return tmp_path / "cases.parquet"


def test_mine_log_writes_the_rules_and_their_test_support(tmp_path) -> None:
    from tleaf_cli.knowledge.log_knowledge import mine_log, support_table_path
    from tleaf_cli.settings.declare import DeclareSettings

    cases = _cases_artifact(tmp_path)
    found = mine_log(cases, tmp_path / "kb.ltl", DeclareSettings(min_activated=1))
    assert (found.train_cases, found.test_cases) == (20, 10)
    rules = {r.formula_id: r.text for r in parse_ltl_text((tmp_path / "kb.ltl").read_text())}
    assert rules["init.open_ticket"] == "open_ticket" and "end.close" in rules
    assert "succession.assign.resolve" in rules  # support 0.9: 2 train cases lack assign
    assert "precedence.assign.resolve" not in rules  # implied by the succession
    table = support_table_path(tmp_path / "kb.ltl").read_text().splitlines()
    assert table[0].split("\t")[-1] == "test_support"
    by_rule = {row.split("\t")[0]: row.split("\t") for row in table[1:]}
    assert list(by_rule) == list(rules)
    # assign once: 18 of 20 train cases, 9 of 10 test cases (implies existence.assign)
    assert by_rule["exactly.assign"][2] == "0.9000" and by_rule["exactly.assign"][-1] == "0.9000"
    assert "atom open_ticket = activity 'Open ticket'" in (tmp_path / "kb.ltl").read_text()
    assert found.test_joint == 0.9  # the test case without assign breaks exactly.assign
    jointly = mine_log(
        cases, tmp_path / "kb2.ltl", DeclareSettings(min_activated=1, min_joint_support=0.95)
    )
    names = {m.constraint.name for m in jointly.rules}
    assert "exactly.assign" not in names and "init.open_ticket" in names  # 18 of 20 < 0.95
    assert jointly.test_joint == 1.0


def test_no_rule_mined_says_why_and_counts_the_test_cases(tmp_path) -> None:
    """With no rule mined the summary says so, which thresholds stopped the candidates, and the
    test cases there are (not "no test cases")."""
    from tleaf_cli.knowledge.log_knowledge import mine_log
    from tleaf_cli.settings.declare import DeclareSettings

    cases = _cases_artifact(tmp_path)
    strict = DeclareSettings(min_activated=25, templates=("response", "chain_response"))
    found = mine_log(cases, tmp_path / "kb.ltl", strict)
    assert found.rules == [] and found.test_cases == 10
    text = found.summary()
    assert text.startswith("no rule mined from 20 train cases, 4 activities: ")
    assert "at least 25 activating cases" in text and "10 test cases" in text
    assert "no test cases" not in text
    assert "--" not in text  # the library never names a flag
    found = mine_log(cases, tmp_path / "kb.ltl", DeclareSettings(min_activated=1))
    assert found.summary().startswith(f"{len(found.rules)} rules from 20 train cases, 4 activities")
    assert "on the 10 test cases each holds on" in found.summary()


def test_mine_declare_command(tmp_path, chain_cli) -> None:
    cases = _cases_artifact(tmp_path)
    out = tmp_path / "kb.ltl"
    result = chain_cli("mine-declare", cases, "-o", out, "--templates", "init,end")
    assert result.exit_code == 0, result.output
    names = [r.formula_id for r in parse_ltl_text(out.read_text())]
    assert names == ["init.open_ticket", "end.close"]
    assert "2 rules" in result.output
    bad = chain_cli("mine-declare", cases, "-o", tmp_path / "x.ltl", "--templates", "respond")
    assert bad.exit_code == 2 and "--templates" in bad.output
    assert not (tmp_path / "x.ltl").exists()
    bad = chain_cli("mine-declare", cases, "-o", tmp_path / "x.ltl", "--min-support", "1.5")
    assert bad.exit_code == 2 and "--min-support" in bad.output


def test_peer_formulas_command(tmp_path, chain_cli) -> None:
    tsv = tmp_path / "formulas.tsv"
    tsv.write_text('log\tkind\tformula\tfrom\tto\nhelpdesk\tWEAK\t<>("8")\t2\t6\n')
    result = chain_cli("peer-formulas", tsv, "-o", tmp_path / "f.ltl")
    assert result.exit_code == 0, result.output
    rules = parse_ltl_text((tmp_path / "f.ltl").read_text())
    assert [(r.formula_id, r.text) for r in rules] == [("helpdesk.weak", "F(a8)")]
    result = chain_cli("peer-formulas", tsv, "-o", tmp_path / "g.ltl", "--log", "bpi_11")
    assert result.exit_code == 2 and "no formulas for log 'bpi_11'" in result.output
    tsv.write_text('log\tkind\tformula\nhelpdesk\tWEAK\t<>("8") &&\n')
    result = chain_cli("peer-formulas", tsv, "-o", tmp_path / "g.ltl")
    assert result.exit_code == 2 and "line 2" in result.output
    assert not (tmp_path / "g.ltl").exists()


def test_the_settings_know_the_templates() -> None:
    """settings/declare.py names the templates of templates.py (it may not import it), in its
    order; the old names are find_template's aliases; the default set is the ten of before."""
    from tleaf_cli.knowledge.templates import TEMPLATES, find_template
    from tleaf_cli.settings.declare import DECLARE_TEMPLATES, TEMPLATE_ALIASES

    assert tuple(TEMPLATES) == DECLARE_TEMPLATES
    assert set(DEFAULT_TEMPLATES) < set(ALL_TEMPLATES) < set(DECLARE_TEMPLATES)
    assert len(ALL_TEMPLATES) == 21 and "end" in ALL_TEMPLATES and "choice" in ALL_TEMPLATES
    for old, key in TEMPLATE_ALIASES.items():
        assert find_template(old) == (TEMPLATES[key], 1)
    assert [Constraint(t, ("a", "b")[: TEMPLATES[t].arity]).name.split(".")[0]
            for t in DEFAULT_TEMPLATES] == [
        "existence", "absence", "exactly", "init", "end", "response", "precedence",
        "succession", "chain_response", "not_co_existence",
    ]  # fmt: skip


def test_mine_declare_says_no_rule_was_mined_and_counts_the_test_cases(tmp_path) -> None:
    """Before: a log with test cases whose thresholds kept no rule printed "no test cases"."""
    from typer.testing import CliRunner

    from tests.test_next_activity import cases_artifact
    from tleaf_cli.cli import app

    cases = cases_artifact(tmp_path)
    result = CliRunner().invoke(
        app,
        ["mine-declare", str(cases), "-o", str(tmp_path / "kb.ltl"), "--templates",
         "response,chain_response", "--min-activated", "1000"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "no rule mined" in result.output and "no test cases" not in result.output
    assert "test cases" in result.output
