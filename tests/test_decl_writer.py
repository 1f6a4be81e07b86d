"""mine-declare -o kb.decl: the mined constraints as a Declare model in RuM's format, the lines
as the protocols' real .decl files write them, read back by tleaf's .decl reader as the same
constraints on the log's activities."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.test_declare import _cases_artifact
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.decl import parse_decl
from tleaf_cli.knowledge.decl_writer import decl_name, decl_text
from tleaf_cli.knowledge.declare import ALL_TEMPLATES, mine_declare
from tleaf_cli.knowledge.log_knowledge import mine_log, support_table_path
from tleaf_cli.logic.formulas import parse
from tleaf_cli.settings.declare import DeclareSettings

# a constraint line as RuM writes them (the peers' published models)
UNARY = re.compile(r"^[A-Z][A-Za-z -]*\d*\[[^],|]+\] \| \|$")
BINARY = re.compile(r"^[A-Z][A-Za-z -]*\[[^],|]+, [^],|]+\] \| \| \|$")


def test_the_names_are_rums() -> None:
    assert [decl_name(k) for k in ("existence", "absence", "exactly", "chain_precedence")] == [
        "Existence", "Absence", "Exactly1", "Chain Precedence",
    ]  # fmt: skip
    assert decl_name("not_co_existence") == "Not Co-Existence"


def test_mine_declare_writes_a_decl_that_reads_back(tmp_path: Path) -> None:
    cases = _cases_artifact(tmp_path)
    out = tmp_path / "kb.decl"
    settings = DeclareSettings(min_activated=1, templates=ALL_TEMPLATES)
    found = mine_log(cases, out, settings)
    assert found.rules and support_table_path(out).exists()
    lines = out.read_text().splitlines()
    activities = sorted(read_cases(cases).activity_atoms)
    assert sorted(x.removeprefix("activity ") for x in lines[: len(activities)]) == activities
    for line, m in zip(lines[len(activities) :], found.rules, strict=True):
        arity = m.constraint.declare.arity
        assert (UNARY if arity == 1 else BINARY).match(line), line
    assert "Init[Open ticket] | |" in lines  # the activity by its name in the log
    model = parse_decl(out.read_text(), str(out))
    assert len(model.constraints) == len(found.rules)
    for read, m in zip(model.constraints, found.rules, strict=True):
        c = m.constraint
        assert (read.template.key, read.count) == (c.template, 1)
        assert tuple(model.atoms[a] for a in read.activities) == c.activities
        assert parse(read.formula(model.atoms)) == parse(c.formula)
    # the rules read back under the names the miner gave them (its .tsv, its .ltl)
    log = read_cases(cases).activity_atoms
    assert [r.name for r in model.rules(log)] == [m.constraint.name for m in found.rules]


def test_the_peers_line_forms_are_of_that_form() -> None:
    """The writer's line forms are those of the peers' published models (their constraint
    lines without conditions, as tests/test_decl.py's PEER_FORMS and examples/helpdesk.decl
    write them)."""
    from tests.test_decl import PEER_FORMS

    example = (Path(__file__).resolve().parents[1] / "examples" / "helpdesk.decl").read_text()
    lines = [
        line.strip()
        for line in (PEER_FORMS + example).splitlines()
        if "[" in line and "|A." not in line  # a constraint without conditions
    ]
    assert lines
    for line in lines:
        assert (UNARY if ", " not in line else BINARY).match(line), line


def test_an_activity_a_decl_cannot_name_is_refused() -> None:
    """A comma, bracket or bar in a name would read back as other activities."""
    mined = mine_declare([["a", "b"]] * 3, min_support=1.0, templates=("init",))
    assert (
        decl_text(mined, {"a": "Open"}, ["Open", "B"]) == "activity Open\nactivity B\n"
        "Init[Open] | |\n"
    )
    for bad in ("Open, then close", "Open [new]", "a|b", " Open"):
        with pytest.raises(InputError, match=r"cannot be written in a \.decl"):
            decl_text(mined, {"a": bad}, [bad, "B"])


def test_the_command_writes_decl(tmp_path: Path, chain_cli) -> None:
    cases = _cases_artifact(tmp_path)
    out = tmp_path / "kb.decl"
    result = chain_cli("mine-declare", cases, "-o", out, "--templates", "all")
    assert result.exit_code == 0, result.output
    assert "Init[Open ticket] | |" in out.read_text()
    table = support_table_path(out).read_text()
    assert table.startswith("rule\tformula\t")
    ltl = tmp_path / "kb.ltl"
    assert chain_cli("mine-declare", cases, "-o", ltl, "--templates", "all").exit_code == 0
    assert support_table_path(ltl).read_text() == table.replace("kb.decl", "kb.ltl")
