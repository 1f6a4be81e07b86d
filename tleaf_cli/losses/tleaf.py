"""The T-LEAF logic loss: ‖q(A_φ) − q(w̃)‖², the paper's ℓ_logic.

q = (q_e, q_m) is a trained, frozen embedder (`embed.embedder.Embedder`). q(A_φ) embeds φ's DFA (or
its formula, for the syntax baseline); w̃ is the soft trace of the model's outputs, a chain
whose step-t edge node carries the expected letter vector Σ_l P_t(l) q_e(l) over φ's one-hot
letters — exactly the discrete letter's vector when P_t is one-hot, and differentiable in P_t
throughout. Gradients reach the model through P_t only; q's weights never change.

What does not depend on the outputs is computed once per rule set and kept by the embedder:
q(A_φ), the letters' q_e vectors, the monitors' walk (the same for every rule set with as many
atoms). A batch is then a few batched products (expected letters, monitor edge weights), the
monitors' steps, and one q_m call on all the rows' chains together.
"""

from __future__ import annotations

import torch

from tleaf_cli.embed.embedder import Embedder
from tleaf_cli.embed.soft_monitors import soft_monitor_walk
from tleaf_cli.embed.soft_traces import soft_trace_vectors
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
    device = letters.device
    width = letters.shape[-1]
    formula_vectors, letter_table = embedder.rule_set_vectors(packed.rule_sets)
    # [N, T, d_e]: padded letters have probability 0 and a zero vector
    probs = letters.exp()
    table = letter_table.to(device)[rows]
    if table.shape[1] < width:  # the packed rule sets' padding is the letters' width
        table = torch.nn.functional.pad(table, (0, 0, 0, width - table.shape[1]))
    expected = torch.bmm(probs, table[:, :width])
    monitor = None
    walks = embedder.monitor_walks(packed.rule_sets)
    if walks is not None:  # a q with monitors reads the soft trace's monitor features too
        bank = embedder.model.trace.monitor_bank
        walks = [walks[r] for r in rows.tolist()]
        monitor = soft_monitor_walk(bank, probs, lengths, walks)
    z_trace = soft_trace_vectors(embedder.model, expected, lengths, monitor)
    return (z_trace - formula_vectors.to(device)[rows]).pow(2).sum(dim=1)
