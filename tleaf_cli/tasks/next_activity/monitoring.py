"""The rules a running case is watched by (`tleaf predict`, predict.py): each rule's own DFA
over the model's tokens and the verdict of each of its states (`logic/verdicts.py`), and the
probability that a rule holds when the case ends, estimated from completions sampled from the
model (`sample_holds`) with a Wilson score interval (`wilson`)."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from tleaf_cli.data.cases import Case
from tleaf_cli.errors import InputError
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.verdicts import state_verdicts
from tleaf_cli.tasks.case_checks import compile_rules, read_case_rules
from tleaf_cli.tasks.next_activity.joint_tokens import JointTokens
from tleaf_cli.tasks.next_activity.rule_automaton import RuleAutomaton
from tleaf_cli.tasks.next_activity.suffix_sampling import sample_suffixes
from tleaf_cli.tasks.next_activity.suffix_search import NextLogProbs, Rows

Z95 = 1.959963984540054  # the standard normal's 97.5 % quantile: a two-sided 95 % interval
SAMPLED_ROWS = 20_000  # sampled completions advanced together (bounds the model's output)


@dataclass(frozen=True)
class MonitoredRules:
    """The rules a predictor watches: each compiled alone (as check-cases compiles it), its
    state after each token, the verdict of each of its states, the condition tests its atoms
    stand for, and all of them as one automaton for the searches."""

    path: str
    names: tuple[str, ...]
    dfas: tuple[DFA, ...]
    tables: tuple[np.ndarray, ...]  # per rule: int64 [S_k, T], the state after each token
    verdicts: tuple[np.ndarray, ...]  # per rule: int8 [S_k], `state_verdicts`
    tests: Mapping[str, object]  # condition atom -> its test (`Case.letters(tests=...)`)
    automaton: RuleAutomaton  # every rule, over the tokens (the hard filter, the soft score)
    unseen: dict[str, tuple[str, ...]]  # rule -> atoms it names that no token has

    def states(self, case: Case) -> np.ndarray:
        """int64 [R]: each rule's DFA state after the case's events (their own letters)."""
        letters = case.letters(tests=self.tests)
        out = np.empty(len(self.dfas), dtype=np.int64)
        for k, dfa in enumerate(self.dfas):
            state = dfa.initial
            for letter in letters:
                state = int(dfa.table[state, dfa.alphabet.index(letter)])
            out[k] = state
        return out

    def accepted(self, starts: np.ndarray, tokens: np.ndarray) -> np.ndarray:
        """bool [M, R]: each rule accepts after continuing from `starts` [M, R] by the tokens
        [M, L] (−1: padding past a continuation's end)."""
        out = np.empty(starts.shape, dtype=bool)
        for k, (dfa, table) in enumerate(zip(self.dfas, self.tables, strict=True)):
            state = starts[:, k].copy()
            for t in range(tokens.shape[1]):
                moving = tokens[:, t] >= 0
                state[moving] = table[state[moving], tokens[moving, t]]
            out[:, k] = dfa.accepting[state]
        return out


def monitored_rules(
    path: str | os.PathLike, tokens: JointTokens, names: Sequence[str] = ()
) -> MonitoredRules:
    """The rules of `path` (all, or those named), a `.decl`'s activities bound through the run's
    name map (`Encoder.names()`); InputError naming the file (and line) for a name the file
    does not have, a rule that does not read or compile, or a rule on an attribute the run does
    not predict (its conditions and attribute values would never be read)."""
    encoder = tokens.encoder
    rules = read_case_rules(path, encoder.names())
    if names:
        by_name = {r.name: r for r in rules}
        unknown = [n for n in names if n not in by_name]
        if unknown:
            listed = ", ".join(list(by_name)[:8]) + (", ..." if len(by_name) > 8 else "")
            raise InputError(f"{path}: no rule named {', '.join(unknown)} (it has {listed})")
        rules = [by_name[n] for n in dict.fromkeys(names)]
    for rule in rules:
        read = sorted({a for t in rule.conditions.values() for a in t.attributes})
        unread = [a for a in read if a not in encoder.attributes]
        if unread:
            raise InputError(
                f"{rule.where}: rule {rule.name} has an MP-Declare condition on "
                f"{', '.join(unread)}, which the run does not predict (it predicts: "
                f"{', '.join(encoder.attributes) or 'activities only'}): a model that predicts "
                "the attribute can read it; or leave such rules out"
            )
        values = [a for a in rule.atoms if "__" in a and a not in rule.conditions]
        if values and not encoder.attributes:
            raise InputError(
                f"{rule.where}: rule {rule.name} names the attribute value {values[0]}: a model "
                "over activities cannot read it (a model that predicts the attribute can, or "
                "leave such rules out)"
            )
    tests = {atom: test for r in rules for atom, test in r.conditions.items()}
    dfas = compile_rules(rules)
    letters = tokens.letters(tests)
    columns = [np.array([d.alphabet.index(ls) for ls in letters], dtype=np.int64) for d in dfas]
    known = set().union(*letters)
    return MonitoredRules(
        os.fspath(path),
        tuple(r.name for r in rules),
        tuple(dfas),
        tuple(d.table[:, c].astype(np.int64) for d, c in zip(dfas, columns, strict=True)),
        tuple(state_verdicts(d) for d in dfas),
        tests,
        RuleAutomaton.of_letters(dfas, columns),
        {
            r.name: tuple(a for a in r.atoms if a not in known)
            for r in rules
            if any(a not in known for a in r.atoms)
        },
    )


def wilson(successes: np.ndarray, n: int, z: float = Z95) -> tuple[np.ndarray, np.ndarray]:
    """The Wilson score interval (low, high) of a proportion: `successes` of `n` draws."""
    p = np.asarray(successes, dtype=np.float64) / n
    denominator = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denominator
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denominator
    return np.clip(centre - half, 0.0, 1.0), np.clip(centre + half, 0.0, 1.0)


def shared(step: NextLogProbs, owner_of: Sequence[int]) -> NextLogProbs:
    """`step` for rows whose owners are renumbered (`owner_of[i]`: the case row i's owner
    stands for), called once per distinct (case, sequence): the completions sampled from one
    prefix share most of their rows."""

    def call(rows: Rows) -> np.ndarray:
        seen: dict[tuple, int] = {}
        index = np.empty(len(rows), dtype=np.int64)
        unique, owners = [], []
        for i, (row, owner) in enumerate(zip(rows, rows.owners, strict=True)):
            key = (owner_of[owner], row)
            j = seen.get(key)
            if j is None:
                j = seen[key] = len(unique)
                unique.append(row)
                owners.append(owner_of[owner])
            index[i] = j
        return np.asarray(step(Rows(unique, owners)))[index]

    return call


def sample_holds(
    step: NextLogProbs,
    prefixes: Sequence[tuple[int, ...]],
    starts: np.ndarray,
    rules: MonitoredRules,
    num_tokens: int,
    samples: int,
    max_length: int,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Per prefix, `samples` completions drawn from the model `step` at temperature 1 (at most
    `max_length` tokens: one reaching it ends there), and how many of them each rule accepts,
    its DFA continuing from `starts` [n, R]: (kept int [n, R], reached the cap int [n])."""
    n, r = len(prefixes), len(rules.names)
    kept = np.zeros((n, r), dtype=np.int64)
    at_cap = np.zeros(n, dtype=np.int64)
    group = max(1, SAMPLED_ROWS // samples)
    for chunk, first in enumerate(range(0, n, group)):
        ids = list(range(first, min(first + group, n)))
        owner_of = np.repeat(ids, samples).tolist()
        drawn = sample_suffixes(
            shared(step, owner_of), [prefixes[i] for i in owner_of], num_tokens,
            temperature=1.0, max_length=max_length, seed=seed + chunk,
        )  # fmt: skip
        width = max((len(d.activities) for d in drawn), default=0)
        padded = np.full((len(drawn), width), -1, dtype=np.int64)
        for row, d in enumerate(drawn):
            padded[row, : len(d.activities)] = d.activities
        lengths = np.array([len(d.activities) for d in drawn])
        holds = rules.accepted(starts[owner_of], padded)
        kept[ids] = holds.reshape(len(ids), samples, r).sum(axis=1)
        at_cap[ids] = (lengths == max_length).reshape(len(ids), samples).sum(axis=1)
    return kept, at_cap
