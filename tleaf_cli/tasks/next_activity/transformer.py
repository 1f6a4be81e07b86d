"""A small causal Transformer for next-activity prediction, of ProcessTransformer's size (Bukhsh,
Saeed and Dijkman, 2021: one or two blocks, 4 heads, a few dozen units).

Each event is read as a learned embedding of its activity plus a linear map of its time features
(`encoding.Encoder.features`: the time features, then any inputs), plus the sinusoidal encoding
of its position (Vaswani et al., 2017: no longest case to fix beforehand); `layers` pre-norm
Transformer blocks with a causal mask (step t attends to events 1..t only) and a linear layer
give logits over the V activities and the end of case [B, T, V + 1], the same contract as
`model.NextActivityLSTM`, so the loss, the rules and the suffix search read it alike.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch
from torch import nn

from tleaf_cli.tasks.next_activity.attribute_heads import AttributeHeads, AttributeInputs


class NextActivityTransformer(nn.Module):
    """(activities [B, T] long, times [B, T, F], lengths [B]) -> logits [B, T, V + 1].

    Args:
        num_activities: V; index V of the output is the end of case.
        time_features: F, the features per event (`Encoder.feature_count`: time and inputs).
        width: d_model, the width of every block (a multiple of `heads`).
        layers: Transformer blocks.
        heads: attention heads per block.
        dropout: dropout on the input and inside the blocks.
        feedforward: the blocks' feed-forward width (default 2 · width).
        value_counts: per event attribute read and predicted, its value indices (R_k + 1,
            attribute_heads.py): each value's embedding is added to the event's, and `heads`
            predict the next event's. Empty: activities and times only.
    """

    def __init__(
        self,
        num_activities: int,
        time_features: int,
        width: int,
        layers: int,
        heads: int,
        dropout: float,
        feedforward: int | None = None,
        value_counts: Sequence[int] = (),
    ) -> None:
        super().__init__()
        if width % heads:
            raise ValueError(f"width {width} is not a multiple of heads {heads}")
        self.num_activities = num_activities
        self.width = width
        self.activity = nn.Embedding(num_activities, width)
        self.time = nn.Linear(time_features, width)
        self.dropout = nn.Dropout(dropout)
        block = nn.TransformerEncoderLayer(
            width, heads, feedforward or 2 * width, dropout, batch_first=True, norm_first=True
        )
        self.blocks = nn.TransformerEncoder(block, layers, enable_nested_tensor=False)
        self.norm = nn.LayerNorm(width)
        self.out = nn.Linear(width, num_activities + 1)
        self.values = AttributeInputs(value_counts, width)
        self.heads = AttributeHeads(width, num_activities, value_counts)

    def positions(self, steps: int, device: torch.device) -> torch.Tensor:
        """The sinusoidal encoding of positions 0..steps-1 [steps, width]."""
        position = torch.arange(steps, device=device, dtype=torch.float32)[:, None]
        rate = torch.exp(
            torch.arange(0, self.width, 2, device=device, dtype=torch.float32)
            * (-math.log(10_000.0) / self.width)
        )
        out = torch.zeros(steps, self.width, device=device)
        out[:, 0::2] = torch.sin(position * rate)
        out[:, 1::2] = torch.cos(position * rate[: self.width // 2])
        return out

    def states(
        self,
        activities: torch.Tensor,
        times: torch.Tensor,
        lengths: torch.Tensor,
        values: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """h [B, T, width]: the state after each event, what `out` and `heads` read."""
        steps = activities.shape[1]
        x = self.activity(activities.clamp(min=0)) + self.time(times.to(self.time.weight.dtype))
        x = self.dropout(x + self.values(values, x) + self.positions(steps, x.device))
        causal = torch.ones(steps, steps, dtype=torch.bool, device=x.device).triu(1)
        padded = torch.arange(steps, device=x.device)[None, :] >= lengths.to(x.device)[:, None]
        h = self.blocks(x, mask=causal, src_key_padding_mask=padded, is_causal=True)
        return self.dropout(self.norm(h))

    def forward(
        self,
        activities: torch.Tensor,
        times: torch.Tensor,
        lengths: torch.Tensor,
        values: torch.Tensor | None = None,
    ) -> torch.Tensor:
        return self.out(self.states(activities, times, lengths, values))
