"""Suffix prediction by minimum Bayes risk: the continuation most similar, on average, to the
model's own completions.

The suffix literature scores a predicted suffix by its Damerau-Levenshtein similarity to the
true one (similarity.py). The most probable continuation (argmax, beam search) is not the one
that scores best on average: where the model spreads its mass over many ways a case goes on, the
single most probable way can be a loop that no real case takes (greedy suffixes that run to the
length cap), or end too early. Minimum Bayes risk decoding (Kumar and Byrne, 2004; for
sequence models Eikema and Aziz, 2020) picks instead, among candidates, the one with the highest
*expected* similarity under the model:

    ŷ = argmax over candidates c of  (1/S) Σ_s sim(c, y_s),   y_1..y_S ~ p(· | prefix),

with the samples y_s drawn from the model at temperature 1 (suffix_sampling.py) and the
candidates the distinct samples themselves. The estimate of the expected similarity is the
sample mean, so S trades time for a steadier choice; ties go to the more probable candidate.
Under rules the samples are drawn under them (a hard filter, or a soft score with a rule
weight), so the choice keeps them as the sampling does.

Cost: the sampling's (S rows per prefix through the model, one call per step), and S² / 2
similarities per prefix, in C++ (rapidfuzz's `cdist`, on the suffixes written as strings).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from rapidfuzz.distance import DamerauLevenshtein
from rapidfuzz.process import cdist

from tleaf_cli.rule_set import RuleSet
from tleaf_cli.tasks.next_activity.suffix_sampling import sample_suffixes
from tleaf_cli.tasks.next_activity.suffix_search import (
    NextLogProbs,
    Rows,
    SearchStats,
    Suffix,
    check_count,
)

_BASE = 0x100  # token t is written as chr(_BASE + t): past the ASCII controls, any token count


def mbr_suffixes(
    next_log_probs: NextLogProbs,
    prefixes: Sequence[Sequence[int]],
    num_activities: int,
    *,
    rules: RuleSet | Sequence[RuleSet] | None = None,
    samples: int = 32,
    max_length: int = 50,
    seed: int = 0,
    stats: SearchStats | None = None,
    rule_weight: float | None = None,
    compared: Callable[[tuple[int, ...]], Sequence[int]] | None = None,
) -> list[Suffix]:
    """Per prefix, of `samples` continuations drawn from the model at temperature 1 (under
    `rules` as `sample_suffixes` draws them), the one with the highest mean Damerau-Levenshtein
    similarity to all of them (module docstring); arguments as `sample_suffixes`'.
    `compared(tokens)`: what of a continuation the similarity reads (default: its tokens; with
    joint tokens, their activities, the measure the suffix is scored by)."""
    s = check_count(samples, "samples", 1)
    own = SearchStats()  # the draws' counts; a prefix falls back once, not once per draw
    repeated = [p for p in prefixes for _ in range(s)]

    def per_prefix(rows: Rows) -> np.ndarray:  # the model sees each draw's own prefix
        return next_log_probs(Rows(list(rows), [o // s for o in rows.owners]))

    drawn = sample_suffixes(
        per_prefix,
        repeated,
        num_activities,
        rules=rules,
        temperature=1.0,
        max_length=max_length,
        seed=seed,
        stats=own,
        rule_weight=rule_weight,
    )
    if stats is not None:
        stats.model_calls += own.model_calls
        stats.branches += own.branches
        stats.pruned += own.pruned
        stats.fallbacks += own.fallbacks // s
    read = compared or (lambda tokens: tokens)
    return [_choose(drawn[i * s : (i + 1) * s], read) for i in range(len(prefixes))]


def _choose(drawn: Sequence[Suffix], read) -> Suffix:
    """The draw with the highest mean similarity to all the draws (repeats counted), the more
    probable one on a tie."""
    distinct: dict[tuple[int, ...], Suffix] = {}
    counts: dict[tuple[int, ...], int] = {}
    for d in drawn:
        distinct.setdefault(d.activities, d)
        counts[d.activities] = counts.get(d.activities, 0) + 1
    keys = list(distinct)
    if len(keys) == 1:
        return distinct[keys[0]]
    words = ["".join(chr(_BASE + t) for t in read(k)) for k in keys]
    similarity = cdist(words, words, scorer=DamerauLevenshtein.normalized_similarity)
    weights = np.array([counts[k] for k in keys], dtype=np.float64)
    expected = similarity @ weights
    log_probs = np.array([distinct[k].log_prob for k in keys])
    best = np.lexsort((-log_probs, -np.round(expected, 9)))[0]
    return distinct[keys[best]]
