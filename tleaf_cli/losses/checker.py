"""The model-checker loss: 1 where the most probable sequence violates φ, else 0.

The paper compares against it. The argmax is not differentiable, so this loss is a constant with
NO gradient: added to an objective it leaves training unchanged (the same updates as without
it). `violates` is the batched exact check behind it, also used to count violations.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from tleaf_cli.logic.checker import PackedDFAs
from tleaf_cli.rule_set import RuleSet


def violates(rule_sets: Sequence[RuleSet], sequences: Sequence[np.ndarray]) -> np.ndarray:
    """bool [n]: sequence i (vocabulary indices, its own length) violates rule_sets[i]."""
    if not rule_sets:
        return np.zeros(0, dtype=bool)
    lengths = np.array([len(s) for s in sequences], dtype=np.int64)
    letters = np.zeros((len(rule_sets), max(int(lengths.max()), 1)), dtype=np.int64)
    for i, (r, seq) in enumerate(zip(rule_sets, sequences, strict=True)):
        letters[i, : len(seq)] = r.letters(seq)
    distinct = list({id(r): r for r in rule_sets}.values())
    which = {id(r): k for k, r in enumerate(distinct)}
    packed = PackedDFAs([r.dfa for r in distinct])
    return ~packed.check(np.array([which[id(r)] for r in rule_sets]), letters, lengths)


def checker_loss(
    log_probs: torch.Tensor, lengths: torch.Tensor, rule_sets: Sequence[RuleSet]
) -> torch.Tensor:
    """1.0 [N] where the argmax sequence of `log_probs` [N, T, V] violates its rule set."""
    with torch.no_grad():
        best = log_probs.argmax(dim=-1).cpu().numpy()
    sequences = [best[i, :n] for i, n in enumerate(lengths.tolist())]
    bad = violates(rule_sets, sequences)
    return torch.as_tensor(bad, dtype=log_probs.dtype, device=log_probs.device)
