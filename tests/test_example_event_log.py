"""The real event log the repository ships (examples/event_logs/, 400 Helpdesk cases) through the
command line as README shows it: read-log, split-cases, mine-declare. Each mined rule is checked
against the cases themselves with the reference LTLf semantics: it holds on the train and test
shares of cases that mine-declare reports."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.event_logs import read_cases
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.semantics import satisfies

SAMPLE = Path(__file__).parent.parent / "examples" / "event_logs" / "helpdesk-400.csv"
runner = CliRunner()


def tleaf(*args):
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result


def _log_rows() -> list[dict[str, str]]:
    with SAMPLE.open(encoding="utf-8", newline="") as f:
        return list(csv.DictReader(f))


def test_the_sample_is_small_and_names_its_source() -> None:
    assert SAMPLE.stat().st_size < 300_000
    attribution = (SAMPLE.parent / "README.md").read_text(encoding="utf-8")
    assert "10.17632/39bp3vv62t.1" in attribution and "Licen" in attribution


@pytest.fixture(scope="module")
def cases(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("helpdesk") / "cases.parquet"
    result = tleaf("read-log", SAMPLE, "-o", out)
    rows = _log_rows()
    case_ids = {r["case:concept:name"] for r in rows}
    assert f"{len(case_ids)} cases, {len(rows)} events" in result.output
    assert "skipped or repaired: none" in result.output
    return out


def _check_mined(cases_path: Path, kb: Path) -> int:
    """Every rule of kb's .tsv holds on its reported share of the train and test cases."""
    data = read_cases(cases_path)
    by_split = {
        split: [[{atom} for atom in case.atoms] for case in data.cases if case.split == split]
        for split in ("train", "test")
    }
    with kb.with_suffix(".tsv").open(encoding="utf-8", newline="") as f:
        rules = list(csv.DictReader(f, delimiter="\t"))
    assert rules
    for rule in rules:
        formula = parse(rule["formula"])
        for split, column in (("train", "train_support"), ("test", "test_support")):
            traces = by_split[split]
            share = sum(satisfies(t, formula) for t in traces) / len(traces)
            assert share == pytest.approx(float(rule[column]), abs=5e-5), (rule["rule"], split)
        assert float(rule["train_support"]) >= 0.9  # mine-declare's default --min-support
    return len(rules)


def test_read_log_then_mine_declare_on_the_shipped_log(cases: Path, tmp_path: Path) -> None:
    kb = tmp_path / "helpdesk.ltl"
    result = tleaf("mine-declare", cases, "-o", kb)
    found = _check_mined(cases, kb)
    assert f"{found} rules from {sum(c.split == 'train' for c in read_cases(cases).cases)}" in (
        result.output
    )
    text = kb.read_text(encoding="utf-8")
    assert "atom assign_seriousness = activity 'Assign seriousness'" in text


def test_one_fold_of_the_cross_validation_then_mine_declare(cases: Path, tmp_path: Path) -> None:
    fold = tmp_path / "fold0.parquet"
    tleaf("split-cases", cases, "-o", fold, "--fold", 0)
    splits = [c.split for c in read_cases(fold).cases]
    assert splits.count("test") == 80  # 400 cases in five folds
    kb = tmp_path / "fold0.ltl"
    tleaf("mine-declare", fold, "-o", kb)
    _check_mined(fold, kb)
