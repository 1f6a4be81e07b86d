"""`tleaf check-cases`: every case against every rule, exactly, on small logs worked out by hand;
one-hot letters where the rules name activities only, powerset letters where a rule names an
attribute value; atoms the log never has reported; bad input refused with nothing written. The
agreement with pm4py and Declare4Py, case by case, is tests/test_peer_agreement.py."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from tleaf_cli.cli.root import app
from tleaf_cli.data.event_logs import read_cases, write_cases
from tleaf_cli.data.log_readers import read_log
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.templates import TEMPLATES
from tleaf_cli.settings.event_logs import LogSettings
from tleaf_cli.tasks.case_checks import check_cases, read_case_rules, summary_path

runner = CliRunner()

# c1: Open (Value 1), Closed (Value 3); c2: Open, Open (Value 3); c3: Closed (Value 1)
CSV = (
    "case:concept:name,concept:name,time:timestamp,org:resource\n"
    "c1,Open,2020-01-01T09:00:00,Value 1\n"
    "c1,Closed,2020-01-01T10:00:00,Value 3\n"
    "c2,Open,2020-01-02T09:00:00,\n"
    "c2,Open,2020-01-02T10:00:00,Value 3\n"
    "c3,Closed,2020-01-03T09:00:00,Value 1\n"
)

RULES = (
    "response.open.closed: " + TEMPLATES["response"].ltlf("open", "closed") + "\n"
    "precedence.open.closed: " + TEMPLATES["precedence"].ltlf("open", "closed") + "\n"
    "init.open: open\n"
)
# by hand: c1 keeps all three; c2 breaks the response; c3 breaks precedence and init
EXPECTED = {
    "c1": [True, True, True],
    "c2": [False, True, True],
    "c3": [True, False, False],
}
ATTRIBUTE_RULES = (
    "closed_by_v3: F(closed & org_resource__value_3)\n"  # c1 only
    "v3_somewhere: F org_resource__value_3\n"  # c1 and c2
    "open_by_v1_first: open & org_resource__value_1\n"  # c1 only
)


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


def _cases(tmp_path: Path, attributes: tuple[str, ...] | None = None) -> Path:
    log = tmp_path / "log.csv"
    log.write_text(CSV)
    settings = LogSettings(attributes=attributes)
    out = tmp_path / "cases.parquet"
    write_cases(read_log(log, settings), out, settings)
    return out


def _kb(tmp_path: Path, text: str, name: str = "kb.ltl") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_rules_over_activities_are_checked_one_hot(tmp_path: Path) -> None:
    cases = read_cases(_cases(tmp_path))
    checks = check_cases(cases, read_case_rules(_kb(tmp_path, RULES)))
    assert checks.alphabet == "one-hot"
    got = {c: list(row) for c, row in zip(checks.case_ids, checks.satisfied, strict=True)}
    assert got == EXPECTED
    assert list(checks.broken_per_case()) == [0, 1, 2]
    assert list(checks.broken_per_rule()) == [1, 1, 1]
    assert checks.unseen == {}


def test_a_rule_on_an_attribute_value_reads_powerset_letters(tmp_path: Path) -> None:
    cases = read_cases(_cases(tmp_path, ("org:resource",)))
    rules = read_case_rules(_kb(tmp_path, RULES + ATTRIBUTE_RULES))
    checks = check_cases(cases, rules)
    assert checks.alphabet == "mixed"  # the rules on activities one-hot, the others powerset
    got = {c: list(row) for c, row in zip(checks.case_ids, checks.satisfied, strict=True)}
    assert got == {
        "c1": [True, True, True, True, True, True],
        "c2": [False, True, True, False, True, False],
        "c3": [True, False, False, False, False, False],
    }


def test_atoms_the_log_never_has_are_reported_not_silently_true(tmp_path: Path) -> None:
    cases = read_cases(_cases(tmp_path, ("org:resource",)))
    text = (
        "ghost_needed: F ghost\n"  # fails everywhere
        "ghost_responds: G(ghost -> X F open)\n"  # vacuously true everywhere
        "value_9: F org_resource__value_9\n"
    )
    checks = check_cases(cases, read_case_rules(_kb(tmp_path, text)))
    assert checks.unseen == {
        "ghost_needed": ("ghost",),
        "ghost_responds": ("ghost",),
        "value_9": ("org_resource__value_9",),
    }
    assert list(checks.broken_per_rule()) == [3, 0, 3]


def test_the_command_writes_rows_and_a_summary(tmp_path: Path) -> None:
    cases, kb = _cases(tmp_path), _kb(tmp_path, RULES + "ghost: F ghost\n")
    out = tmp_path / "checks.parquet"
    result = tleaf("check-cases", cases, kb, "-o", out)
    assert result.exit_code == 0, result.output
    assert "1 rules name an activity or attribute value no event of the log has" in result.output
    table = pq.read_table(out)
    assert table.column_names == ["case_id", "rule", "satisfied", "split"]
    rows = table.to_pylist()
    assert len(rows) == 3 * 4
    assert [r["satisfied"] for r in rows if r["case_id"] == "c3"] == [True, False, False, False]
    summary = json.loads(summary_path(out).read_text())
    assert summary["cases"] == 3 and summary["rules"] == 4
    assert summary["rules_broken_per_case"]["histogram"] == {"1": 1, "2": 1, "3": 1}
    assert summary["cases_per_rule"][3] == {"rule": "ghost", "broken": 3, "satisfied": 0}
    assert summary["rules_naming_unseen_atoms"]["count"] == 1


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("r1: G(open ->\n", "kb.ltl, line 1"),
        ("r1: F open\nr1: F closed\n", "already used on line 1"),
        ("# only a comment\n", "no rules"),
    ],
)
def test_bad_knowledge_exits_2_naming_it_with_nothing_written(tmp_path: Path, text, message):
    cases, kb = _cases(tmp_path), _kb(tmp_path, text)
    out = tmp_path / "checks.parquet"
    result = tleaf("check-cases", cases, kb, "-o", out)
    assert result.exit_code == 2
    assert message in result.output
    assert not out.exists() and not summary_path(out).exists()


def test_a_file_that_is_no_cases_artifact_is_refused(tmp_path: Path) -> None:
    kb = _kb(tmp_path, RULES)
    result = tleaf("check-cases", kb, kb, "-o", tmp_path / "checks.parquet")
    assert result.exit_code == 2
    with pytest.raises(InputError):
        read_case_rules(tmp_path / "missing.ltl")
