"""What the edge and meta embedders give the training loop (`training.fit`): the triplet loss,
its accuracy and the triplet step.

A batch is embedded as (anchor, positive, negative); the loss is the triplet loss (plus a
trainer's extra terms), and the figures reported per epoch are the loss and the share of the
batch's triplets already in order, d(anchor, positive) < d(anchor, negative), both weighted by
the batch's size. Their held-out score is the same accuracy on triplets never trained on.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import torch

from tleaf_cli.training.loop import Step

Triplet = tuple[torch.Tensor, torch.Tensor, torch.Tensor]
SCORE = "heldout_accuracy"  # the loop's name for the embedders' held-out (or val) accuracy


def triplet_loss(
    anchor, positive, negative, margin: float, distance: str = "squared"
) -> torch.Tensor:
    """mean max(d(a, p) - d(a, n) + m, 0) with d the squared Euclidean distance, or with
    `distance="euclidean"` the Euclidean one (torch's `TripletMarginLoss(margin, p=2)`, the
    authors' code).

    The paper prints the two distances the other way round, which would pull violating traces
    closer; this is the form that does what its text says.
    """
    if distance == "euclidean":
        return torch.nn.functional.triplet_margin_loss(anchor, positive, negative, margin, p=2)
    d_pos = (anchor - positive).pow(2).sum(dim=1)
    d_neg = (anchor - negative).pow(2).sum(dim=1)
    return torch.relu(d_pos - d_neg + margin).mean()


def anchor_pull(anchor, positive) -> torch.Tensor:
    """mean d(a, p): pulls satisfying traces onto their formula, not just nearer than violating.

    The triplet loss only orders distances, so q(A_φ) may sit far from all of its traces (on the
    action-recognition rule sets, d ≈ 15 for satisfying and ≈ 15.8 for violating traces). A loss
    that reads the distance itself, ‖q(A_φ) − q(w̃)‖², then mostly pulls towards wherever q(A_φ)
    lies; with this term added (weight `--pull`), small distance means satisfying.
    """
    return (anchor - positive).pow(2).sum(dim=1).mean()


def triplet_accuracy(anchor, positive, negative) -> float:
    """Share of triplets with d(a, p) < d(a, n)."""
    d_pos = (anchor - positive).pow(2).sum(dim=1)
    d_neg = (anchor - negative).pow(2).sum(dim=1)
    return float((d_pos < d_neg).float().mean())


@dataclass
class EpochReport:
    """One epoch of an embedder, as `on_epoch` callbacks receive it (the loop's record)."""

    epoch: int
    loss: float
    train_accuracy: float
    seconds: float  # training time of the epoch, without the held-out evaluation
    heldout_accuracy: float


def triplet_step(
    embed: Callable[[Any], Triplet],
    margin: float,
    extra_loss: Callable[[Triplet], torch.Tensor] | None = None,
    distance: str = "squared",
) -> Callable[[Any], Step]:
    """The loop's `step` for batches that `embed` turns into (anchor, positive, negative);
    `extra_loss`, when given, is added to the triplet loss (on `distance`) of every batch."""

    def step(batch: Any) -> Step:
        anchor, pos, neg = embed(batch)
        loss = triplet_loss(anchor, pos, neg, margin, distance)
        if extra_loss is not None:
            loss = loss + extra_loss((anchor, pos, neg))
        accuracy = triplet_accuracy(anchor.detach(), pos.detach(), neg.detach())
        return Step(loss, {"loss": loss.item(), "train_accuracy": accuracy}, anchor.shape[0])

    return step


def reporting(
    on_epoch: Callable[[EpochReport], None] | None,
) -> Callable[[dict[str, Any]], None] | None:
    """The loop's `on_epoch` that hands each record to `on_epoch` as an EpochReport."""
    if on_epoch is None:
        return None
    return lambda record: on_epoch(EpochReport(**record))
