"""The syntax-tree baseline (the paper's comparison row): an LTLf parse tree to a vector.

    h_v^0   = [ onehot(type_v) ; A[atom_v] ]     type: operator or atom; A: atom features
    h^{l+1} = ReLU( GCNConv_l(h^l) )             (arcs taken both ways)
    q_s(T)  = W_out · mean_v h_v^L

Traces are embedded for it by an `AutomatonEncoder` of their own, trained jointly, so the two
rows of the comparison differ only in how the formula is seen: as its tree, or as its DFA.
"""

from __future__ import annotations

import itertools

import torch
from torch import nn
from torch_geometric.nn import GCNConv, global_mean_pool
from torch_geometric.utils import to_undirected

from tleaf_cli.embed.encoders import typed_atom_features
from tleaf_cli.embed.graphs import SYNTAX_TYPES


class SyntaxEncoder(nn.Module):
    """q_s: syntax-tree graph -> R^out_dim (GCN, mean readout, linear head)."""

    def __init__(
        self, atom_table: torch.Tensor, hidden: int = 100, layers: int = 4, out_dim: int = 200
    ) -> None:
        super().__init__()
        self.register_buffer("atom_table", atom_table.float())
        dims = [SYNTAX_TYPES + atom_table.shape[1]] + [hidden] * layers
        self.convs = nn.ModuleList(GCNConv(a, b) for a, b in itertools.pairwise(dims))
        self.head = nn.Linear(hidden, out_dim)

    def forward(self, batch) -> torch.Tensor:
        x = typed_atom_features(batch.node_type, SYNTAX_TYPES, batch.atom, self.atom_table)
        edge_index = to_undirected(batch.edge_index, num_nodes=x.shape[0])
        for conv in self.convs:
            x = torch.relu(conv(x, edge_index))
        return self.head(global_mean_pool(x, batch.batch))
