"""MP-Declare conditions as tests on one event's attribute values, each read by one atom.

A condition of a `.decl` constraint (`|A.org:resource is not Value 3 |`, `|A.Age >= 80 |`,
`|T.x in (a, b) |`) speaks of the attributes of one event: the activation's or the target's. It
becomes one *condition atom* of the rule's formula (`closed & org_resource__is_not__value_3`),
true at an event exactly when the test holds on that event's own values (`EventCondition.holds`).
So a condition costs one atom however many values its attribute has: the test is never unfolded
into a disjunction over a domain, which made a DFA over the powerset of a domain's atoms (22
resources: 2^24 letters) for what an event answers with one value.

**Reading.** As Declare4Py reads it (Donadello et al.; its checkers evaluate the condition on the
event): a test on an attribute the event has no value for is false (`is not` too), `not (...)`
negates the whole; `is`, `is not`, `in`, `not in` compare text, or numbers where the attribute's
declared domain is a number range; `<`, `<=`, `=`, `!=`, `>=`, `>` compare numbers ("573.0" meets
`= 573`), and a value that is no number meets none of them. A value outside the attribute's
declared domain is tested as it is (`is not Value 3` holds for "Value 23"); check-cases counts
such values (`AttributeDomain.holds`).

**Atoms.** `condition_atoms` names each distinct condition (the same test on the activation and
on a target is one: it is a property of the event) by its words, `<attribute>__<operator>__<values>`
(`org_resource__is_not__value_3`, `age__ge__80`), `__and__` / `__or__` / `not__` joining parts,
cut and hashed past MAX_ATOM characters; two `__` set them apart from activity atoms (no `__`)
and from `attribute_atom`'s (one), and a name that still meets another gets `_2`, `_3`, ...
"""

from __future__ import annotations

import hashlib
import math
import operator as op
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, replace

from tleaf_cli.atom_names import atom_problem
from tleaf_cli.data.activity_names import activity_atom, free_atom
from tleaf_cli.knowledge import decl_grammar as grammar

MAX_ATOM = 60  # characters of a condition atom before it is cut and hashed

_COMPARE: dict[str, Callable[[float, float], bool]] = {
    "<": op.lt,
    "<=": op.le,
    "=": op.eq,
    "!=": op.ne,
    ">=": op.ge,
    ">": op.gt,
}
_OPERATOR_WORDS = {
    "is": "is",
    "is not": "is_not",
    "in": "in",
    "not in": "not_in",
    "<": "lt",
    "<=": "le",
    "=": "eq",
    "!=": "ne",
    ">=": "ge",
    ">": "gt",
}
_NOT_WORD = re.compile(r"[^a-z0-9]+")


@dataclass(frozen=True)
class AttributeDomain:
    """An attribute's declared values: `kind` "values" (a list), "integer" or "float" (a range
    `low`..`high`), and the line that declares it."""

    attribute: str
    kind: str
    line: int
    values: tuple[str, ...] = ()
    low: float = 0.0
    high: float = 0.0

    @property
    def numeric(self) -> bool:
        """A number range: `is` and `in` compare numbers ("3.0" is 3)."""
        return self.kind != "values"

    def lookup(self, value: str) -> str | None:
        """The declared value `value` names (a range's by number: "03" is 3), or None."""
        if self.kind == "values":
            return value if value in self.values else None
        number = number_of(value)
        if number is None or not self.low <= number <= self.high:
            return None
        if self.kind == "integer" and not number.is_integer():
            return None
        return value

    def holds(self, value: str) -> bool:
        """`value` (as an event carries it) is one of the declared values."""
        return self.lookup(value) is not None

    def shown(self) -> str:
        """The domain as the file declares it, shortened."""
        if self.kind != "values":
            return f"{self.kind} between {self.low:g} and {self.high:g}"
        return ", ".join(self.values[:6]) + (", ..." if len(self.values) > 6 else "")


def number_of(text: str) -> float | None:
    """`text` as a finite number, or None."""
    try:
        number = float(text)
    except ValueError:
        return None
    return number if math.isfinite(number) else None


@dataclass(frozen=True)
class EventCondition:
    """A condition on one event's attributes: the parsed test (`grammar.Condition`, roles
    dropped: it reads the event it is on) and the declared domains of the attributes it names."""

    tree: grammar.Condition
    domains: Mapping[str, AttributeDomain]

    @property
    def attributes(self) -> tuple[str, ...]:
        """The attributes it reads, in order of first mention."""
        return tuple(dict.fromkeys(t.attribute for t in _tests(self.tree)))

    def holds(self, values: Mapping[str, str | None]) -> bool:
        """The condition on an event whose attribute values are `values` (attribute -> value,
        None or absent where the event has none)."""
        return _holds(self.tree, values, self.domains)

    def text(self) -> str:
        """The condition written back in `.decl` syntax, on the event itself (no `A.`/`T.`)."""
        return _text(self.tree)


def on_event(tree: grammar.Condition) -> grammar.Condition:
    """`tree` with its tests' roles dropped: the same test on the activation and on a target
    is one condition on an event."""
    if isinstance(tree, grammar.Test):
        return replace(tree, role="")
    if isinstance(tree, grammar.Negation):
        return grammar.Negation(on_event(tree.part))
    if isinstance(tree, grammar.Junction):
        return grammar.Junction(tree.operator, tuple(on_event(p) for p in tree.parts))
    return tree


def condition_atoms(
    conditions: Iterable[grammar.Condition], taken: Iterable[str] = ()
) -> dict[grammar.Condition, str]:
    """Each distinct condition (roles dropped, `on_event`) -> its atom, in order of first
    appearance (module docstring), none of them one of `taken` (the activities' atoms)."""
    used = set(taken)
    out: dict[grammar.Condition, str] = {}
    for tree in conditions:
        if tree in out:
            continue
        base = _words(tree)
        if len(base) > MAX_ATOM:
            digest = hashlib.sha1(repr(tree).encode()).hexdigest()[:8]
            base = f"{base[: MAX_ATOM - 9].rstrip('_')}_{digest}"
        if atom_problem(base) is not None:
            base = "c_" + base
        out[tree] = free_atom(base, used)
    return out


def _tests(tree: grammar.Condition) -> Iterable[grammar.Test]:
    if isinstance(tree, grammar.Test):
        yield tree
    elif isinstance(tree, grammar.Negation):
        yield from _tests(tree.part)
    elif isinstance(tree, grammar.Junction):
        for part in tree.parts:
            yield from _tests(part)


def _holds(
    tree: grammar.Condition,
    values: Mapping[str, str | None],
    domains: Mapping[str, AttributeDomain],
) -> bool:
    if isinstance(tree, grammar.Constant):
        return tree.value
    if isinstance(tree, grammar.Negation):
        return not _holds(tree.part, values, domains)
    if isinstance(tree, grammar.Junction):
        parts = (_holds(p, values, domains) for p in tree.parts)
        return all(parts) if tree.operator == "and" else any(parts)
    value = values.get(tree.attribute)
    if value is None:
        return False
    if tree.operator in _COMPARE:
        number = number_of(value)
        return number is not None and _COMPARE[tree.operator](number, float(tree.values[0]))
    domain = domains.get(tree.attribute)
    numeric = domain is not None and domain.numeric
    met = any(_equal(value, v, numeric) for v in tree.values)
    return met if tree.operator in ("is", "in") else not met


def _equal(value: str, named: str, numeric: bool) -> bool:
    if not numeric:
        return value == named
    a, b = number_of(value), number_of(named)
    return a is not None and a == b


def _words(tree: grammar.Condition) -> str:
    """The condition in atom characters (module docstring)."""
    if isinstance(tree, grammar.Constant):
        return "true_" if tree.value else "false_"
    if isinstance(tree, grammar.Negation):
        return f"not__{_words(tree.part)}"
    if isinstance(tree, grammar.Junction):
        return f"__{tree.operator}__".join(_words(p) for p in tree.parts)
    values = "_".join(_value_words(v) for v in tree.values)
    return f"{activity_atom(tree.attribute)}__{_OPERATOR_WORDS[tree.operator]}__{values}"


def _value_words(value: str) -> str:
    text = value.strip()
    sign = "minus_" if text.startswith("-") and number_of(text) is not None else ""
    words = _NOT_WORD.sub("_", activity_atom(text)).strip("_")
    if text[:1].isdigit() or sign:
        words = words.removeprefix("a")  # activity_atom puts "a" before a leading digit
    if words in ("", "activity"):
        words = "v" + hashlib.sha1(text.encode()).hexdigest()[:8]
    return sign + words


def _text(tree: grammar.Condition) -> str:
    if isinstance(tree, grammar.Constant):
        return "true" if tree.value else "false"
    if isinstance(tree, grammar.Negation):
        return f"not ({_text(tree.part)})"
    if isinstance(tree, grammar.Junction):
        return f" {tree.operator} ".join(f"({_text(p)})" for p in tree.parts)
    if tree.operator in ("in", "not in"):
        return f"{tree.attribute} {tree.operator} ({', '.join(tree.values)})"
    return f"{tree.attribute} {tree.operator} {tree.values[0]}"
