"""Every ```python block of docs/library.md, docs/losses.md and docs/decoding.md runs, and
shows what it says.

The blocks of one file run in order in one namespace, in a temporary working directory. A bare
expression followed by a comment on its last line is a result: the comment must be the value's
repr, spaces ignored (`tl.check(dfa, traces)  # array([False,  True])`). Other comments are prose.
A snippet that needs a trained embedder sets `MODEL_DIR = "..."` to a train-meta folder, as a
reader would; the test points that assignment at a tiny one (`tiny_model_dir`) instead, and the
docs say so where they use it. A name a snippet reads is defined by the doc's blocks before it.
"""

from __future__ import annotations

import ast
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).parent.parent
DOCS = ("docs/library.md", "docs/losses.md", "docs/decoding.md")
FENCE = re.compile(r"^(`{3,})\s*(\S*)")
PYTHON_LIKE = {"py", "python", "python3", "pycon", "ipython"}


def python_blocks(path: Path) -> list[tuple[int, str]]:
    """(line number of the block's first line, source) of every ```python block.

    A fenced block marked as another flavour of Python (```py, ```pycon, ...) is an error: it
    would look like a snippet but not run.
    """
    blocks: list[tuple[int, str]] = []
    lines = path.read_text(encoding="utf-8").splitlines()
    fence, info, start, body = None, "", 0, []
    for number, line in enumerate(lines, start=1):
        match = FENCE.match(line)
        if fence is None:
            if match:
                fence, info, start, body = match.group(1), match.group(2).lower(), number + 1, []
                if info in PYTHON_LIKE and info != "python":
                    raise AssertionError(f"{path}:{number}: mark Python blocks ```python")
        elif line.strip() == fence:
            if info == "python":
                blocks.append((start, "\n".join(body) + "\n"))
            fence = None
        else:
            body.append(line)
    assert fence is None, f"{path}: a ``` block is not closed"
    return blocks


def _comments(source: str) -> dict[int, str]:
    """Line -> the text of the comment that ends it."""
    out = {}
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            out[token.start[0]] = token.string[1:].strip()
    return out


def _squash(text: str) -> str:
    return "".join(text.split())


def run_block(source: str, first_line: int, path: str, namespace: dict) -> int:
    """Run one block statement by statement (tracebacks name the doc's lines); returns how many
    results were checked."""
    tree = ast.parse(source)
    ast.increment_lineno(tree, first_line - 1)
    comments = {line + first_line - 1: text for line, text in _comments(source).items()}
    checked = 0
    for node in tree.body:
        expected = comments.get(node.end_lineno) if isinstance(node, ast.Expr) else None
        if expected is None:
            exec(compile(ast.Module([node], []), path, "exec"), namespace)
            continue
        value = eval(compile(ast.Expression(node.value), path, "eval"), namespace)
        assert _squash(repr(value)) == _squash(expected), (
            f"{path}:{node.end_lineno}: the snippet says {expected}, the code gives {value!r}"
        )
        checked += 1
    return checked


MODEL_DIR_ASSIGNMENT = re.compile(r'^(MODEL_DIR\s*=\s*)"[^"]*"', re.MULTILINE)


def point_model_dir_at(source: str, folder: str) -> str:
    """The block with its `MODEL_DIR = "..."` assignment pointed at `folder`; a block that reads
    MODEL_DIR without one is left as it is (and fails where the name is undefined)."""
    return MODEL_DIR_ASSIGNMENT.sub(lambda m: f"{m.group(1)}{folder!r}", source)


@pytest.fixture(scope="session")
def tiny_model_dir(tmp_path_factory) -> Path:
    """A train-meta folder trained in seconds on 12 synthetic Low-tier formulas (atoms a, b, c):
    the same commands as pipelines/embedder.mk, tiny sizes. Its vectors mean little; it loads,
    embeds and gives gradients like any q."""
    from typer.testing import CliRunner

    from tleaf_cli.cli import app

    d = tmp_path_factory.mktemp("tiny-q")
    runner = CliRunner()
    commands = [
        ("gen-formulas", "--tier", "low", "-n", 12, "-o", d / "f.ltl"),
        ("compile-dfa", d / "f.ltl", "-o", d / "dfas.parquet", "--no-cache"),
        ("gen-traces", d / "dfas.parquet", "-o", d / "traces.parquet", "--per-formula", 4,
         "--split", "0.5,0.25,0.25"),
        ("train-edge", d / "dfas.parquet", "-o", d / "edge", "--epochs", 1, "--hidden", 16,
         "--out-dim", 8, "--per-guard", 1, "-q"),
        ("train-meta", d / "dfas.parquet", d / "traces.parquet", "--edge", d / "edge",
         "-o", d / "meta", "--epochs", 1, "--hidden", 16, "--layers", 1, "--out-dim", 8, "-q"),
    ]  # fmt: skip
    for command in commands:
        result = runner.invoke(app, [str(a) for a in command])
        assert result.exit_code == 0, f"{command[0]}: {result.output}"
    return d / "meta"


@pytest.mark.parametrize("doc", DOCS)
def test_doc_snippets_run_and_show_their_results(doc, request, tmp_path, monkeypatch) -> None:
    blocks = python_blocks(ROOT / doc)
    assert blocks, f"{doc} has no ```python block"
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__doc__"}
    if any("MODEL_DIR" in source for _, source in blocks):
        tiny = str(request.getfixturevalue("tiny_model_dir"))
        blocks = [(line, point_model_dir_at(source, tiny)) for line, source in blocks]
    checked = sum(run_block(source, line, doc, namespace) for line, source in blocks)
    assert checked > 0, f"{doc}: no result comment was checked"


def test_result_comments_are_checked(tmp_path) -> None:
    """The checker itself: a wrong result comment fails, prose comments elsewhere do not."""
    namespace: dict = {}
    assert run_block("x = [1, 2]  # prose\nlen(x)  # 2\n", 1, "doc.md", namespace) == 1
    with pytest.raises(AssertionError, match=r"doc\.md:3: the snippet says 3"):
        run_block("y = 1\n\nlen(x)  # 3\n", 1, "doc.md", namespace)
    doc = tmp_path / "doc.md"
    doc.write_text("```python\n1\n```\n\n````text\n```python\n````\n")
    assert python_blocks(doc) == [(2, "1\n")]
    doc.write_text("```py\n1\n```\n")
    with pytest.raises(AssertionError, match="mark Python blocks"):
        python_blocks(doc)


def test_model_dir_is_defined_by_the_doc() -> None:
    """A doc that reads MODEL_DIR assigns it itself: the test only repoints the assignment, so a
    snippet that uses an undefined MODEL_DIR fails as it would for a reader."""
    assert point_model_dir_at('MODEL_DIR = "out/q"  # a folder\n', "/tmp/t") == (
        "MODEL_DIR = '/tmp/t'  # a folder\n"
    )
    namespace: dict = {}
    with pytest.raises(NameError, match="MODEL_DIR"):
        run_block(point_model_dir_at("len(MODEL_DIR)\n", "/tmp/t"), 1, "doc.md", namespace)
