"""The rules as an automaton over the tokens a suffix search chooses among (activities, or
events with attributes): one DFA per part, each token's next state, and each state's distance
to acceptance, which the searches prune by (suffix_search.py, suffix_sampling.py) and the soft
score counts (`soft_costs`). Rules over joint tokens are
conjoined into their product (`RuleAutomaton.of_letters`), so the distance is exact.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tleaf_cli import arguments
from tleaf_cli.errors import ArgumentError
from tleaf_cli.logic.dfa import DFA
from tleaf_cli.rule_set import RuleSet


def rule_automaton(
    rules: RuleSet | Sequence[RuleSet] | None, num_activities: int
) -> RuleAutomaton | None:
    """The rules (one rule set, or the parts of a conjunction: all must accept) as one
    automaton over activity indices; None without rules. ArgumentError for a rule set over
    another vocabulary size."""
    if rules is None:
        return None
    if isinstance(rules, RuleAutomaton):
        if rules.num_tokens != num_activities:
            raise ArgumentError(
                "rules",
                f"the rule automaton reads {rules.num_tokens} tokens, not {num_activities}",
            )
        return rules
    parts = arguments.rule_sets(rules, None, RuleSet)
    for part in parts:
        if len(part.vocabulary) != num_activities:
            raise ArgumentError(
                "rules",
                f"rule set {part.name} is over {len(part.vocabulary)} items, not the "
                f"{num_activities} activities",
            )
    return RuleAutomaton(parts, num_activities)


class RuleAutomaton:
    """The rules' DFAs (one per part) over activity indices, with each state's distance to
    acceptance. A branch's state is one state per part [..., K]; the distance of a combination
    is the largest of its parts' (a lower bound on the conjunction's, exact for one part), so
    pruning by it never cuts a branch that can still finish accepted."""

    def __init__(self, parts: Sequence[RuleSet], num_activities: int) -> None:
        dfas = [part.dfa for part in parts]
        letters = [part.letters(np.arange(num_activities)) for part in parts]
        self._build(_token_tables(dfas, letters), [d.accepting for d in dfas],
                    [d.initial for d in dfas])  # fmt: skip

    @classmethod
    def of_letters(
        cls, dfas: Sequence[DFA], letters: Sequence[np.ndarray], max_states: int = 100_000
    ) -> RuleAutomaton:
        """The automaton of DFAs over any alphabet whose tokens are letters: `letters[k][t]`,
        the column of DFA k that token t reads (e.g. an (activity, resource) event's letter
        in a powerset alphabet: joint_tokens.py). The DFAs are conjoined into one part, their
        product's reachable states, where it has at most `max_states`: the distance to
        acceptance is then exact, so the search never walks into a state where two rules
        contradict each other (a lower bound over parts would let it)."""
        self = cls.__new__(cls)
        tables = _token_tables(dfas, letters)
        accepting = [dfa.accepting for dfa in dfas]
        initial = [dfa.initial for dfa in dfas]
        if len(tables) > 1:
            product = _product(tables, accepting, initial, max_states)
            if product is not None:
                tables, accepting, initial = [product[0]], [product[1]], [0]
        self._build(tables, accepting, initial)
        return self

    def _build(
        self,
        tables: Sequence[np.ndarray],
        accepting: Sequence[np.ndarray],
        initial: Sequence[int],
    ) -> None:
        """Each part's token table [S_k, V], accepting states and initial state; the
        distances to acceptance computed from them."""
        self.following: list[np.ndarray] = []  # per part: state after each token [S_k, V]
        self.accepting: list[np.ndarray] = []
        self.distance: list[np.ndarray] = []
        self.initial = np.array(initial, dtype=np.int64)
        self.num_tokens = tables[0].shape[1] if len(tables) else 0
        never = np.iinfo(np.int64).max // 2
        for following, accepts in zip(tables, accepting, strict=True):
            # fewest activities from each state to an accepting state (`never`: unreachable);
            # only through activities that exist (letter 0 has none when every activity is an
            # atom), so a finite distance implies `dfa.live()`
            distance = np.where(accepts, 0, never).astype(np.int64)
            while True:
                step = np.minimum(distance, distance[following].min(axis=1) + 1)
                step = np.minimum(step, never)
                if np.array_equal(step, distance):
                    break
                distance = step
            self.following.append(following)
            self.accepting.append(np.asarray(accepts, dtype=bool))
            self.distance.append(distance)

    def run(self, activities: Sequence[int]) -> np.ndarray:
        """int64 [K]: each part's state after `activities`."""
        state = self.initial.copy()
        for k, following in enumerate(self.following):
            for a in activities:
                state[k] = following[state[k], a]
        return state

    def accepts(self, activities: Sequence[int]) -> bool:
        return bool(self.accepted(self.run(activities)))

    def accepted(self, states: np.ndarray) -> np.ndarray:
        """bool [...]: every part accepts, for states [..., K]."""
        out = np.ones(states.shape[:-1], dtype=bool)
        for k, accepting in enumerate(self.accepting):
            out &= accepting[states[..., k]]
        return out

    def within(self, states: np.ndarray, budget: int) -> np.ndarray:
        """bool [...]: every part can reach acceptance in at most `budget` activities."""
        out = np.ones(states.shape[:-1], dtype=bool)
        for k, distance in enumerate(self.distance):
            out &= distance[states[..., k]] <= budget
        return out

    def next_within(self, states: np.ndarray, budget: int) -> np.ndarray:
        """bool [..., V]: per activity, every part's next state reaches acceptance in at most
        `budget` more activities."""
        out = None
        for k, (following, distance) in enumerate(zip(self.following, self.distance, strict=True)):
            ok = distance[following[states[..., k]]] <= budget
            out = ok if out is None else out & ok
        return out

    def soft_costs(self, states: np.ndarray, budget: int) -> np.ndarray:
        """int [..., V + 1], states [..., K]: the soft score's count per token, in units of the
        weight μ. An activity counts each part whose next state does not accept (a rule unmet)
        and again each that cannot accept within `budget` more tokens (out of reach); the end
        (the last column) counts each part that does not accept twice: ending leaves it out of
        reach for good."""
        tokens = None
        end = np.zeros(states.shape[:-1], dtype=np.int64)
        parts = zip(self.following, self.accepting, self.distance, strict=True)
        for k, (following, accepting, distance) in enumerate(parts):
            after = following[states[..., k]]
            count = (~accepting[after]).astype(np.int64) + (distance[after] > budget)
            tokens = count if tokens is None else tokens + count
            end += 2 * ~accepting[states[..., k]]
        return np.concatenate([tokens, end[..., None]], axis=-1)

    def advance(self, states: np.ndarray, tokens: np.ndarray) -> np.ndarray:
        """int64 [n, K]: each part's state after activity tokens[i] from states [n, K]."""
        out = np.empty_like(states)
        for k, following in enumerate(self.following):
            out[:, k] = following[states[:, k], tokens]
        return out


def _token_tables(dfas: Sequence[DFA], letters: Sequence[np.ndarray]) -> list[np.ndarray]:
    """Per DFA, its state after each token [S, V]: the column of the token's letter."""
    return [
        dfa.table[:, np.asarray(columns, dtype=np.int64)].astype(np.int64)
        for dfa, columns in zip(dfas, letters, strict=True)
    ]


def _product(
    tables: Sequence[np.ndarray],
    accepting: Sequence[np.ndarray],
    initial: Sequence[int],
    max_states: int,
) -> tuple[np.ndarray, np.ndarray] | None:
    """The reachable product of token-level DFAs (tables [S_k, T]): its table [S, T] from
    state 0, and its accepting states (every DFA accepts); None past `max_states`.

    A combination of part states is keyed by its bytes, not by a mixed-radix number: the
    number of combinations of a hundred rules passes any integer type (3^106 wrapped int64 and
    merged combinations that differ)."""
    start = np.asarray(initial, dtype=np.int64)
    number = {start.tobytes(): 0}  # a combination's bytes -> its state
    combos = [start]  # state -> its parts' states
    rows: list[np.ndarray] = []
    first = 0
    while first < len(combos):
        parts = np.stack(combos[first:])  # [n, K]
        first = len(combos)
        nxt = np.stack([t[parts[:, k]] for k, t in enumerate(tables)], axis=-1)  # [n, T, K]
        distinct, inverse = np.unique(nxt.reshape(-1, nxt.shape[-1]), axis=0, return_inverse=True)
        found = np.empty(len(distinct), dtype=np.int64)
        for d, combo in enumerate(distinct):
            key = combo.tobytes()
            if key not in number:
                number[key] = len(combos)
                combos.append(combo)
            found[d] = number[key]
        if len(combos) > max_states:
            return None
        rows.extend(found[inverse.reshape(nxt.shape[:2])])
    table = np.stack(rows) if rows else np.zeros((1, 0), dtype=np.int64)
    states = np.stack(combos)
    accepts = np.ones(len(combos), dtype=bool)
    for k, acc in enumerate(accepting):
        accepts &= np.asarray(acc, dtype=bool)[states[:, k]]
    return table, accepts
