"""The environment's rules as LTLf over `action_ingredient` atoms: the cooking knowledge base.

Atoms are the environment's action names for the given ingredients (`cut_lettuce`,
`combine_lettuce_tomato`, `top_with_beef_salt`, `fry_mixture`); one atom holds per step (a
one-hot domain), so `tleaf compile-dfa --one-hot` compiles the rules. Two kinds, as `<kind>.<name>`
formula names in a `.ltl` file:

- `affordance.<atom>: G !<atom>` — the action can never be applied to these arguments: an
  ingredient's properties never change, and the mixture is never added, combined or a topping.
- `ordering.<atom>[.<argument>]: (!<atom> U (e1 | e2 | ...)) | G !<atom>` — "a before b": the
  first time the action is taken, some enabler e (an action whose result is one of the statuses the
  action requires of that argument) came earlier; with no enabler at all, `G !<atom>`. For an
  action on the mixture, the enablers are the adds and combines that put something into it.

Both kinds are sound: a sequence of feasible actions satisfies every rule, and in a sequence that
violates a rule the first offending step is itself infeasible (tested on random rollouts).
What the rules cannot say (they speak of first occurrences and fixed properties only): the status
an ingredient has after its first enabler (so repeated or over-processing actions), an
ingredient's slot being empty after it was merged, the mixture's properties and status (they
depend on what was added and when), and the goal. docs/cooking.md lists these.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from tleaf_cli.data.artifacts import check_writable, write_text_atomic
from tleaf_cli.data.formula_files import check_names
from tleaf_cli.errors import InputError
from tleaf_cli.tasks.cooking.domain import (
    DEFAULT_DOMAIN,
    MIXTURE,
    READY,
    Action,
    ArgumentRule,
    Domain,
    load_domain,
)
from tleaf_cli.tasks.cooking.domain import atom as atom_of

KINDS = ("affordance", "ordering")


@dataclass(frozen=True)
class Rule:
    """One knowledge-base formula; `name` is `<kind>.<rest>`."""

    name: str
    kind: str
    formula: str
    atom: str  # the action atom the rule constrains


def knowledge_base(
    domain: Domain, ingredients: Sequence[str] | None = None, mixture: bool = True
) -> list[Rule]:
    """Affordance and ordering rules for `ingredients` (default: the whole domain).

    `mixture=False` leaves out the rules about the mixture's actions, whose enablers are every add
    and combine of the ingredients (thousands of atoms for the whole domain).
    """
    names = [i.name for i in domain.ingredients] if ingredients is None else list(ingredients)
    for name in names:
        domain.ingredient(name)  # InputError for an unknown name
    if len(set(names)) != len(names):
        raise InputError(f"{domain.source}: an ingredient is named twice in {', '.join(names)}")
    return _Builder(domain, names).rules(mixture)


def write_cooking_kb(
    out: str | Path,
    domain_path: str | Path = DEFAULT_DOMAIN,
    ingredients: Sequence[str] | None = None,
    mixture: bool = True,
) -> list[Rule]:
    """Write the knowledge base for `ingredients` (default: all) of a domain file to `out`."""
    domain = load_domain(domain_path)
    check_writable(out)
    rules = knowledge_base(domain, ingredients, mixture)
    header = (
        "Creative Cooking knowledge base (synthetic environment built from the paper's appendix)\n"
        f"domain: {domain_path}\n"
        f"ingredients: {', '.join(ingredients) if ingredients else 'all'}\n"
        "affordance.<atom>: G !<atom>\n"
        "ordering.<atom>[.<argument>]: (!<atom> U (enablers)) | G !<atom>"
    )
    write_knowledge_base(out, rules, header)
    return rules


def format_knowledge_base(rules: Iterable[Rule], header: str = "") -> str:
    """The rules as a `.ltl` file (docs/design.md): `<kind>.<name>: <formula>` per line."""
    rules = list(rules)
    check_names((r.name for r in rules), "rule name")
    lines = [f"# {line}" for line in header.splitlines()]
    lines += [f"{r.name}: {r.formula}" for r in rules]
    return "\n".join(lines) + "\n"


def write_knowledge_base(path: str | Path, rules: Iterable[Rule], header: str = "") -> None:
    write_text_atomic(path, format_knowledge_base(rules, header))


def before(enablers: Sequence[str], atom: str) -> str:
    """LTLf for "the first `atom` comes after one of `enablers`" (or `atom` never happens)."""
    if not enablers:
        return f"G !{atom}"
    return f"(!{atom} U ({' | '.join(enablers)})) | G !{atom}"


class _Builder:
    def __init__(self, domain: Domain, names: list[str]) -> None:
        self.domain = domain
        self.names = names
        self.props = {n: domain.ingredient(n).properties for n in names}
        self.goal = {n: domain.required_status(self.props[n]) for n in names}

    def rules(self, mixture: bool) -> list[Rule]:
        out: list[Rule] = []
        for action in self.domain.actions:
            if action.arity == 1:
                for x in self.names:
                    out += self._unary(action, x)
                if mixture:
                    out += self._on_mixture(action, (MIXTURE,))
            else:
                for x in self.names:
                    for y in self.names:
                        if x != y:
                            out += self._binary(action, x, y)
                    if mixture:
                        out += self._on_mixture(action, (MIXTURE, x))
                        out += self._on_mixture(action, (x, MIXTURE))
        return out

    def _unary(self, action: Action, x: str) -> list[Rule]:
        atom = atom_of(action.name, x)
        if not action.first.affords(self.props[x]):
            return [_affordance(atom)]
        return self._ordering(atom, action.first, x, f"ordering.{atom}")

    def _binary(self, action: Action, x: str, y: str) -> list[Rule]:
        atom = atom_of(action.name, x, y)
        if not (action.first.affords(self.props[x]) and action.second.affords(self.props[y])):
            return [_affordance(atom)]
        return self._ordering(atom, action.first, x, f"ordering.{atom}.{x}") + self._ordering(
            atom, action.second, y, f"ordering.{atom}.{y}"
        )

    def _on_mixture(self, action: Action, args: tuple[str, ...]) -> list[Rule]:
        """Rules for an action whose arguments include the mixture (always the first, if any)."""
        atom = atom_of(action.name, *args)
        topping = args[1] if len(args) == 2 else None
        if (
            action.category in ("add", "combine")
            or args[0] != MIXTURE
            or (topping and not action.second.affords(self.props[topping]))
        ):
            return [_affordance(atom)]  # the mixture is never added, combined or a topping
        # Any action on the mixture needs something in it: an add or a combine came first.
        merges = [
            atom_of(a.name, *merged)
            for a in self.domain.actions
            if a.category in ("add", "combine")
            for merged in self._arguments(a)
        ]
        out = [Rule(f"ordering.{atom}", "ordering", before(merges, atom), atom)]
        if topping:
            out += self._ordering(atom, action.second, topping, f"ordering.{atom}.{topping}")
        return out

    def _arguments(self, action: Action) -> list[tuple[str, ...]]:
        """The argument tuples of `action` over the ingredients that it affords."""
        if action.arity == 1:
            return [(x,) for x in self.names if action.first.affords(self.props[x])]
        return [
            (x, y)
            for x in self.names
            for y in self.names
            if x != y
            and action.first.affords(self.props[x])
            and action.second.affords(self.props[y])
        ]

    def _ordering(self, atom: str, rule: ArgumentRule, x: str, name: str) -> list[Rule]:
        """ "`atom` only after `x` was put in a status `rule` requires", unless raw is one."""
        needed = set(rule.requires - {READY})
        if READY in rule.requires:
            needed.add(self.goal[x])
        if self.domain.statuses[0] in needed:
            return []  # the action may come first: nothing to order
        # An action cannot enable its own first occurrence (top-with keeps a seasoned target).
        enablers = [e for e in self._enablers(x, needed) if e != atom]
        return [Rule(name, "ordering", before(enablers, atom), atom)]

    def _enablers(self, x: str, statuses: set[str]) -> list[str]:
        """Atoms of the actions that can put `x` into one of `statuses`."""
        out = []
        for action in self.domain.actions:
            if action.result not in statuses:
                continue
            if action.arity == 1:
                if action.first.affords(self.props[x]):
                    out.append(atom_of(action.name, x))
            else:  # top-with: x is the topped ingredient
                out += [
                    atom_of(action.name, x, y)
                    for y in self.names
                    if y != x
                    and action.first.affords(self.props[x])
                    and action.second.affords(self.props[y])
                ]
        return out


def _affordance(atom: str) -> Rule:
    return Rule(f"affordance.{atom}", "affordance", f"G !{atom}", atom)
