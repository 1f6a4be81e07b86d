"""q_e, the edge embedder of T-LEAF, and the typed-graph GCN it shares with the syntax baseline.

`PropositionEncoder` maps a propositional graph (a guard, or a letter written as a conjunction
of literals; `graphs.py`) to a vector:

    h_v^0   = [ onehot(type_v) ; A[atom_v] ]                  (A: atom features, 0 for operators)
    h^{l+1} = ReLU( D^-1/2 (Adj + I) D^-1/2 h^l W_l )          (GCNConv, arcs taken both ways)
    q_e(G)  = W_out · mean_v h_v^L

Atom features `A` are a fixed matrix over the vocabulary (`atom_features.py`), stored with the
weights (a buffer), so a saved model never recomputes them.
"""

from __future__ import annotations

import itertools

import torch
from torch import nn
from torch_geometric.nn import global_mean_pool
from torch_geometric.utils import to_undirected

from tleaf_cli.embed.graphs import PROP_TYPES, gcn_adjacency
from tleaf_cli.embed.layers import NormalisedGCNConv


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
