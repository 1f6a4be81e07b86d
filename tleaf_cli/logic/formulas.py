"""LTLf formulas: parsing with ltlf2dfa's grammar, and errors a person can act on.

The grammar and the formula classes are ltlf2dfa's (`ltlf2dfa/parser/ltlf.lark`); tleaf keeps its
meaning, quirks included (see docs/formulas.md). What this module adds is one parser per process,
a faster reader for the plain cases (`grammar.py`, which defers to lark on anything else), and
syntax errors that name the column and say what was expected, instead of lark's dump.
"""

from __future__ import annotations

import unicodedata
from functools import cache

from lark.exceptions import (
    LarkError,
    UnexpectedCharacters,
    UnexpectedEOF,
    UnexpectedToken,
    VisitError,
)
from ltlf2dfa.ltlf import LTLfFormula, LTLfImplies, LTLfRelease, LTLfUntil
from ltlf2dfa.parser.ltlf import LTLfParser

from tleaf_cli.atom_names import atom_problem
from tleaf_cli.errors import InputError
from tleaf_cli.logic.grammar import read_formula

OPERATORS_HELP = "operators are ! & | -> <-> X WX F G U R (also ~ && || => <=>)"
# The deepest nesting of operators a formula may have. Parsing, printing, the MONA encoding, the
# direct evaluator and the syntax graph all recurse once or more per level, and Python's stack
# holds about 1000 frames: 100 leaves every one of them room, and far exceeds any real rule (the
# paper's formulas have at most 20 nodes).
MAX_DEPTH = 100
TOO_DEEP = f"formula is nested too deeply (at most {MAX_DEPTH} levels of operators or parentheses)"
# n-ary operators that ltlf2dfa encodes as nested binary ones: `a -> b -> c` nests one level per
# operand after the first, in the MONA encoding (and `a U b U c` likewise).
_CHAINED = (LTLfImplies, LTLfUntil, LTLfRelease)


class FormulaSyntaxError(InputError, ValueError):
    """A formula that does not parse; `column` is 1-based within the formula text."""

    def __init__(self, message: str, column: int | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.column = column

    def __str__(self) -> str:
        if self.column is None:
            return self.message
        return f"column {self.column}: {self.message}"


@cache
def _parser() -> LTLfParser:
    return LTLfParser()


def parse(text: str) -> LTLfFormula:
    """Parse one LTLf formula, raising FormulaSyntaxError with a column and a reason (also for
    a formula nested deeper than MAX_DEPTH, which every later walk over it could not handle)."""
    if not text.strip():
        raise FormulaSyntaxError("empty formula")
    if _parenthesis_depth(text) > MAX_DEPTH:
        raise FormulaSyntaxError(TOO_DEEP)
    formula = read_formula(text)  # the common case, without lark (grammar.py)
    if formula is not None:
        check_depth(formula)
        return formula
    try:
        formula = _parser()(text)
    except RecursionError:
        raise FormulaSyntaxError(TOO_DEEP) from None
    except UnexpectedCharacters as e:
        raise _explain_character(text, e) from None
    except (UnexpectedToken, UnexpectedEOF) as e:
        raise _explain_token(text, e) from None
    except VisitError as e:  # lark wraps what its tree transformer raises
        if isinstance(e.orig_exc, RecursionError):
            raise FormulaSyntaxError(TOO_DEEP) from None
        raise FormulaSyntaxError(f"not a formula ({e.__class__.__name__})") from None
    except (LarkError, ValueError, AssertionError) as e:
        raise FormulaSyntaxError(f"not a formula ({e.__class__.__name__})") from None
    check_depth(formula)
    return formula


def depth(formula: LTLfFormula) -> int:
    """Levels of operators in `formula` (an atom: 1), counted without recursion, so any formula
    can be measured; a chained `a -> b -> c` (also U, R) counts a level per extra operand."""
    deepest = 0
    stack = [(formula, 1)]
    while stack:
        f, level = stack.pop()
        deepest = max(deepest, level)
        children = getattr(f, "formulas", None) or ([f.f] if hasattr(f, "f") else [])
        extra = len(children) - 2 if isinstance(f, _CHAINED) and len(children) > 2 else 0
        stack.extend((child, level + 1 + extra) for child in children)
    return deepest


def _parenthesis_depth(text: str) -> int:
    """The deepest nesting of parentheses in `text` (lark's parser recurses on each)."""
    level = deepest = 0
    for char in text:
        if char == "(":
            level += 1
            deepest = max(deepest, level)
        elif char == ")":
            level -= 1
    return deepest


def check_depth(formula: LTLfFormula) -> None:
    """FormulaSyntaxError when `formula` is nested deeper than MAX_DEPTH: every walk over a
    formula (printing, MONA encoding, evaluation, graphs) recurses, and would overflow the stack
    with a RecursionError deep in a third-party library."""
    levels = depth(formula)
    if levels > MAX_DEPTH:
        raise FormulaSyntaxError(f"{TOO_DEEP}, not {levels}")


def atoms(formula: LTLfFormula) -> tuple[str, ...]:
    """The formula's atoms, sorted and without repeats (`last`, `true`, `false` are not atoms)."""
    return tuple(sorted({str(a) for a in formula.find_labels()}))


def _explain_character(text: str, e: UnexpectedCharacters) -> FormulaSyntaxError:
    char = e.char
    col = e.column
    if not char.isascii() and _in_word(char):
        # a letter or digit outside ASCII (`rinse_γ`, `café`): ltlf2dfa's grammar reads only
        # ASCII atoms, and MONA, which reads the atoms as its variable names, refuses any other
        # character ("illegal character"), so such a word can never be an atom
        word = _word_around(text, col - 1)
        return FormulaSyntaxError(
            f"atom '{word}': '{char}' is not ASCII; {atom_problem(word)}", col
        )
    if char.isupper():
        nxt = text[col] if col < len(text) else ""
        word = _word_at(text, col - 1)
        if char in "XFGUR" or (char == "W" and nxt == "X"):
            op = "WX" if char == "W" else char
            return FormulaSyntaxError(
                f"operator '{op}' must be followed by a space or '(' (and {atom_problem(word)})",
                col,
            )
        return FormulaSyntaxError(f"upper-case atom '{word}': {atom_problem(word)}", col)
    return FormulaSyntaxError(f"unexpected character '{char}'; {OPERATORS_HELP}", col)


def _explain_token(text: str, e: UnexpectedToken | UnexpectedEOF) -> FormulaSyntaxError:
    token = getattr(e, "token", None)
    col = getattr(e, "column", None)
    if col is None or col < 0:
        col = None
    if token is None or token.type == "$END":
        end = len(text.rstrip()) + 1  # just past the last character
        return FormulaSyntaxError("formula ends too early (an operand or ')' is missing)", end)
    if token.type == "RSEPARATOR":
        return FormulaSyntaxError("unbalanced ')'", col)
    return FormulaSyntaxError(f"unexpected '{token.value}' here (an operator is missing?)", col)


def _in_word(char: str) -> bool:
    """Whether `char` would be read as part of a word: a letter, digit, _ or combining mark."""
    return char.isalnum() or char == "_" or unicodedata.category(char).startswith("M")


def _word_at(text: str, start: int) -> str:
    end = start
    while end < len(text) and _in_word(text[end]):
        end += 1
    return text[start:end] or text[start]


def _word_around(text: str, index: int) -> str:
    """The whole word (letters, digits, _, marks) that the character at `index` is part of."""
    start = index
    while start > 0 and _in_word(text[start - 1]):
        start -= 1
    return _word_at(text, start)
