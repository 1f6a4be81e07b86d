"""Suffix prediction under the rules: beam search in the product of a next-activity model and
the rules' DFA.

A next-activity model gives, for a running case (a prefix of activities), the log-probability
of each next activity and of the end of the case. Suffix prediction continues the prefix until
the model ends it: greedily (Tax et al. 2017, the argmax at every step) or by beam search. Under
rules — LTLf formulas over the activities, one DFA (`tleaf_cli.rule_set.RuleSet`) — the search
runs in the product of the model and the DFA: a branch is (activities so far, DFA state), the
prefix is run through the DFA first, an activity moves the DFA, and

- a branch is pruned the moment the rules can no longer be met within the length budget: its
  DFA state is dead (no accepting state reachable, `DFA.live()`), or every accepting state is
  further away than the activities it may still add (`max_length`). Dead states are the case
  of an unbounded budget; with the budget, every open branch can still finish accepted;
- the end of the case may be chosen only in an accepting state, and finishes the branch.

Beam search of width `beam_width`: a step extends every open branch by every allowed token
(activities, and the end), and keeps the `beam_width` best-scoring branches, finished or open,
a finished branch carried over unchanged (it competes for its slot; so width 1 is greedy
argmax). A score is the sum of the chosen tokens' log-probabilities, the end included; since
log-probabilities are <= 0, extending never raises a score, and a prefix's search stops as soon
as its best branch is finished: no open branch can overtake it. Ties go to the earlier branch of
the beam, then the smaller token index (the end token is the last index), as numpy's argmax.

What it guarantees:
- every suffix it reports as found satisfies the rules (prefix + suffix accepted by the DFA);
- found is False exactly when no continuation of at most `max_length` activities is accepted
  (the prefix already in a dead state included), whatever the beam width: the pruning above
  keeps only branches that can still finish accepted in time, so the beam never runs dry while
  one exists. The suffix reported then is the unconstrained search's;
- with a beam wide enough to keep every candidate (in the worst case (V + 1)^max_length), the
  most probable accepted continuation of at most `max_length` activities.
What it does not: beam search is approximate; a narrow beam can miss the most probable
accepted continuation (it holds the best branches so far, not the best completions).

Cost: one call of the model per step, with every open branch of every prefix in one batch (at
most `beam_width` rows per prefix), so at most `max_length` + 1 calls for a whole batch of
prefixes, plus as many for the unconstrained search of the prefixes not found. Between calls
the beams of all prefixes advance together as padded numpy arrays (no Python loop over prefixes
or branches but building the model's rows); the DFA adds a table lookup per candidate.

The field's name for this: Di Francescomarino, Ghidini, Maggi, Petrucci, Yeshchenko (BPM 2017),
"An eye into the future: leveraging a-priori knowledge in predictive business process
monitoring": a beam search (with backtracking) that keeps only continuations whose completed
case satisfies an LTL formula known a priori. Theirs checks the formula when the model predicts
the end of the case and backtracks then; this one prunes a branch at the step its DFA state
goes dead, before the model spends a call on it.
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from tleaf_cli.arguments import given
from tleaf_cli.errors import ArgumentError, ArgumentTypeError
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.tasks.next_activity.rule_automaton import RuleAutomaton, rule_automaton

NextLogProbs = Callable[[Sequence[Sequence[int]]], np.ndarray]
"""Given N sequences of activity indices (each a prefix plus the continuation so far), float
[N, V + 1]: log-probabilities of the next token; indices 0..V-1 are activities, index V is the
end of the case. The sequences come as `Rows`: their `owners` say which prefix each continues
(for a model that reads more of a case than its activities, e.g. the prefix's times)."""


class Rows(list):
    """The sequences of one model call; `owners[i]`: the index, in `predict_suffixes`'
    `prefixes`, of the prefix that row i continues."""

    def __init__(self, rows: list[tuple[int, ...]], owners: list[int]) -> None:
        super().__init__(rows)
        self.owners = owners


# log-probabilities above this are refused: the stopping rule needs scores that never rise
_POSITIVE_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Suffix:
    """One prefix's predicted continuation."""

    activities: tuple[int, ...]  # the predicted continuation, end token not included
    log_prob: float  # its score: sum of the chosen tokens' log-probs, end included
    satisfied: bool | None  # prefix + continuation accepted by the rules; None without rules
    found: bool  # False: no continuation within max_length meets the rules (or the prefix is
    # already in a dead DFA state); `activities` is then the unconstrained search's answer


@dataclass
class SearchStats:
    """Counters of `predict_suffixes`, for a report; pass one to add a call's counts to it."""

    model_calls: int = 0  # calls of next_log_probs
    branches: int = 0  # sequences sent to it, over all calls (model rows)
    pruned: int = 0  # extensions cut because the rules could no longer be met in time
    fallbacks: int = 0  # prefixes with no accepted continuation (unconstrained answer)


def predict_suffixes(
    next_log_probs: NextLogProbs,
    prefixes: Sequence[Sequence[int]],
    num_activities: int,
    *,
    rules: RuleSet | Sequence[RuleSet] | None = None,
    beam_width: int = 5,
    max_length: int = 50,
    stats: SearchStats | None = None,
    rule_weight: float | None = None,
) -> list[Suffix]:
    """Per prefix, the most probable continuation the beam finds, under `rules` when given.

    Args:
        next_log_probs: the model (see `NextLogProbs`), called once per step with every open
            branch of every prefix.
        prefixes: non-empty sequences of activity indices (0..num_activities-1).
        num_activities: V, the number of activities; the model's outputs have V + 1 columns.
        rules: a rule set over the activities' vocabulary (item i = activity i), or the parts
            of a conjunction too large for one DFA (`rule_set.rule_parts`: every part must
            accept); None: none.
        beam_width: branches kept per prefix and step (1: greedy argmax).
        max_length: the most activities a continuation may add (0: only the end).
        stats: counters to add this call's model calls, branches and pruning to.
        rule_weight: None: the rules are a hard filter (above). A number μ ≥ 0: a soft score
            instead (the knowledge as evidence, not law; NeSy4PPM's knowledge-contextualised
            beam ranks by the rules' state the same way): nothing is pruned; a token costs μ
            for each rule part whose state after it does not accept (temporarily violated)
            and μ more for each that can no longer accept within the budget (violated for
            good), the end 2μ for each part that does not accept. So a branch that meets the
            rules sooner ranks higher, by μ per step and part. μ = 0 ignores the rules; every
            prefix is found.

    Raises ArgumentTypeError / ArgumentError for arguments that cannot be used and for model
    outputs of the wrong shape, with NaN or with positive log-probabilities.
    """
    if not callable(next_log_probs):
        raise ArgumentTypeError("next_log_probs", f"must be callable, not {given(next_log_probs)}")
    num_activities = check_count(num_activities, "num_activities", 1)
    beam_width = check_count(beam_width, "beam_width", 1)
    max_length = check_count(max_length, "max_length", 0)
    checked = check_prefixes(prefixes, num_activities)
    automaton = rule_automaton(rules, num_activities)
    stats = stats if stats is not None else SearchStats()
    if rule_weight is not None and not (
        isinstance(rule_weight, int | float) and np.isfinite(rule_weight) and rule_weight >= 0
    ):
        raise ArgumentError("rule_weight", f"must be a finite number >= 0, not {rule_weight!r}")
    search = _Search(next_log_probs, num_activities, beam_width, max_length, stats, rule_weight)
    best = search.run(checked, automaton, list(range(len(checked))))
    missing = [i for i, b in enumerate(best) if b is None]
    again = search.run([checked[i] for i in missing], None, missing)
    fallback = dict(zip(missing, again, strict=True))
    stats.fallbacks += len(missing)
    out = []
    for i, prefix in enumerate(checked):
        found = best[i] is not None
        activities, score = best[i] if found else fallback[i]
        satisfied = None if automaton is None else automaton.accepts(prefix + activities)
        out.append(Suffix(activities, score, satisfied, found))
    return out


class _Search:
    """The beam search of every prefix at once: each beam is a row of padded arrays
    [prefixes, beam_width, ...], so a step is a few numpy operations over all of them."""

    def __init__(
        self,
        model: NextLogProbs,
        num_activities: int,
        beam_width: int,
        max_length: int,
        stats: SearchStats,
        rule_weight: float | None = None,
    ) -> None:
        self.model = model
        self.v = num_activities
        self.width = beam_width
        self.max_length = max_length
        self.stats = stats
        self.weight = rule_weight  # None: the rules a hard filter; μ: a soft score

    def run(
        self, prefixes: list[tuple[int, ...]], automaton: RuleAutomaton | None, owners: list[int]
    ) -> list[tuple[tuple[int, ...], float] | None]:
        """Per prefix, (continuation, score) of the best finished branch, or None when no
        branch can finish (only under rules: no accepted continuation within max_length);
        `owners`: each prefix's index for the model (`Rows.owners`)."""
        v, width, max_length = self.v, self.width, self.max_length
        best: list[tuple[tuple[int, ...], float] | None] = [None] * len(prefixes)
        parts = 1 if automaton is None else len(automaton.following)
        start = np.zeros((len(prefixes), parts), dtype=np.int64)
        soft = automaton is not None and self.weight is not None
        if automaton is not None:
            start = np.array([automaton.run(p) for p in prefixes], dtype=np.int64)
            start = start.reshape(len(prefixes), parts)
            reachable = automaton.within(start, max_length)  # not dead, and in time
            if soft:  # the rules cost, they do not cut: every prefix searches
                reachable = np.ones(len(prefixes), dtype=bool)
        else:
            reachable = np.ones(len(prefixes), dtype=bool)
        ids = np.flatnonzero(reachable)  # the prefixes still searching
        n = len(ids)
        tokens = np.zeros((n, width, max_length), dtype=np.int32)  # branch k's continuation
        lengths = np.zeros((n, width), dtype=np.int64)
        states = np.zeros((n, width, parts), dtype=np.int64)  # each part's DFA state
        states[:, 0] = start[ids]
        scores = np.zeros((n, width))
        present = np.zeros((n, width), dtype=bool)  # a slot holds a branch
        present[:, 0] = True
        finished = np.zeros((n, width), dtype=bool)
        step = 0
        while len(ids):
            opened = present & ~finished  # every open branch has `step` activities
            where = np.argwhere(opened)
            pairs = where.tolist()
            rows = Rows(
                [prefixes[ids[p]] + tuple(tokens[p, k, :step].tolist()) for p, k in pairs],
                [owners[ids[p]] for p, _ in pairs],
            )
            block = np.full((len(ids), width, v + 1), -np.inf)
            block[opened] = self._call(rows)
            candidates = scores[..., None] + block
            valid = np.zeros((len(ids), width, v + 1), dtype=bool)
            if step < max_length:
                if automaton is None or soft:  # soft: every token, at a cost (below)
                    valid[..., :v] = opened[..., None]
                else:  # the activity's state still reaches acceptance in the budget left
                    in_time = automaton.next_within(states, max_length - step - 1)
                    valid[..., :v] = opened[..., None] & in_time
                    self.stats.pruned += int((opened[..., None] & ~in_time).sum())
            if soft:  # a rule part unmet costs μ, out of reach μ more; the end 2μ each unmet
                ends = opened
                candidates -= self.weight * automaton.soft_costs(states, max_length - step - 1)
            else:
                ends = opened if automaton is None else opened & automaton.accepted(states)
            valid[..., v] = ends | (present & finished)
            candidates[..., v] = np.where(finished, scores, candidates[..., v])
            flat = candidates.reshape(len(ids), -1)
            flat_valid = valid.reshape(len(ids), -1)
            # per prefix: valid first, then best score; stable, so ties keep candidate order
            order = np.lexsort((-flat, ~flat_valid), axis=-1)[:, :width]
            parent, token = np.divmod(order, v + 1)
            end = token == v
            present = np.take_along_axis(flat_valid, order, axis=1)
            scores = np.take_along_axis(flat, order, axis=1)
            tokens = np.take_along_axis(tokens, parent[..., None], axis=1)
            lengths = np.take_along_axis(lengths, parent, axis=1)
            states = np.take_along_axis(states, parent[..., None], axis=1)
            grown = present & ~end
            if grown.any():
                tokens[grown, step] = token[grown]
                lengths[grown] = step + 1
                if automaton is not None:
                    states[grown] = automaton.advance(states[grown], token[grown])
            finished = end
            # a prefix is done when its beam is empty (nothing can finish accepted) or its best
            # branch is finished (nothing open can overtake it: log-probabilities are <= 0)
            done = ~present[:, 0] | finished[:, 0]
            for p in np.flatnonzero(done & present[:, 0]).tolist():
                best[ids[p]] = (tuple(tokens[p, 0, : lengths[p, 0]].tolist()), float(scores[p, 0]))
            keep = ~done
            ids, tokens, lengths, states = ids[keep], tokens[keep], lengths[keep], states[keep]
            scores, present, finished = scores[keep], present[keep], finished[keep]
            step += 1
        return best

    def _call(self, rows: Rows) -> np.ndarray:
        return call_model(self.model, rows, self.v, self.stats)


def call_model(model: NextLogProbs, rows: Rows, v: int, stats: SearchStats) -> np.ndarray:
    """The model's log-probabilities [len(rows), V + 1] as float64, checked (shape, no NaN,
    none above 0), the call counted in `stats`."""
    out = np.asarray(model(rows), dtype=np.float64)
    stats.model_calls += 1
    stats.branches += len(rows)
    if out.shape != (len(rows), v + 1):
        raise ArgumentError(
            "next_log_probs",
            f"returned shape {list(out.shape)} for {len(rows)} sequences; expected "
            f"[{len(rows)}, {v + 1}] (the activities, then the end of the case)",
        )
    if np.isnan(out).any():
        raise ArgumentError("next_log_probs", "returned NaN")
    if (out > _POSITIVE_TOLERANCE).any():
        raise ArgumentError(
            "next_log_probs",
            f"returned {out.max():g} > 0: log-probabilities are <= 0 (log_softmax)",
        )
    return out


def check_count(value: object, argument: str, least: int) -> int:
    """`value` as an int >= `least` (ArgumentTypeError / ArgumentError otherwise)."""
    try:
        if isinstance(value, bool):
            raise TypeError
        number = operator.index(value)
    except TypeError:
        raise ArgumentTypeError(argument, f"must be an int, not {given(value)}") from None
    if number < least:
        raise ArgumentError(argument, f"must be at least {least}, not {number}")
    return number


def check_prefixes(prefixes: object, num_activities: int) -> list[tuple[int, ...]]:
    """Each prefix as a tuple of ints, checked: non-empty, activities 0..num_activities-1."""
    if isinstance(prefixes, str | bytes) or not isinstance(prefixes, Sequence):
        raise ArgumentTypeError(
            "prefixes", f"must be a sequence of activity-index sequences, not {given(prefixes)}"
        )
    out = []
    for i, prefix in enumerate(prefixes):
        array = np.asarray(prefix)
        if array.ndim != 1 or (array.size and array.dtype.kind not in "iu"):
            raise ArgumentTypeError(
                f"prefixes[{i}]", f"must be a sequence of activity indices, not {given(prefix)}"
            )
        if array.size == 0:
            raise ArgumentError(f"prefixes[{i}]", "is empty: a running case has an activity")
        if array.min() < 0 or array.max() >= num_activities:
            raise ArgumentError(
                f"prefixes[{i}]",
                f"has activity {int(array.max() if array.max() >= num_activities else array.min())}"
                f" outside 0..{num_activities - 1}",
            )
        out.append(tuple(array.tolist()))
    return out
