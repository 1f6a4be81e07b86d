"""`tleaf compile-dfa`: output, --jobs, the cache, and every kind of bad input."""

from __future__ import annotations

import os
import random
import shutil
from pathlib import Path

import networkx as nx
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from tests.test_formulas import ANY_TEXT, DEEP, GRAMMARISH
from tleaf_cli.cli import app
from tleaf_cli.data import compile_dfas
from tleaf_cli.data.artifacts import read_provenance
from tleaf_cli.data.dfa_table import read_dfas
from tleaf_cli.data.formula_files import parse_ltl_text
from tleaf_cli.data.random_formulas import random_formula
from tleaf_cli.logic import mona

runner = CliRunner()
EXAMPLE = Path(__file__).parent.parent / "examples" / "cooking_rules.ltl"
# "a holds k steps before the end": its minimal DFA has 2^k states; MONA needs ~17 s for k=18.
# 2^18 states before the end: past progression's limits (a count, the same everywhere), so MONA's.
SLOW = "F(a & " + "X(" * 18 + "last" + ")" * 18 + ")"
# A MONA that never finishes a formula (and answers `mona -v`, part of the cache key): the
# timeout path is taken whatever the machine's speed or load, with no real work racing a clock.
STUCK_MONA = """#!/bin/sh
if [ "$1" = "-v" ]; then echo "MONA v1.4-18 (a stand-in that never finishes)"; exit 0; fi
exec sleep 60
"""


def tleaf(*args: str):
    return runner.invoke(app, [str(a) for a in args])


def _write(path: Path, lines: list[str]) -> Path:
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_compiles_example_with_provenance(tmp_path: Path) -> None:
    out = tmp_path / "dfas.parquet"
    result = tleaf("compile-dfa", EXAMPLE, "-o", out)
    assert result.exit_code == 0, result.output
    table = read_dfas(out)
    assert len(table.rows) == len(
        [
            ln
            for ln in EXAMPLE.read_text().splitlines()
            if ln.strip() and not ln.lstrip().startswith("#")
        ]
    )
    assert all(r["error"] is None for r in table.rows)
    assert table.ids()[0] == "rinse_before_cook"
    prov = read_provenance(out)
    assert prov.kind == "dfa" and prov.schema == 1
    assert prov.params["alphabet"] == "powerset"
    assert (
        prov.inputs[0]["path"].endswith("cooking_rules.ltl") and len(prov.inputs[0]["sha256"]) == 64
    )
    dfa = table.dfa("never_cut_milk")
    assert dfa.accepts([{"cut_onion"}]) and not dfa.accepts([{"cut_onion"}, {"cut_milk"}])


def test_jobs_two_writes_the_same_table_as_jobs_one(tmp_path: Path) -> None:
    rng = random.Random(5)
    lines = [random_formula(rng, ["a", "b", "c"], rng.randint(5, 15)) for _ in range(40)]
    src = _write(tmp_path / "f.ltl", [*lines, "G A", lines[0]])
    one, two = tmp_path / "one.parquet", tmp_path / "two.parquet"
    r1 = tleaf("compile-dfa", src, "-o", one, "--jobs", "1", "--no-cache")
    r2 = tleaf("compile-dfa", src, "-o", two, "--jobs", "2", "--no-cache")
    assert r1.exit_code == r2.exit_code == 1  # the "G A" line
    assert pq.read_table(one).equals(pq.read_table(two))


def test_cache_hit_runs_no_mona(tmp_path: Path, monkeypatch) -> None:
    src = _write(tmp_path / "f.ltl", ["G(a -> F b)", "a U b", "F(c & last)"])
    settings = compile_dfas.CompileSettings(cache_dir=tmp_path / "cache", engine="mona")
    first = compile_dfas.compile_file(src, tmp_path / "1.parquet", settings)
    assert first.cache_hits == 0 and first.compiled == 3

    def no_mona(*args, **kwargs):
        raise AssertionError("MONA was called on a cached formula")

    monkeypatch.setattr(mona, "run_mona", no_mona)
    second = compile_dfas.compile_file(src, tmp_path / "2.parquet", settings)
    assert second.cache_hits == 3 and second.compiled == 3
    assert pq.read_table(tmp_path / "1.parquet").equals(pq.read_table(tmp_path / "2.parquet"))
    # Another alphabet is another key: a miss, so MONA is needed (and here refused).
    other = compile_dfas.CompileSettings(
        alphabet="one-hot", cache_dir=tmp_path / "cache", engine="mona"
    )
    with pytest.raises(AssertionError, match="MONA was called"):
        compile_dfas.compile_file(src, tmp_path / "3.parquet", other)


def test_identical_formulas_are_compiled_once(tmp_path: Path) -> None:
    src = _write(tmp_path / "f.ltl", ["G a", "G  a", "  G a", "F a"])
    report = compile_dfas.compile_file(
        src, tmp_path / "o.parquet", compile_dfas.CompileSettings(cache_dir=None)
    )
    assert report.unique == 2 and report.compiled == 4


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        ("a & (b | ", "line 2, column 9: formula ends too early"),
        ("a ^ b", "line 2, column 3: unexpected character '^'"),
        ("G Cut_milk", "line 2, column 3: upper-case atom 'Cut_milk'"),
        ("Fb", "line 2, column 1: operator 'F' must be followed by a space"),
        ("my name: a", "line 2: invalid formula name 'my name'"),
        ("ok: b", "line 2: name 'ok' already used on line 1"),
    ],
)
def test_bad_line_becomes_an_error_row_and_the_rest_compiles(
    tmp_path: Path, line: str, expected: str
) -> None:
    src = _write(tmp_path / "f.ltl", ["ok: G(a -> F b)", line, "F c"])
    out = tmp_path / "o.parquet"
    result = tleaf("compile-dfa", src, "-o", out)
    assert result.exit_code == 1
    assert expected in result.output and "Traceback" not in result.output
    rows = read_dfas(out).rows
    assert len(rows) == 3
    assert rows[0]["error"] is None and rows[2]["error"] is None
    assert rows[1]["error"].startswith(expected)
    assert rows[1]["num_states"] is None and rows[1]["edges"] is None


def test_empty_file(tmp_path: Path) -> None:
    src = _write(tmp_path / "f.ltl", ["# only a comment", ""])
    out = tmp_path / "o.parquet"
    result = tleaf("compile-dfa", src, "-o", out)
    assert result.exit_code == 1
    assert "no formulas" in result.output
    assert read_dfas(out).rows == []


def test_timeout_is_an_error_row(tmp_path: Path, monkeypatch) -> None:
    """The formula MONA does not finish within --timeout is an error row; the others, compiled
    by progression (MONA is never asked), are not."""
    stuck = tmp_path / "bin" / "mona"
    stuck.parent.mkdir()
    stuck.write_text(STUCK_MONA)
    stuck.chmod(0o755)
    monkeypatch.setenv("PATH", f"{stuck.parent}{os.pathsep}{os.environ['PATH']}")
    src = _write(tmp_path / "f.ltl", ["G a", SLOW, "F b"])
    out = tmp_path / "o.parquet"
    result = tleaf("compile-dfa", src, "-o", out, "--timeout", "0.5", "--jobs", "2")
    assert result.exit_code == 1
    rows = read_dfas(out).rows
    assert "line 2: MONA did not finish within 0.5 s" in rows[1]["error"]
    assert rows[0]["error"] is None and rows[2]["error"] is None


def test_missing_mona_exits_2_and_writes_nothing(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setenv("PATH", str(tmp_path / "empty-bin"))
    out = tmp_path / "o.parquet"
    result = tleaf("compile-dfa", EXAMPLE, "-o", out)
    assert result.exit_code == 2
    assert "apt-get install -y mona" in result.output
    assert not out.exists()
    assert os.listdir(tmp_path) == []


def test_unusable_inputs_exit_2(tmp_path: Path) -> None:
    assert tleaf("compile-dfa", tmp_path / "missing.ltl").exit_code == 2
    not_parquet = _write(tmp_path / "x.parquet", ["hello"])
    result = tleaf("compile-dfa", not_parquet, "-o", tmp_path / "o.parquet")
    assert result.exit_code == 2 and "Parquet" in result.output
    pq.write_table(pa.table({"text": ["a"]}), tmp_path / "foreign.parquet")
    result = tleaf("compile-dfa", tmp_path / "foreign.parquet", "-o", tmp_path / "o.parquet")
    assert result.exit_code == 2 and "formula_id and formula" in result.output


def test_parquet_input_with_formula_columns(tmp_path: Path) -> None:
    pq.write_table(
        pa.table({"formula_id": ["r1", "r2", "r3"], "formula": ["G a", "a U", "F b"]}),
        tmp_path / "in.parquet",
    )
    out = tmp_path / "o.parquet"
    result = tleaf("compile-dfa", tmp_path / "in.parquet", "-o", out)
    assert result.exit_code == 1
    rows = read_dfas(out).rows
    assert [r["formula_id"] for r in rows] == ["r1", "r2", "r3"]
    assert rows[1]["error"].startswith("row 1, column")


def test_one_hot_option_and_graph_files(tmp_path: Path) -> None:
    out, graphs = tmp_path / "o.parquet", tmp_path / "graphs"
    result = tleaf("compile-dfa", EXAMPLE, "-o", out, "--one-hot", "--graphs", graphs)
    assert result.exit_code == 0, result.output
    table = read_dfas(out)
    assert {r["alphabet"] for r in table.rows} == {"one-hot"}
    row = table.row("rinse_before_cook")
    g = nx.read_graphml(graphs / "rinse_before_cook.graphml")
    assert g.number_of_nodes() == row["num_states"]
    assert g.number_of_edges() == len(row["edges"])
    initial = [n for n, d in g.nodes(data=True) if d["initial"]]
    assert initial == [str(row["initial"])]
    dot = (graphs / "rinse_before_cook.dot").read_text()
    assert dot.startswith("digraph") and "doublecircle" in dot


def test_no_temporary_files_left_behind_and_usual_permissions(tmp_path: Path) -> None:
    out = tmp_path / "o.parquet"
    old = os.umask(0o022)
    try:
        tleaf("compile-dfa", EXAMPLE, "-o", out)
    finally:
        os.umask(old)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.parquet"]
    assert out.stat().st_mode & 0o777 == 0o644


def test_inspect_artifact_and_one_dfa(tmp_path: Path) -> None:
    out = tmp_path / "o.parquet"
    tleaf("compile-dfa", EXAMPLE, "-o", out)
    shown = tleaf("inspect", out)
    assert shown.exit_code == 0
    assert "dfa artifact, schema 1" in shown.output and "rows: 6" in shown.output
    assert "cooking_rules.ltl" in shown.output
    one = tleaf("inspect", out, "--id", "never_cut_milk")
    assert one.exit_code == 0 and "!cut_milk" in one.output and "accepting" in one.output
    dot = tleaf("inspect", out, "--id", "never_cut_milk", "--dot")
    assert dot.output.startswith("digraph")
    assert tleaf("inspect", out, "--id", "nope").exit_code == 2
    assert tleaf("inspect", EXAMPLE).exit_code == 2


@pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz not installed")
def test_inspect_draws_svg(tmp_path: Path) -> None:
    out = tmp_path / "o.parquet"
    tleaf("compile-dfa", EXAMPLE, "-o", out)
    svg = tmp_path / "g.svg"
    result = tleaf("inspect", out, "--id", "cut_then_fry", "--draw", svg)
    assert result.exit_code == 0, result.output
    assert "<svg" in svg.read_text()


def test_unwritable_output_fails_before_any_work(tmp_path: Path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    for args in (
        ["compile-dfa", EXAMPLE, "-o", blocker / "dfas.parquet"],
        ["gen-formulas", "-n", 2, "-o", blocker / "f.ltl"],
        ["compile-dfa", EXAMPLE, "-o", tmp_path],
    ):
        result = tleaf(*args)
        assert result.exit_code == 2, result.output
        assert "Traceback" not in result.output and "error:" in result.output


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


def test_compile_dfa_refuses_an_unwritable_graphs_folder_before_writing(tmp_path: Path) -> None:
    source = tmp_path / "f.ltl"
    source.write_text("a: F a\n", encoding="utf-8")
    graphs = tmp_path / "graphs"
    graphs.write_text("a regular file")
    out = tmp_path / "dfas.parquet"
    result = tleaf("compile-dfa", source, "-o", out, "--graphs", graphs)
    assert result.exit_code == 2 and "not a folder" in result.output, result.output
    assert not out.exists()


def test_compile_dfa_writes_one_graph_file_per_id(tmp_path: Path) -> None:
    source = tmp_path / "f.parquet"
    ids = ["Rule", "rule", "a/b", "a_b"]
    table = pa.table({"formula_id": ids, "formula": ["F a", "G a", "X a", "a U b"]})
    pq.write_table(table, source)
    result = tleaf("compile-dfa", source, "-o", tmp_path / "d.parquet", "--graphs", tmp_path / "g")
    assert result.exit_code == 0, result.output
    names = {p.name.casefold() for p in (tmp_path / "g").glob("*.graphml")}
    assert len(names) == len(ids)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.one_of(GRAMMARISH, ANY_TEXT), min_size=1, max_size=4))
def test_compile_stage_turns_any_line_into_a_row(lines: list[str]) -> None:
    text = "\n".join(line.replace("\n", " ").replace("\r", " ") for line in lines)
    sources = parse_ltl_text(text, "fuzz.ltl")
    report = compile_dfas.compile_sources(
        sources, compile_dfas.CompileSettings(cache_dir=None, timeout=5)
    )
    assert len(report.rows) == len(sources)
    assert len({r["formula_id"] for r in report.rows}) == len(report.rows)
    for row in report.rows:
        assert (row["error"] is None) == (row["num_states"] is not None)
        if row["error"] is not None:
            assert row["error"].startswith(("line ", "row "))
