"""Names, values and conditions exactly as the log and the model write them.

A `.decl` names activities as a person writes them, and a log may hold names that fold to one
atom ("Check in", "Check-in", "check in"; "Réunion", "Reunion"; "検査"): every verdict of
`check-cases` must equal an independent checker's, written here on the names themselves. MP-
Declare conditions are tests on one event's values: any domain size, numbers as numbers, values
outside the declared domain read as Declare4Py reads them.
"""

from __future__ import annotations

import csv
import json
import random
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.event_logs import read_cases, write_cases
from tleaf_cli.data.log_readers import read_log
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.rule_files import read_rule_file
from tleaf_cli.settings.event_logs import LogSettings
from tleaf_cli.tasks.case_checks import check_cases, read_case_rules

runner = CliRunner()

# near-collisions: hyphen / space / case, accents, CJK, quotes, and a comma (no .decl can name it)
NAMES = [
    "Check in",
    "Check-in",
    "check in",
    "Réunion",
    "Reunion",
    "検査",
    "診断",
    "Doctor's visit",
    'Say "hi"',
    "Triage, urgent",
    "Ärztliche Prüfung",
    "Arztliche Prufung",
]


def tleaf(*args: object):
    return runner.invoke(app, [str(a) for a in args])


def write_log(path: Path, cases: list[list[str]], resources: list[list[str]] | None = None) -> None:
    with path.open("w", newline="", encoding="utf-8") as f:
        out = csv.writer(f)
        out.writerow(
            ["case:concept:name", "concept:name", "time:timestamp"]
            + (["org:resource"] if resources else [])
        )
        for k, case in enumerate(cases):
            for i, name in enumerate(case):
                row = [f"c{k}", name, f"2021-01-{k % 28 + 1:02d}T{i // 60:02d}:{i % 60:02d}:00"]
                out.writerow(row + ([resources[k][i]] if resources else []))


def cases_artifact(tmp_path: Path, log: Path, attributes: tuple[str, ...] = ()) -> Path:
    settings = LogSettings(attributes=attributes or None)
    out = tmp_path / "cases.parquet"
    write_cases(read_log(log, settings), out, settings)
    return out


# ---------------------------------------------------------------------- names


def _occurs(case: list[str], a: str) -> list[int]:
    return [i for i, x in enumerate(case) if x == a]


# each: the .decl line, and the same constraint on the names as written
CHECKS: list[tuple[str, Callable[[list[str]], bool]]] = [
    ("Existence[Check-in] | |", lambda c: "Check-in" in c),
    ("Absence[check in] | |", lambda c: "check in" not in c),
    ("Init[Check in] | |", lambda c: c[0] == "Check in"),
    (
        "Response[Check-in, 検査] | | |",
        lambda c: all("検査" in c[i + 1 :] for i in _occurs(c, "Check-in")),
    ),
    (
        "Precedence[Réunion, 診断] | | |",
        lambda c: all("Réunion" in c[:i] for i in _occurs(c, "診断")),
    ),
    (
        "Not Co-Existence[Doctor's visit, Reunion] | | |",
        lambda c: not ("Doctor's visit" in c and "Reunion" in c),
    ),
    (
        'Chain Response[Say "hi", Ärztliche Prüfung] | | |',
        lambda c: all(
            i + 1 < len(c) and c[i + 1] == "Ärztliche Prüfung" for i in _occurs(c, 'Say "hi"')
        ),
    ),
    ("Exactly1[Arztliche Prufung] | |", lambda c: c.count("Arztliche Prufung") == 1),
    ("Existence[Check In] | |", lambda c: False),  # no such activity: never happens
]


@pytest.mark.parametrize("declared", [True, False], ids=["activity-lines", "constraints-only"])
def test_every_verdict_equals_a_checker_on_the_names_as_written(
    tmp_path: Path, declared: bool
) -> None:
    rng = random.Random(7)
    cases = [[rng.choice(NAMES) for _ in range(rng.randint(1, 8))] for _ in range(120)]
    log = tmp_path / "log.csv"
    write_log(log, cases)
    artifact = cases_artifact(tmp_path, log)
    head = "".join(f"activity {n}\n" for n in NAMES if "," not in n) + "activity Check In\n"
    model = tmp_path / "kb.decl"
    model.write_text((head if declared else "") + "\n".join(line for line, _ in CHECKS) + "\n")
    out = tmp_path / "checks.parquet"
    done = tleaf("check-cases", artifact, model, "-o", out, "-q")
    assert done.exit_code == 0, done.output
    rows = pq.read_table(out).to_pylist()
    rules = list(dict.fromkeys(r["rule"] for r in rows))
    assert len(rules) == len(CHECKS)
    got = {(r["case_id"], r["rule"]): r["satisfied"] for r in rows}
    for k, case in enumerate(cases):
        for rule, (line, check) in zip(rules, CHECKS, strict=True):
            assert got[f"c{k}", rule] == check(case), (line, case)


def test_a_decl_name_binds_the_log_atom_of_that_very_name(tmp_path: Path) -> None:
    """ "Check-in" reads the atom the log gave "Check-in", never the one "Check in" has; a name
    the log lacks gets an atom of its own, and CJK names keep readable atoms."""
    log = tmp_path / "log.csv"
    write_log(log, [["Check in", "Check-in", "検査"]])
    atoms = read_cases(cases_artifact(tmp_path, log)).activity_atoms
    assert len(set(atoms.values())) == 3 and atoms["検査"] == "jian_zha"
    model = tmp_path / "kb.decl"
    model.write_text("Existence[Check-in] | |\nExistence[Check In] | |\n")
    first, second = read_rule_file(model, atoms)
    assert first.text == f"F ({atoms['Check-in']})"
    assert second.formula_id.split(".")[1] not in atoms.values()


def test_read_log_and_inspect_show_names_told_apart(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    write_log(log, [["Check in", "Check-in", "検査"]])
    out = tmp_path / "cases.parquet"
    done = tleaf("read-log", log, "-o", out)
    assert done.exit_code == 0, done.output
    assert "'Check in' -> check_in, 'Check-in' -> check_in_2" in done.output
    shown = tleaf("inspect", out)
    assert shown.exit_code == 0, shown.output
    assert "1 groups told apart" in shown.output and "jian_zha" in shown.output


def test_the_run_reads_a_decl_through_its_log_atoms(tmp_path: Path) -> None:
    """train-task and eval read `--kb` / `--rules` through the run's own map (read_rules)."""
    from tleaf_cli.tasks.next_activity.rules import read_rules

    log = tmp_path / "log.csv"
    write_log(log, [["Check in", "Check-in"], ["Check-in", "Check in"]])
    atoms = read_cases(cases_artifact(tmp_path, log)).activity_atoms
    model = tmp_path / "kb.decl"
    model.write_text("Init[Check-in] | |\n")
    vocabulary = sorted(atoms.values())
    rules = read_rules(model, vocabulary, log_atoms=atoms)
    check_in = vocabulary.index(atoms["Check-in"])
    other = vocabulary.index(atoms["Check in"])
    assert list(rules.broken([[check_in, other], [other, check_in]])) == [False, True]


# ---------------------------------------------------------------------- conditions

RESOURCES = [f"Value {i}" for i in range(1, 23)]
HELPDESK = (
    "activity Resolve ticket\nbind Resolve ticket: org:resource\n"
    "activity Closed\nbind Closed: org:resource\n"
    f"org:resource: {', '.join(RESOURCES)}\n"
)


def _condition_cases(tmp_path: Path) -> tuple[Path, list[list[tuple[str, str]]]]:
    rng = random.Random(3)
    cases = [
        [
            (rng.choice(["Resolve ticket", "Closed"]), rng.choice([*RESOURCES, "Value 23"]))
            for _ in range(rng.randint(1, 6))
        ]
        for _ in range(150)
    ]
    log = tmp_path / "log.csv"
    write_log(log, [[a for a, _ in c] for c in cases], [[r for _, r in c] for c in cases])
    return cases_artifact(tmp_path, log, ("org:resource",)), cases


def _number(resource: str) -> int:
    return int(resource.split()[1])


CONDITIONS: list[tuple[str, Callable[[str], bool]]] = [
    ("A.org:resource is not Value 3", lambda r: r != "Value 3"),
    (
        f"A.org:resource in ({', '.join(RESOURCES[:16])})",
        lambda r: r in RESOURCES[:16],
    ),
    (
        "not (A.org:resource is Value 3 or A.org:resource is Value 4)",
        lambda r: r not in ("Value 3", "Value 4"),
    ),
    ("A.org:resource not in (Value 1, Value 2)", lambda r: r not in ("Value 1", "Value 2")),
]


@pytest.mark.parametrize(("condition", "meets"), CONDITIONS)
def test_conditions_over_22_values_check_every_case(
    tmp_path: Path, condition: str, meets: Callable[[str], bool]
) -> None:
    """Existence and Response with a condition over Helpdesk's 22 resources (refused before:
    a powerset over 24 atoms), and a value outside the declared domain (Value 23) read as
    Declare4Py reads it: tested as it is."""
    artifact, cases = _condition_cases(tmp_path)
    model = tmp_path / "kb.decl"
    model.write_text(
        HELPDESK
        + f"Existence[Closed] |{condition} |\n"
        + f"Response[Resolve ticket, Closed] |{condition} | |\n"
    )
    checks = check_cases(
        read_cases(artifact), read_case_rules(model, read_cases(artifact).activity_atoms)
    )
    assert checks.outside == {
        "org:resource": (sum(r == "Value 23" for c in cases for _, r in c), ("Value 23",))
    }
    for k, case in enumerate(cases):
        existence = any(a == "Closed" and meets(r) for a, r in case)
        response = all(
            any(b == "Closed" for b, _ in case[i + 1 :])
            for i, (a, r) in enumerate(case)
            if a == "Resolve ticket" and meets(r)
        )
        assert list(checks.satisfied[k]) == [existence, response], case


def test_is_not_and_not_is_agree_on_values_outside_the_domain(tmp_path: Path) -> None:
    """Before: `A.x is not Value 1` and `not (A.x is Value 1 or ...)` over the other declared
    values gave 0 and 2 cases on events whose value was outside the domain."""
    artifact, _ = _condition_cases(tmp_path)
    others = " or ".join(f"A.org:resource is {v}" for v in RESOURCES if v != "Value 1")
    model = tmp_path / "kb.decl"
    model.write_text(
        HELPDESK
        + "Existence[Closed] |A.org:resource is not Value 1 |\n"
        + "Existence[Closed] |not (A.org:resource is Value 1) |\n"
        + f"Existence[Closed] |{others} |\n"
    )
    cases = read_cases(artifact)
    checks = check_cases(cases, read_case_rules(model, cases.activity_atoms))
    assert (checks.satisfied[:, 0] == checks.satisfied[:, 1]).all()
    # the disjunction over the declared values is another condition: Value 23 does not meet it
    assert (checks.satisfied[:, 2] <= checks.satisfied[:, 0]).all()
    assert (checks.satisfied[:, 2] != checks.satisfied[:, 0]).any()


def test_numbers_compare_as_numbers(tmp_path: Path) -> None:
    """A model's `A.CRP = 573` meets the log's 573.0; `A.Age >= 80` over `integer between 20
    and 95` (76 values) is read as one test."""
    log = tmp_path / "log.csv"
    rows = [
        "case:concept:name,concept:name,time:timestamp,CRP,Age",
        "c1,Lab,2021-01-01T00:00:00,573.0,85",
        "c2,Lab,2021-01-02T00:00:00,572.5,80.0",
        "c3,Lab,2021-01-03T00:00:00,n/a,79",
    ]
    log.write_text("\n".join(rows) + "\n")
    artifact = cases_artifact(tmp_path, log, ("CRP", "Age"))
    model = tmp_path / "kb.decl"
    model.write_text(
        "activity Lab\nbind Lab: CRP, Age\nCRP: float between 0 and 1000\n"
        "Age: integer between 20 and 95\n"
        "Existence[Lab] |A.CRP = 573 |\nExistence[Lab] |A.Age >= 80 |\n"
    )
    cases = read_cases(artifact)
    checks = check_cases(cases, read_case_rules(model, cases.activity_atoms))
    assert [list(row) for row in checks.satisfied] == [[True, True], [False, True], [False, False]]


def test_a_condition_on_an_attribute_the_cases_do_not_keep_says_to_keep_it(tmp_path: Path) -> None:
    log = tmp_path / "plain.csv"
    write_log(log, [["Closed"]])
    bare = tmp_path / "bare"
    bare.mkdir()
    artifact = cases_artifact(bare, log)
    model = tmp_path / "kb.decl"
    model.write_text(HELPDESK + "Existence[Closed] |A.org:resource is Value 3 |\n")
    out = tmp_path / "checks.parquet"
    done = tleaf("check-cases", artifact, model, "-o", out)
    assert done.exit_code == 2
    said = " ".join(done.output.split())
    assert "'org:resource', which" in said and "keeping that event attribute" in said
    assert not out.exists()


def test_check_cases_warns_of_values_outside_the_declared_domain(tmp_path: Path) -> None:
    artifact, cases = _condition_cases(tmp_path)
    model = tmp_path / "kb.decl"
    model.write_text(HELPDESK + "Existence[Closed] |A.org:resource is not Value 3 |\n")
    out = tmp_path / "checks.parquet"
    done = tleaf("check-cases", artifact, model, "-o", out)
    assert done.exit_code == 0, done.output
    n = sum(r == "Value 23" for c in cases for _, r in c)
    assert f"warning: {n} events carry a value of org:resource outside" in " ".join(
        done.output.split()
    )
    summary = json.loads(out.with_name("checks.summary.json").read_text())
    assert summary["values_outside_declared_domains"]["org:resource"]["events"] == n
    assert summary["conditions"] == {"org_resource__is_not__value_3": "org:resource is not Value 3"}


def test_compile_dfa_one_hot_refuses_a_conditional_rule(tmp_path: Path) -> None:
    """Before: each conditional rule compiled to a one-state, always-true DFA, exit 0."""
    model = tmp_path / "kb.decl"
    model.write_text(HELPDESK + "Existence[Closed] |A.org:resource is Value 3 |\n")
    out = tmp_path / "d.parquet"
    done = tleaf("compile-dfa", model, "--one-hot", "-o", out)
    assert done.exit_code == 2
    assert "over the powerset alphabet" in " ".join(done.output.split())
    assert not out.exists()
    done = tleaf("compile-dfa", model, "-o", out, "-q")
    assert done.exit_code == 0, done.output
    row = pq.read_table(out).to_pylist()[0]
    assert row["num_states"] == 2 and row["atoms"] == ["closed", "org_resource__is__value_3"]


@pytest.mark.parametrize(
    ("line", "message"),
    [
        (
            "Existence[Resolve ticket, Closed] | |",
            "Existence takes one activity, found 2: 'Resolve ticket', 'Closed'",
        ),
        ("Existence0[Closed] | |", "line 6: Existence0: a count starts at 1"),
    ],
)
def test_misleading_decl_messages(tmp_path: Path, line: str, message: str) -> None:
    model = tmp_path / "kb.decl"
    model.write_text(HELPDESK + line + "\n")
    with pytest.raises(InputError, match=message):
        read_rule_file(model)


def test_suffix_search_reads_conditions_over_22_values(tmp_path: Path) -> None:
    """The joint tokens of a model predicting the resource read `is not` over 22 values and
    `in` over 16 (refused before: a powerset over 24 atoms): the rules' automaton accepts
    exactly the token sequences a checker on the values accepts."""
    from tleaf_cli.tasks.next_activity.encoding import Encoder
    from tleaf_cli.tasks.next_activity.joint_tokens import JointTokens, joint_rules

    artifact, _ = _condition_cases(tmp_path)
    encoder = Encoder.fit(read_cases(artifact), split="train", attributes=("org:resource",))
    tokens = JointTokens(encoder)
    model = tmp_path / "kb.decl"
    sixteen = ", ".join(RESOURCES[:16])
    model.write_text(
        HELPDESK
        + "Existence[Closed] |A.org:resource is not Value 3 |\n"
        + f"Chain Precedence[Resolve ticket, Closed] |A.org:resource in ({sixteen}) | |\n"
    )
    rules = joint_rules(model, tokens)
    assert not rules.activities_only
    activities, values = tokens.decode(np.arange(tokens.size))
    names = [encoder.activities[a] for a in activities]
    resources = [encoder.values[0][v - 1] if v else None for v in values[:, 0]]

    def keeps(word: tuple[int, ...]) -> bool:
        events = [(names[t], resources[t]) for t in word]
        exists = any(a == "Closed" and r is not None and r != "Value 3" for a, r in events)
        chained = all(
            i > 0 and events[i - 1][0] == "Resolve ticket"
            for i, (a, r) in enumerate(events)
            if a == "Closed" and r in RESOURCES[:16]
        )
        return exists and chained

    rng = np.random.default_rng(0)
    kept = 0
    for _ in range(400):
        word = tuple(rng.integers(0, tokens.size, rng.integers(1, 5)).tolist())
        assert rules.automaton.accepts(word) == keeps(word), word
        kept += keeps(word)
    assert kept > 10


def test_a_model_over_activities_refuses_a_condition_by_the_rule_name(tmp_path: Path) -> None:
    """Before: eval quoted the rule's 22-disjunct formula; now it names the rule and its line."""
    from tleaf_cli.tasks.next_activity.rules import read_rules

    model = tmp_path / "kb.decl"
    model.write_text(HELPDESK + "Existence[Closed] |A.org:resource is not Value 3 |\n")
    with pytest.raises(InputError) as caught:
        read_rules(model, ["closed", "resolve_ticket"])
    message = str(caught.value)
    assert "line 6: rule existence.closed has an MP-Declare condition on org:resource" in message
    assert "|" not in message and "a model that predicts the attribute can" in message


def test_the_product_of_a_hundred_rules_is_their_conjunction() -> None:
    """A combination of the rules' states keyed by a mixed-radix int64 wrapped past 2^63
    (3 states ^ 45 rules): combinations that differ merged, a silent wrong automaton."""
    from tleaf_cli.logic.compile import compile_formula
    from tleaf_cli.tasks.next_activity.rule_automaton import RuleAutomaton

    formulas = ["F(a & X F b)", "F(b & X F c)", "F(c & X F a)"] * 15
    dfas = [compile_formula(f, "one-hot") for f in formulas]
    atoms = ["a", "b", "c", "d"]
    letters = [np.array([d.alphabet.index({x}) for x in atoms]) for d in dfas]
    joined = RuleAutomaton.of_letters(dfas, letters)
    assert len(joined.following) == 1  # one product, not parts
    rng = np.random.default_rng(1)
    kept = 0
    for _ in range(300):
        word = tuple(rng.integers(0, 4, rng.integers(1, 9)).tolist())
        truth = all(d.accepts([{atoms[t]} for t in word]) for d in dfas)
        assert joined.accepts(word) == truth, word
        kept += truth
    assert kept > 0
