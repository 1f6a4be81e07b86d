"""A batch of padded videos for the action recogniser h (training and scoring)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import torch

from tleaf_cli.tasks.action_recognition.activities import Video


@dataclass
class Batch:
    """Padded videos: features [B, T, D], labels [B, T] (-100 on padding), lengths [B]."""

    videos: list[Video]
    features: torch.Tensor
    actions: torch.Tensor
    ingredients: torch.Tensor
    lengths: torch.Tensor

    @classmethod
    def of(cls, videos: Sequence[Video], device: torch.device) -> Batch:
        lengths = torch.tensor([len(v) for v in videos], dtype=torch.long)
        width, dim = int(lengths.max()), videos[0].features.shape[1]
        features = torch.zeros((len(videos), width, dim))
        actions = torch.full((len(videos), width), -100, dtype=torch.long)
        ingredients = torch.full((len(videos), width), -100, dtype=torch.long)
        for b, v in enumerate(videos):
            features[b, : len(v)] = torch.from_numpy(v.features)
            actions[b, : len(v)] = torch.from_numpy(v.actions)
            ingredients[b, : len(v)] = torch.from_numpy(v.ingredients)
        return cls(
            list(videos),
            features.to(device),
            actions.to(device),
            ingredients.to(device),
            lengths.to(device),
        )
