"""The meta embedder q_m: automaton graphs (and trace chains) to vectors.

    h_v^0   = [ onehot(kind_v) ; flags_v ; s_v ]     kind: state/edge node; flags: initial,
                                                      accepting; s_v = q_e(guard_v) on edge nodes
    h^{l+1} = ReLU( GCNConv_l(h^l) )                  (arcs taken both ways), or with
    h^{l+1} = ReLU( GCN→_l(h^l) + GCN←_l(h^l) )       `directed`: arcs forwards and backwards
                                                      through separate weights
    q_m(G)  = W_out · sum_v r_v h_v^L                 readout "walk", or
    q_m(G)  = sum_k W_k · sum_v p_k(v) h_v^L          readout "steps"

With `norm`, s_v is standardised with the training graphs' statistics and each layer's output
passes a LayerNorm before the ReLU.

The readout r is the paper's "aggregate node embeddings along random walks from the initial
state", taken in expectation so that a graph always gets the same vector: a walker starts at the
initial state and follows a uniformly chosen outgoing arc (s -> e -> t) for K steps, staying put
where no arc leaves (the end of a trace chain); r_v is the expected share of the K+1 positions
spent at v. Nodes the walk cannot reach from the initial state get no weight.

The "steps" readout keeps the walk's time: p_k(v) is the probability that the walker is at v after
k steps, and each step k has its own projection W_k. On a trace chain p_k is the k-th node, so the
vector knows the order of the letters (the plain readout only sees it through L hops of message
passing); on a DFA it is the expected node embedding k steps into a random run.
"""

from __future__ import annotations

import itertools

import torch
from torch import nn
from torch_geometric.nn import GCNConv, global_add_pool
from torch_geometric.utils import degree, to_undirected

from tleaf_cli.embed.graphs import EDGE

KINDS = 2  # state, edge node
FLAGS = 2  # initial, accepting
READOUTS = ("walk", "steps")


def walk_distributions(
    edge_index: torch.Tensor, start: torch.Tensor, num_nodes: int, steps: int
) -> torch.Tensor:
    """[steps + 1, num_nodes]: where a uniform random walk from the nodes in `start` (one per graph
    of a batch) is after 0..steps steps; a walker with no arc out stays put."""
    src, dst = edge_index
    out_deg = degree(src, num_nodes=num_nodes)
    p = torch.zeros(num_nodes, device=edge_index.device)
    p[start] = 1.0
    stuck = out_deg == 0
    out = [p]
    for _ in range(steps):
        p = torch.zeros_like(p).index_add_(0, dst, p[src] / out_deg[src]) + p * stuck
        out.append(p)
    return torch.stack(out)


def walk_weights(edge_index: torch.Tensor, start: torch.Tensor, num_nodes: int, steps: int):
    """Expected visit share of every node over a `steps`-step uniform random walk from the nodes
    in `start` (one per graph of a batch): the readout weights r."""
    return walk_distributions(edge_index, start, num_nodes, steps).mean(dim=0)


class AutomatonEncoder(nn.Module):
    """q_m: expanded DFA graph or trace chain, with edge-node vectors, -> R^out_dim."""

    def __init__(
        self,
        edge_dim: int,
        hidden: int = 100,
        layers: int = 4,
        out_dim: int = 200,
        steps: int = 24,
        directed: bool = False,
        readout: str = "walk",
        norm: bool = False,
    ) -> None:
        super().__init__()
        if readout not in READOUTS:
            raise ValueError(f"readout must be one of {READOUTS}, not {readout!r}")
        dims = [KINDS + FLAGS + edge_dim] + [hidden] * layers
        self.convs = nn.ModuleList(GCNConv(a, b) for a, b in itertools.pairwise(dims))
        self.back = (
            nn.ModuleList(GCNConv(a, b) for a, b in itertools.pairwise(dims)) if directed else None
        )
        # `norm`: edge-node vectors standardised with statistics of the training graphs (q_e's
        # vectors share a large common component, so otherwise every graph starts at nearly the
        # same point), and a LayerNorm after every layer. Both act per node, so training and
        # inference compute the same function.
        if norm:
            self.register_buffer("edge_mean", torch.zeros(edge_dim))
            self.register_buffer("edge_std", torch.ones(edge_dim))
        self.norms = nn.ModuleList(nn.LayerNorm(hidden) for _ in range(layers)) if norm else None
        width = hidden * (steps + 1) if readout == "steps" else hidden
        self.head = nn.Linear(width, out_dim)
        self.steps = steps
        self.readout = readout

    def set_edge_statistics(self, edge_vectors: torch.Tensor) -> None:
        """Standardise edge-node vectors like these (rows: the training graphs' edge nodes)."""
        self.edge_mean.copy_(edge_vectors.mean(dim=0))
        self.edge_std.copy_(edge_vectors.std(dim=0).clamp(min=1e-6))

    def forward(self, batch) -> torch.Tensor:
        kinds = nn.functional.one_hot(batch.node_kind, KINDS).float()
        edge_vec = batch.edge_vec
        if self.norms is not None:
            on_edges = (batch.node_kind == EDGE).unsqueeze(1)
            edge_vec = torch.where(on_edges, (edge_vec - self.edge_mean) / self.edge_std, 0.0)
        x = torch.cat([kinds, batch.flags, edge_vec], dim=1)
        arcs = batch.edge_index
        both = to_undirected(arcs, num_nodes=x.shape[0]) if self.back is None else None
        for layer, conv in enumerate(self.convs):
            if self.back is None:
                x = conv(x, both)
            else:
                x = conv(x, arcs) + self.back[layer](x, arcs.flip(0))
            if self.norms is not None:
                x = self.norms[layer](x)
            x = torch.relu(x)
        start = batch.ptr[:-1] + batch.initial
        p = walk_distributions(arcs, start, x.shape[0], self.steps)
        if self.readout == "walk":
            return self.head(global_add_pool(p.mean(dim=0).unsqueeze(1) * x, batch.batch))
        graphs = int(batch.ptr.numel() - 1)
        per_step = [global_add_pool(pk.unsqueeze(1) * x, batch.batch, size=graphs) for pk in p]
        return self.head(torch.cat(per_step, dim=1))
