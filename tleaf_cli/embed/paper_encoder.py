"""The authors' q_m (`--encoder authors`): clear-nus/T-LEAF's `Node_only_random_agg_min_clip`.

    h^0     = [ onehot(kind_v) ; flags_v ; s_v ]        as in AutomatonEncoder
    h^{l+1} = ReLU( GCNConv_l(h^l) )                     widths w_1..w_L, ReLU after every
                                                         layer, the last one included; arcs
                                                         forwards only (`directed`: messages
                                                         go s -> e -> t, as in the authors'
                                                         directed graph) or taken both ways
    q_m(G)  = mean of h^L over the nodes of `paths` random paths of at most `steps` + 1 nodes
              from the start node (no linear head: the vector has width w_L)

The authors' code (`models/models.py`, `sample_path(..., num_path=10, max_length=5,
from_start_node=True)`) starts every path at node index 1: their graphs list the states first,
so node 1 is state 1, as in tleaf's graphs (state 1: the initial state's first successor in
breadth-first order; on a trace chain, the state after the first letter). The paper's text
says the walks start at the initial state: `walk_from` picks either. A path follows a uniformly
chosen out-arc and ends early where none leaves; visits are counted with multiplicity.

The authors' graphs are spot's automata, which leave out a complete DFA's dead state (the
rejecting sink no accepted word passes) and every edge into it; tleaf's DFA graphs keep it.
`dead_state=False` reads the graph as spot prints it: the nodes from which no accepting state
can be reached lose their arcs (so no message or path reaches them), and node 1 is the second
live node.

While training (`module.training`), paths are drawn as the authors draw them, anew at every
call; otherwise the readout is their expectation (the expected visits of each node divided by
the expected number of visits), so a graph always gets the same vector. On DFA graphs (every
state has an out-arc) and on trace chains (one way on) every path has the same length, so this
is exactly the expected mean.

Their unit-length scaling (`out / max(|out|, 1e-3)`) is `TripletEmbedder`'s `sphere`.
"""

from __future__ import annotations

import itertools

import torch
from torch import nn
from torch_geometric.nn import global_add_pool
from torch_geometric.utils import degree, to_undirected

from tleaf_cli.embed.automaton import FLAGS, KINDS
from tleaf_cli.embed.graphs import gcn_adjacency
from tleaf_cli.embed.layers import NormalisedGCNConv
from tleaf_cli.errors import SettingError

WALK_STARTS = ("initial", "node1")
PAPER_READOUTS = ("paths", "walk")


class AuthorsEncoder(nn.Module):
    """The authors' GCN: expanded DFA graph or trace chain, with edge-node vectors, -> R^w_L.

    Args:
        edge_dim: width of the edge nodes' vectors (q_e's output).
        widths: the layers' output widths; the last is the vector's size.
        directed: messages along the arcs only (else along and against, one weight).
        readout: `paths` (drawn while training, expected otherwise) or `walk` (always the
            expectation).
        paths: paths per graph.
        steps: a path has at most steps + 1 nodes.
        walk_from: `node1` (the authors' code) or `initial` (the paper's text).
        dead_state: keep the nodes no accepting state can be reached from (tleaf's graphs);
            off: left out, as in the authors' spot automata.
    """

    monitor_bank = None  # q_m's trainer asks every encoder for its monitors
    monitor_width = 0

    def __init__(
        self,
        edge_dim: int,
        widths: tuple[int, ...] = (2048, 512, 256, 200),
        directed: bool = True,
        readout: str = "paths",
        paths: int = 10,
        steps: int = 4,
        walk_from: str = "node1",
        dead_state: bool = True,
    ) -> None:
        super().__init__()
        if readout not in PAPER_READOUTS:
            raise SettingError("readout", f"must be one of {PAPER_READOUTS}, not {readout!r}")
        if walk_from not in WALK_STARTS:
            raise SettingError("walk_from", f"must be one of {WALK_STARTS}, not {walk_from!r}")
        dims = [KINDS + FLAGS + edge_dim, *widths]
        self.convs = nn.ModuleList(NormalisedGCNConv(a, b) for a, b in itertools.pairwise(dims))
        self.directed = directed
        self.readout = readout
        self.paths = paths
        self.steps = steps
        self.walk_from = walk_from
        self.dead_state = dead_state

    def start_nodes(self, batch, live: torch.Tensor | None = None) -> torch.Tensor:
        """[graphs]: where each graph's paths start (node 1, or the initial state). With
        `live` ([N] bool), node 1 counts the live nodes only: the second live node (the only
        one where there is one; node 1 where there is none)."""
        first, last = batch.ptr[:-1], batch.ptr[1:] - 1
        if self.walk_from == "initial":
            return first + batch.initial
        node1 = torch.minimum(first + 1, last)
        if live is None:
            return node1
        ids = live.nonzero()[:, 0]
        graph_of = batch.batch[ids]
        graphs = torch.arange(len(first), device=ids.device)
        begin = torch.searchsorted(graph_of, graphs)
        end = torch.searchsorted(graph_of, graphs, right=True) - 1
        has_live = end >= begin
        pick = torch.minimum(begin + 1, end).clamp(min=0, max=max(len(ids) - 1, 0))
        return torch.where(has_live, ids[pick] if len(ids) else node1, node1)

    def forward(self, batch) -> torch.Tensor:
        kinds = nn.functional.one_hot(batch.node_kind, KINDS).float()
        x = torch.cat([kinds, batch.flags, batch.edge_vec], dim=1)
        arcs, n = batch.edge_index, x.shape[0]
        live = None
        if not self.dead_state:
            live = live_nodes(arcs, batch.flags[:, 1] > 0)
            arcs = arcs[:, live[arcs[0]] & live[arcs[1]]]
        adjacency = gcn_adjacency(arcs if self.directed else to_undirected(arcs, num_nodes=n), n)
        for conv in self.convs:
            x = torch.relu(conv(x, adjacency))
        start = self.start_nodes(batch, live)
        if self.readout == "paths" and self.training:
            visits = sampled_visits(arcs, start, n, self.paths, self.steps)
        else:
            visits = expected_visits(arcs, start, n, self.steps)
        graphs = int(batch.ptr.numel() - 1)
        total = torch.zeros(graphs, device=x.device).index_add_(0, batch.batch, visits)
        weights = visits / total.clamp(min=1e-12)[batch.batch]
        return global_add_pool(weights.unsqueeze(1) * x, batch.batch, size=graphs)


def live_nodes(arcs: torch.Tensor, accepting: torch.Tensor) -> torch.Tensor:
    """[N] bool: the nodes from which an accepting node can be reached along `arcs` (a
    fixpoint: a node is live when an arc leads from it to a live node)."""
    src, dst = arcs
    live = accepting.clone()
    while True:
        grown = live.clone()
        grown[src[live[dst]]] = True
        if torch.equal(grown, live):
            return live
        live = grown


def sampled_visits(
    arcs: torch.Tensor, start: torch.Tensor, n: int, paths: int, steps: int
) -> torch.Tensor:
    """[n]: how often `paths` random paths per start node, of at most steps + 1 nodes, visit
    each node (a path follows a uniformly chosen out-arc, and ends where none leaves)."""
    src, dst = arcs
    order = torch.argsort(src, stable=True)
    targets = dst[order]
    out_deg = degree(src, num_nodes=n).long()
    first = torch.cumsum(out_deg, 0) - out_deg  # where each node's out-arcs begin in `targets`
    here = start.repeat_interleave(paths)
    visits = torch.zeros(n, device=arcs.device).index_add_(
        0, here, torch.ones(len(here), device=arcs.device)
    )
    alive = torch.ones(len(here), dtype=torch.bool, device=arcs.device)
    for _ in range(steps):
        deg = out_deg[here]
        alive &= deg > 0
        pick = first[here] + (torch.rand(len(here), device=arcs.device) * deg).long().clamp(
            max=(deg - 1).clamp(min=0)
        )
        here = torch.where(alive, targets[pick.clamp(max=max(len(targets) - 1, 0))], here)
        visits.index_add_(0, here[alive], torch.ones(int(alive.sum()), device=arcs.device))
    return visits


def expected_visits(arcs: torch.Tensor, start: torch.Tensor, n: int, steps: int) -> torch.Tensor:
    """[n]: the expected visits of one such path to each node (mass stops at nodes with no
    out-arc)."""
    src, dst = arcs
    out_deg = degree(src, num_nodes=n)
    p = torch.zeros(n, device=arcs.device).index_fill_(0, start, 1.0)
    visits = p.clone()
    for _ in range(steps):
        p = torch.zeros_like(p).index_add_(0, dst, p[src] / out_deg[src])
        visits = visits + p
    return visits
