"""Rule sets drawn from a knowledge base: each sequence's rules as one `RuleSet`, built once.

A sequence's rule set is the conjunction of the knowledge-base rules whose atoms all occur among
its atoms (the paper's extraction, `base.rules_for`); sequences with the same rules share one
`RuleSet`, named by `base.rule_set_id`. The rules (and rule sets) of a set of atoms are
kept by that set: a trainer that derives them from a model's predictions every batch sees the
same atom sets again and again. No torch here.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence

from tleaf_cli.data.compile_dfas import CompileSettings
from tleaf_cli.knowledge.base import (
    KnowledgeBase,
    Rule,
    by_ingredient,
    guarded,
    rule_set_id,
    rules_for,
    sample_formula,
)
from tleaf_cli.rule_set import RuleSet, compile_rules


class KnowledgeRuleSets:
    """The rule sets a knowledge base gives sequences, each distinct set built once.

    A sequence's rule set is the conjunction of the rules whose atoms all occur among its atoms
    (`base.rules_for`); with `per_ingredient`, one conjunction per ingredient
    (`base.by_ingredient`). With `known` (the atoms an embedder can read), rules naming other
    atoms are left out; `skipped_rules` counts how often. The rules of each call's fresh sets are
    compiled in one batch; `prepare()` compiles every rule up front (before training, so that
    epochs do not pay for it).
    """

    def __init__(
        self,
        kb: KnowledgeBase,
        vocabulary: Sequence[str],
        known: Collection[str] | None = None,
        compile_settings: CompileSettings | None = None,
    ) -> None:
        self.kb = kb
        self.vocabulary = tuple(vocabulary)
        self.known = None if known is None else set(known)
        self.settings = compile_settings or CompileSettings(alphabet="one-hot")
        self.by_id: dict[str, RuleSet] = {}
        self.skipped_rules = 0
        # atoms -> (the rules, how many were left out as unknown to q): `rules` is a function
        # of the atom set, and skipped_rules counts every call as if it were recomputed
        self._rules: dict[frozenset[str], tuple[list[Rule], int]] = {}
        self._sets: dict[tuple[frozenset[str], bool], list[RuleSet]] = {}  # atoms -> rule sets
        self._whole: list[RuleSet] | None = None  # the guarded knowledge base (`whole`)

    @property
    def compiled(self) -> int:
        """Distinct rule sets built so far."""
        return len(self.by_id)

    def prepare(self) -> None:
        """Compile every rule of the knowledge base now (in one batch)."""
        compile_rules([r.formula for r in self.kb], self.settings)

    def rules(self, present_atoms: Collection[str]) -> list[Rule]:
        """The KB rules whose atoms all occur in `present_atoms` (and that q can read)."""
        kept, skipped = self._rules_of(frozenset(present_atoms))
        self.skipped_rules += skipped
        return list(kept)

    def _rules_of(self, present: frozenset[str]) -> tuple[list[Rule], int]:
        """`rules` of an atom set, and how many rules q could not read; computed once."""
        if present not in self._rules:
            rules = rules_for(self.kb, present)
            kept = rules if self.known is None else [r for r in rules if set(r.atoms) <= self.known]
            self._rules[present] = (kept, len(rules) - len(kept))
        return self._rules[present]

    def for_atoms(
        self, atoms_per_sequence: Sequence[Collection[str]], per_ingredient: bool = False
    ) -> list[list[RuleSet]]:
        """Each sequence's rule sets: one (the whole set) or one per ingredient; [] where no rule
        applies. Kept per (atom set, per_ingredient): the same atoms give the same sets."""
        keys = [(frozenset(present), per_ingredient) for present in atoms_per_sequence]
        new = list(dict.fromkeys(k for k in keys if k not in self._sets))
        groups = []
        for present, _ in new:
            rules = self._rules_of(present)[0]
            groups.append([g for g in (by_ingredient(rules) if per_ingredient else [rules]) if g])
        keyed = [[(rule_set_id(g), g) for g in gs] for gs in groups]
        fresh = [r.formula for ks in keyed for rid, g in ks if rid not in self.by_id for r in g]
        compile_rules(fresh, self.settings)  # one batch for every rule of the new sets
        for key, ks in zip(new, keyed, strict=True):
            self._sets[key] = [self._named(rid, g) for rid, g in ks]
        self.skipped_rules += sum(self._rules[present][1] for present, _ in keys)
        return [list(self._sets[k]) for k in keys]

    def whole(self) -> list[RuleSet]:
        """The whole knowledge base as rule sets, the same for every sequence: its rules guarded
        (`base.guarded`: each holds where its atoms do not all occur), one conjunction per
        ingredient (`base.by_ingredient`; the whole base as one DFA would be the product of
        them all). A sequence meets every set exactly when the checker finds no violation in
        it, so a loss on these sets needs no guess of which rules apply. With `known`, the
        rules q cannot read are left out. Built once."""
        if self._whole is None:
            rules = [guarded(r) for r in self.kb]
            if self.known is not None:
                rules = [r for r in rules if set(r.atoms) <= self.known]
            compile_rules([r.formula for r in rules], self.settings)
            self._whole = [self.rule_set(g) for g in by_ingredient(rules) if g]
        return list(self._whole)

    def one_each(self, atoms_per_sequence: Sequence[Collection[str]]) -> list[RuleSet | None]:
        """Each sequence's whole rule set (None where no rule applies)."""
        return [g[0] if g else None for g in self.for_atoms(atoms_per_sequence)]

    def rule_set(self, rules: Sequence[Rule]) -> RuleSet:
        """The rule set of `rules` (built on first sight, named by `base.rule_set_id`)."""
        return self._named(rule_set_id(rules), rules)

    def _named(self, rid: str, rules: Sequence[Rule]) -> RuleSet:
        if rid not in self.by_id:
            ordered = sorted(rules, key=lambda r: r.name)
            rule_set = RuleSet([r.formula for r in ordered], self.vocabulary, rid, self.settings)
            rule_set.formula = sample_formula(rules)  # the text kb-extract writes for this set
            self.by_id[rid] = rule_set
        return self.by_id[rid]
