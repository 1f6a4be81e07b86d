"""The meta embedder q_m: automaton graphs (and trace chains) to vectors.

    h_v^0   = [ onehot(kind_v) ; flags_v ; s_v ]     kind: state/edge node; flags: initial,
                                                      accepting; s_v = q_e(guard_v) on edge nodes
    h^{l+1} = ReLU( GCNConv_l(h^l) )                  (arcs taken both ways)
    q_m(G)  = W_out · sum_v r_v h_v^L

The readout r is the paper's "aggregate node embeddings along random walks from the initial
state", taken in expectation so that a graph always gets the same vector: a walker starts at the
initial state and follows a uniformly chosen outgoing arc (s -> e -> t) for K steps, staying put
where no arc leaves (the end of a trace chain); r_v is the expected share of the K+1 positions
spent at v. Nodes the walk cannot reach from the initial state get no weight.
"""

from __future__ import annotations

import itertools

import torch
from torch import nn
from torch_geometric.nn import GCNConv, global_add_pool
from torch_geometric.utils import degree, to_undirected

KINDS = 2  # state, edge node
FLAGS = 2  # initial, accepting


def walk_weights(edge_index: torch.Tensor, start: torch.Tensor, num_nodes: int, steps: int):
    """Expected visit share of every node over a `steps`-step uniform random walk from the nodes
    in `start` (one per graph of a batch): the readout weights r."""
    src, dst = edge_index
    out_deg = degree(src, num_nodes=num_nodes)
    p = torch.zeros(num_nodes, device=edge_index.device)
    p[start] = 1.0
    total = p.clone()
    stuck = out_deg == 0
    for _ in range(steps):
        moved = torch.zeros_like(p).index_add_(0, dst, p[src] / out_deg[src])
        p = moved + p * stuck
        total = total + p
    return total / (steps + 1)


class AutomatonEncoder(nn.Module):
    """q_m: expanded DFA graph or trace chain, with edge-node vectors, -> R^out_dim."""

    def __init__(
        self, edge_dim: int, hidden: int = 100, layers: int = 4, out_dim: int = 200, steps: int = 24
    ) -> None:
        super().__init__()
        dims = [KINDS + FLAGS + edge_dim] + [hidden] * layers
        self.convs = nn.ModuleList(GCNConv(a, b) for a, b in itertools.pairwise(dims))
        self.head = nn.Linear(hidden, out_dim)
        self.steps = steps

    def forward(self, batch) -> torch.Tensor:
        kinds = nn.functional.one_hot(batch.node_kind, KINDS).float()
        x = torch.cat([kinds, batch.flags, batch.edge_vec], dim=1)
        edge_index = to_undirected(batch.edge_index, num_nodes=x.shape[0])
        for conv in self.convs:
            x = torch.relu(conv(x, edge_index))
        start = batch.ptr[:-1] + batch.initial
        r = walk_weights(batch.edge_index, start, x.shape[0], self.steps)
        return self.head(global_add_pool(r.unsqueeze(1) * x, batch.batch))
