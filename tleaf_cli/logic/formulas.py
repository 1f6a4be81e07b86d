"""LTLf formulas: parsing with ltlf2dfa's grammar, and errors a person can act on.

The grammar and the formula classes are ltlf2dfa's (`ltlf2dfa/parser/ltlf.lark`); tleaf keeps its
meaning, quirks included (see docs/formulas.md). What this module adds is one parser per process
and syntax errors that name the column and say what was expected, instead of lark's dump.
"""

from __future__ import annotations

from functools import cache

from lark.exceptions import LarkError, UnexpectedCharacters, UnexpectedEOF, UnexpectedToken
from ltlf2dfa.ltlf import LTLfFormula
from ltlf2dfa.parser.ltlf import LTLfParser

from tleaf_cli.errors import InputError

OPERATORS_HELP = "operators are ! & | -> <-> X WX F G U R (also ~ && || => <=>)"


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
    """Parse one LTLf formula, raising FormulaSyntaxError with a column and a reason."""
    if not text.strip():
        raise FormulaSyntaxError("empty formula")
    try:
        return _parser()(text)
    except UnexpectedCharacters as e:
        raise _explain_character(text, e) from None
    except (UnexpectedToken, UnexpectedEOF) as e:
        raise _explain_token(text, e) from None
    except (LarkError, ValueError, AssertionError) as e:
        raise FormulaSyntaxError(f"not a formula ({e.__class__.__name__})") from None


def atoms(formula: LTLfFormula) -> tuple[str, ...]:
    """The formula's atoms, sorted and without repeats (`last`, `true`, `false` are not atoms)."""
    return tuple(sorted({str(a) for a in formula.find_labels()}))


def _explain_character(text: str, e: UnexpectedCharacters) -> FormulaSyntaxError:
    char = e.char
    col = e.column
    if char.isupper():
        nxt = text[col] if col < len(text) else ""
        if char in "XFGUR" or (char == "W" and nxt == "X"):
            op = "WX" if char == "W" else char
            return FormulaSyntaxError(
                f"operator '{op}' must be followed by a space or '(' "
                f"(and atoms are lower-case [a-z][a-z0-9_]*)",
                col,
            )
        word = _word_at(text, col - 1)
        return FormulaSyntaxError(
            f"upper-case atom '{word}': atoms are lower-case [a-z][a-z0-9_]*", col
        )
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


def _word_at(text: str, start: int) -> str:
    end = start
    while end < len(text) and (text[end].isalnum() or text[end] == "_"):
        end += 1
    return text[start:end] or text[start]
