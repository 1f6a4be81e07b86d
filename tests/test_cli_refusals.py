"""The command line refuses an unusable call with one stderr line naming what to change, exit
status 2, no traceback and nothing written: outputs it cannot write (the user's path named, never
a temporary file), a file output given as a folder, an option the call would ignore, traces
without the split a trainer needs, a damaged embedder folder."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from conftest import tiny_activities
from typer.testing import CliRunner

from tleaf_cli.cli import app

runner = CliRunner()


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


def one_error_line(result) -> str:
    """The single stderr line of a refused call (exit 2, no traceback)."""
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, lines
    return lines[0]


@pytest.fixture
def formulas(tmp_path: Path) -> Path:
    path = tmp_path / "f.ltl"
    path.write_text("a: F a\n", encoding="utf-8")
    return path


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs /proc")
def test_an_output_that_cannot_be_written_is_named_as_given(formulas: Path) -> None:
    line = one_error_line(tleaf("compile-dfa", formulas, "-o", "/proc/x.parquet"))
    assert "/proc/x.parquet" in line and ".tmp" not in line, line


def test_a_file_output_ending_in_a_slash_is_refused(formulas: Path, tmp_path: Path) -> None:
    out = f"{tmp_path / 'dfas'}{os.sep}"
    result = tleaf("compile-dfa", formulas, "-o", out)  # refused by the parser, as a usage error
    assert result.exit_code == 2 and "Traceback" not in result.output
    shown = " ".join(result.output.replace("│", " ").split())
    assert "--out" in shown and "a folder; give a file name" in shown, shown
    assert not (tmp_path / "dfas").exists()


def test_a_file_output_that_is_a_folder_is_refused(formulas: Path, tmp_path: Path) -> None:
    line = one_error_line(tleaf("compile-dfa", formulas, "-o", tmp_path))
    assert str(tmp_path) in line and "folder" in line, line


def test_lambda_without_a_logic_loss_is_refused(tmp_path: Path) -> None:
    data, kb = tiny_activities(tmp_path)
    run = tmp_path / "run"
    result = tleaf(
        "train-task", "action-recognition", data, "--kb", kb, "--logic-loss", "none",
        "--lambda", "2", "--epochs", "1", "-o", run, "-q",
    )  # fmt: skip
    line = one_error_line(result)
    assert "--lambda" in line and "--logic-loss" in line, line
    assert not run.exists()


def test_train_meta_on_traces_without_a_split_says_how_to_draw_one(chain, tmp_path) -> None:
    traces = tmp_path / "nosplit.parquet"
    assert tleaf("gen-traces", chain["dfas"], "-o", traces, "--per-formula", 2, "-q").exit_code == 0
    result = tleaf(
        "train-meta", chain["dfas"], traces, "--edge", chain["edge"], "-o", tmp_path / "q",
        "--epochs", 1, "-q",
    )  # fmt: skip
    line = one_error_line(result)
    assert "split" in line and "tleaf gen-traces" in line and "--split" in line, line


@pytest.mark.parametrize("damage", ["weights", "config"])
def test_a_damaged_embedder_folder_is_one_line(chain, tmp_path: Path, damage: str) -> None:
    """`embed` on a q folder whose weights.pt is not a checkpoint, or whose config.json is `[]`."""
    model = tmp_path / "q"
    result = tleaf(
        "train-meta", chain["dfas"], chain["traces"], "--edge", chain["edge"], "-o", model,
        "--epochs", 1, "--hidden", 16, "-q",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    if damage == "weights":
        (model / "weights.pt").write_bytes(b"not a checkpoint")
    else:
        (model / "config.json").write_text(json.dumps([]), encoding="utf-8")
    line = one_error_line(tleaf("embed", model, chain["dfas"], "-o", tmp_path / "v.parquet"))
    assert str(model) in line, line


@pytest.mark.parametrize("text", ["nan", "4.5", "many"])
def test_a_number_that_is_not_one_is_one_line(tmp_path: Path, text: str) -> None:
    """Before: `--hidden nan` printed click's usage box ("Invalid value for '--hidden'")."""
    run = tmp_path / "run"
    line = one_error_line(tleaf("train-task", "next-activity", "c.parquet", "--hidden", text,
                                "-o", run))  # fmt: skip
    assert line == f"error: --hidden: must be a whole number, not '{text}'", line
    line = one_error_line(tleaf("train-task", "next-activity", "c.parquet", "--lr", "abc"))
    assert line == "error: --lr: must be a number, not 'abc'", line
    assert not run.exists()


def _member_data(path: Path) -> list[range]:
    """The byte ranges of a zip archive's members' contents (what their CRC-32s cover)."""
    import struct
    import zipfile

    ranges = []
    raw = path.read_bytes()
    for info in zipfile.ZipFile(path).infolist():
        at = info.header_offset  # a local header: 30 bytes, then the name and the extra field
        name, extra = struct.unpack("<HH", raw[at + 26 : at + 30])
        start = at + 30 + name + extra
        ranges.append(range(start, start + info.compress_size))
    return [r for r in ranges if len(r)]


def test_a_damaged_checkpoint_is_one_line_naming_it(tmp_path: Path) -> None:
    """--resume on a checkpoint.pt truncated, emptied or with a byte changed. Before: an
    IndexError or AttributeError traceback for some changed bytes, torch's advice to load with
    weights_only=False for others, `error: Invalid argument` (no file named) for a truncated
    one, and a changed weight resumed as another. A changed byte the archive does not read (a
    header's padding) may resume: then as the whole checkpoint would."""
    import random
    import shutil

    import torch
    from test_next_activity import cases_artifact

    data = cases_artifact(tmp_path, cases=40)
    args = ["train-task", "next-activity", data, "--hidden", 4, "--layers", 1, "-q"]
    whole = tmp_path / "whole"
    assert tleaf(*args, "--epochs", 1, "-o", whole).exit_code == 0
    pristine = (whole / "checkpoint.pt").read_bytes()
    shutil.copytree(whole, tmp_path / "kept")
    assert tleaf(*args, "--epochs", 2, "-o", tmp_path / "kept", "--resume").exit_code == 0
    resumed = torch.load(tmp_path / "kept" / "weights.pt", weights_only=True)

    rng = random.Random(0)
    contents = [i for r in _member_data(whole / "checkpoint.pt") for i in r]
    damages = {"truncated": pristine[: len(pristine) // 2], "empty": b"", "zeros": bytes(512)}
    for name, places in (
        ("in", rng.sample(contents, 6)),
        ("at", rng.sample(range(len(pristine)), 6)),
    ):
        for at in places:
            changed = bytearray(pristine)
            changed[at] ^= 1 + rng.randrange(255)
            damages[f"{name}-{at}"] = bytes(changed)
    for name, damaged in damages.items():
        run = tmp_path / name
        shutil.copytree(whole, run)
        (run / "checkpoint.pt").write_bytes(damaged)
        result = tleaf(*args, "--epochs", 2, "-o", run, "--resume")
        if result.exit_code == 0 and name.startswith("at-"):  # a byte no reader reads
            again = torch.load(run / "weights.pt", weights_only=True)
            assert all(torch.equal(again[k], v) for k, v in resumed.items()), name
            continue
        line = one_error_line(result)
        assert str(run / "checkpoint.pt") in line and "damaged" in line, (name, line)
