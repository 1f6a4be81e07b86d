"""Rule sets: a conjunction of LTLf formulas as one DFA over a model's one-hot vocabulary.

A model outputs, at every step, a distribution over a **vocabulary** of atom names (actions,
(action, ingredient) pairs, ...): exactly one item per step. `RuleSet(formulas, vocabulary)`
compiles each formula over the one-hot alphabet of its atoms, conjoins them as a product of DFAs
(minimised) and records where each of the DFA's atoms sits in the vocabulary:

    letter 0      "none of the DFA's atoms" — every vocabulary item the formulas do not mention;
    letter k + 1  dfa.atoms[k], vocabulary position index[k].

Each formula is compiled once per process, in-process by formula progression (no MONA needed),
or by compile-dfa's stage past progression's limits (MONA, once per machine through its disk
cache); a rule set is then a product of small DFAs, without a compilation per conjunction.
Formulas that share no atoms with the rest form their own groups (a knowledge base's rules about
one ingredient), and each group's product is kept: rule sets derived from a model's predictions
every batch differ in a group or two, and rebuild only the product of the groups. The result is
the same DFA whatever the order of the products (minimal and canonically numbered).
`tleaf_cli.knowledge.rule_sets.KnowledgeRuleSets` picks, from a knowledge base, the rule set of a
video (the rules whose atoms all occur in it, the paper's extraction) and builds each distinct
set once.

No torch here: the losses (tleaf_cli/losses/) turn rule sets into tensors.
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Iterable, Sequence
from dataclasses import replace

import numpy as np

from tleaf_cli import arguments
from tleaf_cli.data.compile_dfas import CompileSettings, compile_sources
from tleaf_cli.data.dfa_table import dfa_from_row
from tleaf_cli.data.formula_files import FormulaSource
from tleaf_cli.errors import ArgumentError, InputError, TleafError
from tleaf_cli.logic.alphabet import Alphabet
from tleaf_cli.logic.compile import by_progression
from tleaf_cli.logic.conjunction import conjoin_nonempty
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.formulas import atoms as formula_atoms
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.kept import Kept

_COMPILED: dict[tuple[str, float], DFA] = {}  # (formula text, timeout) -> one-hot DFA


def compile_rules(formulas: Iterable[str], settings: CompileSettings | None = None) -> None:
    """Compile the formulas not compiled yet in this process, so later `RuleSet`s only look
    them up: in-process by formula progression where the engine (`settings.engine`) takes
    that route — it needs no MONA — and the others in one batch through compile-dfa's stage
    (parallel with `settings.jobs`, through the disk cache; MONA past progression's limits).

    Raises InputError naming the first formula that does not compile.
    """
    settings = replace(settings or CompileSettings(), alphabet="one-hot")
    fresh = list(dict.fromkeys(f for f in formulas if (f, settings.timeout) not in _COMPILED))
    for text in fresh:
        dfa = _in_process(text, settings.engine)
        if dfa is not None:
            _COMPILED[(text, settings.timeout)] = dfa
    fresh = [f for f in fresh if (f, settings.timeout) not in _COMPILED]
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
    vocabulary; ArgumentError (ArgumentTypeError) for formulas that are not strs and for a
    vocabulary with a repeated item or an item that can never be an atom.
    """

    def __init__(
        self,
        formulas: str | Sequence[str],
        vocabulary: Sequence[str],
        name: str | None = None,
        compile_settings: CompileSettings | None = None,
    ) -> None:
        if isinstance(formulas, str):
            formulas = [formulas]
        self.formulas = tuple(arguments.sequence(formulas, "formulas", "LTLf formulas (str)"))
        for i, f in enumerate(self.formulas):
            arguments.text(f, f"formulas[{i}]")
        if not self.formulas:
            raise ArgumentError("formulas", "is empty: a rule set needs at least one formula")
        self.vocabulary = arguments.vocabulary(vocabulary)
        self.name = name or "rs-" + _digest(sorted(self.formulas))
        self.formula = " & ".join(f"({f})" for f in self.formulas)
        compile_rules(self.formulas, compile_settings)
        timeout = (compile_settings or CompileSettings()).timeout
        self._finish(_conjunction(self.formulas, timeout))

    @classmethod
    def _of_dfa(cls, formulas: Sequence[str], vocabulary: Sequence[str], dfa: DFA, name: str):
        """The rule set of compiled `formulas` whose conjunction `dfa` (minimal for non-empty
        traces) is already built: `rule_parts`' parts, not conjoined a second time."""
        self = cls.__new__(cls)
        self.formulas = tuple(formulas)
        self.vocabulary = arguments.vocabulary(vocabulary)
        self.name = name
        self.formula = " & ".join(f"({f})" for f in self.formulas)
        self._finish(dfa)
        return self

    def _finish(self, dfa: DFA) -> None:
        """Sets the DFA and where its atoms sit in the vocabulary."""
        self.dfa = dfa
        position = _positions(self.vocabulary)
        missing = [a for a in self.dfa.atoms if a not in position]
        if missing:
            raise InputError(
                f"rule set {self.name}: atoms {', '.join(missing)} are not in the vocabulary "
                f"({len(self.vocabulary)} items)"
            )
        self.index = np.array([position[a] for a in self.dfa.atoms], dtype=np.int64)
        # minimal for non-empty traces: an accepting state exactly when a non-empty trace is
        # accepted (an empty language is one rejecting state), the same as
        # dfa.alive_letters(dfa.initial).any() without its numpy passes
        self.satisfiable = bool(self.dfa.accepting.any())

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


def common_vocabulary(rule_sets: Iterable[RuleSet]) -> tuple[str, ...] | None:
    """The one vocabulary every rule set of `rule_sets` is over (None when there are none).

    Rule sets read together (a shield's, a batch's in the losses and the decoder) must agree
    item by item: letter k + 1 of each is the item at its `index[k]`, so two vocabularies of the
    same size but in another order would read a model's outputs as other actions, silently.
    Raises ArgumentError on `rules` naming the first rule set that differs, and where.
    """
    first: RuleSet | None = None
    for r in rule_sets:
        if first is None:
            first = r
        elif r.vocabulary is not first.vocabulary and r.vocabulary != first.vocabulary:
            raise ArgumentError(
                "rules",
                f"rule set {r.name} is not over the same vocabulary as rule set {first.name} "
                f"({_first_difference(first.vocabulary, r.vocabulary)})",
            )
    return None if first is None else first.vocabulary


PART_STATES = 512
"""`rule_parts`' default bound on a part's states: a DFA this size costs the exact loss and the
suffix search little, and every knowledge base of the event-log pipeline whose conjunction
compiles at all stays one part."""


def rule_parts(
    formulas: Sequence[str],
    vocabulary: Sequence[str],
    max_states: int = PART_STATES,
    name: str | None = None,
    compile_settings: CompileSettings | None = None,
) -> tuple[RuleSet, ...]:
    """The conjunction of `formulas` as a few rule sets, its **parts**, each a DFA of at most
    `max_states` states: a word satisfies the formulas exactly when every part accepts it.

    For knowledge bases whose conjunction is too large for one DFA: thousands of Declare
    constraints mined over hundreds of activities, where every activity a precedence rule still
    waits for doubles the product. Greedy first fit: the formulas, sorted by their atoms (rules
    over the same activities side by side: they often share the product's states), each go to
    the first part whose minimal DFA keeps at most `max_states` states with it, or open a new
    part. A formula larger than `max_states` on its own is a part of its own. (On env_permit's
    2,326 mined rules over 381 activities: 11 parts of at most 512 states, in about 40 s; a
    part per run of consecutive rules instead gave 175.) A knowledge base whose conjunction,
    and each conjunction on the way to it, fits is one part: the DFA `RuleSet` builds.

    What parts lose against one DFA: a state of each part can be live while their conjunction is
    dead (two parts' rules contradict each other later on), so checks that read `DFA.live()`
    per part (constrained decoding, a search's pruning) are sound but not complete.

    Args as `RuleSet`'s; parts are named "`name` part k" (k from 1).
    Raises as `RuleSet`, and ArgumentError for `max_states` below 2.
    """
    if isinstance(formulas, str):
        formulas = [formulas]
    formulas = tuple(arguments.sequence(formulas, "formulas", "LTLf formulas (str)"))
    for i, f in enumerate(formulas):
        arguments.text(f, f"formulas[{i}]")
    if not formulas:
        raise ArgumentError("formulas", "is empty: a rule set needs at least one formula")
    if isinstance(max_states, bool) or not isinstance(max_states, int) or max_states < 2:
        raise ArgumentError("max_states", f"must be an int >= 2, not {max_states!r}")
    vocabulary = arguments.vocabulary(vocabulary)
    name = name or "rs-" + _digest(sorted(formulas))
    compile_rules(formulas, compile_settings)
    timeout = (compile_settings or CompileSettings()).timeout
    parts: list[tuple[list[str], DFA]] = []  # (formulas, their conjunction), first fit
    for formula in sorted(dict.fromkeys(formulas), key=lambda f: (_atoms(f, timeout), f)):
        own = _COMPILED[(formula, timeout)]
        for k, (members, dfa) in enumerate(parts):
            joined = dfa.product(own)
            if joined.num_states <= max_states:
                parts[k] = ([*members, formula], joined)
                break
        else:
            parts.append(([formula], own))
    return tuple(
        RuleSet._of_dfa(texts, vocabulary, part.minimize_nonempty(minimal=True), f"{name} part {k}")
        for k, (texts, part) in enumerate(parts, 1)
    )


def _atoms(formula: str, timeout: float) -> tuple[str, ...]:
    return tuple(sorted(_COMPILED[(formula, timeout)].atoms))


def _first_difference(a: Sequence[str], b: Sequence[str]) -> str:
    """Where vocabulary `b` first departs from `a`, in words."""
    if len(a) != len(b):
        return f"{len(b)} items, not {len(a)}"
    k = next(i for i, (x, y) in enumerate(zip(a, b, strict=True)) if x != y)
    return f"its item {k} is {b[k]!r}, not {a[k]!r}"


def _in_process(text: str, engine: str) -> DFA | None:
    """The one-hot DFA of `text` by the compile stage's first route, formula progression
    (`logic.compile.by_progression`: the same DFA as the stage's); None where the stage must
    take it (a syntax error to report, or MONA's turn)."""
    try:
        formula = parse(text)
        Alphabet(formula_atoms(formula), "one-hot")
        return by_progression(formula, "one-hot", engine)
    except TleafError:  # a syntax error, or past progression's limits (TooLarge)
        return None


def _conjunction(formulas: Sequence[str], timeout: float) -> DFA:
    """The minimal DFA (for non-empty traces) of the conjunction of compiled `formulas`: the
    product of the groups of formulas connected by shared atoms, each group's DFA kept. The
    groups share no atoms, so their product is one walk (`conjunction.conjoin_nonempty`)."""
    parts = _connected(formulas, timeout)
    return conjoin_nonempty([_group(part, timeout) for part in sorted(parts, key=sorted)])


def _connected(formulas: Sequence[str], timeout: float) -> list[frozenset[str]]:
    """The compiled `formulas` in groups connected by shared atoms (union-find over their
    atoms); the formulas without atoms, if any, are one more group."""
    group_of: dict[str, int] = {}  # atom -> its group
    groups: list[set[str]] = []  # formulas per group
    atomless: set[str] = set()
    for formula in dict.fromkeys(formulas):
        atoms = _COMPILED[(formula, timeout)].atoms
        joined = sorted({group_of[a] for a in atoms if a in group_of})
        if not atoms:
            atomless.add(formula)
            continue
        if not joined:
            groups.append(set())
            joined = [len(groups) - 1]
        keep = joined[0]
        for other in joined[1:]:
            groups[keep] |= groups[other]
            for a, g in group_of.items():
                if g == other:
                    group_of[a] = keep
            groups[other] = set()
        groups[keep].add(formula)
        for a in atoms:
            group_of[a] = keep
    return [frozenset(g) for g in groups if g] + ([frozenset(atomless)] if atomless else [])


@functools.lru_cache(maxsize=8192)
def _group(formulas: frozenset[str], timeout: float) -> DFA:
    """The minimal DFA of the conjunction of compiled `formulas` (the empty word included).
    Its table depends on the formulas' automata and on where each one's atoms sit among the
    group's, not on the atoms' names: kept under that key (`_GROUPS`), so the same rules over
    another ingredient are a copy, not a chain of products."""
    dfas = [_COMPILED[(formula, timeout)] for formula in sorted(formulas)]
    if len(dfas) == 1:
        return dfas[0].minimize()
    union = sorted(set().union(*(d.atoms for d in dfas)))
    where = {a: k for k, a in enumerate(union)}
    key = (tuple(d.structure for d in dfas), tuple(tuple(where[a] for a in d.atoms) for d in dfas))
    kept = _GROUPS.get(key)
    if kept is None:
        dfa = dfas[0]
        for other in dfas[1:]:
            dfa = dfa.product(other, canonical=False)
        dfa = dfa.minimize()
        _GROUPS.keep(key, (dfa.table.copy(), dfa.initial, dfa.accepting.copy()))
        return dfa
    table, initial, accepting = kept
    alphabet = Alphabet(tuple(union), dfas[0].alphabet.kind)
    return DFA(alphabet, table.copy(), initial, accepting.copy())


_GROUPS = Kept(8192)  # `_group`'s products per (automata, atom layout): table, initial, accepting


@functools.lru_cache(maxsize=16)
def _positions(vocabulary: tuple[str, ...]) -> dict[str, int]:
    """Item -> its position in `vocabulary` (read only): built once per vocabulary, not once per
    rule set (a trainer builds every rule set of a run over the same few hundred items)."""
    return {item: i for i, item in enumerate(vocabulary)}


def _digest(texts: Iterable[str]) -> str:
    return hashlib.sha256("\n".join(texts).encode()).hexdigest()[:12]
