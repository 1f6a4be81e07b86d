"""The meta embedder q_m: automaton graphs (and trace chains) to vectors.

    h_v^0   = [ onehot(kind_v) ; flags_v ; s_v ]     kind: state/edge node; flags: initial,
                                                      accepting; s_v = q_e(guard_v) on edge nodes
    h^{l+1} = ReLU( GCNConv_l(h^l) )                  (arcs taken both ways), or with
    h^{l+1} = ReLU( GCN→_l(h^l) + GCN←_l(h^l) )       `directed`: arcs forwards and backwards
                                                      through separate weights
    q_m(G)  = W_out · sum_v r_v h_v^L                 readout "walk", or
    q_m(G)  = sum_k W_k · sum_v p_k(v) h_v^L          readout "steps", or
    q_m(G)  = sum_b W_b · sum_v a_b(v) h_v^L          readout "accept" (b: parts of a run), and
              + sum_b U_b · sum_v j_b(v) h_v^L        with "runs", the rejected runs' parts too

The readout r is the paper's "aggregate node embeddings along random walks from the initial
state", taken in expectation so that a graph always gets the same vector: a walker starts at the
initial state and follows a uniformly chosen outgoing arc (s -> e -> t) for K steps, staying put
where no arc leaves (the end of a trace chain); r_v is the expected share of the K+1 positions
spent at v. Nodes the walk cannot reach from the initial state get no weight.

The "steps" readout keeps the walk's time: p_k(v) is the probability that the walker is at v after
k steps, and each step k has its own projection W_k. On a trace chain p_k is the k-th node, so the
vector knows the order of the letters (the plain readout only sees it through L hops of message
passing); on a DFA it is the expected node embedding k steps into a random run.

The "accept" readout weights nodes by where the automaton's accepted words go, not by
where a walk that ignores acceptance goes: `accepted_run_weights`. a_b(v) is the share of part b
(of B equal parts of a run) of uniformly drawn accepted runs of 1..max_length letters that lies
on v; "runs" adds j_b(v), the same for rejected runs. A trace chain has one accepted run (its
word, read in order) and no rejected ones.
"""

from __future__ import annotations

import functools
import itertools

import torch
from torch import nn
from torch_geometric.nn import global_add_pool
from torch_geometric.utils import degree

from tleaf_cli.embed.batches import Blocks, JointBatch, Unit
from tleaf_cli.embed.graphs import joint_adjacency, read_limits, readout_pool, trace_graph_batch
from tleaf_cli.embed.layers import NormalisedGCNConv, gcn_layer, sparse_product
from tleaf_cli.embed.probes import ProbeBank
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.logic.monitors import MonitorBank
from tleaf_cli.settings.meta import READOUTS, RUN_READOUTS

KINDS = 2  # state, edge node
FLAGS = 2  # initial, accepting
PROBE_STATES = 4  # states of each probe automaton


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


def accepted_run_weights(
    edge_index: torch.Tensor,
    share: torch.Tensor,
    ends: torch.Tensor,
    start: torch.Tensor,
    graph_of: torch.Tensor,
    max_length: int | torch.Tensor,
    bins: int = 1,
) -> torch.Tensor:
    """[bins, num_nodes]: how much of an accepted run lies at each node, by part of the run.

    `ends` [num_nodes] marks the states a run must end in: the accepting states (accepted runs),
    or the others (rejected runs); `start` holds each graph's initial node, `graph_of` the graph
    of every node. Letters are drawn uniformly: from a state, an edge node is taken with
    probability `share` (the share of the alphabet its guard reads) and leads on to its target
    state. For each length T in 1..max_length at which a graph has such a run, one is drawn
    uniformly among them (the uniform distribution over accepted words of length T) and its
    2T + 1 nodes are counted, the i-th into part floor(bins * i / (2T + 1)); `max_length` is one
    bound for every graph or a tensor [graphs] of bounds, one per graph; the counts of all
    lengths are added (a longer run brings more nodes) and each part is normalised to sum to 1
    per graph (0 where a graph has no such run). Forward-backward: a_h(v) = P(at v after h
    hops), b_h(v) = P(in `ends` h hops after v); the share of the runs of H = 2T hops at v at
    hop h is a_h(v) b_(H-h)(v) / Z_T, Z_T = b_H(start).

    On a trace chain (share 1, its last state accepting) the one accepted run reads every node
    once, so part k is the k-th stretch of the trace; on a DFA it is where accepted words go —
    what satisfying traces of the formula have in common, which a walk ignoring acceptance does
    not see.
    """
    src, dst = edge_index
    n = share.shape[0]
    graphs = int(start.numel())
    limit = torch.as_tensor(max_length, device=share.device).expand(graphs)
    hops = 2 * int(limit.max()) if graphs else 0
    # a letter's probability is carried by the arc out of its edge node (edge->state: share of
    # the edge node; state->edge: 1): a_h at an edge node is the mass arriving there, b_h the
    # mass going on, and their product at every node is the same as with the share on the way in
    prob = torch.where(share[src] > 0, share[src], 1.0)
    # a (forwards along the arcs) and b (backwards) as one vector [a ; b] of 2n entries, so a
    # hop is one gather, product and index-add for both
    reads = torch.cat([src, n + dst])
    writes = torch.cat([dst, n + src])
    prob = torch.cat([prob, prob])
    first = torch.zeros(n, device=share.device).index_fill_(0, start, 1.0)
    both = [torch.cat([first, ends.float()])]
    for _ in range(hops):
        step = both[-1].index_select(0, reads) * prob
        both.append(torch.zeros(2 * n, device=share.device).index_add_(0, writes, step))
    a_t, b_t = torch.stack(both).view(hops + 1, 2, n).unbind(1)
    # every length T = 1..hops / 2 at once: node i of a run of 2T hops is at v with a_i(v)
    # b_(2T - i)(v) (`_part_matrices`' zero columns drop i > 2T), the parts summed over i by one
    # batched product, each length's runs normalised by its own Z_T
    parts, later = _part_matrices(hops, bins, share.device)
    occupancy = a_t.unsqueeze(0) * b_t[later]  # [T, hops + 1, n]
    per_part = torch.bmm(parts, occupancy)  # [T, bins, n]
    lengths = torch.arange(1, hops // 2 + 1, device=share.device)
    z = b_t[2 * lengths][:, start]  # [T, graphs]: accepted mass at each length
    ok = (z > 0) & (lengths[:, None] <= limit)
    scale = torch.where(ok, z, 1.0)[:, graph_of].unsqueeze(1)
    out = torch.where(ok[:, graph_of].unsqueeze(1), per_part / scale, 0.0).sum(dim=0)
    # each part sums to 1 per graph (or 0 where the graph never reaches it)
    total = torch.zeros(len(out), graphs, device=share.device).index_add_(1, graph_of, out)
    return out / total.clamp(min=1e-12)[:, graph_of]


@functools.lru_cache(maxsize=64)
def _part_matrices(hops: int, bins: int, device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
    """For runs of 2T hops, T = 1..hops / 2: [T, bins, hops + 1], which part each node of such a
    run counts into (`accepted_run_weights`: the i-th of its 2T + 1 nodes into part
    floor(bins * i / (2T + 1)); columns past 2T zero), and [T, hops + 1], the hop 2T − i whose
    backward mass meets node i (0 past 2T, where the zero columns drop it). Built once per
    (hops, bins, device)."""
    lengths = hops // 2
    i = torch.arange(hops + 1)
    parts = torch.zeros(lengths, bins, hops + 1)
    for t in range(1, lengths + 1):
        h = 2 * t
        parts[t - 1, (i[: h + 1] * bins) // (h + 1), i[: h + 1]] = 1.0
    later = (2 * torch.arange(1, lengths + 1)[:, None] - i).clamp(min=0)
    return parts.to(device), later.to(device)


def run_readout(
    weights: torch.Tensor, x: torch.Tensor, graph_of: torch.Tensor, graphs: int
) -> torch.Tensor:
    """[graphs, parts · hidden]: Σ_v w_k(v) x_v per graph and part k, the parts side by side
    (part 0's hidden units first), for node weights `weights` [n, parts] and node states `x`
    [n, hidden]: one sparse product S · x (`graphs.readout_pool`), instead of a pool per part or
    a [n, parts, hidden] product (and no padding: graphs of a batch differ in size by a
    hundredfold)."""
    return sparse_product(readout_pool(weights, graph_of, graphs), x).reshape(graphs, -1)


def walk_weights(edge_index: torch.Tensor, start: torch.Tensor, num_nodes: int, steps: int):
    """Expected visit share of every node over a `steps`-step uniform random walk from the nodes
    in `start` (one per graph of a batch): the readout weights r."""
    return walk_distributions(edge_index, start, num_nodes, steps).mean(dim=0)


class AutomatonEncoder(nn.Module):
    """q_m: expanded DFA graph or trace chain, with edge-node vectors, -> R^out_dim.

    Args:
        edge_dim: width of the edge nodes' vectors (q_e's output).
        hidden: width of every layer.
        layers: message-passing layers.
        out_dim: width of the output vector.
        steps: random-walk steps of the `walk` and `steps` readouts.
        directed: messages along and against the arcs through separate weights (else one
            GCNConv over the arcs taken both ways, the paper's).
        readout: `walk`, `steps`, `accept` or `runs` (module docstring).
        bins: parts of a run, each with its own projection (`accept` / `runs`).
        max_length: the longest run of a DFA counted (a trace chain is read whole).
        probes: learned probe automata read along the runs (`probes.ProbeBank`); 0: none.
        monitors: atom slots of the fixed temporal monitors (`logic.monitors.MonitorBank`)
            whose shares the graphs carry; 0: none.
        monitor_ranges: ranges of word length the monitors' shares are kept apart in.
    """

    def __init__(
        self,
        edge_dim: int,
        hidden: int = 100,
        layers: int = 4,
        out_dim: int = 200,
        steps: int = 24,
        directed: bool = False,
        readout: str = "walk",
        bins: int = 1,
        max_length: int = 12,
        probes: int = 0,
        monitors: int = 0,
        monitor_ranges: int = 1,
    ) -> None:
        super().__init__()
        if readout not in READOUTS:
            raise SettingError("readout", f"must be one of {READOUTS}, not {readout!r}")
        dims = [KINDS + FLAGS + edge_dim] + [hidden] * layers
        # GCN layers reading each direction's adjacency, normalised once per batch
        self.convs = nn.ModuleList(NormalisedGCNConv(a, b) for a, b in itertools.pairwise(dims))
        self.back = (
            nn.ModuleList(NormalisedGCNConv(a, b) for a, b in itertools.pairwise(dims))
            if directed
            else None
        )
        parts = {"walk": 1, "steps": steps + 1, "accept": bins, "runs": 2 * bins}[readout]
        width = hidden * parts
        # `probes` M > 0 (run readouts only): M probe automata read along the same runs
        # (probes.ProbeBank), their features beside the nodes' parts
        self.probes = None
        if probes > 0:
            if readout not in RUN_READOUTS:
                raise SettingError("probes", f"need an accept/runs readout, not {readout!r}")
            self.probes = ProbeBank(edge_dim, probes, PROBE_STATES, bins, max_length)
            width += self.probes.width * (2 if readout == "runs" else 1)
        # `monitors` K > 0: fixed temporal monitors over the first K atoms (logic/monitors.py);
        # the graphs carry their features (`monitor`, [graphs, 2 R F]: accepted, rejected words),
        # computed when they are built, so here they are only read
        self.monitor_bank = (
            MonitorBank(monitors, max_length, monitor_ranges) if monitors > 0 else None
        )
        self.monitor_width = 0
        if self.monitor_bank is not None:
            ends = 2 if readout == "runs" else 1
            self.monitor_width = self.monitor_bank.features * ends
            width += self.monitor_width
        self.head = nn.Linear(width, out_dim)
        self.steps = steps
        self.readout = readout
        self.bins = bins
        self.max_length = max_length
        self._chains: dict[int, torch.Tensor] = {}  # trace length -> its chain's run weights

    def chain_run_weights(self, lengths: list[int]) -> torch.Tensor:
        """[num_nodes, parts]: `run_weights` of the trace chains of these lengths, batched as
        `graphs.trace_graph_batch` batches them. A chain's weights depend on its length only
        (the one accepted run reads it whole), so each length is computed once and reused: the
        same values, since a graph's weights never depend on the others in its batch."""
        for length in set(lengths) - set(self._chains):
            self._chains[length] = self.run_weights(trace_graph_batch([length])[0]).t()
        return torch.cat([self._chains[length] for length in lengths])

    @torch.no_grad()
    def run_weights(self, batch) -> torch.Tensor:
        """[parts, num_nodes]: the `accept` / `runs` readout's weights (accepted runs' parts,
        then rejected runs' parts); they depend on the graphs only, so callers that embed the
        same graphs again may store them as `run_weights` [num_nodes, parts] on each graph."""
        start = batch.ptr[:-1] + batch.initial
        ends = self._ends(batch)
        limit = read_limits(batch, self.max_length)
        return torch.cat(
            [
                accepted_run_weights(
                    batch.edge_index,
                    batch.share,
                    e,
                    start,
                    batch.batch,
                    limit,
                    self.bins,
                )
                for e in ends
            ]
        )

    def _ends(self, batch) -> list[torch.Tensor]:
        """Where the readout's runs end: accepting states, and for `runs` the rejecting ones."""
        return [batch.flags[:, 1]] + ([batch.rejecting] if self.readout == "runs" else [])

    def block_matrices(self, batch) -> dict[str, tuple[Blocks, Blocks]]:
        """The matrices `forward` builds from a batch's graphs, for a whole collated store
        (`batches.GraphStore`, whose batches then carry their blocks): the joint adjacency
        (`graphs.joint_adjacency`) and, for run readouts, the readout pool
        (`graphs.readout_pool`), each with its transpose."""
        ptr, ways = batch.ptr, 1 if self.back is None else 2
        adjacency = joint_adjacency(
            batch.edge_index, int(batch.num_nodes), ways == 2, batch.edge_vec.dtype
        )
        node, spread = Unit(1), Unit(ways)
        out = {
            "adjacency": (
                Blocks.of(adjacency.matrix, ptr, node, spread),
                Blocks.of(adjacency.transposed, ptr, spread, node),
            )
        }
        if self.readout in RUN_READOUTS:
            weights = self._run_weights_of(batch)
            pool = readout_pool(weights, batch.batch, int(ptr.numel() - 1))
            parts = Unit(weights.shape[1], per_graph=True)
            out["pool"] = (
                Blocks.of(pool.matrix, ptr, parts, node),
                Blocks.of(pool.transposed, ptr, node, parts),
            )
        return out

    def _run_weights_of(self, batch) -> torch.Tensor:
        """[n, parts]: the graphs' stored run weights, or computed now."""
        cached = getattr(batch, "run_weights", None)
        return cached if cached is not None else self.run_weights(batch).t()

    def node_inputs(self, batch) -> torch.Tensor:
        """[n, KINDS + FLAGS + edge_dim]: the nodes' input vectors, one-hot kind, flags and
        edge-node vector (0 on states)."""
        kinds = nn.functional.one_hot(batch.node_kind, KINDS).to(batch.edge_vec.dtype)
        return torch.cat([kinds, batch.flags.to(kinds.dtype), batch.edge_vec], dim=1)

    def forward(self, batch) -> torch.Tensor:
        if isinstance(batch, JointBatch):  # a JointStore's batch: inputs and matrices made
            return self._forward_joint(batch)
        x = self.node_inputs(batch)
        arcs, n = batch.edge_index, x.shape[0]
        # every direction in one sparse product per layer (graphs.joint_adjacency): the batch's
        # blocks where a GraphStore gathered them, else built here
        adjacency = getattr(batch, "adjacency", None)
        if adjacency is None:
            adjacency = joint_adjacency(arcs, n, self.back is not None, x.dtype)
        x = self._layers(x, adjacency)
        graphs = int(batch.ptr.numel() - 1)
        if self.readout in RUN_READOUTS:
            pool = getattr(batch, "pool", None)
            if pool is None:
                pool = readout_pool(self._run_weights_of(batch), batch.batch, graphs)
            parts = [sparse_product(pool, x).reshape(graphs, -1)]
            if self.probes is not None:
                parts.append(self.probes(batch, self._ends(batch), batch.edge_vec))
            if self.monitor_bank is not None:
                parts.append(self.monitor_features(batch))
            return self.head(torch.cat(parts, dim=1))
        start = batch.ptr[:-1] + batch.initial
        p = walk_distributions(arcs, start, x.shape[0], self.steps)
        if self.readout == "walk":
            parts = [global_add_pool(p.mean(dim=0).unsqueeze(1) * x, batch.batch, size=graphs)]
        else:
            parts = [global_add_pool(pk.unsqueeze(1) * x, batch.batch, size=graphs) for pk in p]
        if self.monitor_bank is not None:
            parts.append(self.monitor_features(batch))
        return self.head(torch.cat(parts, dim=1))

    def _layers(
        self, x: torch.Tensor, adjacency, index: torch.Tensor | None = None
    ) -> torch.Tensor:
        """The GCN layers over node states `x` and the batch's joint adjacency; with `index`,
        x holds distinct input rows and node i's is x[index[i]] (`gcn_layer`)."""
        for k, conv in enumerate(self.convs):
            convs = (conv,) if self.back is None else (conv, self.back[k])
            weights, biases = tuple(c.lin.weight for c in convs), tuple(c.bias for c in convs)
            x = gcn_layer(x, adjacency, weights, biases, index if k == 0 else None)
        return x

    def _forward_joint(self, batch: JointBatch) -> torch.Tensor:
        """`forward` of a `JointStore` batch (run readouts, no probes)."""
        if self.readout not in RUN_READOUTS or self.probes is not None:
            raise SettingError("readout", "a JointStore batch needs a run readout and no probes")
        x = self._layers(batch.x, batch.adjacency, batch.x_index)
        parts = [sparse_product(batch.pool, x).reshape(batch.graphs, -1)]
        if self.monitor_bank is not None:  # carried as the head reads them, or cut here
            monitor = batch.monitor
            same = monitor is not None and monitor.shape[1] == self.monitor_width
            parts.append(monitor if same else self.monitor_features(batch))
        # the head as `nn.Linear` computes it (addmm), without its wrapper's operators
        head = self.head
        return torch.addmm(head.bias, torch.cat(parts, dim=1), head.weight.transpose(0, 1))

    def monitor_features(self, batch) -> torch.Tensor:
        """[graphs, monitor_width]: the monitors' shares of the accepted (and, for `runs`,
        the rejected) words the graphs carry as `monitor` (meta_data builds them)."""
        features = getattr(batch, "monitor", None)
        if features is None:
            raise InputError("this q reads monitor features; build its graphs with its bank")
        return features[:, : self.monitor_width].to(self.head.weight.dtype)
