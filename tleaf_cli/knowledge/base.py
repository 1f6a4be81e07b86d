"""Knowledge bases of (action, ingredient) rules: reading, writing, per-video extraction, mining.

A knowledge base (docs/knowledge.md) is a `.ltl` formula file whose names carry the rule kind:
`affordance.<rest>` (a pair that cannot happen: `G !cut_milk`) or `ordering.<rest>` (if both
happen, the first before the second: `(!cook_cabbage U rinse_cabbage) | G !cook_cabbage`), over
atoms `action_ingredient`.

The paper (Sec. VI) gives each video the conjunction of the rules whose atoms ALL occur in it
(`rules_for`, `sample_formula`); a rule set is named by a hash of its rule names (`rule_set_id`),
so every video with the same rules shares one DFA. The `kb-extract` stage
(`tasks/action_recognition/kb_extract.py`) does this for the LABELLED pairs of every video and
compiles each distinct rule set once; `rule_sets.KnowledgeRuleSets` does it for a model's
sequences.
"""

from __future__ import annotations

import hashlib
import os
from collections import Counter
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Literal

from tleaf_cli.arguments import given
from tleaf_cli.data.artifacts import write_text_atomic
from tleaf_cli.data.formula_files import check_names, read_formulas
from tleaf_cli.errors import ArgumentTypeError, InputError
from tleaf_cli.knowledge import mining_arguments as check
from tleaf_cli.logic.formulas import FormulaSyntaxError, atoms, parse

RuleKind = Literal["affordance", "ordering"]
RULE_KINDS: tuple[RuleKind, ...] = ("affordance", "ordering")


def atom(action: str, ingredient: str) -> str:
    """The knowledge base's atom for an (action, ingredient) pair: `action_ingredient` (e.g.
    `rinse_cabbage`); `ingredient_of` reads the ingredient back."""
    return f"{action}_{ingredient}"


@dataclass(frozen=True)
class Rule:
    """One named rule: its kind (from the name), formula text, and the sorted atoms it mentions."""

    name: str
    kind: RuleKind
    formula: str
    atoms: tuple[str, ...]


@dataclass(frozen=True)
class KnowledgeBase:
    """Rules in file order, indexed by atom so `rules_for` looks only at rules that can apply."""

    rules: tuple[Rule, ...] = ()
    _by_atom: dict[str, list[int]] = field(init=False, repr=False, compare=False, hash=False)
    _always: tuple[int, ...] = field(init=False, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        index: dict[str, list[int]] = {}
        for k, rule in enumerate(self.rules):
            for a in rule.atoms:
                index.setdefault(a, []).append(k)
        object.__setattr__(self, "_by_atom", index)
        object.__setattr__(
            self, "_always", tuple(k for k, r in enumerate(self.rules) if not r.atoms)
        )

    def __len__(self) -> int:
        return len(self.rules)

    def __iter__(self) -> Iterator[Rule]:
        return iter(self.rules)

    def of_kind(self, kind: RuleKind) -> list[Rule]:
        return [r for r in self.rules if r.kind == kind]

    def merged(self, other: KnowledgeBase) -> KnowledgeBase:
        """These rules, then `other`'s whose names are new."""
        names = {r.name for r in self.rules}
        return KnowledgeBase(self.rules + tuple(r for r in other.rules if r.name not in names))


def affordance_rule(action: str, ingredient: str) -> Rule:
    """`action` is never applied to `ingredient`: `G !action_ingredient`."""
    a = atom(action, ingredient)
    return Rule(f"affordance.{a}", "affordance", f"G !{a}", (a,))


def ordering_rule(ingredient: str, first: str, then: str) -> Rule:
    """If both happen to `ingredient`, `first` happens before `then`: `(!y U x) | G !y`."""
    x, y = atom(first, ingredient), atom(then, ingredient)
    return Rule(f"ordering.{x}.{y}", "ordering", f"(!{y} U {x}) | G !{y}", tuple(sorted((x, y))))


def rules_for(kb: KnowledgeBase, present_atoms: Iterable[str]) -> list[Rule]:
    """The rules whose atoms ALL occur among `present_atoms` (the paper's extraction), KB order.

    A rule without atoms (e.g. `true`) always applies.
    """
    present = set(present_atoms)
    candidates = {k for a in present for k in kb._by_atom.get(a, ())}
    candidates.update(kb._always)
    return [kb.rules[k] for k in sorted(candidates) if present.issuperset(kb.rules[k].atoms)]


def forbidden_atom(rule: Rule) -> str | None:
    """The atom `rule` forbids outright (`G !a`, as `affordance_rule` writes it), or None."""
    if len(rule.atoms) == 1 and rule.formula.replace(" ", "") == f"G!{rule.atoms[0]}":
        return rule.atoms[0]
    return None


def guarded(rule: Rule) -> Rule:
    """`rule` where it applies, as a formula over any sequence: `(F a & F b) -> φ`.

    `rules_for` applies a rule to a sequence only when all its atoms occur in it; the guarded
    rule holds on every sequence on which the rule either does not apply or holds, so the
    conjunction of a knowledge base's guarded rules is the checker's verdict as one formula,
    the same for every sequence and known before any prediction. A one-atom rule's guard adds
    nothing where the rule forbids its atom (`F a -> G !a` is `G !a`), and is left out then.
    """
    formula = rule.formula
    if rule.atoms and forbidden_atom(rule) is None:
        formula = f"({' & '.join(f'F {a}' for a in rule.atoms)}) -> ({rule.formula})"
    return Rule(f"guarded.{rule.name}", rule.kind, formula, rule.atoms)


def ingredient_of(atom: str) -> str:
    """The ingredient of a pair atom `action_ingredient` (actions have no `_`)."""
    return atom.split("_", 1)[-1]


def by_ingredient(rules: Sequence[Rule]) -> list[list[Rule]]:
    """`rules` grouped by the ingredients their atoms (`action_ingredient`) name, groups sorted.

    Every affordance and ordering rule is about one ingredient, so a video's rule set splits into
    one conjunction per ingredient over disjoint atoms: φ = ∧_x φ_x, each φ_x far smaller than φ
    (the cooking experiment's "related clauses for the current ingredient"). A rule naming
    several ingredients stays in one group keyed by all of them.
    """
    groups: dict[tuple[str, ...], list[Rule]] = {}
    for r in rules:
        key = tuple(sorted({ingredient_of(a) for a in r.atoms}))
        groups.setdefault(key, []).append(r)
    return [groups[k] for k in sorted(groups)]


def sample_formula(rules: Sequence[Rule]) -> str:
    """The conjunction of the rules, each parenthesised; `true` when there are none."""
    if not rules:
        return "true"
    return " & ".join(f"({r.formula})" for r in rules)


def rule_set_id(rules: Iterable[Rule]) -> str:
    """A stable short id of a set of rules: a hash of their sorted names (`rs-` + 12 hex)."""
    names = "\n".join(sorted({r.name for r in rules}))
    return "rs-" + hashlib.sha256(names.encode()).hexdigest()[:12]


def read_knowledge_base(path: str | os.PathLike) -> KnowledgeBase:
    """Rules from a `.ltl` file; InputError naming the file and line of the first bad rule."""
    rules = []
    for src in read_formulas(path):
        where = f"{src.path}: {src.location}"
        if src.problem is not None:
            raise InputError(f"{src.path}: {src.located(src.problem)}")
        kind, _, rest = src.formula_id.partition(".")
        if kind not in RULE_KINDS or not rest:
            raise InputError(
                f"{where}: rule '{src.formula_id}' needs a name 'affordance.<rest>' or "
                "'ordering.<rest>' (the kind of rule)"
            )
        try:
            formula = parse(src.text)
        except FormulaSyntaxError as e:
            raise InputError(f"{src.path}: {src.located(e.message, e.column)}") from None
        rules.append(Rule(src.formula_id, kind, src.text, atoms(formula)))  # type: ignore[arg-type]
    return KnowledgeBase(tuple(rules))


def write_knowledge_base(
    kb: KnowledgeBase, path: str | os.PathLike, header: Sequence[str] = ()
) -> None:
    """Write `kb` as a `.ltl` file (atomically), `header` lines as comments on top."""
    check_names((r.name for r in kb.rules), "rule name")
    lines = [f"# {h}" for h in header]
    lines += [f"{r.name}: {r.formula}" for r in kb.rules]
    write_text_atomic(path, "\n".join(lines) + "\n")


def mine_knowledge_base(
    sequences: Iterable[Sequence[tuple[str, str]]],
    vocabulary: tuple[Sequence[str], Sequence[str]],
    min_support: int,
) -> KnowledgeBase:
    """Rules that the labelled `sequences` of (action, ingredient) pairs never break.

    Affordances: every (action, ingredient) of the `vocabulary` (actions, ingredients) whose
    action and ingredient were each seen but never together. Orderings: for two actions on the
    same ingredient, "a before b" (first a before first b, what the formula says) when at least
    `min_support` sequences contain both, a first, and none contains both with b first.
    Rules come in vocabulary order: affordances, then orderings by ingredient, a, b.
    ArgumentError / ArgumentTypeError naming the argument for a value of another shape (atom
    strings instead of pairs, a support that is not an int ≥ 1); InputError for a pair outside
    the vocabulary.
    """
    check.count(min_support, "min_support", 1)
    actions, ingredients = _vocabulary(vocabulary)
    if isinstance(sequences, str | bytes) or not isinstance(sequences, Iterable):
        raise ArgumentTypeError(
            "sequences", f"must be sequences of (action, ingredient) pairs, not {given(sequences)}"
        )
    a_rank = {a: k for k, a in enumerate(actions)}
    i_rank = {i: k for k, i in enumerate(ingredients)}
    seen_pairs: set[tuple[str, str]] = set()
    before: Counter[tuple[str, str, str]] = Counter()  # (ingredient, a, b): sequences, a first
    for s, sequence in enumerate(sequences):
        first: dict[tuple[str, str], int] = {}
        if isinstance(sequence, str | bytes) or not isinstance(sequence, Iterable):
            raise ArgumentTypeError(
                f"sequences[{s}]", f"must be a sequence of pairs, not {given(sequence)}"
            )
        for t, pair in enumerate(sequence):
            if type(pair) not in (tuple, list) or len(pair) != 2:
                raise ArgumentTypeError(
                    f"sequences[{s}][{t}]",
                    f"must be an (action, ingredient) pair, not {given(pair)}",
                )
            a, i = pair
            if a not in a_rank or i not in i_rank:
                raise InputError(f"pair ({a}, {i}) is outside the vocabulary")
            first.setdefault((i, a), t)
        seen_pairs.update((a, i) for i, a in first)
        for (i, a), ta in first.items():
            for (j, b), tb in first.items():
                if i == j and ta < tb:
                    before[(i, a, b)] += 1
    seen_actions = {a for a, _ in seen_pairs}
    seen_ingredients = {i for _, i in seen_pairs}
    rules = [
        affordance_rule(a, i)
        for a in actions
        for i in ingredients
        if a in seen_actions and i in seen_ingredients and (a, i) not in seen_pairs
    ]
    orderings = [
        key
        for key, n in before.items()
        if n >= min_support and (key[0], key[2], key[1]) not in before
    ]
    orderings.sort(key=lambda k: (i_rank[k[0]], a_rank[k[1]], a_rank[k[2]]))
    rules += [ordering_rule(i, a, b) for i, a, b in orderings]
    return KnowledgeBase(tuple(rules))


def _vocabulary(value: object) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """`mine_knowledge_base`'s vocabulary: (actions, ingredients), two collections of names."""
    if isinstance(value, str | bytes) or not isinstance(value, Sequence) or len(value) != 2:
        raise ArgumentTypeError(
            "vocabulary", f"must be (actions, ingredients), two lists of names, not {given(value)}"
        )
    actions = check.names(value[0], "vocabulary", "action names (str) first")
    ingredients = check.names(value[1], "vocabulary", "ingredient names (str) second")
    return actions, ingredients
