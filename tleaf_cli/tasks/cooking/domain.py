"""The Creative Cooking domain: a TOML file read into frozen dataclasses, every name checked.

The domain is data (examples/creative_cooking.toml): statuses in rank order, properties, the goal
status of each property, ingredients with their properties, and actions with their category,
arity, affordances (`only` / `never` properties), pre-requisite statuses and resulting status.
A mistake in the file is an InputError naming the key, e.g.
`creative_cooking.toml: actions.fry.only: unknown property 'meet'`.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

from tleaf_cli.errors import InputError

DEFAULT_DOMAIN = Path(__file__).resolve().parents[3] / "examples" / "creative_cooking.toml"

# A status-changing category changes its argument's status to `result`; the merge categories
# have the fixed effects documented in the TOML file and docs/cooking.md.
STATUS_CATEGORIES = ("wash", "cut", "peel", "heat", "cook", "season", "serve")
MERGE_CATEGORIES = ("add", "combine", "top-with")
BINARY_CATEGORIES = ("combine", "top-with")
READY = "ready"  # pre-requisite word: the argument is at its own required status
MIXTURE = "mixture"
_NAME = re.compile(r"[a-z][a-z0-9_]*")


def atom(action: str, *arguments: str) -> str:
    """The LTLf atom of an action on its arguments: `cut_lettuce`, `top_with_beef_salt`."""
    return "_".join((action, *arguments))


@dataclass(frozen=True)
class ArgumentRule:
    """Affordance and pre-requisite for one argument of an action."""

    only: frozenset[str]  # empty: any properties
    never: frozenset[str]
    requires: frozenset[str]  # status names, or READY

    def affords(self, properties: Iterable[str]) -> bool:
        """True when an ingredient (or mixture) with these properties may take the action."""
        props = set(properties)
        return (not self.only or bool(props & self.only)) and not props & self.never

    def admits(self, properties: Iterable[str], status: str, goal: str) -> bool:
        """Affordance and pre-requisite: may something with these properties, in `status`,
        whose required status is `goal`, take the action?"""
        ready = READY in self.requires and status == goal
        return self.affords(properties) and (status in self.requires or ready)


@dataclass(frozen=True)
class Action:
    name: str
    category: str
    arity: int
    first: ArgumentRule
    second: ArgumentRule | None  # binary actions only
    result: str | None  # status-changing categories and top-with


@dataclass(frozen=True)
class Ingredient:
    name: str
    index: int  # 1-based; 0 is the empty slot
    properties: frozenset[str]


@dataclass(frozen=True)
class Domain:
    """The whole domain; `status_code` and `required_status` are the rules' vocabulary."""

    statuses: tuple[str, ...]  # rank order
    properties: tuple[str, ...]
    goals: Mapping[str, str]  # property -> status
    ingredients: tuple[Ingredient, ...]
    actions: tuple[Action, ...]
    source: str = "<domain>"

    @cached_property
    def by_name(self) -> dict[str, Ingredient]:
        return {i.name: i for i in self.ingredients}

    @property
    def mixture_index(self) -> int:
        """The mixture's index in observations: one past the last ingredient."""
        return len(self.ingredients) + 1

    def status_code(self, status: str) -> int:
        """Observation code of a status: 1 (raw) .. len(statuses); 0 is the empty slot."""
        return self.statuses.index(status) + 1

    def required_status(self, properties: Iterable[str]) -> str:
        """The highest-ranked goal among the properties (raw when there are none)."""
        ranks = [self.statuses.index(self.goals[p]) for p in properties]
        return self.statuses[max(ranks, default=0)]

    def ingredient(self, name: str) -> Ingredient:
        try:
            return self.by_name[name]
        except KeyError:
            raise InputError(f"{self.source}: no ingredient '{name}'") from None


def load_domain(path: str | Path = DEFAULT_DOMAIN) -> Domain:
    """Read and check a domain TOML file; InputError naming the file and key on any mistake."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{path}: not valid TOML ({e})") from None
    return parse_domain(data, str(path))


def parse_domain(data: Mapping[str, Any], source: str = "<domain>") -> Domain:
    """Build a Domain from parsed TOML, checking every name and reference."""
    check = _Checker(source)
    statuses = tuple(check.names(data, "statuses", pattern=None))
    properties = tuple(check.names(data, "properties"))
    goals_table = check.table(data, "goals")
    goals = {}
    for prop in properties:
        if prop not in goals_table:
            check.fail(f"goals: no goal status for property '{prop}'")
        goals[prop] = check.member(goals_table[prop], statuses, f"goals.{prop}", "status")
    for extra in goals_table.keys() - set(properties):
        check.fail(f"goals.{extra}: unknown property '{extra}'")

    ingredients = []
    for index, (name, props) in enumerate(check.table(data, "ingredients").items(), start=1):
        key = f"ingredients.{name}"
        check.name(name, key)
        if name == MIXTURE:
            check.fail(f"{key}: '{MIXTURE}' is reserved for the mixture")
        props = check.name_list(props, key, properties, "property")
        if not props:
            check.fail(f"{key}: an ingredient needs at least one property")
        ingredients.append(Ingredient(name, index, frozenset(props)))
    if not ingredients:
        check.fail("ingredients: no ingredients")

    actions = [
        _parse_action(check, name, spec, statuses, properties)
        for name, spec in check.table(data, "actions").items()
    ]
    if not actions:
        check.fail("actions: no actions")
    domain = Domain(statuses, properties, goals, tuple(ingredients), tuple(actions), source)
    _check_atoms_unique(check, domain)
    _check_goals_reachable(check, domain)
    return domain


def _parse_action(check, name, spec, statuses, properties) -> Action:
    key = f"actions.{name}"
    check.name(name, key)
    if not isinstance(spec, Mapping):
        check.fail(f"{key}: expected a table")
    known = {"category", "arity", "only", "never", "requires", "result", "second"}
    for extra in spec.keys() - known:
        check.fail(f"{key}.{extra}: unknown key (known: {', '.join(sorted(known))})")
    category = check.member(
        spec.get("category"), STATUS_CATEGORIES + MERGE_CATEGORIES, f"{key}.category", "category"
    )
    arity = spec.get("arity")
    expected = 2 if category in BINARY_CATEGORIES else 1
    if arity != expected:
        check.fail(f"{key}.arity: a '{category}' action has arity {expected}, not {arity!r}")
    first = _parse_rule(check, spec, key, statuses, properties)
    second = None
    if category == "top-with":
        if "second" not in spec:
            check.fail(f"{key}.second: a top-with action needs rules for its topping")
        second = _parse_rule(check, spec["second"], f"{key}.second", statuses, properties)
    elif "second" in spec:
        check.fail(f"{key}.second: only top-with actions have a second-argument table")
    elif category == "combine":
        second = first
    result = spec.get("result")
    if category in STATUS_CATEGORIES or category == "top-with":
        result = check.member(result, statuses, f"{key}.result", "status")
    elif result is not None:
        check.fail(f"{key}.result: an '{category}' action has no result status (it merges)")
    return Action(name, category, arity, first, second, result)


def _parse_rule(check, spec, key, statuses, properties) -> ArgumentRule:
    if not isinstance(spec, Mapping):
        check.fail(f"{key}: expected a table")
    only = check.name_list(spec.get("only", []), f"{key}.only", properties, "property")
    never = check.name_list(spec.get("never", []), f"{key}.never", properties, "property")
    if "requires" not in spec:
        check.fail(f"{key}.requires: missing (the statuses the action needs)")
    requires = check.name_list(spec["requires"], f"{key}.requires", (*statuses, READY), "status")
    if not requires:
        check.fail(f"{key}.requires: empty (the action could never be taken)")
    return ArgumentRule(frozenset(only), frozenset(never), frozenset(requires))


def _check_atoms_unique(check, domain: Domain) -> None:
    """Every `action_ingredient[_ingredient]` atom must name one action and arguments only."""
    seen: dict[str, str] = {}
    names = [i.name for i in domain.ingredients] + [MIXTURE]
    for action in domain.actions:
        argument_lists = (
            [(x,) for x in names]
            if action.arity == 1
            else [(x, y) for x in names for y in names if x != y]
        )
        for args in argument_lists:
            name = atom(action.name, *args)
            where = f"{action.name}({', '.join(args)})"
            if name in seen:
                check.fail(f"actions.{action.name}: atom '{name}' means {where} and {seen[name]}")
            seen[name] = where


def _check_goals_reachable(check, domain: Domain) -> None:
    """Every ingredient can reach its required status on its own, so every episode is solvable."""
    unary = [a for a in domain.actions if a.arity == 1 and a.result is not None]
    for ingredient in domain.ingredients:
        goal = domain.required_status(ingredient.properties)
        reached, frontier = {domain.statuses[0]}, [domain.statuses[0]]
        while frontier:
            status = frontier.pop()
            for a in unary:
                if a.first.admits(ingredient.properties, status, goal) and a.result not in reached:
                    reached.add(a.result)
                    frontier.append(a.result)
        if goal not in reached:
            check.fail(
                f"ingredients.{ingredient.name}: its required status '{goal}' cannot be reached "
                f"by the unary actions its properties afford (it reaches: {', '.join(reached)})"
            )


class _Checker:
    """Small helpers that raise InputError naming the source file and key."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, message: str):
        raise InputError(f"{self.source}: {message}")

    def table(self, data: Mapping[str, Any], key: str) -> Mapping[str, Any]:
        value = data.get(key)
        if not isinstance(value, Mapping):
            self.fail(f"{key}: missing table [{key}]")
        return value

    def name(self, value: Any, key: str) -> str:
        if not isinstance(value, str) or not _NAME.fullmatch(value):
            self.fail(f"{key}: name {value!r} must match [a-z][a-z0-9_]* (it becomes an atom)")
        return value

    def names(self, data: Mapping[str, Any], key: str, pattern: str | None = "atom") -> list[str]:
        values = data.get(key)
        if not isinstance(values, list) or not values:
            self.fail(f"{key}: expected a non-empty list of names")
        for v in values:
            if pattern:
                self.name(v, key)
            elif not isinstance(v, str) or not v:
                self.fail(f"{key}: expected names, got {v!r}")
        if len(set(values)) != len(values):
            self.fail(f"{key}: a name appears twice")
        return values

    def member(self, value: Any, allowed: Iterable[str], key: str, what: str) -> str:
        allowed = tuple(allowed)
        if value not in allowed:
            self.fail(f"{key}: unknown {what} {value!r} (known: {', '.join(allowed)})")
        return value

    def name_list(self, values: Any, key: str, allowed: Iterable[str], what: str) -> list[str]:
        if not isinstance(values, list):
            self.fail(f"{key}: expected a list of {what} names")
        return [self.member(v, allowed, key, what) for v in values]
