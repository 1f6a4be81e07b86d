"""The target model h of the action-recognition task (the paper's Fig. 4A, sized for a CPU).

Per-step features [B, T, D] go through a backbone that mixes information across steps, then two
independent heads — each a one-layer bidirectional LSTM and a linear layer — give action logits
[B, T, A] and ingredient logits [B, T, I]. Backbones:

* ``lstm``: a bidirectional LSTM (the paper's uses 1024 units; 128 by default here);
* ``tcn``: a stack of non-causal dilated 1-d convolutions (dilation 1, 2, 4, ...) with residual
  connections, a temporal convolution network as in Bai et al. (the paper: 3 layers, 800 units).

Videos in a batch are padded to the longest; `lengths` keeps padding out of every LSTM (packed
sequences) and out of the convolutions (padded steps are zeroed before each layer).
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn.utils.rnn import pack_padded_sequence, pad_packed_sequence

from tleaf_cli.errors import SettingError
from tleaf_cli.settings.action_recognition import MODELS


def _mask(x: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
    """bool [B, T, 1]: the step exists (not padding)."""
    steps = torch.arange(x.shape[1], device=x.device)
    return (steps[None, :] < lengths.to(x.device)[:, None]).unsqueeze(-1)


class BiLSTM(nn.Module):
    """A bidirectional LSTM over padded sequences: [B, T, D] -> [B, T, 2 * hidden]."""

    def __init__(self, in_dim: int, hidden: int, layers: int = 1) -> None:
        super().__init__()
        self.lstm = nn.LSTM(in_dim, hidden, layers, batch_first=True, bidirectional=True)

    def forward(self, x: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        packed = pack_padded_sequence(x, lengths.cpu(), batch_first=True, enforce_sorted=False)
        out, _ = self.lstm(packed)
        out, _ = pad_packed_sequence(out, batch_first=True, total_length=x.shape[1])
        return out


class TCN(nn.Module):
    """Dilated non-causal 1-d convolutions with residuals: [B, T, D] -> [B, T, hidden]."""

    def __init__(self, in_dim: int, hidden: int, layers: int = 3, kernel: int = 3) -> None:
        super().__init__()
        self.inp = nn.Linear(in_dim, hidden)
        self.convs = nn.ModuleList(
            nn.Conv1d(hidden, hidden, kernel, dilation=2**k, padding=(kernel - 1) * 2**k // 2)
            for k in range(layers)
        )

    def forward(self, x: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        mask = _mask(x, lengths)
        h = self.inp(x) * mask
        for conv in self.convs:
            h = (h + torch.relu(conv(h.transpose(1, 2)).transpose(1, 2))) * mask
        return h


class ActionRecognizer(nn.Module):
    """h: per-step features -> (action logits [B, T, A], ingredient logits [B, T, I])."""

    def __init__(
        self,
        model: str,
        feature_dim: int,
        num_actions: int,
        num_ingredients: int,
        hidden: int = 128,
        head_hidden: int = 64,
        dropout: float = 0.2,
    ) -> None:
        super().__init__()
        if model == "lstm":
            self.backbone: nn.Module = BiLSTM(feature_dim, hidden)
            width = 2 * hidden
        elif model == "tcn":
            self.backbone = TCN(feature_dim, hidden)
            width = hidden
        else:
            raise SettingError("model", f"must be one of {', '.join(MODELS)}, not {model!r}")
        self.dropout = nn.Dropout(dropout)
        self.action_rnn = BiLSTM(width, head_hidden)
        self.ingredient_rnn = BiLSTM(width, head_hidden)
        self.action_out = nn.Linear(2 * head_hidden, num_actions)
        self.ingredient_out = nn.Linear(2 * head_hidden, num_ingredients)

    @classmethod
    def from_config(cls, config: dict) -> ActionRecognizer:
        """The untrained model a run's config.json describes (its weights load apart)."""
        s = config["settings"]
        return cls(
            s["model"],
            int(config["feature_dim"]),
            len(config["actions"]),
            len(config["ingredients"]),
            hidden=s["hidden"],
            head_hidden=s["head_hidden"],
            dropout=s["dropout"],
        )

    def forward(
        self, features: torch.Tensor, lengths: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        z = self.dropout(self.backbone(features, lengths))
        actions = self.action_out(self.action_rnn(z, lengths))
        ingredients = self.ingredient_out(self.ingredient_rnn(z, lengths))
        return actions, ingredients
