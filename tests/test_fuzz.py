"""Hypothesis fuzzing of formula text: a user's mistake is an error message, never a traceback."""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tleaf_cli.data.compile_dfas import CompileSettings, compile_sources
from tleaf_cli.data.formula_files import parse_ltl_text
from tleaf_cli.logic.formulas import FormulaSyntaxError, parse

# Text built mostly from the grammar's own pieces, so many samples are nearly valid.
PIECES = st.sampled_from(
    [
        "a",
        "b",
        "c_1",
        "A",
        "X",
        "WX",
        "F",
        "G",
        "U",
        "R",
        "!",
        "~",
        "&",
        "&&",
        "|",
        "||",
        "->",
        "=>",
        "<->",
        "<=>",
        "(",
        ")",
        " ",
        "true",
        "false",
        "last",
        ":",
        "#",
        "Fb",
        "é",
        "\t",
        "1",
    ]
)
GRAMMARISH = st.lists(PIECES, max_size=14).map("".join)
ANY_TEXT = st.text(max_size=30)


@settings(max_examples=400, deadline=None)
@given(st.one_of(GRAMMARISH, ANY_TEXT))
def test_parse_raises_only_syntax_errors_with_a_column(text: str) -> None:
    try:
        parse(text)
    except FormulaSyntaxError as e:
        assert e.message
        assert e.column is None or 1 <= e.column <= len(text) + 1


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.one_of(GRAMMARISH, ANY_TEXT), min_size=1, max_size=4))
def test_compile_stage_turns_any_line_into_a_row(lines: list[str]) -> None:
    text = "\n".join(line.replace("\n", " ").replace("\r", " ") for line in lines)
    sources = parse_ltl_text(text, "fuzz.ltl")
    report = compile_sources(sources, CompileSettings(cache_dir=None, timeout=5))
    assert len(report.rows) == len(sources)
    assert len({r["formula_id"] for r in report.rows}) == len(report.rows)
    for row in report.rows:
        assert (row["error"] is None) == (row["num_states"] is not None)
        if row["error"] is not None:
            assert row["error"].startswith(("line ", "row "))
