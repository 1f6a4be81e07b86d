"""Di Francescomarino et al.'s formulas.tsv into tleaf's syntax (knowledge/peer_formulas.py)."""

from __future__ import annotations

import pytest

from tleaf_cli.data.activity_names import activity_atoms
from tleaf_cli.data.formula_files import parse_ltl_text
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.peer_formulas import (
    peer_formula,
    peer_ltl_text,
    read_peer_formulas,
)
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.semantics import satisfies

# Rows of each kind the published file has (header, strong and weak formulas, one or more
# conjuncts), copied here: the repository never reads the shared data folder.
TSV = (
    "log\tkind\tformula (the peer's syntax)\tprefix lengths evaluated (from, to exclusive)\n"
    'helpdesk\tSTRONG\t[]( ( "8" -> <>( "6" ) ) ) /\\ <>"8"\t2\t6\n'
    'helpdesk\tWEAK\t<>("8")\t2\t6\n'
    'bpi_13_incidents\tWEAK\t<>("5") /\\ <>("3")\t2\t6\n'
    'env_permit\tSTRONG\t[]( ( "114" -> <>( "131" ) ) ) /\\ <>"114" /\\ []( ( "116" -> '
    '<>( "136" ) ) ) /\\ <>"116"\t19\t23\n'
)


def test_each_construct_becomes_tleafs() -> None:
    assert peer_formula('[]( ( "8" -> <>( "6" ) ) ) /\\ <>"8"') == "G((a8 -> F(a6))) & F a8"
    assert peer_formula('<>("8")') == "F(a8)"
    assert peer_formula('<>("5") /\\ <>("3")') == "F(a5) & F(a3)"
    assert peer_formula('!"1" \\/ X "2" U "3"') == "!a1 | X a2 U a3"


def test_atoms_are_the_readers_atoms() -> None:
    """An activity becomes the atom activity_atoms gives it, or the one a log's own map gives."""
    names = ["8", "6"]
    atoms = activity_atoms(names)
    assert peer_formula('<>"8" /\\ <>"6"') == f"F {atoms['8']} & F {atoms['6']}"
    assert peer_formula('<>"8"', {"8": "resolve"}) == "F resolve"
    with pytest.raises(InputError, match='activity "9" has no atom'):
        peer_formula('<>"9"', {"8": "resolve"})


def test_the_strong_formula_means_what_they_say_on_complete_cases() -> None:
    """8 occurs and every 8 is followed within the case by a 6."""
    formula = parse(peer_formula('[]( ( "8" -> <>( "6" ) ) ) /\\ <>"8"'))
    cases = {("a1", "a8", "a6"): True, ("a8", "a6", "a8"): False, ("a1", "a6"): False}
    for case, expected in cases.items():
        assert satisfies([{x} for x in case], formula) is expected


def test_the_file_becomes_one_named_rule_per_log_and_kind() -> None:
    rows = read_peer_formulas(TSV)
    assert [r.name for r in rows] == [
        "helpdesk.strong",
        "helpdesk.weak",
        "bpi_13_incidents.weak",
        "env_permit.strong",
    ]
    assert rows[0].prefix_lengths == (2, 6) and rows[3].prefix_lengths == (19, 23)
    assert rows[3].formula == "G((a114 -> F(a131))) & F a114 & G((a116 -> F(a136))) & F a116"
    rules = parse_ltl_text(peer_ltl_text(rows, ["from formulas.tsv"]))
    assert [(r.formula_id, r.text) for r in rules] == [(r.name, r.formula) for r in rows]
    assert all(r.problem is None for r in rules)
    for r in rules:
        parse(r.text)


def test_bad_rows_name_their_line() -> None:
    with pytest.raises(InputError, match="line 2: expected log, kind, formula"):
        read_peer_formulas("header\nhelpdesk\tSTRONG\n")
    with pytest.raises(InputError, match=r"line 3: .*cannot read '&&"):
        read_peer_formulas('header\nh\tWEAK\t<>"1"\nh\tSTRONG\t<>"1" && <>"2"\n')
    with pytest.raises(InputError, match=r"h\.weak appears twice"):
        read_peer_formulas('header\nh\tWEAK\t<>"1"\nh\tWEAK\t<>"2"\n')


def test_one_logs_rows_keep_their_line_numbers() -> None:
    rows = read_peer_formulas(TSV, log="env_permit")
    assert [r.name for r in rows] == ["env_permit.strong"]
    with pytest.raises(InputError, match=r'line 4: .*activity "5" has no atom'):
        read_peer_formulas(TSV, {"3": "a3"}, log="bpi_13_incidents")


@pytest.mark.parametrize(
    ("row", "expected"),
    [
        ('h\tWEAK\t<>("8"', r"line 3: formula '<>\(\"8\"' is 'F\(a8' in tleaf's syntax, which "),
        ('h\tWEAK\t<>"8")', "line 3: .* which does not parse"),
        ('h\tMEDIUM\t<>"8"', "line 3: kind 'MEDIUM' is neither STRONG nor WEAK"),
        ('h\tstrong\t<>"8"', "line 3: kind 'strong' is neither STRONG nor WEAK"),
        ('h\tWEAK\t<>"8"\t2.5\t6', "line 3: prefix lengths '2.5' and '6' are not whole numbers"),
        ('h\tWEAK\t<>"8"\tx\t', "line 3: prefix lengths 'x' and '' are not whole numbers"),
        ('h\tWEAK\t<>"8"\t2', "line 3: prefix lengths '2' and '' are not whole numbers"),
        ('h\tWEAK\t<>"8"\t6\t2', "line 3: prefix lengths from 6 to 2 .* none"),
    ],
)
def test_rows_it_cannot_write_faithfully_are_refused(row: str, expected: str) -> None:
    """A formula that would not parse once converted, a kind that is not STRONG or WEAK, prefix
    lengths that are not two whole numbers (from < to): an error naming the line, never a rule
    written that no later stage reads or a column dropped silently."""
    with pytest.raises(InputError, match=expected):
        read_peer_formulas(f'header\ng\tSTRONG\t<>"1"\n{row}\n')


def test_blank_prefix_lengths_are_none() -> None:
    (row,) = read_peer_formulas('header\nh\tWEAK\t<>"8"\t\t\n')
    assert row.prefix_lengths is None


def test_a_bad_row_writes_nothing(tmp_path) -> None:
    """The .ltl is written only when every row converts; an earlier file there is kept."""
    from tleaf_cli.knowledge.log_knowledge import convert_peer_file

    tsv, out = tmp_path / "formulas.tsv", tmp_path / "f.ltl"
    tsv.write_text('log\tkind\tformula\nh\tWEAK\t<>"8"\nh\tSTRONG\t[]("8" -> <>("6")\n')
    out.write_text("kept: a\n")
    with pytest.raises(InputError, match=r"formulas\.tsv: line 3: .*does not parse"):
        convert_peer_file(tsv, out)
    assert out.read_text() == "kept: a\n"
