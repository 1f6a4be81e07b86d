"""A hand-written reader for ltlf2dfa's LTLf grammar, for the formulas it reads without doubt.

ltlf2dfa parses with lark (`ltlf2dfa/parser/ltlf.lark`); that costs ~0.3 ms per formula, as much
as compiling one by progression. This reader covers the grammar's plain cases — lower-case atoms,
`true false last`, the operators `! ~ & && | || -> => <-> <=> X WX F G U R`, parentheses,
whitespace — and builds the same ltlf2dfa objects lark's transformer builds:

    formula  := impl (('<->'|'<=>') impl)*        n-ary LTLfEquivalence
    impl     := or (('->'|'=>') or)*              n-ary LTLfImplies ((a -> b) -> c)
    or       := and (('|'|'||') and)*             n-ary LTLfOr
    and      := until (('&'|'&&') until)*         n-ary LTLfAnd
    until    := release ('U' release)*            n-ary LTLfUntil (a U (b U c))
    release  := unary ('R' unary)*                n-ary LTLfRelease
    unary    := ('!'|'~'|'X'|'WX'|'F'|'G') unary | '(' formula ')' | atom | true | false | last

Anything else — a syntax error, upper-case words, `TRUE`, words that begin with `true`, `false`
or `last` (lark's terminal priorities split those), quoted symbols, nesting deeper than Python's
stack — returns None, and `formulas.parse` hands the text to lark, which decides and explains.
So this reader can only be faster, never different; the tests compare it with lark on thousands of
random texts.
"""

from __future__ import annotations

import re

from tleaf_cli.atom_names import AMBIGUOUS as _AMBIGUOUS
from tleaf_cli.logic import ltlf_nodes as ltlf

# One token per match; `word` and `upper` are checked further in _tokens.
_TOKEN = re.compile(
    r"\s*(?:(?P<word>[a-z][a-z0-9_]*)|(?P<op><->|<=>|->|=>|\|\||&&|[|&!~()])"
    r"|(?P<upper>WX|[XFGUR])(?![a-z]))"
)
_CONSTANTS = {"true": ltlf.LTLfTrue, "false": ltlf.LTLfFalse, "last": ltlf.LTLfLast}
_UNARY = {"!": ltlf.LTLfNot, "~": ltlf.LTLfNot, "X": ltlf.LTLfNext, "WX": ltlf.LTLfWeakNext}
_UNARY.update({"F": ltlf.LTLfEventually, "G": ltlf.LTLfAlways})
_LEVELS = (  # loosest first: the operator tokens of each binary level and the class it builds
    ({"<->", "<=>"}, ltlf.LTLfEquivalence),
    ({"->", "=>"}, ltlf.LTLfImplies),
    ({"|", "||"}, ltlf.LTLfOr),
    ({"&", "&&"}, ltlf.LTLfAnd),
    ({"U"}, ltlf.LTLfUntil),
    ({"R"}, ltlf.LTLfRelease),
)


class _Unsure(Exception):
    """This reader does not decide the text; lark will."""


def read_formula(text: str) -> ltlf.LTLfFormula | None:
    """The formula lark would build from `text`, or None when this reader is not sure."""
    try:
        tokens = _tokens(text)
        formula, pos = _binary(tokens, 0, 0)
    except (_Unsure, RecursionError):
        return None
    return formula if pos == len(tokens) else None


def _tokens(text: str) -> list[str]:
    tokens: list[str] = []
    pos, end = 0, len(text)
    while True:
        m = _TOKEN.match(text, pos)
        if m is None:
            if text[pos:].strip():
                raise _Unsure
            return tokens
        word = m.group("word")
        if word is not None and word not in _CONSTANTS and word.startswith(_AMBIGUOUS):
            raise _Unsure
        tokens.append(m.group(m.lastgroup))
        pos = m.end()
        if pos >= end:
            return tokens


def _binary(tokens: list[str], pos: int, level: int) -> tuple[ltlf.LTLfFormula, int]:
    if level == len(_LEVELS):
        return _unary(tokens, pos)
    ops, cls = _LEVELS[level]
    first, pos = _binary(tokens, pos, level + 1)
    operands = [first]
    while pos < len(tokens) and tokens[pos] in ops:
        operand, pos = _binary(tokens, pos + 1, level + 1)
        operands.append(operand)
    return (first if len(operands) == 1 else cls(operands)), pos


def _unary(tokens: list[str], pos: int) -> tuple[ltlf.LTLfFormula, int]:
    if pos >= len(tokens):
        raise _Unsure
    token = tokens[pos]
    if token in _UNARY:
        operand, pos = _unary(tokens, pos + 1)
        return _UNARY[token](operand), pos
    if token == "(":
        inner, pos = _binary(tokens, pos + 1, 0)
        if pos >= len(tokens) or tokens[pos] != ")":
            raise _Unsure
        return inner, pos + 1
    constant = _CONSTANTS.get(token)
    if constant is not None:
        return constant(), pos + 1
    if token[0].islower():
        return ltlf.LTLfAtomic(token), pos + 1
    raise _Unsure
