"""Rule sets: a conjunction of LTLf formulas as one DFA over a model's one-hot vocabulary.

A model outputs, at every step, a distribution over a **vocabulary** of atom names (actions,
(action, ingredient) pairs, ...): exactly one item per step. `RuleSet(formulas, vocabulary)`
compiles each formula over the one-hot alphabet of its atoms, conjoins them as a product of DFAs
(minimised) and records where each of the DFA's atoms sits in the vocabulary:

    letter 0      "none of the DFA's atoms" — every vocabulary item the formulas do not mention;
    letter k + 1  dfa.atoms[k], vocabulary position index[k].

Each formula is compiled by MONA once per process (and once per machine, through compile-dfa's
disk cache); a rule set is then a product of small DFAs, without a MONA call per conjunction.
`KnowledgeRuleSets` picks, from a knowledge base, the rule set of a video (the rules whose atoms
all occur in it, the paper's extraction) and builds each distinct set once.

No torch here: the losses (tleaf_cli/losses/) turn rule sets into tensors.
"""

from __future__ import annotations

import hashlib
from collections.abc import Collection, Iterable, Sequence
from dataclasses import replace

import numpy as np

from tleaf_cli.data.compile_dfas import CompileSettings, compile_sources
from tleaf_cli.data.dfa_table import dfa_from_row
from tleaf_cli.data.formula_files import FormulaSource
from tleaf_cli.data.knowledge import (
    KnowledgeBase,
    Rule,
    by_ingredient,
    rule_set_id,
    rules_for,
    sample_formula,
)
from tleaf_cli.errors import InputError
from tleaf_cli.logic.dfa import DFA

_COMPILED: dict[tuple[str, float], DFA] = {}  # (formula text, timeout) -> one-hot DFA


def compile_rules(formulas: Iterable[str], settings: CompileSettings | None = None) -> None:
    """Compile the formulas not compiled yet in this process, in one batch (parallel with
    `settings.jobs`, through the disk cache), so later `RuleSet`s only look them up.

    Raises InputError naming the first formula that does not compile.
    """
    settings = replace(settings or CompileSettings(), alphabet="one-hot")
    fresh = list(dict.fromkeys(f for f in formulas if (f, settings.timeout) not in _COMPILED))
    if not fresh:
        return
    sources = [FormulaSource(f"rule {i}", f, "rules", f"rule {f!r}") for i, f in enumerate(fresh)]
    report = compile_sources(sources, settings)
    for text, row in zip(fresh, report.rows, strict=True):
        if row["error"] is not None:
            raise InputError(row["error"])  # "rule '<text>'[, column c]: what is wrong"
        _COMPILED[(text, settings.timeout)] = dfa_from_row(row)


class RuleSet:
    """The conjunction of `formulas` as one minimal DFA over the one-hot `vocabulary`.

    Args:
        formulas: one LTLf formula or several (their conjunction); every atom they mention must
            be an item of `vocabulary`.
        vocabulary: the model's output items, in the order of its last dimension.
        name: an id for reports and caches; default a hash of the sorted formulas.
        compile_settings: MONA timeout, cache folder, parallel jobs (the alphabet is one-hot,
            whatever the settings say).

    Attributes: `dfa` (letter 0 = none of its atoms, letter k+1 = `dfa.atoms[k]`), `index`
    (int64 [k], vocabulary position of each atom), `satisfiable` (some non-empty sequence is
    accepted), `formula` (the conjunction as one text, for embedders that read formulas).

    Raises InputError for a formula that does not compile or names an atom outside the
    vocabulary.
    """

    def __init__(
        self,
        formulas: str | Sequence[str],
        vocabulary: Sequence[str],
        name: str | None = None,
        compile_settings: CompileSettings | None = None,
    ) -> None:
        self.formulas = (formulas,) if isinstance(formulas, str) else tuple(formulas)
        if not self.formulas:
            raise InputError("a rule set needs at least one formula")
        self.vocabulary = tuple(vocabulary)
        self.name = name or "rs-" + _digest(sorted(self.formulas))
        self.formula = " & ".join(f"({f})" for f in self.formulas)
        compile_rules(self.formulas, compile_settings)
        timeout = (compile_settings or CompileSettings()).timeout
        dfa = _COMPILED[(self.formulas[0], timeout)]
        for formula in self.formulas[1:]:
            dfa = dfa.intersect(_COMPILED[(formula, timeout)])
        self.dfa = dfa.minimize_nonempty()
        position = {item: i for i, item in enumerate(self.vocabulary)}
        missing = [a for a in self.dfa.atoms if a not in position]
        if missing:
            raise InputError(
                f"rule set {self.name}: atoms {', '.join(missing)} are not in the vocabulary "
                f"({len(self.vocabulary)} items)"
            )
        self.index = np.array([position[a] for a in self.dfa.atoms], dtype=np.int64)
        self.satisfiable = bool(self.dfa.alive_letters(self.dfa.initial).any())

    @property
    def atoms(self) -> tuple[str, ...]:
        return self.dfa.atoms

    def letters(self, sequences: np.ndarray) -> np.ndarray:
        """The DFA's letters of vocabulary-index sequences (any shape): k+1 for atoms[k], else 0."""
        code = np.zeros(len(self.vocabulary), dtype=np.int64)
        code[self.index] = np.arange(1, len(self.index) + 1)
        return code[np.asarray(sequences, dtype=np.int64)]

    def __repr__(self) -> str:
        return (
            f"RuleSet({self.name}, {len(self.formulas)} formula(s), {self.dfa.num_states} states, "
            f"atoms {list(self.atoms)})"
        )


def _digest(texts: Iterable[str]) -> str:
    return hashlib.sha256("\n".join(texts).encode()).hexdigest()[:12]


class KnowledgeRuleSets:
    """The rule sets a knowledge base gives sequences, each distinct set built once.

    A sequence's rule set is the conjunction of the rules whose atoms all occur among its atoms
    (`knowledge.rules_for`); with `per_ingredient`, one conjunction per ingredient
    (`knowledge.by_ingredient`). With `known` (the atoms an embedder can read), rules naming other
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

    @property
    def compiled(self) -> int:
        """Distinct rule sets built so far."""
        return len(self.by_id)

    def prepare(self) -> None:
        """Compile every rule of the knowledge base now (in one batch)."""
        compile_rules([r.formula for r in self.kb], self.settings)

    def rules(self, present_atoms: Collection[str]) -> list[Rule]:
        """The KB rules whose atoms all occur in `present_atoms` (and that q can read)."""
        rules = rules_for(self.kb, present_atoms)
        if self.known is None:
            return rules
        kept = [r for r in rules if set(r.atoms) <= self.known]
        self.skipped_rules += len(rules) - len(kept)
        return kept

    def for_atoms(
        self, atoms_per_sequence: Sequence[Collection[str]], per_ingredient: bool = False
    ) -> list[list[RuleSet]]:
        """Each sequence's rule sets: one (the whole set) or one per ingredient; [] where no rule
        applies."""
        groups = []
        for present in atoms_per_sequence:
            rules = self.rules(present)
            groups.append([g for g in (by_ingredient(rules) if per_ingredient else [rules]) if g])
        keyed = [[(rule_set_id(g), g) for g in gs] for gs in groups]
        fresh = [r.formula for ks in keyed for rid, g in ks if rid not in self.by_id for r in g]
        compile_rules(fresh, self.settings)  # one batch for every rule of the new sets
        return [[self._named(rid, g) for rid, g in ks] for ks in keyed]

    def one_each(self, atoms_per_sequence: Sequence[Collection[str]]) -> list[RuleSet | None]:
        """Each sequence's whole rule set (None where no rule applies)."""
        return [g[0] if g else None for g in self.for_atoms(atoms_per_sequence)]

    def rule_set(self, rules: Sequence[Rule]) -> RuleSet:
        """The rule set of `rules` (built on first sight, named by `knowledge.rule_set_id`)."""
        return self._named(rule_set_id(rules), rules)

    def _named(self, rid: str, rules: Sequence[Rule]) -> RuleSet:
        if rid not in self.by_id:
            ordered = sorted(rules, key=lambda r: r.name)
            rule_set = RuleSet([r.formula for r in ordered], self.vocabulary, rid, self.settings)
            rule_set.formula = sample_formula(rules)  # the text kb-extract writes for this set
            self.by_id[rid] = rule_set
        return self.by_id[rid]
