"""Training the edge embedder q_e with the triplet loss (`tleaf train-edge`).

Read top to bottom: settings, data, model, the shared loop (`training.fit` with the triplet
step of `triplets`), the model directory. Each triplet is
(guard G, letter that satisfies G, letter that violates G); the loss pulls q_e(G) towards the
satisfying letter and pushes it from the violating one, and held-out triplet accuracy
(d(G, sat) < d(G, unsat)) on formulas never trained on is measured after every epoch. The best
epoch's weights are kept. CPU training is repeatable for a seed.

Model directory (docs/design.md): `config.json` (architecture, settings, vocabulary, input hashes),
`weights.pt` (state_dict of the best epoch, loadable with `torch.load(weights_only=True)`),
`metrics.json` (curve and final figures), and `checkpoint.pt` (last epoch, for `resume`:
`training.fit`). `load.load_edge_model` reads the folder back.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch

from tleaf_cli.data.artifacts import describe_inputs, write_text_atomic
from tleaf_cli.data.dfa_table import read_dfas
from tleaf_cli.embed.atom_features import atom_features
from tleaf_cli.embed.edge_data import TripletStore, guard_triplets, split_by_formula, vocabulary
from tleaf_cli.embed.proposition_encoder import PropositionEncoder
from tleaf_cli.embed.triplets import (
    SCORE,
    EpochReport,
    reporting,
    triplet_accuracy,
    triplet_step,
)
from tleaf_cli.errors import InputError
from tleaf_cli.settings import check_values
from tleaf_cli.settings.edge import EdgeSettings
from tleaf_cli.training.loop import LoopSettings, chunks, device_for, fit


def train_edge(
    dfas_path: str | Path,
    out_dir: str | Path,
    settings: EdgeSettings,
    resume: bool = False,
    on_epoch: Callable[[EpochReport], None] | None = None,
) -> dict:
    out_dir = Path(out_dir)
    check_values(settings)
    torch.manual_seed(settings.seed)
    rng = np.random.default_rng(settings.seed)
    device = device_for(settings.device)

    # ---- data: triplets of propositional graphs, split by formula
    table = read_dfas(dfas_path)
    vocab = vocabulary(table)
    if not vocab:
        raise InputError(f"{dfas_path}: no compiled formula with atoms to train on")
    index = {a: i for i, a in enumerate(vocab)}
    train, heldout = split_by_formula(
        guard_triplets(table, settings.per_guard, settings.random_guards, rng),
        settings.holdout,
        rng,
    )
    if not train or not heldout:
        raise InputError(f"{dfas_path}: too few formulas for a train / held-out split")
    # every triplet's three graphs collated once; a batch selects its triplets' graphs
    train_graphs = TripletStore(train, index, device)
    heldout_graphs = TripletStore(heldout, index, device)

    # ---- model, then the shared triplet loop
    atoms = atom_features(vocab, settings.atom_features, settings.feature_dim, settings.seed)
    model = PropositionEncoder(atoms, settings.hidden, settings.layers, settings.out_dim).to(device)

    metrics = fit(
        model,
        lambda epoch, generator: chunks(
            list(range(len(train_graphs))), settings.batch_size, generator
        ),
        triplet_step(lambda ids: train_graphs.embed(model, ids), settings.margin),
        lambda: evaluate(model, heldout_graphs, settings.batch_size),
        LoopSettings.of(settings),
        out_dir,
        score=SCORE,
        resume=resume,
        on_epoch=reporting(on_epoch),
    )

    # ---- the model directory
    config = {
        "kind": "edge-embedder",
        "settings": asdict(settings),
        "vocabulary": vocab,
        "atom_feature_dim": int(atoms.shape[1]),
        "inputs": describe_inputs([dfas_path]),
        "triplets": {"train": len(train), "heldout": len(heldout)},
    }
    write_text_atomic(out_dir / "config.json", json.dumps(config, indent=2))
    write_text_atomic(out_dir / "metrics.json", json.dumps(metrics, indent=2))
    return metrics


def evaluate(model: PropositionEncoder, graphs: TripletStore, batch_size: int) -> float:
    """Triplet accuracy over (guard, sat, unsat) graph triples."""
    hits = 0.0
    for i in range(0, len(graphs), batch_size):
        ids = list(range(i, min(i + batch_size, len(graphs))))
        hits += triplet_accuracy(*graphs.embed(model, ids)) * len(ids)
    return hits / max(len(graphs), 1)
