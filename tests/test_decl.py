"""Declare models (`.decl`, knowledge/decl.py): every template as RuM writes it, MP-Declare
conditions checked on hand-made traces by tleaf's LTLf evaluator, the forms of the peers'
published models, the lines refused, `.decl` wherever a formula file is read,
and docs/knowledge.md's template table against TEMPLATES."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.decl import DeclRule, parse_decl
from tleaf_cli.knowledge.rule_files import read_rule_file
from tleaf_cli.knowledge.templates import TEMPLATES
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.semantics import satisfies

ROOT = Path(__file__).resolve().parent.parent

HEAD = """activity Resolve ticket
bind Resolve ticket: org:resource
activity Closed
bind Closed: org:resource, amount
activity Accepted_In Progress
org:resource: Value 1, Value 2, Value 3,
 Value 4
amount: integer between 1 and 5
"""


def tleaf(*args: object):
    return CliRunner().invoke(app, [str(a) for a in args])


def rules(text: str) -> dict[str, str]:
    return {r.name: r.formula for r in parse_decl(text, "m.decl").rules()}


def rule(text: str, name: str) -> DeclRule:
    return {r.name: r for r in parse_decl(text, "m.decl").rules()}[name]


Event = tuple[str, dict[str, str]]


def event(activity: str, resource: str | None = None, amount: float | str | None = None) -> Event:
    """An event: its activity's atom and its attribute values (as a log writes them)."""
    values = {"org:resource": resource, "amount": None if amount is None else str(amount)}
    return activity, {k: v for k, v in values.items() if v is not None}


def holds(r: DeclRule, *trace: Event) -> bool:
    """The rule on a trace of events, each the letter of its activity's atom and the condition
    atoms whose test holds on its values."""
    letters = [
        {activity} | {atom for atom, test in r.conditions.items() if test.holds(values)}
        for activity, values in trace
    ]
    return satisfies(letters, parse(r.formula))


# ---------------------------------------------------------------------- templates


def rum_line(template, count: int = 1) -> str:
    name = template.name + (str(count) if template.counting and count != 1 else "")
    if template.arity == 1:
        return f"{name}[Resolve ticket] | |"
    return f"{name}[Resolve ticket, Accepted_In Progress] | | |"


@pytest.mark.parametrize("key", list(TEMPLATES))
def test_every_template_as_rum_writes_it(key: str) -> None:
    template = TEMPLATES[key]
    ((name, formula),) = rules(HEAD + rum_line(template) + "\n").items()
    args = ["resolve_ticket"] + (["accepted_in_progress"] if template.arity == 2 else [])
    assert name == ".".join([key, *args])
    assert formula == template.ltlf(*args)
    parse(formula)


@pytest.mark.parametrize(
    ("written", "name", "count"),
    [
        ("Existence2", "existence2", 2),
        ("Absence3", "absence3", 3),
        ("Exactly1", "exactly", 1),
        ("Absence", "absence", 1),
        ("Existence", "existence", 1),
    ],
)
def test_counting_templates_take_their_count(written: str, name: str, count: int) -> None:
    ((rule, formula),) = rules(HEAD + f"{written}[Closed] | |\n").items()
    template = TEMPLATES[name.rstrip("0123456789")]
    assert rule == f"{name}.closed"
    assert formula == template.ltlf("closed", n=count)


def test_a_name_that_repeats_gets_a_suffix_and_no_conditions_is_allowed() -> None:
    text = HEAD + "Existence[Closed]\nExistence[Closed] |A.org:resource is Value 3 |\n"
    assert list(rules(text)) == ["existence.closed", "existence.closed.2"]


# ---------------------------------------------------------------------- MP-Declare semantics


def test_existence_with_an_activation_condition() -> None:
    f = rule(HEAD + "Existence[Closed] |A.org:resource is Value 3 |\n", "existence.closed")
    assert holds(f, event("resolve_ticket", "Value 1"), event("closed", "Value 3"))
    assert not holds(f, event("resolve_ticket", "Value 3"), event("closed", "Value 1"))


def test_chain_precedence_narrows_its_activation_the_second_activity() -> None:
    """NeSy4PPM's rule: every Closed by Value 3 comes right after a Resolve ticket."""
    f = rule(
        HEAD + "Chain Precedence[Resolve ticket, Closed] |A.org:resource is Value 3 | |\n",
        "chain_precedence.resolve_ticket.closed",
    )
    assert holds(f, event("resolve_ticket", "Value 1"), event("closed", "Value 3"))
    assert holds(f, event("accepted_in_progress"), event("closed", "Value 1"))  # not activated
    assert not holds(f, event("accepted_in_progress"), event("closed", "Value 3"))
    assert not holds(f, event("closed", "Value 3"))


def test_response_with_activation_and_target_conditions() -> None:
    text = HEAD + (
        "Response[Resolve ticket, Closed] |A.org:resource in (Value 1, Value 2) "
        "|T.org:resource is not Value 4 and T.amount >= 4 |\n"
    )
    f = rule(text, "response.resolve_ticket.closed")
    assert holds(f, event("resolve_ticket", "Value 3"))  # not an activation
    assert not holds(f, event("resolve_ticket", "Value 2"))
    assert not holds(f, event("resolve_ticket", "Value 2"), event("closed", "Value 4", 5))
    assert not holds(f, event("resolve_ticket", "Value 2"), event("closed", "Value 1", 3))
    assert holds(f, event("resolve_ticket", "Value 1"), event("closed", "Value 1", 4))


@pytest.mark.parametrize(
    ("condition", "meets"),
    [
        ("A.amount < 3", {1, 2}),
        ("A.amount <= 3", {1, 2, 3}),
        ("A.amount = 3", {3}),
        ("A.amount != 3", {1, 2, 4, 5}),
        ("A.amount >= 4", {4, 5}),
        ("A.amount > 4.5", {5}),
        ("A.amount is 2 or A.amount is 5", {2, 5}),
        ("A.amount not in (1, 2)", {3, 4, 5}),
        ("(A.amount < 2 or A.amount > 4) and A.org:resource is Value 1", {1, 5}),
        ("not (A.amount in (1, 2, 3))", {4, 5}),
        ("true", {1, 2, 3, 4, 5}),
    ],
)
def test_numeric_and_combined_conditions(condition: str, meets: set[int]) -> None:
    f = rule(HEAD + f"Existence[Closed] |{condition} |\n", "existence.closed")
    for amount in range(1, 6):
        assert holds(f, event("closed", "Value 1", amount)) == (amount in meets), amount


def test_a_value_holding_and_or_spaces_is_read_whole() -> None:
    text = (
        "activity A\nbind A: dept\ndept: Research and Development, Sales or Marketing, R\n"
        "Existence[A] |A.dept is Research and Development or A.dept is R |\n"
    )
    f = rule(text, "existence.a")
    assert holds(f, ("a", {"dept": "Research and Development"})) and holds(f, ("a", {"dept": "R"}))
    assert not holds(f, ("a", {"dept": "Sales or Marketing"}))


# ---------------------------------------------------------------------- files and stages


def test_read_formulas_reads_decl_and_compile_dfa_runs_it(tmp_path: Path) -> None:
    example = ROOT / "examples" / "helpdesk.decl"
    sources = read_rule_file(example)
    assert [s.formula_id for s in sources][:3] == [
        "init.assign_seriousness",
        "end.closed",
        "exactly.closed",
    ]
    assert all(s.problem is None and s.location.startswith("line ") for s in sources)
    out = tmp_path / "d.parquet"
    done = tleaf("compile-dfa", example, "-o", out)
    assert done.exit_code == 0, done.output
    assert out.exists()


def test_bad_decl_exits_2_and_writes_nothing(tmp_path: Path) -> None:
    bad = tmp_path / "kb.decl"
    bad.write_text("activity A\nResponse[A, B] | | |\n")
    out = tmp_path / "d.parquet"
    done = tleaf("compile-dfa", bad, "-o", out)
    assert done.exit_code == 2
    assert f"{bad}: line 2: activity 'B' is not declared" in " ".join(done.output.split())
    assert not out.exists()


# the forms of the peers' published models (NeSy4PPM's background knowledge, Mezini et al.'s
# mined model): a domain continued on the next line, conditions on the resource, names with
# spaces and underscores
PEER_FORMS = """activity Resolve ticket
bind Resolve ticket: org:resource
activity Closed
bind Closed: org:resource
activity Accepted_In Progress
org:resource: Value 1, Value 2, Value 3,
 Value 4, Value 5
Existence[Closed] |A.org:resource is Value 3 |
Chain Precedence[Resolve ticket, Closed] |A.org:resource is Value 3 | |
Not Co-Existence[Accepted_In Progress, Closed] | | |
Response[Accepted_In Progress, Closed] | | |
"""


def test_the_peers_model_forms() -> None:
    model = parse_decl(PEER_FORMS, "bk.decl")
    assert len(model.activities) == 3 and len(model.domains["org:resource"].values) == 5
    assert [r.name for r in model.rules()] == [
        "existence.closed",
        "chain_precedence.resolve_ticket.closed",
        "not_co_existence.accepted_in_progress.closed",
        "response.accepted_in_progress.closed",
    ]
    for rule in model.rules():
        parse(rule.formula)


# ---------------------------------------------------------------------- refused lines


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("foo bar", "line 9: cannot read 'foo bar': expected 'activity NAME'"),
        ("Response[Resolve ticket, Wait] | | |", "line 9: activity 'Wait' is not declared"),
        ("Existence[Closed] |A.org:resource is Value 9 |", "'Value 9' is not a declared value"),
        ("Response[Resolve ticket, Closed] | | |1,2,s", "LTLf has no clock"),
        ("Response[Resolve ticket, Closed] | |same org:resource |", "'same' relates"),
        ("Response[Resolve ticket, Closed] | |different amount |", "'different' relates"),
        (
            "Response[Resolve ticket, Closed] | |T.org:resource is A.org:resource |",
            "comparing two events' attributes",
        ),
        (
            "Response[Resolve ticket, Closed] | |A.org:resource is Value 1 |",
            "a test on the activation there is not supported",
        ),
        ("Existence[Closed] |T.amount < 3 |", "the activation condition names T.amount"),
        (
            "Existence[Closed] |A.org:resource < 3 |",
            "'Value 1' (declared on line 6) is not a number",
        ),
        ("Existence[Resolve ticket] |A.amount < 3 |", "not bound to activity 'Resolve ticket'"),
        ("Existence[Closed] |A.amount is |", "expected a value"),
        ("Existence[Closed] |A.amount < 3 and |", "expected 'A.attribute'"),
        ("Existence[Closed] |A.amount ~ 3 |", "expected 'is', 'is not'"),
        ("Existence[Closed] |(A.amount < 3 |", "expected ')'"),
        ("Existence[Closed] |A.amount < 3 | | | |", "at most 2 condition fields"),
        ("Either[Closed, Resolve ticket] | | |", "'Either' is not a Declare template"),
        ("Co-Existence[Closed, Resolve ticket] |A.amount < 3 | |", "both its activities activate"),
        ("Existence[Closed] x", "expected '|' before the conditions"),
        ("activity Closed", "activity 'Closed' is already declared on line 3"),
        ("bind Wait: org:resource", "bind names activity 'Wait'"),
        ("amount: 1, 2", "attribute 'amount' already has its values, declared on line 8"),
        ("size: integer between 5 and 1", "an empty range"),
        ("size: integer between 1.5 and 3", "needs whole numbers"),
        ("size: integer from 1 to 3", "expected 'integer between X and Y'"),
        ("size: a, , b", "none empty"),
    ],
)
def test_bad_lines_name_the_line_and_what_was_expected(text: str, message: str) -> None:
    with pytest.raises(InputError) as caught:
        parse_decl(HEAD + text + "\n", "m.decl")
    assert str(caught.value).startswith("m.decl: line ")
    assert message in str(caught.value)


def test_large_and_float_ranges_are_read_as_numbers() -> None:
    """A condition is a test on the event's value: no domain is enumerated, so an integer range
    of thousands and a float range are read, and numbers compare as numbers."""
    text = "activity A\nbind A: n, w\nn: integer between 0 and 5000\nw: float between 0 and 1\n"
    big = rule(text + "Existence[A] |A.n > 3000 |\n", "existence.a")
    assert holds(big, ("a", {"n": "4000"})) and holds(big, ("a", {"n": "3000.5"}))
    assert not holds(big, ("a", {"n": "2999"})) and not holds(big, ("a", {"n": "many"}))
    half = rule(text + "Existence[A] |A.w is 0.5 |\n", "existence.a")
    assert holds(half, ("a", {"w": "0.50"})) and not holds(half, ("a", {"w": "0.25"}))


def test_values_that_fold_to_one_word_stay_two_conditions() -> None:
    """ "a b" and "a_b" read the same in atom characters; each condition is its own atom, met by
    its own value only."""
    text = "activity A\nbind A: x\nx: a b, a_b\n"
    model = parse_decl(text + "Existence[A] |A.x is a b |\nAbsence[A] |A.x is a_b |\n", "m.decl")
    first, second = model.rules()
    (atom_1, test_1), (atom_2, test_2) = *first.conditions.items(), *second.conditions.items()
    assert atom_1 != atom_2
    assert test_1.holds({"x": "a b"}) and not test_1.holds({"x": "a_b"})
    assert test_2.holds({"x": "a_b"}) and not test_2.holds({"x": "a b"})


# ---------------------------------------------------------------------- the docs' table


def template_table() -> list[str]:
    """The rows of docs/knowledge.md's template table, from TEMPLATES."""
    rows = []
    for t in TEMPLATES.values():
        formula = t.ltlf("a", "b" if t.arity == 2 else None).replace("|", "\\|")
        activation = "—" if t.activation is None else "ab"[t.activation]
        name = f"{t.name}, {t.name}2, ..." if t.counting else t.name
        rows.append(f"| {name} | `{t.key}` | `{formula}` | {activation} |")
    return rows


def test_the_docs_template_table_matches_templates() -> None:
    page = (ROOT / "docs" / "knowledge.md").read_text(encoding="utf-8")
    section = page.split("## Declare models (.decl)", 1)[1].split("\n## ", 1)[0]
    table = [line for line in section.splitlines() if re.match(r"\| \w.* \| `", line)]
    assert table == template_table()
