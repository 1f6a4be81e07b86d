"""The line grammar of Declare's `.decl` files (RuM, Declare4Py) and of MP-Declare conditions.

A `.decl` file has one statement per line (blank lines and lines starting with `#` skipped):

    activity Resolve ticket
    bind Resolve ticket: org:resource
    org:resource: Value 1, Value 2,          (a value list may go on over the next line)
     Value 3
    amount: integer between 0 and 100
    Chain Precedence[Resolve ticket, Closed] |A.org:resource is Value 3 | |

This module only reads the text of a line into plain values: which statement it is, its parts,
and a condition as a small tree (`Test`, `Junction`, `Negation`, `Constant`). Whether an activity
is declared, a value in its attribute's domain, and what a condition means as LTLf is
`knowledge/decl.py`'s business. Every problem is an InputError saying what was expected, without
the line's place (the caller adds the file and the line number).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from tleaf_cli.errors import InputError

_ACTIVITY = re.compile(r"^activity\s+(?P<name>.+)$")
_BIND = re.compile(r"^bind\s+(?P<rest>.+)$")
_CONSTRAINT = re.compile(r"^(?P<template>[^\[\]|:]+?)\s*\[(?P<args>[^\[\]]*)\]\s*(?P<rest>.*)$")
_DOMAIN = re.compile(r"^(?P<attributes>[^\[\]|]+?):\s+(?P<values>.*)$|^(?P<bare>[^\[\]|\s]+):$")
_RANGE = re.compile(
    r"^(?P<kind>integer|float)\s+between\s+(?P<low>[-+]?\d+(?:\.\d+)?)\s+and\s+"
    r"(?P<high>[-+]?\d+(?:\.\d+)?)$",
    re.IGNORECASE,
)
_NUMBER = re.compile(r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?")
_REF = re.compile(r"(?P<role>[AaTt])\.(?P<attribute>[^\s<>=!(),|]+)")
_OPERATOR = re.compile(r"(?i:is\s+not|is|not\s+in|in)\b|<=|>=|!=|<|>|=")
_WORD = re.compile(r"[A-Za-z]+")

NUMERIC_OPERATORS = ("<", "<=", "=", "!=", ">=", ">")
UNSUPPORTED_TIME = (
    "a time condition is not supported: LTLf has no clock (tleaf's formulas see the order of "
    "events, not their timestamps)"
)


@dataclass(frozen=True)
class Test:
    """`A.attr is v` and its kin: `role` "A" (the activation) or "T" (the target), the attribute,
    the operator (`is`, `is not`, `in`, `not in`, or a numeric one of NUMERIC_OPERATORS) and its
    values (one for `is` and the numeric ones, the list for `in`)."""

    role: str
    attribute: str
    operator: str
    values: tuple[str, ...]


@dataclass(frozen=True)
class Junction:
    """`and` / `or` over two or more parts."""

    operator: str
    parts: tuple[Condition, ...]


@dataclass(frozen=True)
class Negation:
    """`not (...)`."""

    part: Condition


@dataclass(frozen=True)
class Constant:
    """`true` / `false`."""

    value: bool


Condition = Test | Junction | Negation | Constant


def line_kind(line: str) -> str:
    """Which statement a stripped, non-empty line is: "activity", "bind", "constraint",
    "domain"; InputError saying what a line may be otherwise."""
    if _ACTIVITY.match(line):
        return "activity"
    if _BIND.match(line):
        return "bind"
    if _CONSTRAINT.match(line):
        return "constraint"
    if _DOMAIN.match(line):
        return "domain"
    raise InputError(
        f"cannot read {line[:60]!r}: expected 'activity NAME', 'bind NAME: attribute, ...', "
        "'attribute: value, value, ...' (or 'integer between X and Y', 'float between X and "
        "Y') or 'Template[activity, activity] |activation |correlation |time'"
    )


def activity_name(line: str) -> str:
    """The name of `activity NAME` (spaces kept, as in `Accepted_In Progress`)."""
    return _ACTIVITY.match(line).group("name").strip()


def binding(line: str) -> tuple[str, tuple[str, ...]]:
    """`bind NAME: attr, attr` as (NAME, attributes). The name is everything up to the last
    ': ' (attribute names have no ': ', activity names may)."""
    rest = _BIND.match(line).group("rest")
    name, sep, attributes = rest.rpartition(": ")
    if not sep:
        name, sep, attributes = rest.rpartition(":")
        if not sep or attributes.strip():
            raise InputError(f"expected 'bind NAME: attribute, ...', got {line[:60]!r}")
    names = tuple(a.strip() for a in attributes.split(",") if a.strip())
    if not name.strip() or not names:
        raise InputError(f"expected 'bind NAME: attribute, ...', got {line[:60]!r}")
    return name.strip(), names


def domain(line: str) -> tuple[tuple[str, ...], str]:
    """`attr[, attr]: values` as (attributes, the values' text, possibly empty)."""
    match = _DOMAIN.match(line)
    if match.group("bare") is not None:
        return (match.group("bare"),), ""
    attributes = tuple(a.strip() for a in match.group("attributes").split(","))
    if not all(attributes):
        raise InputError(f"expected 'attribute[, attribute]: values', got {line[:60]!r}")
    return attributes, match.group("values").strip()


def domain_values(text: str) -> tuple[str, tuple[str, ...] | tuple[float, float]]:
    """A domain's text as ("values", the values) or ("integer" | "float", (low, high))."""
    match = _RANGE.match(text)
    if match is not None:
        kind = match.group("kind").lower()
        low, high = float(match.group("low")), float(match.group("high"))
        if kind == "integer" and not (low.is_integer() and high.is_integer()):
            raise InputError(f"'integer between X and Y' needs whole numbers, got {text!r}")
        if low > high:
            raise InputError(f"an empty range: {text!r} (X must be at most Y)")
        return kind, (low, high)
    if re.match(r"(?i)(integer|float)\b", text):
        raise InputError(
            f"expected 'integer between X and Y' or 'float between X and Y', got {text!r}"
        )
    values = tuple(v.strip() for v in text.split(","))
    if not text or not all(values):
        raise InputError(f"expected values separated by ',' (none empty), got {text!r}")
    return "values", values


def constraint_parts(line: str) -> tuple[str, str, list[str]]:
    """`Template[args] |c1 |c2 |c3` as (template name, the arguments' text, the condition
    fields, each stripped: none, or as many as the line has)."""
    match = _CONSTRAINT.match(line)
    rest = match.group("rest").strip()
    if rest and not rest.startswith("|"):
        raise InputError(f"expected '|' before the conditions after ']', got {rest[:40]!r}")
    fields = [f.strip() for f in rest[1:].split("|")] if rest else []
    return match.group("template").strip(), match.group("args"), fields


def split_arguments(text: str, arity: int, declared: Callable[[str], bool]) -> list[str]:
    """The `arity` activities of a constraint's brackets. Names are split at a comma; where a
    name holds a comma, the split whose parts are all declared activities wins."""
    if arity == 1:
        return [text.strip()]
    commas = [i for i, c in enumerate(text) if c == ","]
    splits = [[text[:i].strip(), text[i + 1 :].strip()] for i in commas]
    for parts in splits:
        if all(declared(p) for p in parts):
            return parts
    if len(commas) != 1:
        raise InputError(f"expected two activities separated by ',' in [{text}]")
    return splits[0]


def parse_condition(text: str, values_of: Callable[[str], Sequence[str] | None]) -> Condition:
    """An MP-Declare condition: `A.attr is v`, `is not v`, `in (v, w)`, `not in (...)`, numeric
    `A.attr < 3` (`<=`, `=`, `!=`, `>=`, `>`), `true`, `false`, joined by `and` / `or` (and binds
    tighter), `not`, parentheses. `values_of(attribute)` gives an attribute's declared values, so
    that a value holding spaces or the words `and` / `or` ("Research and Development") is read
    whole; the longest declared value that fits wins.

    `same attr`, `different attr` and a value that is another event's attribute (`A.x is T.x`)
    relate the activation to the target: InputError saying they are not supported."""
    parser = _ConditionParser(text, values_of)
    condition = parser.disjunction()
    parser.skip()
    if parser.pos < len(text):
        raise InputError(f"condition {text!r}: unexpected {text[parser.pos :][:30]!r}")
    return condition


class _ConditionParser:
    """Recursive descent over the text, one position; values are read in context."""

    def __init__(self, text: str, values_of: Callable[[str], Sequence[str] | None]) -> None:
        self.text, self.values_of, self.pos = text, values_of, 0

    def fail(self, expected: str) -> InputError:
        found = self.text[self.pos :][:30] or "the end"
        return InputError(f"condition {self.text!r}: expected {expected}, found {found!r}")

    def skip(self) -> None:
        while self.pos < len(self.text) and self.text[self.pos].isspace():
            self.pos += 1

    def keyword(self, *words: str) -> str | None:
        """The next word when it is one of `words` (any case), consumed; None otherwise."""
        self.skip()
        match = _WORD.match(self.text, self.pos)
        if match is not None and match.group().lower() in words:
            self.pos = match.end()
            return match.group().lower()
        return None

    def disjunction(self) -> Condition:
        parts = [self.conjunction()]
        while self.keyword("or"):
            parts.append(self.conjunction())
        return parts[0] if len(parts) == 1 else Junction("or", tuple(parts))

    def conjunction(self) -> Condition:
        parts = [self.unit()]
        while self.keyword("and"):
            parts.append(self.unit())
        return parts[0] if len(parts) == 1 else Junction("and", tuple(parts))

    def unit(self) -> Condition:
        self.skip()
        if self.text.startswith("(", self.pos):
            self.pos += 1
            inner = self.disjunction()
            self.skip()
            if not self.text.startswith(")", self.pos):
                raise self.fail("')'")
            self.pos += 1
            return inner
        word = self.keyword("not", "true", "false", "same", "different")
        if word == "not":
            return Negation(self.unit())
        if word in ("true", "false"):
            return Constant(word == "true")
        if word in ("same", "different"):
            raise InputError(
                f"condition {self.text!r}: '{word}' relates the activation's attribute to the "
                "target's, which is not supported (tleaf reads a condition on one event)"
            )
        return self.test()

    def test(self) -> Test:
        ref = _REF.match(self.text, self.pos)
        if ref is None:
            raise self.fail("'A.attribute' or 'T.attribute', '(', 'not', 'true' or 'false'")
        self.pos = ref.end()
        role, attribute = ref.group("role").upper(), ref.group("attribute")
        self.skip()
        op = _OPERATOR.match(self.text, self.pos)
        if op is None:
            raise self.fail(
                f"'is', 'is not', 'in', 'not in' or one of "
                f"{' '.join(NUMERIC_OPERATORS)} after {ref.group()!r}"
            )
        self.pos = op.end()
        operator = " ".join(op.group().lower().split())
        if operator in ("in", "not in"):
            return Test(role, attribute, operator, self.value_list())
        value = self.number() if operator in NUMERIC_OPERATORS else self.value(attribute)
        return Test(role, attribute, operator, (value,))

    def refuse_reference(self) -> None:
        """Another event's attribute where a value should be: A relates to T."""
        self.skip()
        ref = _REF.match(self.text, self.pos)
        if ref is not None and self.values_of(ref.group("attribute")) is not None:
            raise InputError(
                f"condition {self.text!r}: comparing two events' attributes "
                f"({ref.group()!r}) is not supported (tleaf reads a condition on one event)"
            )

    def number(self) -> str:
        self.refuse_reference()
        match = _NUMBER.match(self.text, self.pos)
        if match is None:
            raise self.fail("a number")
        self.pos = match.end()
        return match.group()

    def value(self, attribute: str) -> str:
        """The value after `is`: the longest declared value that ends at the end, a `)`, or
        before `and` / `or`; else the text up to one of those."""
        self.refuse_reference()
        rest = self.text[self.pos :]
        ends = re.compile(r"\s*(?:$|\))|\s+(?i:and|or)\b")
        for candidate in sorted(self.values_of(attribute) or (), key=len, reverse=True):
            if rest.startswith(candidate) and ends.match(rest, len(candidate)):
                self.pos += len(candidate)
                return candidate
        stop = re.search(r"\s+(?i:and|or)\b|\)", rest)
        text = (rest[: stop.start()] if stop else rest).strip()
        if not text:
            raise self.fail("a value")
        self.pos += len(rest[: stop.start()] if stop else rest)
        return text

    def value_list(self) -> tuple[str, ...]:
        self.skip()
        if not self.text.startswith("(", self.pos):
            raise self.fail("'(' and values separated by ','")
        end = self.text.find(")", self.pos)
        if end < 0:
            raise self.fail("')' closing the list of values")
        values = tuple(v.strip() for v in self.text[self.pos + 1 : end].split(","))
        if not all(values):
            raise self.fail("values separated by ',' (none empty)")
        self.pos = end + 1
        return values
