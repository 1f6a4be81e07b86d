"""Adapters: a model's heads as per-step log-probabilities over one one-hot vocabulary.

`logic_loss` reads `log_probs` [B, T, V]. A policy's action logits are already that, after a
log-softmax. A model with two independent heads — an action and an ingredient per step, as the
paper's action recogniser — gives the distribution over (action, ingredient) pairs

    P_t(a, i) = softmax(action_logits_t)_a · softmax(ingredient_logits_t)_i ,

a vocabulary of A·I pair atoms, pair (a, i) at position a·I + i (`pair_vocabulary`).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch

from tleaf_cli.knowledge.base import atom


def pair_log_probs(action_logits: torch.Tensor, ingredient_logits: torch.Tensor) -> torch.Tensor:
    """log P_t(a, i) = log_softmax_a + log_softmax_i, flattened: [..., T, A·I] (pair a·I + i)."""
    la = torch.log_softmax(action_logits, dim=-1)
    li = torch.log_softmax(ingredient_logits, dim=-1)
    return (la.unsqueeze(-1) + li.unsqueeze(-2)).flatten(-2)


def pair_vocabulary(actions: Sequence[str], ingredients: Sequence[str]) -> list[str]:
    """The pair atoms in `pair_log_probs` order: `action_ingredient` (the knowledge bases'
    atoms, `knowledge.base.atom`) of actions[a] and ingredients[i] at position a·I + i."""
    return [atom(a, i) for a in actions for i in ingredients]
