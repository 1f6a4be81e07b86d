"""The rules a next-activity run or its evaluation uses: formulas of a `.ltl` file (mined
Declare constraints, a peer's a-priori formula) or the constraints of a `.decl` Declare model
(its activity names matched to the log's exactly, `knowledge/rule_files.py`), some or all of
them, conjoined over the model's
activities — as one DFA, or, for a knowledge base too large for one (thousands of rules mined
over hundreds of activities), as a few DFAs, its parts (`tleaf_cli.rule_set.rule_parts`): a
case keeps the rules when every part accepts it."""

from __future__ import annotations

import functools
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from tleaf_cli.data.formula_files import FormulaSource
from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.rule_files import read_rule_file
from tleaf_cli.logic.formulas import FormulaSyntaxError, atoms, parse
from tleaf_cli.losses import violates
from tleaf_cli.rule_set import PART_STATES, RuleSet, rule_parts


@dataclass(frozen=True)
class Rules:
    """The chosen rules' names and their conjunction over the model's vocabulary, in `parts`
    (one part unless the conjunction is larger than `read_rules`' `max_states`)."""

    path: str
    names: tuple[str, ...]
    parts: tuple[RuleSet, ...]
    unseen: dict[str, tuple[str, ...]] = field(default_factory=dict)  # rule -> activities
    # it names that the model does not know (read as never happening)

    @property
    def atoms(self) -> set[str]:
        return {a for part in self.parts for a in part.atoms}

    @property
    def states(self) -> list[int]:
        """Each part's DFA states."""
        return [part.dfa.num_states for part in self.parts]

    @functools.cached_property
    def lives(self) -> tuple[np.ndarray, ...]:
        """Each part's `DFA.live()`, computed once."""
        return tuple(part.dfa.live() for part in self.parts)

    @functools.cached_property
    def following(self) -> tuple[np.ndarray, ...]:
        """Each part's state after each activity, int [S_k, V], computed once."""
        return tuple(
            part.dfa.table[:, part.letters(np.arange(len(part.vocabulary)))] for part in self.parts
        )

    def satisfiable(self, limit: int = 100_000) -> bool | None:
        """Whether some case (one activity or more) satisfies every part: a search of the
        parts' product from their initial states, through states live in every part, to one
        every part accepts. None where it passes `limit` product states undecided."""
        start = tuple(part.dfa.initial for part in self.parts)
        if not all(live[s] for live, s in zip(self.lives, start, strict=True)):
            return False
        accepting = [part.dfa.accepting for part in self.parts]
        seen, frontier = {start}, [start]
        while frontier:
            state = frontier.pop()
            ahead = [following[s] for following, s in zip(self.following, state, strict=True)]
            for nxt in zip(*(row.tolist() for row in ahead), strict=True):
                if not all(live[s] for live, s in zip(self.lives, nxt, strict=True)):
                    continue
                if all(acc[s] for acc, s in zip(accepting, nxt, strict=True)):
                    return True
                if nxt not in seen:
                    seen.add(nxt)
                    frontier.append(nxt)
                    if len(seen) > limit:
                        return None
        return False

    def broken(self, cases: Sequence[np.ndarray]) -> np.ndarray:
        """bool [n]: the cases (activity-index arrays) some part rejects."""
        out = np.zeros(len(cases), dtype=bool)
        for part in self.parts:
            out |= violates([part] * len(cases), cases)
        return out


def read_rules(
    path: str | os.PathLike,
    vocabulary: Sequence[str],
    names: Sequence[str] = (),
    max_states: int = PART_STATES,
    log_atoms: Mapping[str, str] | None = None,
) -> Rules:
    """The rules of `path` named in `names` (all without), conjoined over `vocabulary` in parts
    of at most `max_states` states; a `.decl`'s activities bound to atoms by the log's map
    `log_atoms` (activity name -> atom: the run's `Encoder.activities` and `.atoms`).

    An activity the model does not know (the log never has it) is read as never happening, and
    the rules naming it are listed in `Rules.unseen`, for the caller to report. Raises
    InputError naming the file and line of a formula that does not read, a name the file does
    not have, a rule on an attribute value, or rules that together accept no case."""
    sources = read_rule_file(path, log_atoms)
    for src in sources:
        if src.problem is not None:
            raise InputError(f"{src.path}: {src.located(src.problem)}")
        if src.conditions:
            read = sorted({a for t in src.conditions.values() for a in t.attributes})
            raise InputError(
                f"{src.path}: {src.location}: rule {src.formula_id} has an MP-Declare condition "
                f"on {', '.join(read)}: a model over activities cannot read it (a model that "
                "predicts the attribute can; or leave such rules out)"
            )
    if not sources:
        raise InputError(f"{path}: no rules in the file")
    chosen = sources
    if names:
        by_name = {s.formula_id: s for s in sources}
        unknown = [n for n in names if n not in by_name]
        if unknown:
            raise InputError(
                f"{path}: no rule named {', '.join(unknown)} (it has "
                f"{', '.join(list(by_name)[:8])}{', ...' if len(by_name) > 8 else ''})"
            )
        chosen = [by_name[n] for n in names]
    texts, unseen = [], {}
    for source in chosen:
        text, missing = _without_unknown(source, set(vocabulary))
        texts.append(text)
        if missing:
            unseen[source.formula_id] = missing
    try:
        parts = rule_parts(texts, list(vocabulary), max_states, name=os.fspath(path))
    except InputError as e:
        raise InputError(f"{path}: {e}") from None
    rules = Rules(os.fspath(path), tuple(s.formula_id for s in chosen), parts, unseen)
    if rules.satisfiable() is False:  # a loss of 0 and no decoding: knowledge that never applies
        raise InputError(
            f"{path}: its rules{' ' + ', '.join(names) if names else ''} together accept no "
            "case (unsatisfiable): no prediction could keep them"
        )
    return rules


def _without_unknown(source: FormulaSource, vocabulary: set[str]) -> tuple[str, tuple[str, ...]]:
    """The formula with each activity atom outside `vocabulary` read as `false` (an activity the
    log never has never happens: Not Co-Existence with it always holds, its Existence never),
    and those atoms; InputError naming the rule for an atom of an attribute value
    (`attribute_atom`'s double _), which a model over activities cannot read at all."""
    text = source.text
    try:
        named = atoms(parse(text))
    except FormulaSyntaxError:
        return text, ()  # rule_parts names the rule and what is wrong
    missing = tuple(a for a in named if a not in vocabulary)
    values = [a for a in missing if "__" in a]
    if values:
        raise InputError(
            f"{source.path}: {source.location}: rule {source.formula_id} names the attribute "
            f"value {values[0]}: a model over activities cannot read it (a model that predicts "
            "the attribute can, or leave such rules out)"
        )
    for atom in missing:
        text = re.sub(rf"(?<![A-Za-z0-9_]){re.escape(atom)}(?![A-Za-z0-9_])", "false", text)
    return text, missing


def allowed_next(rules: Rules, activities: np.ndarray) -> np.ndarray:
    """bool [n, V + 1]: after each prefix of `activities`, the tokens that keep the rules
    satisfiable — an activity after which every part's DFA state can still reach acceptance,
    the end where every part accepts the prefix. A prefix that already broke the rules (some
    part dead) allows every token. With one part, exactly the tokens that keep some completion
    accepted; with several, a token can pass whose parts' completions contradict each other."""
    n, v = len(activities), len(rules.parts[0].vocabulary)
    keep = np.ones(n, dtype=bool)  # every part live after the prefix
    tokens = np.ones((n, v + 1), dtype=bool)
    for part, live, following in zip(rules.parts, rules.lives, rules.following, strict=True):
        states = np.empty(n, dtype=np.int64)
        state = part.dfa.initial
        for t, a in enumerate(activities):
            state = int(following[state, a])
            states[t] = state
        keep &= live[states]
        tokens[:, :-1] &= live[following[states]]
        tokens[:, -1] &= part.dfa.accepting[states]
    tokens[~keep] = True
    return tokens
