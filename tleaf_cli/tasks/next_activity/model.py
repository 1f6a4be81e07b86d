"""The next-activity model: a causal LSTM in the shape of Tax et al.'s (CAiSE 2017).

Each step reads its event — the activity one-hot [V] and its features [F] (the time features,
then any attributes read as inputs: `encoding.Encoder.features`) — through `layers` stacked LSTM
layers of `hidden` units (dropout between them), and a linear layer gives logits over the V
activities and the end of case [B, T, V + 1]. The LSTM runs forward only, so step t sees events
1..t: the logits at step t are the prediction for prefix a_1..a_t. Tax et al. split the second
layer into one per output (activity, time); tleaf predicts no times, so one stack serves. With
event attributes (`value_counts`), each event also reads its values and `heads` predict the next
event's (attribute_heads.py).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import nn
from torch.nn.utils.rnn import pack_padded_sequence, pad_packed_sequence

from tleaf_cli.tasks.next_activity.attribute_heads import AttributeHeads, AttributeInputs
from tleaf_cli.tasks.next_activity.prefix_table import PrefixTable
from tleaf_cli.tasks.next_activity.transformer import NextActivityTransformer


class NextActivityLSTM(nn.Module):
    """(activities [B, T] long, times [B, T, F], lengths [B]) -> logits [B, T, V + 1].

    Args:
        num_activities: V; index V of the output is the end of case.
        time_features: F, the features per event (`Encoder.feature_count`: time and inputs).
        hidden: units of each LSTM layer.
        layers: stacked LSTM layers.
        dropout: dropout on the LSTM's input and between its layers.
        value_counts: per event attribute read and predicted, its value indices (R_k + 1,
            attribute_heads.py): each read as an embedding of `ATTRIBUTE_WIDTH` units beside
            the one-hot, and predicted by `heads`. Empty: activities and times only.
    """

    ATTRIBUTE_WIDTH = 16

    def __init__(
        self,
        num_activities: int,
        time_features: int,
        hidden: int,
        layers: int,
        dropout: float,
        value_counts: Sequence[int] = (),
    ) -> None:
        super().__init__()
        self.num_activities = num_activities
        self.dropout = nn.Dropout(dropout)
        width = self.ATTRIBUTE_WIDTH if value_counts else 0
        self.values = AttributeInputs(value_counts, width)
        self.lstm = nn.LSTM(
            num_activities + time_features + width,
            hidden,
            layers,
            batch_first=True,
            dropout=dropout if layers > 1 else 0.0,
        )
        self.out = nn.Linear(hidden, num_activities + 1)
        self.heads = AttributeHeads(hidden, num_activities, value_counts)

    def states(
        self,
        activities: torch.Tensor,
        times: torch.Tensor,
        lengths: torch.Tensor,
        values: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """h [B, T, hidden]: the state after each event, what `out` and `heads` read."""
        h, _ = self.run(self.inputs(activities, times, values), lengths)
        return h

    def inputs(
        self, activities: torch.Tensor, times: torch.Tensor, values: torch.Tensor | None = None
    ) -> torch.Tensor:
        """x [B, T, input width]: what the LSTM reads at each event (the activity one-hot, its
        features, its attribute values' embedding), after dropout."""
        onehot = nn.functional.one_hot(activities.clamp(min=0), self.num_activities)
        parts = [onehot.to(times.dtype), times, self.values(values, times).to(times.dtype)]
        return self.dropout(torch.cat(parts, dim=-1))

    def run(
        self,
        x: torch.Tensor,
        lengths: torch.Tensor,
        state: tuple[torch.Tensor, torch.Tensor] | None = None,
    ) -> tuple[torch.Tensor, tuple[torch.Tensor, torch.Tensor]]:
        """The LSTM over inputs x [B, T, ·] of `lengths`, from `state` (h, c [layers, B,
        hidden]; zeros where None): h [B, T, hidden] after dropout, and the state after each
        row's last event (so a row can be continued by one more event later)."""
        packed = pack_padded_sequence(x, lengths.cpu(), batch_first=True, enforce_sorted=False)
        h, last = self.lstm(packed, state)
        h, _ = pad_packed_sequence(h, batch_first=True, total_length=x.shape[1])
        return self.dropout(h), last

    def forward(
        self,
        activities: torch.Tensor,
        times: torch.Tensor,
        lengths: torch.Tensor,
        values: torch.Tensor | None = None,
    ) -> torch.Tensor:
        return self.out(self.states(activities, times, lengths, values))


# Every next-activity model: the same inputs, the same logits [B, T, V + 1] (settings' `model`)
NextActivityModel = NextActivityLSTM | NextActivityTransformer | PrefixTable
