"""GNN encoders over the graphs of `graphs.py` (torch_geometric layers; no data handling here).

`PropositionEncoder` is the edge embedder q_e of T-LEAF: it maps a propositional graph (a guard,
or a letter written as a conjunction of literals) to a vector.

    h_v^0   = [ onehot(type_v) ; A[atom_v] ]                  (A: atom features, 0 for operators)
    h^{l+1} = ReLU( D^-1/2 (Adj + I) D^-1/2 h^l W_l )          (GCNConv, arcs taken both ways)
    q_e(G)  = W_out · mean_v h_v^L

Atom features `A` are a fixed matrix over the vocabulary (see `atom_features`), so atoms unseen
in training still get the features of their kind (random, one-hot or, later, text).
"""

from __future__ import annotations

import itertools

import torch
from torch import nn
from torch_geometric.nn import GCNConv, global_mean_pool
from torch_geometric.utils import to_undirected

from tleaf_cli.embed.graphs import PROP_TYPES

ATOM_FEATURE_KINDS = ("onehot", "random")


def atom_features(vocabulary_size: int, kind: str, dim: int = 64, seed: int = 0) -> torch.Tensor:
    """A fixed [vocabulary_size, d] feature matrix: identity (`onehot`) or seeded Gaussian rows
    scaled to unit norm (`random`, d = `dim`)."""
    if kind == "onehot":
        return torch.eye(vocabulary_size)
    if kind == "random":
        generator = torch.Generator().manual_seed(seed)
        rows = torch.randn(vocabulary_size, dim, generator=generator)
        return rows / rows.norm(dim=1, keepdim=True)
    raise ValueError(f"atom features must be one of {ATOM_FEATURE_KINDS}, not {kind!r}")


class PropositionEncoder(nn.Module):
    """q_e: propositional graph -> R^out_dim (GCN, mean readout, linear head)."""

    def __init__(
        self, atom_table: torch.Tensor, hidden: int = 256, layers: int = 2, out_dim: int = 100
    ) -> None:
        super().__init__()
        self.register_buffer("atom_table", atom_table.float())
        in_dim = PROP_TYPES + atom_table.shape[1]
        dims = [in_dim] + [hidden] * layers
        self.convs = nn.ModuleList(GCNConv(a, b) for a, b in itertools.pairwise(dims))
        self.head = nn.Linear(hidden, out_dim)

    def node_features(self, node_type: torch.Tensor, atom: torch.Tensor) -> torch.Tensor:
        kinds = nn.functional.one_hot(node_type, PROP_TYPES).float()
        feats = self.atom_table[atom.clamp(min=0)] * (atom >= 0).unsqueeze(1).float()
        return torch.cat([kinds, feats], dim=1)

    def forward(self, batch) -> torch.Tensor:
        x = self.node_features(batch.node_type, batch.atom)
        edge_index = to_undirected(batch.edge_index, num_nodes=x.shape[0])
        for conv in self.convs:
            x = torch.relu(conv(x, edge_index))
        return self.head(global_mean_pool(x, batch.batch))


def triplet_loss(anchor, positive, negative, margin: float) -> torch.Tensor:
    """mean max(d(a, p) - d(a, n) + m, 0) with d the squared Euclidean distance.

    The paper prints the two distances the other way round, which would pull violating traces
    closer; this is the form that does what its text says.
    """
    d_pos = (anchor - positive).pow(2).sum(dim=1)
    d_neg = (anchor - negative).pow(2).sum(dim=1)
    return torch.relu(d_pos - d_neg + margin).mean()


def triplet_accuracy(anchor, positive, negative) -> float:
    """Share of triplets with d(a, p) < d(a, n)."""
    d_pos = (anchor - positive).pow(2).sum(dim=1)
    d_neg = (anchor - negative).pow(2).sum(dim=1)
    return float((d_pos < d_neg).float().mean())
