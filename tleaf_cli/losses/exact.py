"""The exact logic loss: −log P(a sequence drawn from the model's outputs satisfies φ).

The model's outputs are independent across steps given its inputs, so the probability that a
sequence w drawn step by step from P_t satisfies φ is the forward algorithm over φ's DFA:

    α_0 = 1[initial],   α_t(s') = Σ_{(s, l): δ(s, l) = s'} α_{t−1}(s) · P_t(l),
    P(w ⊨ φ) = Σ_{s ∈ F} α_T(s).

Computed in log space: each step scatters the S·L terms log α(s) + log P_t(l) into their target
states as a log-sum-exp per state (O(S·L) per step, not the O(S·L·S) of a transition tensor:
whole-video rule sets reach hundreds of states). Log space keeps a sequence the model is sure
violates φ at a finite loss with a gradient, in float32, where a product of probabilities would
need float64 and a floor (1e-300, −log = 690.8) to stay finite.

The rows of a batch run together without padding: their states are laid end to end in one
vector and their (state, letter) arcs in one list, so a batch with one large rule set and many
small ones costs the arcs it has, not rows × the largest set's arcs.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import torch

from tleaf_cli.losses.packed import NEG, PackedRuleSets
from tleaf_cli.rule_set import RuleSet


def exact_loss(
    letters: torch.Tensor, lengths: torch.Tensor, packed: PackedRuleSets, rows: torch.Tensor
) -> torch.Tensor:
    """−log P(w ⊨ φ_rows[i]) [N] for letter log-probabilities [N, T, L] (`packed.
    letter_log_probs`); steps at or past lengths[i] are not read."""
    n, _, width = letters.shape
    if not n:
        return letters.new_zeros(0)
    arcs = _arcs([packed.rule_sets[j] for j in rows.tolist()], width)
    source, letter, target, row_of, accepting, initial = (
        torch.as_tensor(a, device=letters.device) for a in arcs
    )
    states = len(row_of)
    alpha = letters.new_full((states,), NEG).index_fill(0, initial, 0.0)
    steps = int(lengths.max())
    running = torch.arange(steps, device=letters.device)[:, None] < lengths[row_of]  # [T, states]
    # every step's arc letters in one gather [T, arcs], unbound once: indexing step t in the
    # loop would give a full-size gradient each
    on_arcs = letters[:, :steps].transpose(0, 1).flatten(1)[:, letter]
    # the scatters start from these (out of place: each step's result is a new tensor), and
    # gathers are index_select: the same values in fewer operators each way than indexing
    lowest, zeros = letters.new_full((states,), NEG), letters.new_zeros(states)
    for at_t, running_t in zip(on_arcs.unbind(0), running.unbind(0), strict=True):
        terms = alpha.index_select(0, source) + at_t  # [arcs]
        top = lowest.scatter_reduce(0, target, terms.detach(), "amax")
        spread = (terms - top.index_select(0, target)).exp()
        step = top + zeros.scatter_add(0, target, spread).clamp(min=1.0).log()  # reached: >= 1
        alpha = torch.where(running_t, step, alpha)
    final = torch.where(accepting, alpha, letters.new_tensor(NEG))
    top = letters.new_full((n,), NEG).scatter_reduce(0, row_of, final.detach(), "amax")
    total = letters.new_zeros(n).scatter_add(0, row_of, (final - top[row_of]).exp())
    return -(top + total.log())


def _arcs(rule_sets: list[RuleSet], width: int) -> tuple[np.ndarray, ...]:
    """The rows' DFAs end to end: each arc's source state, letter (flat index into a step's
    [rows, width] letters) and target state; each state's row and acceptance; the rows'
    initial states. States of row i are numbered from the sum of the earlier rows' states."""
    parts = [_arcs_of(r) for r in rule_sets]
    sizes = np.array([len(p[3]) for p in parts], dtype=np.int64)
    offset = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    arcs = np.array([len(p[0]) for p in parts], dtype=np.int64)
    state_shift = np.repeat(offset, arcs)
    letter_shift = np.repeat(np.arange(len(parts), dtype=np.int64) * width, arcs)
    return (
        np.concatenate([p[0] for p in parts]) + state_shift,
        np.concatenate([p[1] for p in parts]) + letter_shift,
        np.concatenate([p[2] for p in parts]) + state_shift,
        np.repeat(np.arange(len(parts), dtype=np.int64), sizes),
        np.concatenate([p[3] for p in parts]),
        offset + np.array([p[4] for p in parts], dtype=np.int64),
    )


@lru_cache(maxsize=4096)
def _arcs_of(rule_set: RuleSet) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """One DFA's arcs (source, letter, target) for every (state, letter), its accepting states
    and initial state; built once per rule set."""
    table = rule_set.dfa.table.astype(np.int64)  # [S, L]
    source, letter = np.indices(table.shape).reshape(2, -1)
    return source, letter, table.ravel(), rule_set.dfa.accepting.copy(), rule_set.dfa.initial
