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
        self._signs: dict[tuple, torch.Tensor] = {}  # (triplets, device) -> [-1] * B + [1] * B

    def forward(self, anchor: torch.Tensor, other: torch.Tensor) -> torch.Tensor:
        d = (anchor - other).pow(2).sum(dim=1)
        return self.log_scale.exp() * (self.radius - d)

    def loss(self, anchor, positive, negative) -> torch.Tensor:
        return self.loss_of_distances(
            torch.cat([(anchor - z).pow(2).sum(dim=1) for z in (positive, negative)])
        )

    def loss_of_distances(self, distances: torch.Tensor) -> torch.Tensor:
        """`loss` from the squared distances [2 B] of B triplets' positive pairs, then their
        negative pairs: binary cross-entropy of the logits, written as mean softplus(∓ logit)
        (− for the positive pairs, whose target is 1), three operators where torch's
        `binary_cross_entropy_with_logits` launches about twenty."""
        logits = self.log_scale.exp() * (self.radius - distances)
        half = distances.shape[0] // 2
        sign = self._signs.get((half, distances.device))
        if sign is None:
            sign = torch.cat([-torch.ones(half), torch.ones(half)]).to(distances)
            self._signs[(half, distances.device)] = sign
        return nn.functional.softplus(logits * sign).mean()
