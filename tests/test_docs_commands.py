"""The shell commands of README.md and docs/ run as written.

Every `tleaf ...` line of a ```bash block names a command that exists and only options that
command has (a renamed option fails here, not in a reader's terminal), and README's first run, a
sequence from rules to an embedder's vectors, runs start to end in an empty folder.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import typer

ROOT = Path(__file__).parent.parent
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").glob("*.md"), *(ROOT / "docs").glob("*/*.md")])
FENCE = re.compile(r"^(`{3,})\s*(\S*)")


def bash_blocks(path: Path) -> list[tuple[int, list[str]]]:
    """(first line number, lines) of every ```bash block, continuation lines joined."""
    blocks, fence, start, body = [], None, 0, []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        match = FENCE.match(line)
        if fence is None and match:
            fence, info, start, body = match.group(1), match.group(2), number + 1, []
        elif fence is not None and line.strip() == fence:
            if info == "bash":
                joined = "\n".join(body).replace("\\\n", " ")
                blocks.append((start, joined.splitlines()))
            fence = None
        elif fence is not None:
            body.append(line)
    return blocks


def tleaf_commands(line: str) -> list[list[str]]:
    """The argument lists of the `tleaf` calls on a shell line (after `;`, `&&`, a variable
    assignment or a path to the script), its comment dropped."""
    try:
        words = shlex.split(line, comments=True)
    except ValueError:
        return []
    calls, current = [], None
    for word in words:
        if word in {";", "&&", "||", "|"} or word.endswith(";"):
            current = None
            continue
        if current is None and (word == "tleaf" or word.endswith("/tleaf")):
            current = []
            calls.append(current)
        elif current is not None:
            current.append(word)
    return calls


def _option_names(command) -> set[str]:
    names = {"--help"}
    for param in command.params:
        names.update(param.opts)
        names.update(param.secondary_opts)
    return names


def unknown_options(args: list[str]) -> list[str]:
    """What is wrong with one `tleaf ARGS` call: an unknown command or an option it lacks."""
    from tleaf_cli.cli import app

    command = typer.main.get_command(app)  # typer's own click: a group is what has commands
    rest = list(args)
    while hasattr(command, "commands"):
        if not rest or rest[0].startswith("-"):
            return []  # `tleaf --help`, `tleaf eval --help`
        name = rest.pop(0)
        if name not in command.commands:
            return [f"no command {name!r}"]
        command = command.commands[name]
    names = _option_names(command)
    return [
        f"{args[0]}: no option {word.split('=')[0]}"
        for word in rest
        if word.startswith("-") and word != "-" and word.split("=")[0] not in names
        and not re.fullmatch(r"-\d[\d.e-]*", word)  # a negative number
    ]  # fmt: skip


CALLS = [
    (f"{page.relative_to(ROOT)}:{start + i}", call)
    for page in PAGES
    for start, lines in bash_blocks(page)
    for i, line in enumerate(lines)
    for call in tleaf_commands(line)
    if call
]


def test_the_docs_have_tleaf_commands() -> None:
    assert len(CALLS) > 20


@pytest.mark.parametrize(("where", "args"), CALLS, ids=[w for w, _ in CALLS])
def test_each_documented_command_has_its_options(where: str, args: list[str]) -> None:
    assert unknown_options(args) == [], where


def test_an_unknown_option_or_command_is_found() -> None:
    assert tleaf_commands("OMP_NUM_THREADS=1 tleaf embed m d.parquet -o v.parquet  # vectors") == [
        ["embed", "m", "d.parquet", "-o", "v.parquet"]
    ]
    assert unknown_options(["gen-traces", "d.parquet", "--per-formula", "5", "--splits", "x"]) == [
        "gen-traces: no option --splits"
    ]
    assert unknown_options(["eval", "model-checks"]) == ["no command 'model-checks'"]
    assert unknown_options(["train-meta", "d", "t", "--no-sphere", "--seed", "-1"]) == []


def first_run_block() -> list[str]:
    """README's "A first run" shell block as written, one command a line."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## A first run") :]
    start = section.index("```bash") + len("```bash")
    block = section[start : section.index("```", start)]
    return [line for line in block.strip().splitlines() if line.strip()]


@pytest.mark.slow
def test_the_readme_first_run_runs_as_written(tmp_path: Path) -> None:
    """In an empty folder with the repository's examples, every command of the first run exits
    0, in order. Left out: activating the venv (tleaf is put on PATH instead), the drawing where
    Graphviz is missing, and the data tiers' make (minutes; the pipelines have their own
    tests)."""
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env['PATH']}"
    ran = 0
    for line in first_run_block():
        if line.startswith((". ", "source ", "make ", "#")):
            continue
        if "--draw" in line and shutil.which("dot") is None:
            continue
        result = subprocess.run(
            line, shell=True, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
        )
        assert result.returncode == 0, f"{line}\n{result.stderr[-2000:]}"
        ran += 1
    assert ran >= 8
    assert (tmp_path / "vectors.parquet").exists()
