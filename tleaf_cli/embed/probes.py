"""Probe automata: a readout that describes a language by where its words lead small learned
automata.

A bank of M soft automata ("probes") with S states each reads words letter by letter:

    π_m        = softmax(p_m)                                 (start distribution of probe m)
    T_m(x)     = softmax_rows( reshape(W_m x + c_m, [S, S]) )  (its transition on a letter whose
                                                               q_e vector is x)
    φ_m,t(w)   = π_m T_m(x_1) ... T_m(x_t)                    (its states after t letters)

A trace w has the features φ(w): the probes' state distributions along the word, averaged over
B equal parts of its positions 0..T (part floor(B t / (T + 1))), and after its last letter. An
automaton A gets the same features in expectation over the words it accepts,

    μ(A) = mean over lengths T  E_{w uniform among accepted words of length T} [ φ(w) ]

computed exactly (for the guard vectors given) by a forward pass through the product of A and the
probes: α_t(u) = P(A at u after t uniform letters) · (probe distribution on those runs), and
β_h(u) = P(A reaches an accepting state h letters after u) from A alone (the probes do not
decide acceptance), so E[φ_t | accepted at T] = Σ_u α_t(u) β_(T-t)(u) / β_T(start).

A trace chain is the automaton that accepts its one word, so the same computation gives φ(w)
on it: formula and trace vectors live in one space by construction, where the GNN readouts
compare a DFA state's neighbourhood with a stretch of a trace and must learn to make those
comparable. Where the GNN readout averages node vectors that see a few letters around them,
a probe carries state along the whole word (like an RNN), so it can follow "since a, b has held"
or "the last a came before the first c" over any distance.

On an edge node of a DFA the transition is taken on its guard's vector q_e(guard) with weight
share(guard): the letters it reads stand in for one averaged letter. That is exact for a trace
chain (its edge nodes carry the letters) and an approximation on DFAs (the probes read a guard as
a letter; q_e places guards among the letters they accept).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import nn

from tleaf_cli.embed.graphs import STATE, read_limits


class ProbeBank(nn.Module):
    """M learned soft automata with S states each, read along an automaton's accepted runs.

    Args:
        edge_dim: width of the edge-node vectors (q_e's output).
        probes: M, the number of probe automata.
        states: S, the states of each.
        bins: B, equal parts of a run's positions, each averaged on its own.
        max_length: the longest run of a DFA counted (a trace chain is read to its end).

    `forward(batch, ends, edge_vec)` returns, for each set of end states in the list `ends`
    (accepting states: accepted words; rejecting ones: rejected words), [graphs, `width`] side by
    side, `width` = (B + 1) · M · S: for each part and after the last letter, each probe's
    state distribution in expectation over the runs that end there, averaged over the lengths at
    which the graph has such runs; zeros for a graph that has none.
    """

    def __init__(
        self,
        edge_dim: int,
        probes: int = 16,
        states: int = 4,
        bins: int = 5,
        max_length: int = 12,
    ) -> None:
        super().__init__()
        self.probes, self.states, self.bins, self.max_length = probes, states, bins, max_length
        self.transition = nn.Linear(edge_dim, probes * states * states)
        self.start = nn.Parameter(torch.zeros(probes, states))
        with torch.no_grad():  # start near "stay put" so long words do not blur to the mean
            eye = torch.eye(states).expand(probes, states, states).reshape(-1)
            self.transition.bias.copy_(2.0 * eye)
            self.start[:, 0] = 2.0

    @property
    def width(self) -> int:
        return (self.bins + 1) * self.probes * self.states

    def forward(self, batch, ends: Sequence[torch.Tensor], edge_vec: torch.Tensor) -> torch.Tensor:
        """[graphs, len(ends) · width]: the features for each set of end states in `ends`, side
        by side. The probes' forward pass does not depend on where runs end, so it is computed
        once for all of them."""
        src, dst = batch.edge_index
        n, m, s = int(batch.num_nodes), self.probes, self.states
        start = batch.ptr[:-1] + batch.initial
        device = edge_vec.device
        limit = read_limits(batch, self.max_length)
        letters = int(limit.max())
        is_edge = batch.node_kind != STATE
        # transitions on edge nodes, weighted by the share of letters they read
        edges = torch.nonzero(is_edge).flatten()
        trans = self.transition(edge_vec[edges]).view(-1, m, s, s).softmax(dim=-1)
        trans = trans * batch.share[edges].view(-1, 1, 1, 1)
        slot = torch.full((n,), -1, dtype=torch.long, device=device)
        slot[edges] = torch.arange(len(edges), device=device)
        into_edge = slot[dst] >= 0  # state -> edge arcs; the others go edge -> state
        into, out = (src[into_edge], dst[into_edge]), (src[~into_edge], dst[~into_edge])
        # forward: alpha at states after t letters, [letters + 1, n, m, s]
        alpha = torch.zeros(n, m, s, device=device)
        alpha[start] = self.start.softmax(dim=-1)
        a = [alpha]
        for _ in range(letters):
            at_edges = torch.zeros(len(edges), m, s, device=device)
            at_edges.index_add_(0, slot[into[1]], a[-1][into[0]])
            moved = (at_edges.unsqueeze(-1) * trans).sum(dim=-2)  # 4 x 4: faster than bmm
            a.append(torch.zeros(n, m, s, device=device).index_add(0, out[1], moved[slot[out[0]]]))
        # runs are counted at states only (after each letter), so keep the states' rows
        states = torch.nonzero(~is_edge).flatten()
        a_t = torch.stack(a)[:, states]  # [L + 1, states, m, s]
        features = []
        for e in ends:
            # backward on the automaton alone: beta_h(u), P(in `e` h letters after state u)
            b = [e.float()]
            for _ in range(letters):  # from a state, over its edges: share * beta(target)
                on_edge = torch.zeros(n, device=device).index_add_(
                    0, out[0], b[-1][out[1]] * batch.share[out[0]]
                )
                b.append(torch.zeros(n, device=device).index_add_(0, into[0], on_edge[into[1]]))
            b_t = torch.stack(b)
            features.append(
                self._expected(a_t, b_t[:, states], b_t[:, start], batch.batch[states], limit)
            )
        return torch.cat(features, dim=1)

    def _expected(
        self,
        a_t: torch.Tensor,
        b_t: torch.Tensor,
        at_start: torch.Tensor,
        graph_of: torch.Tensor,
        limit: torch.Tensor,
    ) -> torch.Tensor:
        """[graphs, width]: the features in expectation over the runs that end where `b_t`
        (beta on the states rows, [L + 1, states]) counts, from the forward pass `a_t`."""
        graphs, device = len(limit), a_t.device
        m, s, letters = self.probes, self.states, a_t.shape[0] - 1
        parts = self.bins + 1
        total = torch.zeros(graphs, parts, m, s, device=device)
        counted = torch.zeros(graphs, device=device)
        for length in range(1, letters + 1):
            z = at_start[length]  # accepted mass at this length, per graph
            ok = (z > 0) & (length <= limit)
            if not bool(ok.any()):
                continue
            # occupancy at time t of runs of this length that end where b_t counts, on the states
            # of the graphs that have such runs (a batch of trace chains: those of this length
            # only)
            keep = torch.nonzero(ok[graph_of]).flatten()
            occ = a_t[: length + 1, keep] * b_t[: length + 1, keep].flip(0)[..., None, None]
            t = torch.arange(length + 1, device=device)
            part = (t * self.bins) // (length + 1)
            part_of = torch.zeros(parts, length + 1, device=device)
            part_of[part, t] = 1.0 / torch.bincount(part, minlength=self.bins)[part].float()
            part_of[self.bins, length] = 1.0
            per_part = torch.einsum("pt,tnms->npms", part_of, occ)  # [kept states, parts, m, s]
            per_part = per_part / z[graph_of[keep]].view(-1, 1, 1, 1)
            total = total.index_add(0, graph_of[keep], per_part)
            counted = counted + ok.float()
        return (total / counted.clamp(min=1).view(-1, 1, 1, 1)).reshape(graphs, -1)
