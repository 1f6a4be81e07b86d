"""q_m in few, large operations: the joint adjacency (both directions in one sparse product per
layer), the readout pool as a CSR pair, and a GraphStore that gathers a batch's matrices instead
of rebuilding them give the vectors of the per-direction implementation they replaced, to float
rounding. The references below are that implementation, kept here."""

from __future__ import annotations

import torch
from torch import nn
from torch_geometric.data import Batch
from torch_geometric.utils import to_undirected

from tleaf_cli.embed.automaton import KINDS, AutomatonEncoder, run_readout
from tleaf_cli.embed.batches import GraphStore, join
from tleaf_cli.embed.evidence import MonitorEvidence
from tleaf_cli.embed.graphs import dfa_graph, gcn_adjacency, joint_adjacency, readout_pool
from tleaf_cli.embed.meta_data import chain_batch, with_chain_templates
from tleaf_cli.embed.model import TripletEmbedder
from tleaf_cli.logic.compile import compile_formula

EDGE_DIM = 6


def reference_run_readout(weights, x, graph_of, graphs):
    """The readout as it was: a COO pooling matrix through torch.sparse.mm."""
    n, parts = weights.shape
    rows = (graph_of.unsqueeze(1) * parts + torch.arange(parts)).reshape(-1)
    cols = torch.arange(n).repeat_interleave(parts)
    pool = torch.sparse_coo_tensor(
        torch.stack([rows, cols]), weights.reshape(-1), (graphs * parts, n)
    )
    return torch.sparse.mm(pool, x).reshape(graphs, -1)


def reference_forward(encoder: AutomatonEncoder, batch) -> torch.Tensor:
    """AutomatonEncoder.forward as it was: one GCN layer per direction, each with its own
    adjacency, summed (run readouts, no probes)."""
    kinds = nn.functional.one_hot(batch.node_kind, KINDS).float()
    x = torch.cat([kinds, batch.flags, batch.edge_vec], dim=1)
    arcs, n = batch.edge_index, x.shape[0]
    if encoder.back is None:
        both = gcn_adjacency(to_undirected(arcs, num_nodes=n), n, x.dtype)
        for conv in encoder.convs:
            x = torch.relu(conv(x, both))
    else:
        along, against = gcn_adjacency(arcs, n, x.dtype), gcn_adjacency(arcs.flip(0), n, x.dtype)
        for conv, back in zip(encoder.convs, encoder.back, strict=True):
            x = torch.relu(conv(x, along) + back(x, against))
    graphs = int(batch.ptr.numel() - 1)
    r = getattr(batch, "run_weights", None)
    r = r if r is not None else encoder.run_weights(batch).t()
    parts = [reference_run_readout(r, x, batch.batch, graphs)]
    if encoder.monitor_bank is not None:
        parts.append(encoder.monitor_features(batch))
    return encoder.head(torch.cat(parts, dim=1))


def dfa_graphs(count: int = 6) -> list:
    """Featured DFA graphs of a few formulas (random edge vectors, fixed seed)."""
    texts = ["F(a)", "G(a -> X(b))", "a U b", "F(a & F(b))", "G(!a) | F(b)", "X(a) & F(b)"]
    generator = torch.Generator().manual_seed(1)
    out = []
    for text in texts[:count]:
        graph, _ = dfa_graph(compile_formula(text))
        graph.edge_vec = torch.randn(graph.num_nodes, EDGE_DIM, generator=generator)
        graph.edge_vec[graph.guard < 0] = 0.0
        out.append(graph)
    return out


def encoder(directed: bool) -> AutomatonEncoder:
    torch.manual_seed(0)
    return AutomatonEncoder(
        EDGE_DIM,
        hidden=16,
        layers=3,
        out_dim=8,
        directed=directed,
        readout="runs",
        bins=3,
        max_length=6,
    )


def test_joint_adjacency_is_both_directions_summed():
    batch = Batch.from_data_list(dfa_graphs())
    n, x = int(batch.num_nodes), torch.randn(int(batch.num_nodes), 5)
    joint = joint_adjacency(batch.edge_index, n, True)
    y = torch.randn(n, 2, 5)
    want = (
        gcn_adjacency(batch.edge_index, n).matrix @ y[:, 0]
        + gcn_adjacency(batch.edge_index.flip(0), n).matrix @ y[:, 1]
    )
    assert torch.allclose(joint.matrix @ y.reshape(2 * n, 5), want, atol=1e-6)
    assert torch.allclose(joint.transposed.to_dense(), joint.matrix.to_dense().t())
    both = joint_adjacency(batch.edge_index, n, False)
    undirected = gcn_adjacency(to_undirected(batch.edge_index, num_nodes=n), n)
    assert torch.allclose(both.matrix @ x, undirected.matrix @ x, atol=1e-6)


def test_readout_pool_matches_the_coo_readout_and_its_gradient():
    batch = Batch.from_data_list(dfa_graphs())
    weights = encoder(True).run_weights(batch).t()
    x = torch.randn(int(batch.num_nodes), 7, requires_grad=True)
    graphs = int(batch.ptr.numel() - 1)
    got = run_readout(weights, x, batch.batch, graphs)
    want = reference_run_readout(weights, x, batch.batch, graphs)
    assert torch.allclose(got, want, atol=1e-6)
    (g1,) = torch.autograd.grad(got.pow(2).sum(), x)
    (g2,) = torch.autograd.grad(want.pow(2).sum(), x)
    assert torch.allclose(g1, g2, atol=1e-5)
    pool = readout_pool(weights, batch.batch, graphs)
    assert torch.allclose(pool.transposed.to_dense(), pool.matrix.to_dense().t())


def test_forward_matches_the_per_direction_reference_with_gradients():
    for directed in (True, False):
        model = encoder(directed)
        batch = Batch.from_data_list(dfa_graphs())
        got, want = model(batch), reference_forward(model, batch)
        assert torch.allclose(got, want, atol=1e-5), directed
        g1 = torch.autograd.grad(got.pow(2).sum(), list(model.parameters()), allow_unused=True)
        g2 = torch.autograd.grad(want.pow(2).sum(), list(model.parameters()), allow_unused=True)
        for a, b in zip(g1, g2, strict=True):
            assert (a is None) == (b is None)
            if a is not None:
                assert torch.allclose(a, b, atol=1e-4, rtol=1e-4)


def test_store_gathers_the_matrices_collation_would_build():
    model = encoder(True)
    graphs = dfa_graphs()
    store = GraphStore(graphs, matrices=model.block_matrices)
    ids = [4, 0, 0, 5, 2]  # repeats and any order
    selected = store.select(ids)
    built = model.block_matrices(Batch.from_data_list([graphs[i] for i in ids]))
    for key in ("adjacency", "pool"):
        for got, blocks in zip(selected[key], (built[key][0], built[key][1]), strict=True):
            crow = torch.cat([torch.zeros(1, dtype=torch.long), blocks.row_entries.cumsum(0)])
            assert torch.equal(got.crow_indices(), crow), key
            assert torch.allclose(got.values(), blocks.values), key
    plain = GraphStore(graphs).select(ids)
    assert torch.allclose(model(selected), reference_forward(model, plain), atol=1e-5)


def test_one_select_of_formulas_and_chains_gives_the_joined_vectors():
    """train_meta's batch (one select of formula graphs and chain templates, letters placed on
    the chains) against the batches it replaced (formulas selected, chains built, joined)."""
    model = encoder(True)
    graphs = dfa_graphs()
    bank_width = 4
    for g in graphs:
        g.monitor = torch.rand(1, bank_width, generator=torch.Generator().manual_seed(len(g.share)))
    store_graphs, chain_of = with_chain_templates(model, graphs, {2, 3, 5})
    store = GraphStore(store_graphs, matrices=model.block_matrices)
    lengths = [3, 5, 2, 3]
    letters = torch.randn(sum(lengths), EDGE_DIM)
    monitor = torch.rand(len(lengths), bank_width)
    formulas = [1, 3]
    batch = store.select(formulas + [chain_of[t] for t in lengths])
    on = (batch.letter >= 0).nonzero().flatten()
    batch.edge_vec = batch.edge_vec.index_copy(0, on, letters)
    batch.monitor = torch.cat([batch.monitor[: len(formulas)], monitor])
    old = join(GraphStore(graphs).select(formulas), chain_batch(model, letters, lengths, monitor))
    assert torch.allclose(model(batch), reference_forward(model, old), atol=1e-5)


def test_embed_joined_is_embed_both_with_evidence():
    from tleaf_cli.logic.monitors import MonitorBank

    torch.manual_seed(0)
    trace = AutomatonEncoder(
        EDGE_DIM,
        hidden=16,
        layers=2,
        out_dim=8,
        directed=True,
        readout="runs",
        bins=2,
        max_length=6,
        monitors=2,
    )
    bank: MonitorBank = trace.monitor_bank
    model = TripletEmbedder(trace, trace, sphere=True, evidence=MonitorEvidence(bank, 32.0))
    graphs = dfa_graphs(3)
    for g in graphs:
        g.monitor = torch.rand(1, 2 * bank.features)
    lengths = [2, 4]
    letters = torch.randn(sum(lengths), EDGE_DIM)
    monitor = torch.rand(len(lengths), 2 * bank.features)
    chains = chain_batch(trace, letters, lengths, monitor)
    formulas = Batch.from_data_list(graphs)
    want = model.embed_both(formulas, chains)
    got = model.embed_joined(join(formulas, chains), len(graphs))
    for a, b in zip(got, want, strict=True):
        assert torch.allclose(a, b, atol=1e-6)
