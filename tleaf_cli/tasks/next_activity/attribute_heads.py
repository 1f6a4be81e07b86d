"""Event attributes in a next-activity model: read as inputs, predicted as outputs.

The field's leaders read more than the activity (Camargo et al. 2019, Theis and Darabi 2019: the
resource); the neuro-symbolic suffix predictor NeSy4PPM (Oukharijane, Donadello, Maggi) predicts
the resource beside the activity. Here each kept event attribute k (e.g. `org:resource`) with
R_k training values (index 0: none or a value training never saw) is

- an **input**: a learned embedding of the event's value (`AttributeInputs`), beside the
  activity and the time features;
- an **output head** (`AttributeHeads`): the next event's value given the model's state h_t and
  the next event's activity a,

      logits_k(h_t, a) = W_k h_t + b_k + U_k[a]       [R_k],

  so p(a, v | prefix) = p(a | prefix) · Π_k p(v_k | prefix, a): which resource works next depends
  on what is done next. Training reads the true next activity (teacher forcing); suffix
  prediction scores every (activity, values) pair at once (`every`), as joint tokens
  (joint_tokens.py).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import nn


class AttributeInputs(nn.Module):
    """values [B, T, K] (indices, 0: none) -> [B, T, width]: the sum of each attribute's value
    embedding (zeros for K = 0).

    Args:
        value_counts: per attribute, R_k + 1 (its training values and the none index 0).
        width: the embedding width (the model's input width it is added to, or concatenated).
    """

    def __init__(self, value_counts: Sequence[int], width: int) -> None:
        super().__init__()
        self.width = width
        self.embeddings = nn.ModuleList(nn.Embedding(n, width) for n in value_counts)

    def forward(self, values: torch.Tensor | None, like: torch.Tensor) -> torch.Tensor:
        out = like.new_zeros((*like.shape[:2], self.width))
        if values is None:
            return out
        for k, embedding in enumerate(self.embeddings):
            out = out + embedding(values[..., k].clamp(min=0))
        return out


class AttributeHeads(nn.Module):
    """The next event's attribute values given the state and its activity (module docstring).

    Args:
        hidden: the width of the model's state h.
        num_activities: V; index V (the end of the case) is accepted and has its own offset.
        value_counts: per attribute, R_k + 1 (index 0: none, never a target).
    """

    def __init__(self, hidden: int, num_activities: int, value_counts: Sequence[int]) -> None:
        super().__init__()
        self.num_activities = num_activities
        self.state = nn.ModuleList(nn.Linear(hidden, n) for n in value_counts)
        self.activity = nn.ModuleList(nn.Embedding(num_activities + 1, n) for n in value_counts)

    def forward(self, h: torch.Tensor, next_activity: torch.Tensor) -> list[torch.Tensor]:
        """Per attribute, logits [..., R_k + 1] for states h [..., H] and the next activities
        [...] (PAD or any negative index read as 0: its rows are not scored)."""
        given = next_activity.clamp(min=0)
        return [
            state(h) + activity(given)
            for state, activity in zip(self.state, self.activity, strict=True)
        ]

    def every(self, h: torch.Tensor) -> list[torch.Tensor]:
        """Per attribute, log-probabilities [N, V, R_k + 1] of its next value for each of the V
        activities that may come next, for states h [N, H]."""
        v = self.num_activities
        return [
            torch.log_softmax(state(h)[:, None, :] + activity.weight[None, :v, :], dim=-1)
            for state, activity in zip(self.state, self.activity, strict=True)
        ]
