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
"""

from __future__ import annotations

import torch

from tleaf_cli.losses.packed import NEG, PackedRuleSets


def exact_loss(
    letters: torch.Tensor, lengths: torch.Tensor, packed: PackedRuleSets, rows: torch.Tensor
) -> torch.Tensor:
    """−log P(w ⊨ φ_rows[i]) [N] for letter log-probabilities [N, T, L] (`packed.
    letter_log_probs`); steps at or past lengths[i] are not read."""
    n = letters.shape[0]
    states = packed.num_states
    targets = packed.targets[rows].flatten(1)  # [N, S·L], the sink state S for padding
    alpha = letters.new_full((n, states), NEG)
    alpha[torch.arange(n, device=letters.device), packed.initial[rows]] = 0.0
    steps = int(lengths.max()) if n else 0
    running = torch.arange(steps, device=letters.device)[:, None, None] < lengths[:, None]
    # the steps unbound once: indexing step t in the loop would give a full-size gradient each
    for t, at_t in enumerate(letters[:, :steps].unbind(1)):
        terms = (alpha[:, :, None] + at_t[:, None, :]).flatten(1)  # [N, S·L]
        top = letters.new_full((n, states + 1), NEG)
        top = top.scatter_reduce(1, targets, terms.detach(), "amax")
        sums = letters.new_zeros((n, states + 1))
        sums = sums.scatter_add(1, targets, (terms - top.gather(1, targets)).exp())
        step = (top + sums.clamp(min=1.0).log())[:, :states]  # a reached state's sum is >= 1
        alpha = torch.where(running[t], step, alpha)
    final = torch.where(packed.accepting[rows], alpha, letters.new_tensor(NEG))
    return -torch.logsumexp(final, dim=1)
