"""The T-LEAF logic loss: ‖q(A_φ) − q(w̃)‖², the paper's ℓ_logic.

q = (q_e, q_m) is a trained, frozen embedder (`embed.soft.Embedder`). q(A_φ) embeds φ's DFA (or
its formula, for the syntax baseline); w̃ is the soft trace of the model's outputs, a chain
whose step-t edge node carries the expected letter vector Σ_l P_t(l) q_e(l) over φ's one-hot
letters — exactly the discrete letter's vector when P_t is one-hot, and differentiable in P_t
throughout. Gradients reach the model through P_t only; q's weights never change.
"""

from __future__ import annotations

import torch

from tleaf_cli.embed.soft import Embedder, soft_trace_vectors
from tleaf_cli.embed.soft_monitors import soft_monitor_features
from tleaf_cli.losses.packed import PackedRuleSets


def tleaf_loss(
    letters: torch.Tensor,
    lengths: torch.Tensor,
    packed: PackedRuleSets,
    rows: torch.Tensor,
    embedder: Embedder,
) -> torch.Tensor:
    """‖q(A_φ) − q(w̃)‖² [N] for letter log-probabilities [N, T, L] (`packed.letter_log_probs`);
    every row's soft trace through q_m in one graph batch. Each rule set is embedded once per
    embedder (cached by the embedder)."""
    formula_vectors, letter_table = embedder.rule_set_vectors(packed.rule_sets)
    device = letters.device
    # [N, T, d_e]: padded letters have probability 0 and a zero vector
    probs = letters.exp()
    expected = probs @ letter_table.to(device)[rows]
    classes = embedder.monitor_classes(packed.rule_sets, letters.shape[-1])
    monitor = None
    if classes is not None:  # a q with monitors reads the soft trace's monitor features too
        bank = embedder.model.trace.monitor_bank
        monitor = soft_monitor_features(bank, probs, lengths, classes[0][rows], classes[1][rows])
    z_trace = soft_trace_vectors(embedder.model, expected, lengths, monitor)
    return (z_trace - formula_vectors.to(device)[rows]).pow(2).sum(dim=1)
