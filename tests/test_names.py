"""Names and ids of formulas, rules and videos: the `.ltl` format's `name:` (ASCII letters, digits,
_ . -), said exactly in the error a user reads, and generated names and ids checked where they are
written, since a bad one reads back as another formula and a repeated one merges rows."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.data.formula_files import NAME_CHARS, check_names, parse_ltl_text
from tleaf_cli.data.graphs import graph_file_stems
from tleaf_cli.errors import InputError

runner = CliRunner()


def tleaf(*args):
    return runner.invoke(app, [str(a) for a in args])


def test_the_allowed_characters_are_said_to_be_ascii() -> None:
    """`é` is a letter: a message saying "letters" would promise it; the names are ASCII."""
    assert NAME_CHARS.startswith("ASCII letters")


@pytest.mark.parametrize("name", ["rinsé", "γ1", "ｒinse"])
def test_a_name_with_a_letter_outside_ascii_is_refused_saying_ascii(name: str) -> None:
    (source,) = parse_ltl_text(f"{name}: F a\n")
    assert source.problem == f"invalid formula name '{name}' (allowed: {NAME_CHARS})"
    assert "ASCII" in source.problem
    with pytest.raises(InputError, match=f"'{name}' is not a valid name \\(allowed: ASCII"):
        check_names([name], "rule name")


def test_ascii_names_with_dots_and_dashes_are_names() -> None:
    (source,) = parse_ltl_text("ordering.rinse-1_a: F a\n")
    assert source.problem is None and source.formula_id == "ordering.rinse-1_a"


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
