"""Reading LTLf formulas (`logic.formulas.parse`): what an atom may be, said in the error a user
reads; formulas nested too deeply, a syntax error with the limit, never a RecursionError; and any
text at all (hypothesis), an error message with a column, never a traceback."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ltlf2dfa.ltlf import LTLfAtomic, LTLfImplies, LTLfNot

from tleaf_cli.atom_names import atom_problem
from tleaf_cli.embed.graphs import syntax_graph
from tleaf_cli.logic import mona
from tleaf_cli.logic.formulas import MAX_DEPTH, FormulaSyntaxError, parse
from tleaf_cli.logic.semantics import satisfies

# 1. Atoms: lower-case ASCII words, and an error that says so for a word that is not one.

ASCII_RULE = atom_problem("Rinse")  # what every atom error states: the one rule for atoms


def test_the_atom_rule_is_stated_in_ascii_terms() -> None:
    assert ASCII_RULE is not None and "ASCII" in ASCII_RULE


@pytest.mark.parametrize(
    ("text", "word", "char", "column"),
    [
        ("F rinse_γ", "rinse_γ", "γ", 9),
        ("G (a -> rinse_γ)", "rinse_γ", "γ", 15),
        ("F café & b", "café", "é", 6),
        ("F Γx", "Γx", "Γ", 3),
        ("F e\u0301", "e\u0301", "\u0301", 4),  # é written as e and a combining accent
    ],
)
def test_a_non_ascii_letter_in_an_atom_is_named_with_the_atom_rule(
    text: str, word: str, char: str, column: int
) -> None:
    """An atom with a letter outside ASCII is refused by ltlf2dfa's grammar (and MONA, which
    reads atoms as variable names, says "illegal character"): the error names the atom and the
    character and states the rule for atoms, not the operators."""
    with pytest.raises(FormulaSyntaxError) as caught:
        parse(text)
    message = str(caught.value)
    assert message == f"column {column}: atom '{word}': '{char}' is not ASCII; {ASCII_RULE}"
    assert "operators are" not in message


def test_a_symbol_that_is_no_letter_still_lists_the_operators() -> None:
    """'→' is not part of a word: the user meant an operator, and the error lists them."""
    with pytest.raises(FormulaSyntaxError, match="unexpected character '→'; operators are"):
        parse("a → b")


def test_upper_case_atoms_are_told_the_same_rule() -> None:
    with pytest.raises(FormulaSyntaxError) as caught:
        parse("G Cut_milk")
    assert str(caught.value) == f"column 3: upper-case atom 'Cut_milk': {ASCII_RULE}"


def test_ascii_atoms_with_digits_and_underscores_parse() -> None:
    assert {str(a) for a in parse("F rinse_2 & G !cut_milk").find_labels()} == {
        "rinse_2",
        "cut_milk",
    }


# 2. Formulas nested too deeply: a per-formula error, never a RecursionError.

DEEP = {
    "negations": "!" * 500 + "a",
    "parentheses": "(" * 400 + "a" + ")" * 400,
    "always": "G (" * 300 + "a" + ")" * 300,
    "next": "X " * 2000 + "a",
}


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


# 3. Any text: a user's mistake is an error message, never a traceback.

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
