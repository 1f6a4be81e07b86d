"""Settings of the edge embedder q_e (`tleaf train-edge`). Pure Python: the command line builds
train-edge's options from this module."""

from __future__ import annotations

from dataclasses import dataclass

from tleaf_cli.settings import DEVICES, setting

ATOM_FEATURE_KINDS = ("onehot", "random", "text")


@dataclass(frozen=True)
class EdgeSettings:
    """Every setting of q_e's training (saved as config.json's "settings")."""

    atom_features: str = setting(
        "onehot",
        "Atom node features: onehot (over the vocabulary), random, or text (the atom's name "
        "through a packaged sentence model; needs tleaf\\[text]).",
        choices=ATOM_FEATURE_KINDS,
    )
    feature_dim: int = 64  # for random features
    per_guard: int = setting(
        4, "Triplets (guard, satisfying letter, violating letter) per distinct guard.", min=1
    )
    hidden: int = setting(256, "GCN width.", min=1)
    layers: int = setting(2, "GCN layers.", min=1)
    out_dim: int = setting(100, "Embedding size.", min=1)
    margin: float = setting(1.0, "Triplet loss margin.")
    lr: float = setting(1e-3, "Adam learning rate.")
    batch_size: int = setting(128, "Triplets per batch.", min=1)
    epochs: int = setting(30, "Most epochs to train.", min=1)
    patience: int | None = setting(
        5, "Stop after this many epochs without a better held-out score.", min=1
    )
    random_guards: int = 2  # random CNFs per formula, besides its guards
    holdout: float = 0.2  # share of formulas held out
    seed: int = setting(0, "Random seed; the same seed writes the same model.")
    device: str = setting("cpu", "Where to compute.", choices=DEVICES)
    max_minutes: float | None = setting(
        None, "Stop after the epoch that passes this budget.", auto="none"
    )
