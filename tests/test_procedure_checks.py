"""Recordings checked against their recipe's rules (tasks/procedure_checks.py, `tleaf
check-recordings`), on hand-made recordings and a hand-made edge list, where the broken rules and
the detection scores are known by hand."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.artifacts import read_provenance
from tleaf_cli.data.captaincook import Recording, write_recordings
from tleaf_cli.data.cases import Cases
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.task_graphs import write_graph_knowledge
from tleaf_cli.tasks.procedure_checks import (
    KIND,
    check_recordings,
    detection,
    read_recipe_rules,
    rule_files,
    summarise,
)

BOIL_STEEP = "tea.before.boil.steep"
STEEP_POUR = "tea.before.steep.pour"


def row(rid, recipe, atoms, errors, categories=(), split="train"):
    """A recording with the fields the checker reads (the rest filled in)."""
    n = len(atoms)
    return Recording.of(
        **{
            "recording_id": rid,
            "activity_id": 1,
            "activity_name": recipe,
            "recipe": recipe,
            "step_ids": list(range(n)),
            "step_descriptions": list(atoms),
            "atoms": list(atoms),
            "start_s": [float(k) for k in range(n)],
            "end_s": [k + 0.5 for k in range(n)],
            "step_has_error": [False] * n,
            "step_error_categories": [[] for _ in range(n)],
            "skipped_step_ids": [],
            "has_errors": errors,
            "error_categories": list(categories),
            "split": split,
        }
    )


# (recording, steps, has_errors, categories, split) -> the tea rules it breaks, by hand
ROWS = [
    row("t1", "tea", ["boil", "steep", "pour"], False),  # TN
    row("t2", "tea", ["steep", "boil", "pour"], True, ["Order Error"]),  # TP: boil.steep
    row("t3", "tea", ["boil", "pour"], True, ["Missing Step", "Order Error"]),  # TP: steep.pour
    row("t4", "tea", ["pour", "boil", "steep"], False, split="test"),  # FP: steep.pour
    row("t5", "tea", ["boil", "steep", "pour"], True, ["Measurement Error"], "test"),  # FN
    row("k1", "toast", ["slice", "toast"], True, ["Timing Error"]),  # no rules: not checked
]
BROKEN = {"t1": [], "t2": [BOIL_STEEP], "t3": [STEEP_POUR], "t4": [STEEP_POUR], "t5": []}


@pytest.fixture()
def files(tmp_path: Path) -> tuple[Path, Path]:
    """(recordings.parquet, tea.ltl): the rows above and the edges boil -> steep -> pour."""
    (tmp_path / "tea.txt").write_text("boil -> steep\nsteep -> pour\n")
    kb = tmp_path / "tea.ltl"
    write_graph_knowledge(tmp_path / "tea.txt", kb)
    recordings = tmp_path / "recordings.parquet"
    write_recordings(Cases(list(ROWS), {}, "hand-made"), recordings)
    return recordings, kb


def test_each_recording_breaks_the_rules_found_by_hand(files: tuple[Path, Path]) -> None:
    rules = read_recipe_rules(rule_files(files[1]))
    assert [r.name for r in rules["tea"]] == [BOIL_STEEP, STEEP_POUR]
    checks = check_recordings(ROWS, rules)
    assert {c["recording_id"]: c["broken_rules"] for c in checks if c["checked"]} == BROKEN
    assert [c["recording_id"] for c in checks if not c["checked"]] == ["k1"]


def test_rules_agree_with_precedence_on_every_order(files: tuple[Path, Path]) -> None:
    """Every sequence of 1 to 4 steps over boil, steep, pour (and a step no rule names): an
    edge a -> b is broken exactly when b occurs with no a before its first occurrence."""
    rules = read_recipe_rules(rule_files(files[1]))
    seqs = [
        list(s)
        for n in range(1, 5)
        for s in itertools.product(["boil", "steep", "pour", "stir"], repeat=n)
    ]
    rows = [row(f"r{k}", "tea", s, False) for k, s in enumerate(seqs)]
    for seq, check in zip(seqs, check_recordings(rows, rules), strict=True):
        expected = [
            name
            for name, a, b in ((BOIL_STEEP, "boil", "steep"), (STEEP_POUR, "steep", "pour"))
            if b in seq and a not in seq[: seq.index(b)]
        ]
        assert check["broken_rules"] == expected, seq


def test_detection_scores_by_hand() -> None:
    m = detection([(True, True), (True, True), (False, True), (True, False), (False, False)])
    assert (m["tp"], m["fp"], m["fn"], m["tn"]) == (2, 1, 1, 1)
    assert m["precision"] == pytest.approx(2 / 3) and m["recall"] == pytest.approx(2 / 3)
    assert m["f1"] == pytest.approx(2 / 3) and m["accuracy"] == pytest.approx(3 / 5)
    nothing = detection([(False, False)])
    assert nothing["precision"] is None and nothing["recall"] is None and nothing["f1"] is None
    assert detection([(True, False), (False, True)])["f1"] == 0.0


def test_summary_per_recipe_split_kind_and_category(files: tuple[Path, Path]) -> None:
    rules = read_recipe_rules(rule_files(files[1]))
    report = summarise(check_recordings(ROWS, rules), rules)
    assert report["checked"] == 5 and report["unchecked_by_recipe"] == {"toast": 1}
    d = report["detection"]
    assert list(d) == ["all", "train", "test"]
    assert (d["all"]["tp"], d["all"]["fp"], d["all"]["fn"], d["all"]["tn"]) == (2, 1, 1, 1)
    assert d["train"]["precision"] == 1.0 and d["train"]["recall"] == 1.0
    assert (d["test"]["tp"], d["test"]["fp"], d["test"]["fn"]) == (0, 1, 1)
    assert report["detection_by_kind"]["before"]["recall"] == pytest.approx(2 / 3)
    (tea,) = report["by_recipe"]
    assert (tea["normal"], tea["normal_breaking"], tea["error"], tea["error_breaking"]) == (
        2,
        1,
        3,
        2,
    )
    assert tea["broken_rules"] == {
        STEEP_POUR: {"normal": 1, "error": 1},
        BOIL_STEEP: {"normal": 0, "error": 1},
    }
    c = report["by_category"]
    assert (c["Order Error"]["breaking"], c["Order Error"]["recordings"]) == (2, 2)
    assert (c["Order Error"]["only_breaking"], c["Order Error"]["only_recordings"]) == (1, 1)
    assert c["Missing Step"]["only_recordings"] == 0 and c["Missing Step"]["only_recall"] is None
    assert c["Measurement Error"]["recall"] == 0.0
    assert "Timing Error" not in c  # only on the unchecked recording
    sequence = report["by_sequence_errors"]
    assert sequence["Order Error or Missing Step"] == {
        "recordings": 2,
        "breaking": 2,
        "recall": 1.0,
    }
    assert sequence["other errors only"] == {"recordings": 1, "breaking": 0, "recall": 0.0}


def test_rule_kinds_once_and_ends(tmp_path: Path) -> None:
    (tmp_path / "tea.txt").write_text("boil -> steep\nsteep -> END\n")
    kb = tmp_path / "tea.ltl"
    write_graph_knowledge(tmp_path / "tea.txt", kb, at_most_once=True, last_step_ends=True)
    rules = read_recipe_rules([kb])
    rows = [
        row("a", "tea", ["boil", "steep", "steep"], True),  # steep twice
        row("b", "tea", ["boil", "steep", "boil"], False),  # ends on boil, boil twice
        row("c", "tea", ["boil", "steep"], False),
    ]
    broken = [c["broken_rules"] for c in check_recordings(rows, rules)]
    assert broken == [["tea.once.steep"], ["tea.once.boil", "tea.ends"], []]
    kinds = summarise(check_recordings(rows, rules), rules)["detection_by_kind"]
    assert kinds["once"]["rules"] == 2 and (kinds["once"]["tp"], kinds["once"]["fp"]) == (1, 1)
    assert (kinds["ends"]["tp"], kinds["ends"]["fp"]) == (0, 1)


def test_cli_writes_metrics_report_and_checks(files: tuple[Path, Path], tmp_path: Path) -> None:
    out = tmp_path / "checks"
    result = CliRunner().invoke(app, ["check-recordings", *map(str, files), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "5 of 6 recordings checked against 2 rules" in result.output
    assert "precision 66.7 %, recall 66.7 %" in result.output
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["detection"]["all"]["tp"] == 2 and metrics["version"]
    assert [i["path"] for i in metrics["inputs"]] == [str(files[0]), str(files[1])]
    table = pq.read_table(out / "checks.parquet").to_pylist()
    assert {r["recording_id"]: r["broken_rules"] for r in table if r["checked"]} == BROKEN
    assert read_provenance(out / "checks.parquet").kind == KIND
    assert "| tea | 2 | 1 / 2 | 2 / 3 |" in (out / "report.md").read_text()


@pytest.mark.parametrize(
    ("ltl", "message"),
    [
        ("boil_first: F boil\n", "rule 'boil_first' is not named <recipe>.<kind>"),
        ("F boil\n", "rule 'L1' is not named <recipe>.<kind>"),
        ("tea.a: F boil\ntea.a: F steep\n", "name 'tea.a' already used on line 1"),
        ("tea.a: F (boil\n", "line 1"),
        ("coffee.a: F grind\n", "no recording's recipe has rules"),
    ],
)
def test_bad_rules_exit_2_in_one_line(
    files: tuple[Path, Path], tmp_path: Path, ltl: str, message: str
) -> None:
    kb = tmp_path / "bad.ltl"
    kb.write_text(ltl)
    out = tmp_path / "checks"
    result = CliRunner().invoke(app, ["check-recordings", str(files[0]), str(kb), "-o", str(out)])
    assert result.exit_code == 2
    assert message in result.output and len(result.output.strip().splitlines()) == 1
    assert not out.exists()


def test_bad_inputs_are_refused(files: tuple[Path, Path], tmp_path: Path) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InputError, match=r"a folder without \.ltl files"):
        rule_files(empty)
    with pytest.raises(InputError, match="no such file"):
        rule_files(tmp_path / "missing.ltl")
    kbs = tmp_path / "kbs"
    kbs.mkdir()
    (kbs / "a.ltl").write_text("tea.x: F boil\n")
    (kbs / "b.ltl").write_text("tea.x: F steep\n")
    with pytest.raises(InputError, match=r"b\.ltl, line 1: rule 'tea\.x' is also at .*a\.ltl"):
        read_recipe_rules(rule_files(kbs))
    out = tmp_path / "checks"
    result = CliRunner().invoke(app, ["check-recordings", str(files[1]), str(files[1])])
    assert result.exit_code == 2 and "not a Parquet file" in result.output
    result = CliRunner().invoke(
        app, ["check-recordings", str(files[0]), str(files[1]), "-o", str(files[0])]
    )
    assert result.exit_code == 2 and "is also an input" in result.output
    assert not out.exists()


def test_rules_naming_steps_no_recording_has_are_counted_and_named(
    files: tuple[Path, Path], tmp_path: Path
) -> None:
    """Another recipe's rules under this recipe's name hold vacuously: said, not hidden."""
    kb = tmp_path / "coffee_as_tea.ltl"
    kb.write_text(
        "tea.before.grind.brew: (!brew U grind) | G !brew\n"
        "tea.before.boil.grind: (!grind U boil) | G !grind\n"
    )
    out = tmp_path / "checks"
    result = CliRunner().invoke(app, ["check-recordings", str(files[0]), str(kb), "-o", str(out)])
    assert result.exit_code == 0, result.output
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["rules_naming_unseen_steps"] == {
        "count": 2,
        "examples": ["tea.before.grind.brew (brew, grind)", "tea.before.boil.grind (grind)"],
    }
    text = result.output.replace("\n", " ")
    assert "2 rules name steps no recording of their recipe has" in text, result.output
    assert "tea.before.grind.brew" in text
    # no recording breaks a rule: precision is undefined, shown alike in summary and table
    assert metrics["detection"]["all"]["precision"] is None
    assert "precision —" in text and "0.000" not in text
