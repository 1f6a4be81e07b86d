"""Defects a new user hits, each for its whole class: formulas nested too deeply, an output that
is an input, stages that refuse their call after writing something, options combined and silently
ignored, generated names that break the `.ltl` format."""

from __future__ import annotations

import os
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from ltlf2dfa.ltlf import LTLfAtomic, LTLfImplies, LTLfNot
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.dfa_table import read_dfas
from tleaf_cli.data.formula_files import check_names
from tleaf_cli.data.graphs import graph_file_stems
from tleaf_cli.embed.graphs import syntax_graph
from tleaf_cli.errors import InputError
from tleaf_cli.logic import mona
from tleaf_cli.logic.formulas import MAX_DEPTH, FormulaSyntaxError, parse
from tleaf_cli.logic.semantics import satisfies

runner = CliRunner()

DEEP = {
    "negations": "!" * 500 + "a",
    "parentheses": "(" * 400 + "a" + ")" * 400,
    "always": "G (" * 300 + "a" + ")" * 300,
    "next": "X " * 2000 + "a",
}


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


# 1. Formulas nested too deeply: a per-formula error, never a RecursionError.


@pytest.mark.parametrize("text", DEEP.values(), ids=DEEP.keys())
def test_a_deeply_nested_formula_is_a_syntax_error_with_the_limit(text: str) -> None:
    with pytest.raises(FormulaSyntaxError, match=f"nested too deeply \\(at most {MAX_DEPTH}"):
        parse(text)


def test_the_limit_itself_parses_and_every_walk_handles_it() -> None:
    formula = parse("!" * (MAX_DEPTH - 1) + "a")
    assert satisfies([{"a"}], formula) is (MAX_DEPTH % 2 == 1)
    assert syntax_graph(formula, {"a": 0}).num_nodes == MAX_DEPTH
    assert mona.mona_program(formula).count("~(") >= MAX_DEPTH - 1


def _deep_not(levels: int):
    formula = LTLfAtomic("a")
    for _ in range(levels):
        formula = LTLfNot(formula)
    return formula


@pytest.mark.parametrize(
    "walk",
    [
        lambda f: satisfies([{"a"}], f),
        lambda f: syntax_graph(f, {"a": 0}),
        mona.mona_program,
    ],
    ids=["semantics", "syntax_graph", "mona_program"],
)
def test_walks_refuse_a_formula_built_too_deep(walk) -> None:
    """Formulas built in code, never parsed, are checked by every walk that recurses."""
    with pytest.raises(FormulaSyntaxError, match="nested too deeply"):
        walk(_deep_not(3000))


def test_a_long_implication_chain_is_too_deep_for_the_mona_encoding() -> None:
    """`a -> a -> ...` parses flat, but ltlf2dfa's encoding nests it one level per operand."""
    chain = LTLfImplies([LTLfAtomic("a")] * 3000)
    with pytest.raises(FormulaSyntaxError, match="nested too deeply"):
        mona.mona_program(chain)
    with pytest.raises(FormulaSyntaxError, match="not 3000"):
        parse(" -> ".join(["a"] * 3000))


def test_an_encoding_that_doubles_per_level_is_refused_before_it_is_written() -> None:
    """20 nested G make a 185 MB MONA program; 25 exhausted the memory writing it."""
    with pytest.raises(mona.MonaError, match="too large for MONA"):
        mona.mona_program(parse("G (" * 25 + "a" + ")" * 25))
    nested_f = parse("F (" * 25 + "a" + ")" * 25)  # F writes its operand once: fine
    assert mona.encoding_nodes(nested_f) < 100


def test_compile_dfa_reports_deep_rows_and_compiles_the_others(tmp_path: Path) -> None:
    source = tmp_path / "deep.ltl"
    lines = ["ok1: G (a -> F b)"] + [f"{k}: {t}" for k, t in DEEP.items()] + ["ok2: X a"]
    source.write_text("\n".join(lines) + "\n", encoding="utf-8")
    out = tmp_path / "dfas.parquet"
    result = tleaf("compile-dfa", source, "-o", out)
    assert result.exit_code == 1, result.output
    assert "Traceback" not in result.output and "RecursionError" not in result.output
    rows = {r["formula_id"]: r for r in read_dfas(out).rows}
    assert rows["ok1"]["error"] is None and rows["ok2"]["error"] is None
    for name in DEEP:
        assert "nested too deeply" in rows[name]["error"], rows[name]["error"]


# 2. and 3. An output that is an input, or cannot be written: exit 2, nothing written.


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


def test_compile_dfa_refuses_an_unwritable_graphs_folder_before_writing(tmp_path: Path) -> None:
    source = tmp_path / "f.ltl"
    source.write_text("a: F a\n", encoding="utf-8")
    graphs = tmp_path / "graphs"
    graphs.write_text("a regular file")
    out = tmp_path / "dfas.parquet"
    result = tleaf("compile-dfa", source, "-o", out, "--graphs", graphs)
    assert result.exit_code == 2 and "not a folder" in result.output, result.output
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


# 4. Options combined and ignored: both work, or the call is refused.


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
            ["train-task", "action-recognition", "{dfas}", "--kb", "k.ltl", "--decode", "argmax",
             "--decode-top-k", "3"],  # fmt: skip
            "--decode-top-k: only with --decode constrained",
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


# 5. Generated names and ids checked where they are written.


def test_gen_formulas_refuses_a_prefix_that_is_no_formula_name(tmp_path: Path) -> None:
    out = tmp_path / "f.ltl"
    result = tleaf("gen-formulas", "--prefix", "a b#", "-n", "1", "-o", out)
    assert result.exit_code == 2 and "--prefix" in result.output, result.output
    assert not out.exists()


def test_check_names_refuses_bad_and_repeated_names() -> None:
    check_names(["f00000", "low-1", "rs-0a1b.c_d"], "formula id")
    with pytest.raises(InputError, match="formula id 'a b#' is not a valid name"):
        check_names(["a b#"], "formula id")
    with pytest.raises(InputError, match="written twice"):
        check_names(["x", "x"], "video id")


def test_graph_files_of_ids_that_meet_get_distinct_names() -> None:
    ids = ["Rule", "rule", "a/b", "a_b", "plain"]
    stems = graph_file_stems(ids)
    assert stems[-1] == "plain"  # ids that meet no other keep their own name
    assert len({s.casefold() for s in stems}) == len(ids)
    assert graph_file_stems(ids) == stems  # stable


def test_compile_dfa_writes_one_graph_file_per_id(tmp_path: Path) -> None:
    source = tmp_path / "f.parquet"
    ids = ["Rule", "rule", "a/b", "a_b"]
    table = pa.table({"formula_id": ids, "formula": ["F a", "G a", "X a", "a U b"]})
    pq.write_table(table, source)
    result = tleaf("compile-dfa", source, "-o", tmp_path / "d.parquet", "--graphs", tmp_path / "g")
    assert result.exit_code == 0, result.output
    names = {p.name.casefold() for p in (tmp_path / "g").glob("*.graphml")}
    assert len(names) == len(ids)


def test_a_refused_call_creates_no_folder(tmp_path: Path) -> None:
    """Exit 2 writes nothing, not even the output's folder."""
    out = tmp_path / "new" / "deeper" / "f.ltl"
    result = tleaf("gen-formulas", "--tier", "low", "--atoms", "4", "-o", out)
    assert result.exit_code == 2
    assert not (tmp_path / "new").exists()
    result = tleaf("gen-formulas", "--tier", "low", "-n", "3", "-o", out)
    assert result.exit_code == 0 and out.exists()  # the folder is made when the file is written
