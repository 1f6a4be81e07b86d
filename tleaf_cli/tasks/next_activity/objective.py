"""ℓ_logic of a batch of cases: the rules on each case's soft trace (`tl.logic_loss`).

The model reads a case a_1..a_n with its true prefixes (teacher forcing) and gives, at step t,
P_t = P(a_{t+1} | a_1..a_t). A case's **soft trace** w̃ has n positions:

    w̃_1 = the one-hot of a_1 (observed: the model does not predict a case's first activity),
    w̃_{t+1} = P_t restricted to the activities and renormalised (t = 1..n−1),

so position t+1 is what the model expects the (t+1)-th activity to be, given that the case goes
on (it does: the trace has the case's length). The end-of-case probabilities are not read.
`exact` is then −log P(w ⊨ φ) for w drawn position by position from w̃, and `tleaf` is
‖q(A_φ) − q(w̃)‖². **Independence assumption**: each P_t is conditioned on the TRUE prefix, and
the positions are treated as independent draws; the model's own joint distribution over whole
continuations (each step conditioned on the model's earlier guesses) is not what is scored.
φ is the conjunction of every rule of the knowledge base (one `RuleSet` over the activities); a
knowledge base too large for one DFA comes in parts φ = φ_1 ∧ … ∧ φ_K (`rules.Rules`), and
ℓ_logic is then the sum of the parts' losses: for `exact`, −Σ_k log P(w ⊨ φ_k), which treats
the parts as independent events (they are not: they read the same positions).

Only the training cases that **keep** φ are read: a case that breaks it (mined rules hold on
90 %, not all, of the cases) is the log's own exception, and the loss would pull its
predictions away from what happened (and −log P is unbounded where no trace of its length and
first activity keeps φ); ℓ_task alone teaches it. On a kept case the true continuation is in the
soft trace's support, so the loss is finite.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch

from tleaf_cli.losses import logic_loss
from tleaf_cli.tasks.next_activity.batch import CaseBatch
from tleaf_cli.tasks.next_activity.rules import Rules

if TYPE_CHECKING:  # q's modules load torch_geometric: only the tleaf loss needs them
    from tleaf_cli.embed.embedder import Embedder

OBSERVED = -1e4  # log-probability of the letters an observed position does not hold (exp: 0)


def soft_trace(batch: CaseBatch, logits: torch.Tensor) -> torch.Tensor:
    """log w̃ [B, T, V] of the module docstring, for logits [B, T, V + 1]."""
    activities = logits.shape[-1] - 1
    first = torch.nn.functional.one_hot(batch.activities[:, :1].clamp(min=0), activities)
    observed = torch.where(first.bool(), 0.0, OBSERVED).to(logits.dtype)
    predicted = torch.log_softmax(logits[:, :-1, :activities], dim=-1)
    return torch.cat([observed, predicted], dim=1)


def logic_term(
    kind: str,
    batch: CaseBatch,
    logits: torch.Tensor,
    rules: Rules | None,
    embedder: Embedder | None = None,
) -> torch.Tensor:
    """ℓ_logic per case [B] (zeros for `none` or without rules)."""
    out = logits.new_zeros(logits.shape[0])
    if kind == "none" or rules is None:
        return out
    activities = batch.activities.cpu().numpy()
    cases = [activities[b, :n] for b, n in enumerate(batch.lengths.tolist())]
    # a case cut for training (`max_events`) is no whole case: the rules judge whole ones
    whole = [not batch.cases or len(batch.cases[b]) == len(c) for b, c in enumerate(cases)]
    kept = np.flatnonzero(~rules.broken(cases) & np.array(whole)).tolist()
    if not kept:
        return out
    rows = torch.tensor(kept, device=logits.device)
    lengths = batch.lengths.to(logits.device)[rows]
    trace = soft_trace(batch, logits)[rows]
    values = sum(
        logic_loss(kind, trace, part, lengths, embedder, reduction="none") for part in rules.parts
    )
    return out.index_put((rows,), values)
