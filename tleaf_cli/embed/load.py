"""Reading trained model folders back: q_e (`load_edge_model`) and q (`load_embedder`).

A damaged folder gives an InputError naming the file at fault and what it should hold
(`model_folder.py`), never the error of the JSON reader, pickle or torch underneath.

Nothing here trains: the trainers (`train_edge`, `train_meta`) write these folders and the
inference path (losses, tasks, `tleaf embed`) reads them, through this module only.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict
from pathlib import Path

import torch

from tleaf_cli.arguments import given
from tleaf_cli.embed.embedder import Embedder
from tleaf_cli.embed.meta_data import GuardVectors
from tleaf_cli.embed.model import build_model
from tleaf_cli.embed.model_folder import (
    CONFIG,
    check_types,
    config_field,
    load_weights,
    read_model_config,
    settings_of,
)
from tleaf_cli.embed.proposition_encoder import PropositionEncoder
from tleaf_cli.errors import ArgumentTypeError, InputError, SettingError
from tleaf_cli.settings.edge import EdgeSettings
from tleaf_cli.settings.meta import recommended_lambda, settings_from_config


def load_edge_model(model_dir: str | Path) -> tuple[PropositionEncoder, dict]:
    """The trained q_e (best epoch) and its config."""
    model_dir = Path(model_dir)
    config = read_model_config(model_dir, "edge-embedder")
    where = model_dir / CONFIG
    vocabulary = config_field(config, "vocabulary", list, where, "the atoms q_e was trained on")
    if not all(isinstance(a, str) for a in vocabulary):
        raise InputError(f"{where}: 'vocabulary' must be a list of atom names (str)")
    feature_dim = config_field(config, "atom_feature_dim", int, where, "the atom features' width")
    s = settings_of(EdgeSettings, config, where)
    # The atom table is a buffer in the weights: a placeholder of its shape is enough here.
    table = torch.zeros(len(vocabulary), feature_dim)
    model = PropositionEncoder(table, s.hidden, s.layers, s.out_dim)
    load_weights(model, model_dir, "edge-embedder")
    return model.eval(), config


def edge_model_dir(model_dir: Path, config: dict) -> Path:
    """Where a meta model's edge model is: relative to the meta folder where it is there (the
    tree was moved or copied whole), else at the absolute path recorded when it was trained."""
    where = model_dir / CONFIG
    recorded = Path(config_field(config, "edge_model", str, where, "the edge model's folder"))
    relative = config.get("edge_model_relative")
    if relative is not None:
        relative = config_field(config, "edge_model_relative", str, where, "a relative path")
        relative = Path(os.path.normpath(model_dir / relative))
        if (relative / CONFIG).exists():
            return relative
    if not (recorded / CONFIG).exists():
        places = [str(recorded)] + ([str(relative)] if relative is not None else [])
        raise InputError(
            f"{where}: its edge model (q_e) is at none of {', '.join(places)}; copy the "
            "train-edge folder there, or move the meta folder back beside it"
        )
    return recorded


def load_embedder(model_dir: str | Path) -> Embedder:
    """A trained meta embedder directory (with its edge model) as an `Embedder`.

    Raises ArgumentTypeError for a `model_dir` that is not a path, InputError for a folder that
    does not hold a loadable q (naming the file at fault)."""
    if not isinstance(model_dir, str | os.PathLike):
        raise ArgumentTypeError(
            "model_dir", f"must be a path (str or Path), not {given(model_dir)}"
        )
    model_dir = Path(model_dir)
    config = read_model_config(model_dir, "meta-embedder")
    where = model_dir / CONFIG
    config_field(config, "settings", dict, where, "q's training settings")
    try:
        settings = settings_from_config(config, where)
    except TypeError as e:  # a field this tleaf does not know
        raise InputError(f"{where}: 'settings' are not train-meta's ({e})") from None
    check_types(settings, where)
    if "recommended_lambda" not in config:  # written before q carried its λ: from its metrics
        config["recommended_lambda"] = _lambda_from_metrics(model_dir)
    config_field(config, "recommended_lambda", float, where, "the tleaf loss's λ for this q")
    config["settings"] = asdict(settings)
    edge_model, edge_config = load_edge_model(edge_model_dir(model_dir, config))
    vectors = GuardVectors(edge_model, edge_config["vocabulary"])
    try:
        model = build_model(settings, vectors.dim, edge_model.atom_table)
    except SettingError as e:
        raise InputError(f"{where}: its settings do not build a q ({e})") from None
    load_weights(model, model_dir, "meta-embedder")
    return Embedder(model, vectors, config)


def _lambda_from_metrics(model_dir: Path) -> float:
    """`recommended_lambda` of a model folder written before config.json carried it, from the
    test split's distances its metrics.json records."""
    path = model_dir / "metrics.json"
    try:
        test = json.loads(path.read_text())["test"]
        return recommended_lambda(test)
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise InputError(f"{path}: cannot read q's distances to choose its λ ({e})") from None
