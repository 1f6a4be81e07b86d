"""Declare models in the `.decl` format of RuM and Declare4Py, as tleaf LTLf rules.

`read_decl(path)` reads a model (`DeclModel`): its activities, which attributes each activity
carries (`bind`), each attribute's domain, and its constraints (`DeclConstraint`). Each
constraint becomes one LTLf formula over atoms (`DeclConstraint.formula`), from its template's
single definition (`knowledge/templates.py`):

- an activity is its atom by `activity_atoms` over the model's declared activities, the map
  `read-log` gives a log's activities (the two agree when the names are equal and no two of the
  log's names meet on one atom: `activity_atoms` then adds `_2` to one of them);
- "this event's attribute is v" is `attribute_atom(attribute, v)`;
- an MP-Declare activation condition narrows the activation's event formula (`closed &
  org_resource__value_3`), a condition on the target (`T.attr ...` in the correlation field)
  the target's. A condition becomes a disjunction over the attribute's DECLARED values that
  meet it, so it is exact on every event whose attribute value is one of them (`A.x is not v`:
  x has a declared value other than v; `A.x < 3`: one of the declared values below 3).

Refused, each with the file, the line and the reason (an InputError: the CLI exits 2): a line
the grammar cannot read (`decl_grammar.py`), an activity no `activity` line declares, a value
outside its attribute's declared domain, an attribute not bound to the event it is read on,
a numeric condition on values that are not numbers or on a domain that is not finite (`float
between`, or `integer between` of more than MAX_ENUMERATED values), a time condition (LTLf has
no clock), a condition relating the activation to the target (`same`, `different`, `A.x is
T.x`, an `A.` test in the correlation field), and any condition on a template both of whose
arguments activate it (`Template.activated_by_both`: Declare4Py, the reference, has no checker
for them).
"""

from __future__ import annotations

import functools
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from tleaf_cli.data.activity_names import activity_atoms, attribute_atom
from tleaf_cli.data.artifacts import read_text_file
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge import decl_grammar as grammar
from tleaf_cli.knowledge.templates import Template, find_template

MAX_ENUMERATED = 1000  # the most values an `integer between X and Y` domain is enumerated to


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

    def finite(self) -> tuple[str, ...]:
        """Every declared value as text; an integer range enumerated. InputError for a float
        range or an integer range of more than MAX_ENUMERATED values."""
        if self.kind == "values":
            return self.values
        if self.kind == "integer" and self.high - self.low < MAX_ENUMERATED:
            return tuple(str(v) for v in range(int(self.low), int(self.high) + 1))
        size = "a float range" if self.kind == "float" else "more than 1000 integers"
        raise InputError(
            f"attribute {self.attribute!r} is declared on line {self.line} as {size}: a "
            "condition on it needs a finite set of values (at most 1000), one atom each"
        )

    def lookup(self, value: str) -> str | None:
        """The declared value `value` names (an integer range's by number: "03" is 3), or None."""
        if self.kind == "values":
            return value if value in self.values else None
        try:
            number = float(value)
        except ValueError:
            return None
        if not number.is_integer() or not self.low <= number <= self.high:
            return None
        return str(int(number))


@dataclass(frozen=True)
class DeclConstraint:
    """One constraint line: its template and count, its activities (as declared), its three
    condition fields as written, and the activation's and the target's conditions as formulas
    over attribute atoms (None without one)."""

    template: Template
    activities: tuple[str, ...]
    count: int
    line: int
    activation: str = ""
    correlation: str = ""
    time: str = ""
    activation_formula: str | None = None
    target_formula: str | None = None

    def base_name(self, atoms: Mapping[str, str]) -> str:
        """`<template key>[count].<activity atoms>`, e.g. `chain_precedence.resolve_ticket.closed`,
        `existence2.closed` (a count shown from 2 on)."""
        key = self.template.key + (str(self.count) if self.count > 1 else "")
        return ".".join([key, *(atoms[a] for a in self.activities)])

    def formula(self, atoms: Mapping[str, str]) -> str:
        """The constraint in tleaf's LTLf, each activity its atom under `atoms` (activity name ->
        atom), narrowed by the activation's and the target's conditions."""
        events = [atoms[a] for a in self.activities]
        activation = self.template.activation or 0
        for index, condition in (
            (activation, self.activation_formula),
            (1 - activation, self.target_formula),
        ):
            if condition is not None:
                events[index] = f"{events[index]} & ({condition})"
        return self.template.ltlf(*events, n=self.count)


@dataclass(frozen=True)
class DeclRule:
    """A constraint as a named rule: its unique name, its formula, its line in the file."""

    name: str
    formula: str
    line: int


@dataclass(frozen=True)
class DeclModel:
    """A `.decl` model: activities in file order, `bindings` activity -> its attributes,
    `domains` attribute -> its declared values, constraints in file order."""

    path: str
    activities: tuple[str, ...]
    bindings: dict[str, tuple[str, ...]] = field(default_factory=dict)
    domains: dict[str, AttributeDomain] = field(default_factory=dict)
    constraints: tuple[DeclConstraint, ...] = ()

    @functools.cached_property
    def atoms(self) -> dict[str, str]:
        """Each declared activity -> its atom (`activity_atoms` over the declared names)."""
        return activity_atoms(self.activities)

    def rules(self) -> list[DeclRule]:
        """Every constraint as a rule named `<template key>.<activity atoms>`; a name that
        repeats (one template on the same activities, other conditions) gets `.2`, `.3`, ..."""
        out, seen = [], {}
        for c in self.constraints:
            name = c.base_name(self.atoms)
            seen[name] = seen.get(name, 0) + 1
            unique = name if seen[name] == 1 else f"{name}.{seen[name]}"
            out.append(DeclRule(unique, c.formula(self.atoms), c.line))
        return out


def read_decl(path: str | os.PathLike) -> DeclModel:
    """The model in the `.decl` file `path`; InputError naming the file and the line of the
    first line it cannot read or refuses (module docstring)."""
    return parse_decl(read_text_file(path), os.fspath(path))


def parse_decl(text: str, name: str = "<text>") -> DeclModel:
    """A `.decl` model from its text (`name` for messages)."""
    reader = _Reader(name)
    constraint_lines: list[tuple[int, str]] = []
    for lineno, line in _statements(text):
        with reader.at(lineno):
            kind = grammar.line_kind(line)
            if kind == "constraint":
                constraint_lines.append((lineno, line))  # read once every name is declared
            else:
                getattr(reader, kind)(line, lineno)
    with reader.at(None):
        reader.check_atoms()
    constraints = []
    for lineno, line in constraint_lines:
        with reader.at(lineno):
            constraints.append(reader.constraint(line, lineno))
    return DeclModel(
        name,
        tuple(reader.activities),
        dict(reader.bindings),
        dict(reader.domains),
        tuple(constraints),
    )


def _statements(text: str) -> list[tuple[int, str]]:
    """(line number, statement) for each statement: blank lines and `#` comments skipped, and
    a domain line that ends with ',' joined with the lines that go on with it."""
    out: list[tuple[int, str]] = []
    for lineno, raw in enumerate(text.split("\n"), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if out and out[-1][1].endswith(",") and not _starts_statement(out[-1][1]):
            out[-1] = (out[-1][0], f"{out[-1][1]} {line}")
        else:
            out.append((lineno, line))
    return out


def _starts_statement(line: str) -> bool:
    """True for a line that a ',' at its end does not continue (activity, bind, constraint)."""
    try:
        return grammar.line_kind(line) != "domain"
    except InputError:
        return True


class _Reader:
    """The declarations read so far, and each statement's checks."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.activities: dict[str, int] = {}  # name -> its line
        self.bindings: dict[str, tuple[str, ...]] = {}
        self.domains: dict[str, AttributeDomain] = {}

    def at(self, lineno: int | None) -> _Located:
        return _Located(self.path, lineno)

    def activity(self, line: str, lineno: int) -> None:
        name = grammar.activity_name(line)
        if name in self.activities:
            raise InputError(
                f"activity {name!r} is already declared on line {self.activities[name]}"
            )
        self.activities[name] = lineno

    def bind(self, line: str, lineno: int) -> None:
        name, attributes = grammar.binding(line)
        if name not in self.activities:
            raise InputError(
                f"bind names activity {name!r}, which no earlier 'activity' line declares"
            )
        self.bindings[name] = tuple(dict.fromkeys(self.bindings.get(name, ()) + attributes))

    def domain(self, line: str, lineno: int) -> None:
        attributes, text = grammar.domain(line)
        kind, spec = grammar.domain_values(text)
        for attribute in attributes:
            if attribute in self.domains:
                raise InputError(
                    f"attribute {attribute!r} already has its values, declared on "
                    f"line {self.domains[attribute].line}"
                )
            if kind == "values":
                self.domains[attribute] = AttributeDomain(attribute, kind, lineno, spec)
            else:
                self.domains[attribute] = AttributeDomain(attribute, kind, lineno, (), *spec)

    def check_atoms(self) -> None:
        """Every declared value a distinct atom, none an activity's: a condition is exact only
        when no two values (or a value and an activity) read as one atom."""
        owner = {
            atom: f"activity {name!r}" for name, atom in activity_atoms(self.activities).items()
        }
        for domain in self.domains.values():
            if domain.kind == "float" or (
                domain.kind == "integer" and domain.high - domain.low >= MAX_ENUMERATED
            ):
                continue
            for value in domain.finite():
                atom = attribute_atom(domain.attribute, value)
                if atom in owner:
                    raise InputError(
                        f"line {domain.line}: {domain.attribute} = {value!r} reads as the atom "
                        f"{atom!r}, as {owner[atom]} does: rename one of them"
                    )
                owner[atom] = f"{domain.attribute} = {value!r}"

    def constraint(self, line: str, lineno: int) -> DeclConstraint:
        name, args, fields = grammar.constraint_parts(line)
        template, count = find_template(name)
        activities = grammar.split_arguments(args, template.arity, self.activities.__contains__)
        for activity in activities:
            if activity not in self.activities:
                raise InputError(f"activity {activity!r} is not declared by an 'activity' line")
        most = 2 if template.arity == 1 else 3
        if len(fields) > most:
            what = "activation |time" if template.arity == 1 else "activation |correlation |time"
            raise InputError(
                f"{template.name} takes at most {most} condition fields "
                f"(|{what}), found {len(fields)}"
            )
        activation = fields[0] if fields else ""
        correlation = fields[1] if template.arity == 2 and len(fields) > 1 else ""
        time = fields[most - 1] if len(fields) == most else ""
        if time:
            raise InputError(f"time condition {time!r}: {grammar.UNSUPPORTED_TIME}")
        if (activation or correlation) and template.activated_by_both:
            raise InputError(
                f"a condition on {template.name}, which both its activities activate, is not "
                "supported (no single event to narrow; Declare4Py has no checker for it either)"
            )
        act = template.activation or 0
        return DeclConstraint(
            template,
            tuple(activities),
            count,
            lineno,
            activation,
            correlation,
            time,
            self.condition(activation, "A", activities[act], "activation"),
            self.condition(
                correlation, "T", activities[1 - act] if correlation else "", "correlation"
            ),
        )

    def condition(self, text: str, role: str, activity: str, where: str) -> str | None:
        """The condition `text` as a formula over attribute atoms, on `activity`'s event."""
        if not text:
            return None
        tree = grammar.parse_condition(text, self._values_of)
        return self._formula(tree, role, activity, where)

    def _values_of(self, attribute: str) -> tuple[str, ...] | None:
        domain = self.domains.get(attribute)
        return domain.values if domain is not None else None

    def _formula(self, node: grammar.Condition, role: str, activity: str, where: str) -> str:
        if isinstance(node, grammar.Constant):
            return "true" if node.value else "false"
        if isinstance(node, grammar.Negation):
            return f"!({self._formula(node.part, role, activity, where)})"
        if isinstance(node, grammar.Junction):
            op = " & " if node.operator == "and" else " | "
            return op.join(f"({self._formula(p, role, activity, where)})" for p in node.parts)
        return self._test(node, role, activity, where)

    def _test(self, test: grammar.Test, role: str, activity: str, where: str) -> str:
        name = f"{test.role}.{test.attribute}"
        if test.role != role:
            if where == "activation":
                raise InputError(
                    f"the activation condition names {name}, the target's "
                    "attribute: a target's condition goes in the correlation field"
                )
            raise InputError(
                f"the correlation condition names {name}: a test on the activation there is "
                "not supported (it would tie the activation to its target); put A.'s tests "
                "in the activation condition"
            )
        if test.attribute not in self.bindings.get(activity, ()):
            raise InputError(
                f"{name}: attribute {test.attribute!r} is not bound to activity "
                f"{activity!r} (no 'bind {activity}: {test.attribute}' line)"
            )
        domain = self.domains.get(test.attribute)
        if domain is None:
            raise InputError(
                f"{name}: attribute {test.attribute!r} has no declared values "
                f"(a line '{test.attribute}: v1, v2, ...')"
            )
        values = domain.finite()
        chosen = _meeting(test, domain, values)
        atoms = [attribute_atom(test.attribute, v) for v in values if v in chosen]
        return " | ".join(atoms) if atoms else "false"


def _meeting(test: grammar.Test, domain: AttributeDomain, values: tuple[str, ...]) -> set[str]:
    """The declared values that meet `test`."""
    if test.operator in grammar.NUMERIC_OPERATORS:
        numbers = {}
        for v in values:
            try:
                numbers[v] = float(v)
            except ValueError:
                raise InputError(
                    f"{test.role}.{test.attribute} {test.operator} {test.values[0]}: a numeric "
                    f"comparison, but {v!r} (declared on line {domain.line}) is not a number"
                ) from None
        bound = float(test.values[0])
        compare = {
            "<": float.__lt__,
            "<=": float.__le__,
            "=": float.__eq__,
            "!=": float.__ne__,
            ">=": float.__ge__,
            ">": float.__gt__,
        }[test.operator]
        return {v for v, x in numbers.items() if compare(x, bound)}
    named = set()
    for value in test.values:
        found = domain.lookup(value)
        if found is None:
            shown = ", ".join(values[:6]) + (", ..." if len(values) > 6 else "")
            raise InputError(
                f"{test.role}.{test.attribute}: {value!r} is not a declared value of "
                f"{test.attribute!r} (line {domain.line}: {shown})"
            )
        named.add(found)
    return named if test.operator in ("is", "in") else set(values) - named


class _Located:
    """A context that turns an InputError into one naming the file and the line."""

    def __init__(self, path: str, lineno: int | None) -> None:
        self.path, self.lineno = path, lineno

    def __enter__(self) -> None:
        return None

    def __exit__(self, kind: type | None, error: BaseException | None, tb: object) -> bool:
        if isinstance(error, InputError):
            where = f"{self.path}: line {self.lineno}" if self.lineno else self.path
            raise InputError(f"{where}: {error}") from None
        return False


def decl_path(path: str | os.PathLike) -> bool:
    """True for a path tleaf reads as a Declare model (suffix `.decl`, any case)."""
    return Path(path).suffix.lower() == ".decl"
