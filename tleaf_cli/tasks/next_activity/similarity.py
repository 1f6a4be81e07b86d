"""Suffix similarity: the Damerau-Levenshtein measure the suffix-prediction literature reports.

Tax et al. (2017, "Predictive business process monitoring with LSTM neural networks") and Di
Francescomarino et al. (2017, "An eye into the future: leveraging a-priori knowledge in
predictive business process monitoring") score a predicted suffix against the true one by

    DL similarity = 1 − DL(predicted, true) / max(|predicted|, |true|),

with DL from `jellyfish._jellyfish.damerau_levenshtein_distance` (both evaluation scripts import
exactly that, on activities written as one character each). That function is the
*unrestricted* Damerau-Levenshtein distance (Lowrance-Wagner: insertions, deletions,
substitutions and transpositions of adjacent symbols, where a transposed pair may be edited
further), not the optimal-string-alignment variant: DL("CA", "ABC") = 2, where OSA gives 3.
`rapidfuzz.distance.DamerauLevenshtein` computes the same unrestricted distance, in C++, on any
sequences of hashables — activity indices directly, with no character encoding — so it is the
one used here (jellyfish ≥ 1 takes strs only).

Mezini et al. (Information Systems 2026) score the whole trace instead: the same similarity
between prefix + predicted suffix + an end symbol and prefix + true suffix + the end
(`trace_dl_similarity`). The shared prefix raises it: a wrong suffix after a long prefix
still scores high.
"""

from __future__ import annotations

from collections.abc import Sequence

from rapidfuzz.distance import DamerauLevenshtein


def damerau_levenshtein(a: Sequence[int], b: Sequence[int]) -> int:
    """The unrestricted Damerau-Levenshtein distance between two sequences of activities
    (insertions, deletions, substitutions, adjacent transpositions; each costs 1)."""
    return int(DamerauLevenshtein.distance(list(a), list(b)))


def dl_similarity(a: Sequence[int], b: Sequence[int]) -> float:
    """1 − DL(a, b) / max(|a|, |b|): 1.0 for equal sequences (both empty included), 0.0 when
    nothing is shared. The suffix measure of Tax et al. and Di Francescomarino et al."""
    longest = max(len(a), len(b))
    if longest == 0:
        return 1.0
    return 1.0 - damerau_levenshtein(a, b) / longest


def trace_dl_similarity(
    prefix: Sequence[int], predicted: Sequence[int], true: Sequence[int]
) -> float:
    """Mezini et al.'s measure: `dl_similarity` of prefix + predicted + end and prefix + true +
    end, the end a symbol no activity is (-1)."""
    head = list(prefix)
    return dl_similarity([*head, *predicted, -1], [*head, *true, -1])


def jaccard_similarity(a: Sequence[int], b: Sequence[int]) -> float:
    """|A ∩ B| / |A ∪ B| of the sets of symbols in a and b (1.0 when both are empty): how much
    of what happens is predicted, order and repeats aside. NeSy4PPM's measure (`1 −
    distance.jaccard`) on suffixes."""
    left, right = set(a), set(b)
    union = left | right
    return len(left & right) / len(union) if union else 1.0
