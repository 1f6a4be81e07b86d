"""One satisfy/violate radius for all formulas, learned beside q_m (`--radius-weight`)."""

from __future__ import annotations

import torch
from torch import nn


class RadiusClassifier(nn.Module):
    """satisfies(φ, w) ⇔ d(z_φ, z_w) < r: the logit s · (r − d) with the radius r and the scale
    s = exp(log_scale) learned, d the squared Euclidean distance.

    Trained with binary cross-entropy on a triplet's two pairs (`loss`), it asks for what the
    triplet loss does not: one radius for every formula, satisfying traces inside it and
    violating ones outside — the distance rule the T-LEAF loss and `eval`'s distance row read —
    instead of each formula's traces merely ordered at a scale of its own.
    """

    def __init__(self, radius: float = 1.0) -> None:
        super().__init__()
        self.radius = nn.Parameter(torch.tensor(float(radius)))
        self.log_scale = nn.Parameter(torch.tensor(0.0))

    def forward(self, anchor: torch.Tensor, other: torch.Tensor) -> torch.Tensor:
        d = (anchor - other).pow(2).sum(dim=1)
        return self.log_scale.exp() * (self.radius - d)

    def loss(self, anchor, positive, negative) -> torch.Tensor:
        logits = torch.cat([self(anchor, positive), self(anchor, negative)])
        target = torch.cat([torch.ones(len(anchor)), torch.zeros(len(anchor))]).to(logits)
        return nn.functional.binary_cross_entropy_with_logits(logits, target)
