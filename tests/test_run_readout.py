"""The accepted-run readout of q_m (`--readout accept|runs`): weights checked by enumeration."""

from __future__ import annotations

import itertools

import pytest
import torch
from torch_geometric.data import Batch

from tleaf_cli.embed.automaton import AutomatonEncoder, accepted_run_weights
from tleaf_cli.embed.graphs import EDGE, dfa_graph, trace_graph, trace_graph_batch
from tleaf_cli.logic.compile import compile_formula


def _weights(batch: Batch, ends: torch.Tensor, max_length: int, bins: int) -> torch.Tensor:
    start = batch.ptr[:-1] + batch.initial
    return accepted_run_weights(
        batch.edge_index, batch.share, ends, start, batch.batch, max_length, bins
    )


def _enumerated(dfa, graph, ends: set[int], max_length: int, bins: int) -> torch.Tensor:
    """The same weights by listing every word: each length's runs ending in `ends`, uniform
    among them, their nodes counted into parts, each part normalised to sum to 1."""
    src, dst = graph.edge_index.tolist()
    node_of = {}  # (state, target state) -> edge node
    for s, e in zip(src, dst, strict=True):
        if graph.node_kind[e] == EDGE:
            node_of[s, dst[src.index(e)]] = e
    out = torch.zeros(bins, graph.num_nodes, dtype=torch.float64)
    for length in range(1, max_length + 1):
        runs = []
        for word in itertools.product(range(dfa.alphabet.size), repeat=length):
            nodes, state = [dfa.initial], dfa.initial
            for letter in word:
                nxt = int(dfa.table[state, letter])
                nodes += [node_of[state, nxt], nxt]
                state = nxt
            if state in ends:
                runs.append(nodes)
        for nodes in runs:
            for i, v in enumerate(nodes):
                out[i * bins // len(nodes), v] += 1.0 / len(runs)
    return (out / out.sum(dim=1, keepdim=True).clamp(min=1e-12)).float()


@pytest.mark.parametrize("formula", ["a U b", "G(a -> X b)", "F(a & X !b)"])
@pytest.mark.parametrize("bins", [1, 3])
def test_weights_are_where_accepted_and_rejected_words_go(formula: str, bins: int) -> None:
    dfa = compile_formula(formula)
    graph, _ = dfa_graph(dfa)
    batch = Batch.from_data_list([trace_graph(2), graph])  # a chain before it shifts indices
    offset = int(batch.ptr[1])
    accepting = {s for s in range(dfa.num_states) if dfa.accepting[s]}
    rejecting = set(range(dfa.num_states)) - accepting
    for ends, mask in ((accepting, batch.flags[:, 1]), (rejecting, batch.rejecting)):
        got = _weights(batch, mask, max_length=4, bins=bins)[:, offset:]
        assert torch.allclose(got, _enumerated(dfa, graph, ends, 4, bins), atol=1e-5), ends


def test_a_trace_chain_is_read_once_in_order_and_has_no_rejected_runs() -> None:
    batch, _ = trace_graph_batch([3, 1])
    r = _weights(batch, batch.flags[:, 1], max_length=12, bins=2)
    # trace of 3 letters: nodes s0 s1 s2 s3 e1 e2 e3; the run s0 e1 s1 e2 | s2 e3 s3
    first = torch.tensor([1, 1, 0, 0, 1, 1, 0]) / 4
    second = torch.tensor([0, 0, 1, 1, 0, 0, 1]) / 3
    assert torch.allclose(r[:, :7], torch.stack([first, second]))
    assert torch.allclose(r[:, 7:], torch.tensor([[0.5, 0.0, 0.5], [0.0, 1.0, 0.0]]))
    assert not _weights(batch, batch.rejecting, 12, 2).any()


def test_runs_readout_tells_a_language_from_its_complement() -> None:
    """`runs` reads accepted and rejected runs apart: a DFA and its complement have the same
    graph but for the flags; each gets its own vector, and a trace is encoded as before."""
    torch.manual_seed(0)
    dfa = compile_formula("a U b")
    graphs = [dfa_graph(d)[0] for d in (dfa, dfa.complement())]
    edge_vec = torch.randn(graphs[0].num_nodes, 4) * (graphs[0].node_kind == EDGE).unsqueeze(1)
    for g in graphs:
        assert torch.equal(g.edge_index, graphs[0].edge_index)
        g.edge_vec = edge_vec
    encoder = AutomatonEncoder(4, hidden=8, layers=2, out_dim=5, readout="runs", bins=2)
    z = encoder(Batch.from_data_list(graphs))
    assert z.shape == (2, 5) and not torch.allclose(z[0], z[1], atol=1e-4)
