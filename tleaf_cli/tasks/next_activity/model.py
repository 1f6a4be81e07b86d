"""The next-activity model: a causal LSTM in the shape of Tax et al.'s (CAiSE 2017).

Each step reads its event — the activity one-hot [V] and its time features [F]
(`encoding.TIME_FEATURES`) — through `layers` stacked LSTM layers of `hidden` units (dropout
between them), and a linear layer gives logits over the V activities and the end of case
[B, T, V + 1]. The LSTM runs forward only, so step t sees events 1..t: the logits at step t are
the prediction for prefix a_1..a_t. Tax et al. split the second layer into one per output
(activity, time); tleaf predicts no times, so one stack serves.
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn.utils.rnn import pack_padded_sequence, pad_packed_sequence

from tleaf_cli.tasks.next_activity.prefix_table import PrefixTable
from tleaf_cli.tasks.next_activity.transformer import NextActivityTransformer


class NextActivityLSTM(nn.Module):
    """(activities [B, T] long, times [B, T, F], lengths [B]) -> logits [B, T, V + 1].

    Args:
        num_activities: V; index V of the output is the end of case.
        time_features: F, the time features per event.
        hidden: units of each LSTM layer.
        layers: stacked LSTM layers.
        dropout: dropout on the LSTM's input and between its layers.
    """

    def __init__(
        self, num_activities: int, time_features: int, hidden: int, layers: int, dropout: float
    ) -> None:
        super().__init__()
        self.num_activities = num_activities
        self.dropout = nn.Dropout(dropout)
        self.lstm = nn.LSTM(
            num_activities + time_features,
            hidden,
            layers,
            batch_first=True,
            dropout=dropout if layers > 1 else 0.0,
        )
        self.out = nn.Linear(hidden, num_activities + 1)

    def forward(
        self, activities: torch.Tensor, times: torch.Tensor, lengths: torch.Tensor
    ) -> torch.Tensor:
        onehot = nn.functional.one_hot(activities.clamp(min=0), self.num_activities)
        x = self.dropout(torch.cat([onehot.to(times.dtype), times], dim=-1))
        packed = pack_padded_sequence(x, lengths.cpu(), batch_first=True, enforce_sorted=False)
        h, _ = self.lstm(packed)
        h, _ = pad_packed_sequence(h, batch_first=True, total_length=x.shape[1])
        return self.out(self.dropout(h))


# Every next-activity model: the same inputs, the same logits [B, T, V + 1] (settings' `model`)
NextActivityModel = NextActivityLSTM | NextActivityTransformer | PrefixTable
