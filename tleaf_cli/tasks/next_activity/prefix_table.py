"""The trivial next-activity baseline the field's critics ask for beside every model (Abb et al.,
2023; Pfeiffer et al., BISE 2025), and the example leakage they measure.

**Prefix table** (`--model prefix-table`): the next token (an activity or the end of the case)
most often seen after the same prefix in the training cases; for a prefix never seen whole, the
one most often seen after its longest suffix that was seen (backing off one event at a time), and
for none, the most frequent token overall. No training: the table is counted once. As a model it
gives log-probabilities [B, T, V + 1], the counts of the entry it reads normalised (and smoothed
by a thousandth of a count, so that rules can still choose any token), so accuracy, prediction
under the rules and the suffix search read it as they read the LSTM.

**Leakage**: the share of test prefixes whose exact prefix, with its next token, already occurs in
the training cases: those a model can get right by memory alone.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import numpy as np
import torch
from torch import nn

SMOOTHING = 1e-3  # added to every token's count: no token impossible


class PrefixTable(nn.Module):
    """(activities [B, T] long, times, lengths [B]) -> log-probabilities [B, T, V + 1] of the
    next token after each prefix, from the training cases' counts (module docstring).

    Args:
        sequences: the training cases as activity indices (0..V-1), the end not included.
        num_activities: V; index V is the end of the case.
    """

    def __init__(self, sequences: Sequence[Sequence[int]], num_activities: int) -> None:
        super().__init__()
        self.num_activities = num_activities
        self.whole: dict[tuple[int, ...], Counter] = {}  # prefix from the case's start
        self.tails: dict[tuple[int, ...], Counter] = {}  # any run of events
        self.overall: Counter = Counter()
        end = num_activities
        for seq in sequences:
            tokens = [int(a) for a in seq]
            for t in range(1, len(tokens) + 1):
                following = tokens[t] if t < len(tokens) else end
                self.whole.setdefault(tuple(tokens[:t]), Counter())[following] += 1
                for k in range(1, t + 1):
                    self.tails.setdefault(tuple(tokens[t - k : t]), Counter())[following] += 1
                self.overall[following] += 1

    def counts(self, prefix: tuple[int, ...]) -> Counter:
        """The counts the prediction after `prefix` reads: the whole prefix's, else its longest
        seen suffix's, else the overall ones."""
        if prefix in self.whole:
            return self.whole[prefix]
        for k in range(len(prefix) - 1, 0, -1):
            tail = self.tails.get(prefix[len(prefix) - k :])
            if tail is not None:
                return tail
        return self.overall

    def log_probs(self, prefix: tuple[int, ...]) -> np.ndarray:
        """float [V + 1]: the normalised, smoothed counts after `prefix`, as logs."""
        row = np.full(self.num_activities + 1, SMOOTHING)
        for token, n in self.counts(prefix).items():
            row[token] += n
        return np.log(row / row.sum())

    def forward(
        self,
        activities: torch.Tensor,
        times: torch.Tensor,
        lengths: torch.Tensor,
        values: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """Log-probabilities [B, T, V + 1] (the attribute `values` are not read)."""
        out = np.zeros((*activities.shape, self.num_activities + 1))
        for b, (row, n) in enumerate(zip(activities.tolist(), lengths.tolist(), strict=True)):
            for t in range(n):
                out[b, t] = self.log_probs(tuple(row[: t + 1]))
        return torch.as_tensor(out, dtype=times.dtype, device=times.device)


def seen_in_training(
    train: Sequence[Sequence[int]], cases: Sequence[Sequence[int]], end: int
) -> np.ndarray:
    """bool, one per prefix of `cases` (in order, every length ≥ 1, the end a target): the same
    prefix with the same next token occurs in `train` (example leakage)."""
    pairs = set()
    for seq in train:
        tokens = tuple(int(a) for a in seq)
        for t in range(1, len(tokens) + 1):
            pairs.add((tokens[:t], tokens[t] if t < len(tokens) else end))
    out = []
    for seq in cases:
        tokens = tuple(int(a) for a in seq)
        for t in range(1, len(tokens) + 1):
            out.append((tokens[:t], tokens[t] if t < len(tokens) else end) in pairs)
    return np.array(out, dtype=bool)
