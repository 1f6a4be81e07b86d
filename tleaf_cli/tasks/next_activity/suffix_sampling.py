"""Suffix prediction by temperature sampling, with the rules as a hard filter.

Where beam search (suffix_search.py) looks for the most probable continuation, sampling draws
one: at each step the next token (an activity, or the end of the case) is drawn from the model's
distribution sharpened by a temperature τ, p_τ(x) ∝ p(x)^(1/τ) (τ < 1: closer to argmax; the
neuro-symbolic suffix predictors of Mezini et al., 2026, sample at τ = 0.7). Every prefix of a
batch advances together, one model call per step.

Under rules the draw is restricted to the tokens that keep them satisfiable within the budget:
an activity only where each rule part's next DFA state still reaches acceptance within the
activities left (`RuleAutomaton.next_within`), the end only in an accepting state — the same
filter as the beam search's pruning, so every continuation drawn is accepted. A prefix that
already cannot meet the rules in time (a dead state) is sampled without them and counted in
`SearchStats.fallbacks`. With a rule weight the rules are a soft score instead (as the beam
search's, suffix_search.py): the draw is from the model's distribution times e^(−μ · cost), so
continuations that meet the rules sooner are likelier and none is impossible. The draws are
reproducible: one `numpy` generator seeded by `seed`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from tleaf_cli.errors import ArgumentError
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.tasks.next_activity.rule_automaton import rule_automaton
from tleaf_cli.tasks.next_activity.suffix_search import (
    NextLogProbs,
    Rows,
    SearchStats,
    Suffix,
    call_model,
    check_count,
    check_prefixes,
)


def sample_suffixes(
    next_log_probs: NextLogProbs,
    prefixes: Sequence[Sequence[int]],
    num_activities: int,
    *,
    rules: RuleSet | Sequence[RuleSet] | None = None,
    temperature: float = 0.7,
    max_length: int = 50,
    seed: int = 0,
    stats: SearchStats | None = None,
    rule_weight: float | None = None,
) -> list[Suffix]:
    """Per prefix, one continuation drawn token by token at `temperature`, under `rules` when
    given (arguments as `suffix_search.predict_suffixes`'; `log_prob` is the drawn tokens'
    log-probabilities under the model, untempered). A continuation reaching `max_length`
    activities ends there. `rule_weight` μ: the rules as a soft score instead of a filter, as
    `predict_suffixes`' (each token's log-probability lowered by μ per rule part it leaves
    unmet and μ more per part out of reach, the end by 2μ per part unmet) before tempering.
    ArgumentError for a temperature that is not a finite number above 0.
    """
    v = check_count(num_activities, "num_activities", 1)
    max_length = check_count(max_length, "max_length", 0)
    if not (
        isinstance(temperature, int | float) and math.isfinite(temperature) and temperature > 0
    ):
        raise ArgumentError("temperature", f"must be a finite number above 0, not {temperature!r}")
    checked = check_prefixes(prefixes, v)
    automaton = rule_automaton(rules, v)
    stats = stats if stats is not None else SearchStats()
    rng = np.random.default_rng(seed)
    n = len(checked)
    drawn: list[list[int]] = [[] for _ in range(n)]
    scores = np.zeros(n)
    states = None
    ruled = np.zeros(n, dtype=bool)  # sampled under the rules (not a fallback)
    soft = automaton is not None and rule_weight is not None
    if automaton is not None:
        states = np.array([automaton.run(p) for p in checked], dtype=np.int64).reshape(n, -1)
        ruled = automaton.within(states, max_length)
        if soft:  # the rules cost, they do not cut: nothing falls back
            ruled = np.ones(n, dtype=bool)
        else:
            stats.fallbacks += int((~ruled).sum())
    open_ = list(range(n))
    for step in range(max_length + 1):
        if not open_:
            break
        rows = Rows([checked[i] + tuple(drawn[i]) for i in open_], list(open_))
        log_probs = call_model(next_log_probs, rows, v, stats)
        allowed = np.ones_like(log_probs, dtype=bool)
        if step == max_length:
            allowed[:, :v] = False  # the budget is spent: only the end
        weights = log_probs
        if soft:
            costs = automaton.soft_costs(states[open_], max_length - step - 1)
            weights = log_probs - rule_weight * costs  # past the budget only the end is allowed
        elif automaton is not None:
            mine = ruled[open_]
            here = states[open_]
            if step < max_length:
                allowed[:, :v] &= ~mine[:, None] | automaton.next_within(
                    here, max_length - step - 1
                )
            allowed[:, v] &= ~mine | automaton.accepted(here)
        tokens = _draw(weights, allowed, temperature, rng)
        still = []
        for row, (i, token) in enumerate(zip(open_, tokens.tolist(), strict=True)):
            scores[i] += log_probs[row, token]
            if token == v:
                continue
            drawn[i].append(token)
            if states is not None:
                states[i] = automaton.advance(states[i : i + 1], np.array([token]))[0]
            still.append(i)
        open_ = still
    out = []
    for i, prefix in enumerate(checked):
        satisfied = None if automaton is None else automaton.accepts(prefix + tuple(drawn[i]))
        found = automaton is None or bool(ruled[i])
        out.append(Suffix(tuple(drawn[i]), float(scores[i]), satisfied, found))
    return out


def _draw(
    log_probs: np.ndarray, allowed: np.ndarray, temperature: float, rng: np.random.Generator
) -> np.ndarray:
    """One token per row from softmax(log p / τ) over the allowed tokens (a row with none
    allowed draws from all)."""
    none = ~allowed.any(axis=1)
    allowed = allowed | none[:, None]
    logits = np.where(allowed, log_probs / temperature, -np.inf)
    logits -= logits.max(axis=1, keepdims=True)
    p = np.exp(logits)
    p /= p.sum(axis=1, keepdims=True)
    u = rng.random((len(p), 1))
    last = allowed.shape[1] - 1 - np.argmax(allowed[:, ::-1], axis=1)  # rounding: stay allowed
    return np.minimum((p.cumsum(axis=1) < u).sum(axis=1), last)
