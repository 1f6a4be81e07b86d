"""Options given together: both take effect, or the call is refused (exit 2) naming the option
the call would otherwise ignore, and nothing is written."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app

runner = CliRunner()


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def dfas(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("dfas")
    (d / "f.ltl").write_text("p: G (a -> F b)\n", encoding="utf-8")
    assert tleaf("compile-dfa", d / "f.ltl", "-o", d / "dfas.parquet").exit_code == 0
    return d / "dfas.parquet"


def test_inspect_dot_and_draw_together_do_both(dfas: Path, tmp_path: Path) -> None:
    drawing = tmp_path / "p.dot"
    result = tleaf("inspect", dfas, "--id", "p", "--dot", "--draw", drawing)
    assert result.exit_code == 0, result.output
    assert "digraph" in result.output and drawing.read_text().startswith("digraph")


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["inspect", "{dfas}", "--id", "p", "--rows", "3"], "--rows: not with --id"),
        (["inspect", "{dfas}", "--id", "p", "--stats"], "--stats: not with --id"),
        (["inspect", "{dfas}", "--stats", "--rows", "3"], "--rows: not with --stats"),
        (["gen-formulas", "--tier", "low", "--atoms", "4"], "--atoms: set by --tier"),
        (["gen-traces", "{dfas}", "--once-each", "--max-len", "5"], "--max-len: ignored"),
        (["gen-traces", "{dfas}", "--max-none", "1"], "--max-none: only with --once-each"),
        (
            ["train-meta", "{dfas}", "t", "--edge", "e", "--readout", "walk", "--bins", "2"],
            "--bins: only",
        ),
        (
            [
                "train-task",
                "action-recognition",
                "{dfas}",
                "--kb",
                "k.ltl",
                "--decode",
                "argmax",
                "--decode-top-k",
                "3",
            ],
            "--decode-top-k: only with --decode constrained",
        ),
        # next activity: what a model does not read (the refusal comes before the cases are read)
        (
            ["train-task", "next-activity", "{dfas}", "--model", "prefix-table", "--hidden", "8"],
            "--hidden: the prefix table is counted",
        ),
        (
            [
                "train-task",
                "next-activity",
                "{dfas}",
                "--model",
                "prefix-table",
                "--epochs",
                "3",
                "--lr",
                "0.1",
                "--batch-size",
                "4",
            ],
            "--epochs, --lr, --batch-size: the prefix table",
        ),
        (
            ["train-task", "next-activity", "{dfas}", "--model", "prefix-table", "--resume"],
            "--resume: the prefix table",
        ),
        (
            ["train-task", "next-activity", "{dfas}", "--model", "lstm", "--heads", "2"],
            "--heads: only with --model transformer",
        ),
        (
            ["train-task", "next-activity", "{dfas}", "--grid", "heads=2,4"],
            "--grid: an LSTM reads no heads",
        ),
        (["train-task", "next-activity", "{dfas}", "--grid", "hidden=4,4"], "4 is named twice"),
        (
            ["eval", "next-activity", "{dfas}", "{dfas}", "--rule-weight", "1"],
            "--rule-weight: only with --prefix-lengths",
        ),
        (
            ["eval", "next-activity", "{dfas}", "{dfas}", "--min-suffix", "1"],
            "--min-suffix: only with --prefix-lengths",
        ),
    ],
)
def test_options_that_would_be_ignored_are_refused(
    dfas: Path, tmp_path: Path, args: list[str], expected: str
) -> None:
    out = [] if args[0] == "inspect" else ["-o", tmp_path / "out"]
    result = tleaf(*[a.format(dfas=dfas) for a in args], *out)
    assert result.exit_code == 2 and expected in result.output, result.output
    assert not (tmp_path / "out").exists()
