"""Where a stage writes: an output that is also an input, two outputs on one file, an output
folder under a file are refused (exit 2) before anything is written, not even the output's
folder."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app

runner = CliRunner()


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


def _same_file_spellings(path: Path) -> list[Path]:
    """The same file as the same string, through `./`, and through a symbolic link."""
    link = path.parent / f"link-{path.name}"
    link.symlink_to(path)
    return [path, Path(os.path.relpath(path.parent, Path.cwd())) / "." / path.name, link]


# (command line with {input} where the input goes, kind of the -o target: file or folder)
STAGES = [
    ("compile-dfa {input} -o {out}", "file"),
    ("gen-traces {input} -o {out}", "file"),
    ("embed model {input} -o {out}", "file"),
    ("eval table {input} -o {out}", "file"),
    ("demos-kb {input} -o {out}", "file"),
    ("gen-demos --domain {input} -o {out}", "file"),
    ("cooking-kb --domain {input} -o {out}", "file"),
    ("eval tsne dfas.parquet {input} --embedder m -o {out}", "file"),
    ("inspect {input} --id x --draw {out}", "file"),
    ("kb-extract kb.ltl {input} -o kb --mine", "kb/kb.ltl"),
    ("train-edge {input} -o {out}", "folder"),
    ("train-meta dfas.parquet traces.parquet --edge {input} -o {out}", "folder"),
    ("eval model-checking {input} t.parquet --embedder m -o {out}", "folder"),
    ("train-task action-recognition a.parquet --kb k.ltl --embedder {input} -o {out}", "folder"),
    ("train-task cooking demos.parquet --embedder {input} -o {out}", "folder"),
    ("eval action-recognition {input} -o {out}", "folder"),
    ("eval cooking {input} -o {out}", "folder"),
]


@pytest.mark.parametrize(("line", "kind"), STAGES, ids=[s[0].split(" {")[0] for s in STAGES])
def test_an_output_that_is_an_input_is_refused(
    tmp_path: Path, monkeypatch, line: str, kind: str
) -> None:
    monkeypatch.chdir(tmp_path)
    if kind == "folder":
        source = tmp_path / "inputdir"
        source.mkdir()
        (source / "keep.txt").write_text("precious")
    else:
        source = tmp_path / ("kb/kb.ltl" if kind == "kb/kb.ltl" else "input.parquet")
        source.parent.mkdir(exist_ok=True)
        source.write_text("precious")
    for out in _same_file_spellings(source):
        args = line.format(input=source, out=out).split()
        result = tleaf(*args)
        assert result.exit_code == 2, (args, result.output)
        assert "is also an input" in result.output, result.output
        if kind == "folder":
            assert sorted(p.name for p in source.iterdir()) == ["keep.txt"]
        else:
            assert source.read_text() == "precious"


def test_two_outputs_on_one_file_are_refused(tmp_path: Path) -> None:
    out = tmp_path / "both"
    result = tleaf("gen-activities", "-o", out, "--kb-out", tmp_path / "." / "both")
    assert result.exit_code == 2 and "given for two outputs" in result.output
    assert not out.exists()


@pytest.mark.parametrize(
    "line",
    [
        "train-edge dfas.parquet -o {blocker}/model",
        "eval model-checking d.parquet t.parquet --embedder m -o {blocker}",
        "eval cooking run -o {blocker}/sub",
    ],
)
def test_an_output_folder_under_a_file_is_refused_first(tmp_path: Path, line: str) -> None:
    blocker = tmp_path / "blocker"
    blocker.write_text("x")
    result = tleaf(*line.format(blocker=blocker).split())
    assert result.exit_code == 2 and "existing file" in result.output, result.output


def test_a_refused_call_creates_no_folder(tmp_path: Path) -> None:
    """Exit 2 writes nothing, not even the output's folder."""
    out = tmp_path / "new" / "deeper" / "f.ltl"
    result = tleaf("gen-formulas", "--tier", "low", "--atoms", "4", "-o", out)
    assert result.exit_code == 2
    assert not (tmp_path / "new").exists()
    result = tleaf("gen-formulas", "--tier", "low", "-n", "3", "-o", out)
    assert result.exit_code == 0 and out.exists()  # the folder is made when the file is written
