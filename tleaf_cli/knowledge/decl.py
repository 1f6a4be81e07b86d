"""Declare models in the `.decl` format of RuM and Declare4Py, as tleaf LTLf rules.

`read_decl(path)` reads a model (`DeclModel`): its activities, which attributes each activity
carries (`bind`), each attribute's domain, and its constraints (`DeclConstraint`). Each
constraint becomes one LTLf formula over atoms (`DeclModel.rules`), from its template's single
definition (`knowledge/templates.py`):

- an activity is its atom under a log's map (`bind_atoms`: the name matched exactly to the
  log's names, the atom `read-log` gave it), or, without a log, `activity_atoms` over the
  model's names;
- an MP-Declare activation condition narrows the activation's event formula (`closed &
  org_resource__is__value_3`), a condition on the target (`T.attr ...` in the correlation field)
  the target's: each condition is one atom, true at an event where the test holds on the event's
  own values (`decl_conditions.py`: any domain size, numbers compared as numbers, values outside
  the declared domain read as Declare4Py reads them). `DeclRule.conditions` maps each such atom
  to its test, for whoever makes the events' letters.

A model may leave out its `activity` lines (as several published models do): its activities are
then the names its constraints use. Declarations are needed where a condition names an
attribute (`bind`, and the attribute's domain).

Refused, each with the file, the line and the reason (an InputError: the CLI exits 2): a line
the grammar cannot read (`decl_grammar.py`), an activity no `activity` line declares (in a model
that has them), a template given the wrong number of activities or a count below 1, a value
outside its attribute's declared domain, an attribute not bound to the event it is read on, a
numeric condition on declared values that are not numbers, a time condition (LTLf has no
clock), a condition relating the activation to the target (`same`, `different`, `A.x is T.x`,
an `A.` test in the correlation field), and any condition on a template both of whose
arguments activate it (`Template.activated_by_both`: Declare4Py, the reference, has no checker
for them).
"""

from __future__ import annotations

import functools
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from tleaf_cli.data.activity_names import bind_atoms
from tleaf_cli.data.artifacts import read_text_file
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge import decl_grammar as grammar
from tleaf_cli.knowledge.decl_conditions import (
    AttributeDomain,
    EventCondition,
    condition_atoms,
    number_of,
    on_event,
)
from tleaf_cli.knowledge.templates import Template, find_template


@dataclass(frozen=True)
class DeclConstraint:
    """One constraint line: its template and count, its activities (as written), its three
    condition fields as written, and the activation's and the target's conditions as tests on
    one event (`decl_conditions.on_event`; None without one)."""

    template: Template
    activities: tuple[str, ...]
    count: int
    line: int
    activation: str = ""
    correlation: str = ""
    time: str = ""
    activation_condition: grammar.Condition | None = None
    target_condition: grammar.Condition | None = None

    def base_name(self, atoms: Mapping[str, str]) -> str:
        """`<template key>[count].<activity atoms>`, e.g. `chain_precedence.resolve_ticket.closed`,
        `existence2.closed` (a count shown from 2 on), `exactly.closed` (Exactly1)."""
        key = self.template.key + (str(self.count) if self.count > 1 else "")
        return ".".join([key, *(atoms[a] for a in self.activities)])

    def formula(
        self, atoms: Mapping[str, str], conditions: Mapping[grammar.Condition, str] | None = None
    ) -> str:
        """The constraint in tleaf's LTLf, each activity its atom under `atoms` (activity name ->
        atom), narrowed by the activation's and the target's conditions, each its atom under
        `conditions` (`condition_atoms`)."""
        events = [atoms[a] for a in self.activities]
        activation = self.template.activation or 0
        for index, condition in (
            (activation, self.activation_condition),
            (1 - activation, self.target_condition),
        ):
            if condition is None:
                continue
            if isinstance(condition, grammar.Constant):
                test = "true" if condition.value else "false"
            else:
                test = conditions[condition]
            events[index] = f"{events[index]} & {test}"
        return self.template.ltlf(*events, n=self.count)

    def conditions(self) -> list[grammar.Condition]:
        """Its conditions that are tests (not `true` / `false`)."""
        both = (self.activation_condition, self.target_condition)
        return [c for c in both if c is not None and not isinstance(c, grammar.Constant)]


@dataclass(frozen=True)
class DeclRule:
    """A constraint as a named rule: its unique name, its formula, its line in the file, and the
    test behind each condition atom the formula names."""

    name: str
    formula: str
    line: int
    conditions: dict[str, EventCondition] = field(default_factory=dict)


@dataclass(frozen=True)
class DeclModel:
    """A `.decl` model: activities (declared, in file order, or the constraints' own where the
    file declares none), `bindings` activity -> its attributes, `domains` attribute -> its
    declared values, constraints in file order."""

    path: str
    activities: tuple[str, ...]
    bindings: dict[str, tuple[str, ...]] = field(default_factory=dict)
    domains: dict[str, AttributeDomain] = field(default_factory=dict)
    constraints: tuple[DeclConstraint, ...] = ()

    @functools.cached_property
    def atoms(self) -> dict[str, str]:
        """Each activity -> its atom with no log (`activity_atoms` over the model's names)."""
        return bind_atoms(self.activities)

    def rules(self, log_atoms: Mapping[str, str] | None = None) -> list[DeclRule]:
        """Every constraint as a rule named `<template key>.<activity atoms>` (a name that
        repeats, one template on the same activities with other conditions, gets `.2`, `.3`,
        ...). `log_atoms`: a log's activity -> atom map (its cases artifact's), so that every
        activity the log has reads the log's atom (`bind_atoms`)."""
        atoms = self.atoms if log_atoms is None else bind_atoms(self.activities, log_atoms)
        taken = set(atoms.values()) | set((log_atoms or {}).values())
        trees = condition_atoms((tree for c in self.constraints for tree in c.conditions()), taken)
        out, seen = [], {}
        for c in self.constraints:
            name = c.base_name(atoms)
            seen[name] = seen.get(name, 0) + 1
            unique = name if seen[name] == 1 else f"{name}.{seen[name]}"
            tests = {
                trees[tree]: EventCondition(tree, self._domains_of(tree)) for tree in c.conditions()
            }
            out.append(DeclRule(unique, c.formula(atoms, trees), c.line, tests))
        return out

    def _domains_of(self, tree: grammar.Condition) -> dict[str, AttributeDomain]:
        names = EventCondition(tree, {}).attributes
        return {a: self.domains[a] for a in names if a in self.domains}


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
    constraints = []
    implicit = not reader.activities  # no `activity` line: the constraints' names are the model's
    for lineno, line in constraint_lines:
        with reader.at(lineno):
            constraints.append(reader.constraint(line, lineno, implicit))
    activities = reader.activities
    if implicit:
        activities = {a: c.line for c in constraints for a in c.activities}
    return DeclModel(
        name,
        tuple(activities),
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

    def constraint(self, line: str, lineno: int, implicit: bool = False) -> DeclConstraint:
        """The constraint of a line. `implicit`: the model declares no activity, so any name is
        one (as the name is written)."""
        name, args, fields = grammar.constraint_parts(line)
        template, count = find_template(name)
        if count < 1:
            raise InputError(
                f"{name}: a count starts at 1 ({template.name}1, {template.name}2, ...)"
            )
        if implicit:  # a .decl cannot name an activity holding a comma without declaring it

            def declared(part: str) -> bool:
                return "," not in part
        else:
            declared = self.activities.__contains__
        activities = grammar.split_arguments(args, template.arity, declared)
        parts = [p.strip() for p in args.split(",")]
        if template.arity == 1 and not declared(activities[0]) and all(map(declared, parts)):
            raise InputError(
                f"{template.name} takes one activity, found {len(parts)}: "
                + ", ".join(repr(p) for p in parts)
            )
        for activity in activities:
            if not activity:
                raise InputError(f"{template.name}[{args}]: an empty activity name")
            if activity not in self.activities and not implicit:
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

    def condition(
        self, text: str, role: str, activity: str, where: str
    ) -> grammar.Condition | None:
        """The condition `text` on `activity`'s event, checked, as a test on that event."""
        if not text:
            return None
        tree = grammar.parse_condition(text, self._values_of)
        self._check(tree, role, activity, where)
        return on_event(tree)

    def _values_of(self, attribute: str) -> tuple[str, ...] | None:
        domain = self.domains.get(attribute)
        return domain.values if domain is not None else None

    def _check(self, node: grammar.Condition, role: str, activity: str, where: str) -> None:
        if isinstance(node, grammar.Negation):
            self._check(node.part, role, activity, where)
        elif isinstance(node, grammar.Junction):
            for part in node.parts:
                self._check(part, role, activity, where)
        elif isinstance(node, grammar.Test):
            self._check_test(node, role, activity, where)

    def _check_test(self, test: grammar.Test, role: str, activity: str, where: str) -> None:
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
            declared = "" if self.activities else " and an 'activity' line"
            raise InputError(
                f"{name}: attribute {test.attribute!r} is not bound to activity "
                f"{activity!r} (no 'bind {activity}: {test.attribute}' line{declared})"
            )
        domain = self.domains.get(test.attribute)
        if domain is None:
            raise InputError(
                f"{name}: attribute {test.attribute!r} has no declared values "
                f"(a line '{test.attribute}: v1, v2, ...' or '{test.attribute}: integer "
                "between X and Y')"
            )
        if test.operator in grammar.NUMERIC_OPERATORS:
            if domain.kind == "values":
                for v in domain.values:
                    if number_of(v) is None:
                        raise InputError(
                            f"{name} {test.operator} {test.values[0]}: a numeric comparison, "
                            f"but {v!r} (declared on line {domain.line}) is not a number"
                        )
            return
        for value in test.values:
            if domain.lookup(value) is None:
                raise InputError(
                    f"{name}: {value!r} is not a declared value of {test.attribute!r} "
                    f"(line {domain.line}: {domain.shown()})"
                )


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
