"""q_m in few, large operations: the joint adjacency (both directions in one sparse product per
layer), the readout pool as a CSR pair, and a GraphStore that gathers a batch's matrices instead
of rebuilding them give the vectors of the per-direction implementation they replaced, to float
rounding; a JointStore's batches, the one-node GCN layer, joint_step and Adam over flat
parameters give that implementation's losses, gradients and updates. The references below are
that implementation, kept here."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
import torch
from torch import nn
from torch_geometric.data import Batch
from torch_geometric.utils import to_undirected

from tleaf_cli.embed.automaton import KINDS, AutomatonEncoder, run_readout
from tleaf_cli.embed.batches import GraphStore, JointStore, join
from tleaf_cli.embed.evidence import MonitorEvidence, chain_lengths
from tleaf_cli.embed.graphs import dfa_graph, gcn_adjacency, joint_adjacency, readout_pool
from tleaf_cli.embed.layers import csr_product, gcn_layer
from tleaf_cli.embed.meta_data import chain_batch, with_chain_templates
from tleaf_cli.embed.model import TripletEmbedder
from tleaf_cli.embed.radius import RadiusClassifier
from tleaf_cli.embed.train_meta import joint_step
from tleaf_cli.embed.triplets import anchor_pull, triplet_step
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.training.loop import LoopSettings, Step, fit

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


def monitor_encoder(directed: bool, layers: int) -> AutomatonEncoder:
    """A small q_m encoder with the runs readout and monitors over two atoms."""
    torch.manual_seed(0)
    return AutomatonEncoder(
        EDGE_DIM,
        hidden=16,
        layers=layers,
        out_dim=8,
        directed=directed,
        readout="runs",
        bins=2,
        max_length=6,
        monitors=2,
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

    trace = monitor_encoder(True, layers=2)
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


# ---- q_m's training step in few operators (JointStore, gcn_layer, joint_step, flat Adam),
# against the implementation it replaced (GraphStore batches, a GCN layer per direction,
# triplet_step with F.normalize and binary_cross_entropy_with_logits), kept here


def reference_radius_loss(radius, anchor, positive, negative):
    """RadiusClassifier.loss as it was: binary cross-entropy with logits on both pairs."""
    logits = torch.cat([radius(anchor, positive), radius(anchor, negative)])
    target = torch.cat([torch.ones(len(anchor)), torch.zeros(len(anchor))])
    return nn.functional.binary_cross_entropy_with_logits(logits, target)


def reference_vectors(model: TripletEmbedder, batch, formulas: int):
    """TripletEmbedder.embed_joined as it was: F.normalize, the evidence block from the
    monitor features, both per part."""
    z = model.trace(batch)
    unit = [nn.functional.normalize(part, dim=-1) for part in (z[:formulas], z[formulas:])]
    monitor = model.trace.monitor_features(batch)
    lengths = chain_lengths(batch)[formulas:]
    return (
        torch.cat([unit[0], model.evidence.formulas(monitor[:formulas])], dim=1),
        torch.cat([unit[1], model.evidence.traces(monitor[formulas:], lengths)], dim=1),
    )


def joint_setup(directed: bool = True):
    """A small q_m with monitors, evidence, the sphere and a radius, fixed formula graphs and
    traces (letters, monitor features), its JointStore and the plain GraphStore of the same
    graphs."""
    trace = monitor_encoder(directed, layers=3)
    bank = trace.monitor_bank
    model = TripletEmbedder(
        trace, trace, RadiusClassifier(1.5), sphere=True, evidence=MonitorEvidence(bank, 32.0)
    )
    generator = torch.Generator().manual_seed(3)
    graphs = dfa_graphs()
    for g in graphs:
        g.monitor = torch.rand(1, 2 * bank.features, generator=generator)
    lengths = [3, 5, 2, 3, 4, 1]
    letters = [torch.randn(t, EDGE_DIM, generator=generator) for t in lengths]
    monitor = torch.rand(len(lengths), 2 * bank.features, generator=generator)
    store_graphs, chain_of = with_chain_templates(trace, graphs, set(lengths))
    width = trace.monitor_width
    formula_monitor = torch.cat([g.monitor for g in graphs])[:, :width]
    with torch.no_grad():
        units = (
            model.evidence.formula_units(formula_monitor),
            model.evidence.trace_units(monitor[:, :width], torch.tensor(lengths)),
        )
    store = JointStore(
        store_graphs,
        chain_of,
        trace.node_inputs,
        trace.block_matrices,
        letters,
        monitor[:, :width],
        evidence=units,
    )
    plain = GraphStore(store_graphs, matrices=trace.block_matrices)
    return model, store, plain, chain_of, letters, monitor


def plain_batch(plain, chain_of, letters, monitor, formulas, traces):
    """train_meta's batch before JointStore: one GraphStore select, the letters placed on the
    chains' edge nodes, the traces' monitor features in their rows."""
    batch = plain.select(formulas + [chain_of[len(letters[k])] for k in traces])
    on = (batch.letter >= 0).nonzero().flatten()
    batch.edge_vec = batch.edge_vec.index_copy(0, on, torch.cat([letters[k] for k in traces]))
    batch.monitor = torch.cat([batch.monitor[: len(formulas)], monitor[list(traces)]])
    return batch


def test_gcn_layer_is_a_layer_per_direction_summed_with_gradients():
    batch = Batch.from_data_list(dfa_graphs())
    n = int(batch.num_nodes)
    arcs = batch.edge_index
    for directed in (True, False):
        model = encoder(directed)
        convs = [model.convs[0]] + ([model.back[0]] if directed else [])
        x = torch.randn(n, convs[0].in_channels, requires_grad=True)
        joint = joint_adjacency(arcs, n, directed)
        got = gcn_layer(x, joint, tuple(c.lin.weight for c in convs), tuple(c.bias for c in convs))
        if directed:
            along, against = gcn_adjacency(arcs, n), gcn_adjacency(arcs.flip(0), n)
            want = torch.relu(convs[0](x, along) + convs[1](x, against))
        else:
            want = torch.relu(convs[0](x, gcn_adjacency(to_undirected(arcs, num_nodes=n), n)))
        assert torch.allclose(got, want, atol=1e-5), directed
        inputs = [x] + [p for c in convs for p in (c.lin.weight, c.bias)]
        weights = torch.randn_like(got)  # a gradient that differs per entry
        g1 = torch.autograd.grad((got * weights).sum(), inputs)
        g2 = torch.autograd.grad((want * weights).sum(), inputs)
        for a, b in zip(g1, g2, strict=True):
            assert torch.allclose(a, b, atol=1e-5, rtol=1e-5), directed


@pytest.mark.parametrize("directed", [True, False])
def test_gcn_layer_over_distinct_inputs_is_the_layer_over_every_node(directed):
    """x given once per distinct row with each node's index: the layer's output and every
    gradient (weights, biases, the distinct rows) are those of the layer over x[index]."""
    batch = Batch.from_data_list(dfa_graphs())
    n = int(batch.num_nodes)
    model = encoder(directed)
    convs = [model.convs[0]] + ([model.back[0]] if directed else [])
    weights, biases = tuple(c.lin.weight for c in convs), tuple(c.bias for c in convs)
    joint = joint_adjacency(batch.edge_index, n, directed)
    rows = torch.randn(7, convs[0].in_channels, requires_grad=True)
    index = torch.randint(0, 7, (n,))
    got = gcn_layer(rows, joint, weights, biases, index)
    want = gcn_layer(rows[index], joint, weights, biases)
    assert torch.allclose(got, want, atol=1e-6)
    scale = torch.randn_like(got)
    inputs = (rows, *weights, *biases)
    for a, b in zip(
        torch.autograd.grad((got * scale).sum(), inputs),
        torch.autograd.grad((want * scale).sum(), inputs),
        strict=True,
    ):
        assert torch.allclose(a, b, atol=1e-5, rtol=1e-5)


def test_gcn_layer_of_a_frozen_q_gives_the_inputs_their_gradient():
    """Weights that ask for no gradient (q frozen under the tleaf loss) get none, and the
    inputs' gradient is the one a trainable layer gives them."""
    batch = Batch.from_data_list(dfa_graphs())
    n = int(batch.num_nodes)
    conv = encoder(False).convs[0]
    joint = joint_adjacency(batch.edge_index, n, False)
    x = torch.randn(n, conv.in_channels, requires_grad=True)
    scale = torch.randn(n, conv.out_channels)
    trainable = gcn_layer(x, joint, (conv.lin.weight,), (conv.bias,))
    (want,) = torch.autograd.grad((trainable * scale).sum(), (x,))
    weight, bias = conv.lin.weight.detach(), conv.bias.detach()
    frozen = gcn_layer(x, joint, (weight,), (bias,))
    (got,) = torch.autograd.grad((frozen * scale).sum(), (x,))
    assert torch.equal(frozen, trainable)
    assert torch.allclose(got, want, atol=1e-6)


def test_csr_product_ignores_what_its_output_held():
    batch = Batch.from_data_list(dfa_graphs())
    n = int(batch.num_nodes)
    joint = joint_adjacency(batch.edge_index, n, True)
    x = torch.randn(2 * n, 5)
    assert torch.allclose(csr_product(joint.matrix, x), joint.matrix.to_dense() @ x, atol=1e-6)


def test_joint_store_batch_is_the_graph_store_batch():
    """Inputs, matrices, monitor features and evidence units of a JointStore select are the
    plain batch's, and q_m reads both to the same vectors."""
    model, store, plain, chain_of, letters, monitor = joint_setup()
    formulas, traces = [4, 0, 2], [5, 1, 1, 3, 0]  # repeats and any order
    joint = store.select(formulas, traces)
    old = plain_batch(plain, chain_of, letters, monitor, formulas, traces)
    assert torch.equal(joint.node_inputs(), model.trace.node_inputs(old))
    for key in ("adjacency", "pool"):
        for got, want in zip(getattr(joint, key), old[key], strict=True):
            assert got.crow_indices().dtype == torch.int32
            assert torch.equal(got.to_dense(), want.to_dense()), key
    assert torch.equal(joint.monitor, model.trace.monitor_features(old))
    lengths = chain_lengths(old)[len(formulas) :]
    assert torch.equal(joint.lengths, lengths)
    with torch.no_grad():
        want = torch.cat(
            [
                model.evidence.formula_units(joint.monitor[: len(formulas)]),
                model.evidence.trace_units(joint.monitor[len(formulas) :], lengths),
            ]
        )
    assert torch.allclose(joint.evidence, want, atol=1e-7)
    assert torch.allclose(model.trace(joint), reference_forward(model.trace, old), atol=1e-5)


@pytest.mark.parametrize("directed", [True, False])
def test_joint_step_is_the_triplet_step_with_gradients(directed):
    """One training step of q_m (triplet loss, pull, radius loss, accuracy) from a JointStore
    batch, against triplet_step on the plain batch with the implementation it replaced: the
    same loss, figures and parameter gradients."""
    model, store, plain, chain_of, letters, monitor = joint_setup(directed)
    settings = SimpleNamespace(margin=1.0, pull=0.02, radius_weight=0.5)
    chunk = [(4, 0, 1), (4, 3, 2), (0, 5, 1), (2, 3, 4)]  # (formula, satisfying, violating)
    got = joint_step(model, store, settings)(chunk)

    def embed(chunk):
        formulas, sats, negs = zip(*chunk, strict=True)
        distinct = list(dict.fromkeys(formulas))
        batch = plain_batch(plain, chain_of, letters, monitor, distinct, sats + negs)
        z_formulas, z_traces = reference_vectors(model, batch, len(distinct))
        rows = torch.tensor([distinct.index(f) for f in formulas])
        return z_formulas[rows], z_traces[: len(sats)], z_traces[len(sats) :]

    def extra(triplet):
        loss = anchor_pull(triplet[0], triplet[1]) * settings.pull
        return loss + settings.radius_weight * reference_radius_loss(model.radius, *triplet)

    want = triplet_step(embed, settings.margin, extra)(chunk)
    assert abs(got.loss.item() - want.loss.item()) < 1e-5
    assert got.figures["train_accuracy"] == want.figures["train_accuracy"]
    assert got.weight == want.weight
    parameters = list(model.parameters())
    g1 = torch.autograd.grad(got.loss, parameters)
    g2 = torch.autograd.grad(want.loss, parameters)
    assert any(a.abs().sum() > 0 for a in g1)
    for a, b in zip(g1, g2, strict=True):
        assert torch.allclose(a, b, atol=1e-5, rtol=1e-4)


def test_unit_vectors_are_normalize_with_its_gradient():
    z = torch.randn(7, 5, requires_grad=True)
    model = TripletEmbedder(nn.Identity(), nn.Identity(), sphere=True)
    got, want = model._out(z), nn.functional.normalize(z, dim=-1)
    assert torch.allclose(got, want, atol=1e-7)
    weights = torch.randn(7, 5)
    (g1,) = torch.autograd.grad((got * weights).sum(), z)
    (g2,) = torch.autograd.grad((want * weights).sum(), z)
    assert torch.allclose(g1, g2, atol=1e-6)


def test_radius_loss_of_distances_is_the_cross_entropy():
    torch.manual_seed(0)
    radius = RadiusClassifier(1.5)
    anchor, pos, neg = (torch.randn(6, 4) for _ in range(3))
    got, want = radius.loss(anchor, pos, neg), reference_radius_loss(radius, anchor, pos, neg)
    assert torch.allclose(got, want, atol=1e-6)
    g1 = torch.autograd.grad(got, list(radius.parameters()))
    g2 = torch.autograd.grad(want, list(radius.parameters()))
    for a, b in zip(g1, g2, strict=True):
        assert torch.allclose(a, b, atol=1e-6)


def test_flat_parameters_give_adams_updates(tmp_path):
    """fit with the parameters laid out flat ends at the weights of fit over the separate
    tensors; a parameter left without a gradient is refused."""
    data = [(torch.randn(8, 3), torch.randn(8, 2)) for _ in range(4)]

    def train(flat: bool, out: str) -> nn.Module:
        torch.manual_seed(0)
        model = nn.Sequential(nn.Linear(3, 5), nn.ReLU(), nn.Linear(5, 2))
        step = lambda b: Step(nn.functional.mse_loss(model(b[0]), b[1]), {"loss": 0.0})  # noqa: E731
        epochs = iter(range(100))
        settings = LoopSettings(epochs=3, patience=None, lr=0.05, seed=0, weight_decay=0.01)
        fit(model, lambda e, g: data, step, lambda: next(epochs), settings, tmp_path / out,
            score="s", flat=flat)  # fmt: skip
        return model

    separate, flat = train(False, "a"), train(True, "b")
    for (name, a), (_, b) in zip(
        separate.state_dict().items(), flat.state_dict().items(), strict=True
    ):
        assert torch.allclose(a, b, atol=1e-6), name
    torch.manual_seed(0)
    start = nn.Sequential(nn.Linear(3, 5), nn.ReLU(), nn.Linear(5, 2))
    assert not torch.allclose(flat[0].weight, start[0].weight, atol=1e-3)  # it trained
    unused = nn.Sequential(nn.Linear(3, 2), nn.Linear(3, 2))
    settings = LoopSettings(epochs=1, patience=None, lr=0.05, seed=0)
    with pytest.raises(RuntimeError, match="no gradient"):
        fit(
            unused,
            lambda e, g: data,
            lambda b: Step(nn.functional.mse_loss(unused[0](b[0]), b[1]), {}),
            lambda: 0.0,
            settings,
            tmp_path / "c",
            score="s",
            flat=True,
        )


def reference_accepted_run_weights(edge_index, share, ends, start, graph_of, max_length, bins):
    """accepted_run_weights as it was: one length at a time."""
    src, dst = edge_index
    n, graphs = share.shape[0], int(start.numel())
    limit = torch.as_tensor(max_length).expand(graphs)
    hops = 2 * int(limit.max())
    prob = torch.where(share[src] > 0, share[src], 1.0)
    a = [torch.zeros(n).index_fill_(0, start, 1.0)]
    b = [ends.float()]
    for _ in range(hops):
        a.append(torch.zeros(n).index_add_(0, dst, a[-1][src] * prob))
        b.append(torch.zeros(n).index_add_(0, src, b[-1][dst] * prob))
    a_t, b_t = torch.stack(a), torch.stack(b)
    out = torch.zeros(bins, n)
    for length in range(1, hops // 2 + 1):
        h = 2 * length
        z = b_t[h, start]
        occupancy = a_t[: h + 1] * b_t[: h + 1].flip(0)
        i = torch.arange(h + 1)
        part = torch.zeros(bins, h + 1)
        part[(i * bins) // (h + 1), i] = 1.0
        ok = (z > 0) & (length <= limit)
        out += torch.where(ok[graph_of], part @ occupancy / torch.where(ok, z, 1.0)[graph_of], 0.0)
    total = torch.zeros(len(out), graphs).index_add_(1, graph_of, out)
    return out / total.clamp(min=1e-12)[:, graph_of]


@pytest.mark.parametrize("bins", [1, 3])
def test_run_weights_of_every_length_at_once_are_the_length_by_length_ones(bins):
    from tleaf_cli.embed.automaton import accepted_run_weights
    from tleaf_cli.embed.graphs import trace_graph

    graphs = [*dfa_graphs(), trace_graph(4), trace_graph(1)]
    for chain in graphs[-2:]:
        chain.edge_vec = torch.zeros(chain.num_nodes, EDGE_DIM)
    batch = Batch.from_data_list(graphs)
    start = batch.ptr[:-1] + batch.initial
    limit = torch.tensor([6] * 6 + [4, 1])  # the DFAs to 6 letters, each chain to its end
    for ends in (batch.flags[:, 1], batch.rejecting):
        arguments = (batch.edge_index, batch.share, ends, start, batch.batch, limit, bins)
        got = accepted_run_weights(*arguments)
        want = reference_accepted_run_weights(*arguments)
        assert got.abs().sum() > 0
        assert torch.allclose(got, want, atol=1e-6)


def test_embed_dfas_collated_on_the_host_is_the_data_objects_path():
    """Embedder.embed_dfas (meta_data.dfa_batch, the readout weights per batch) against the
    path it replaced: featured_dfa_graphs, store_run_weights and Batch.from_data_list."""
    from tleaf_cli.embed.embedder import Embedder
    from tleaf_cli.embed.meta_data import GuardVectors, dfa_batch, featured_dfa_graphs
    from tleaf_cli.embed.model import store_run_weights
    from tleaf_cli.embed.proposition_encoder import PropositionEncoder

    torch.manual_seed(0)
    vocabulary = ["a", "b", "c"]
    edge = PropositionEncoder(torch.eye(3), hidden=8, layers=2, out_dim=EDGE_DIM)
    trace = monitor_encoder(True, layers=2)
    model = TripletEmbedder(trace, trace, sphere=True).eval()
    embedder = Embedder(model, GuardVectors(edge, vocabulary), {"settings": {"embedder": "dfa"}})
    texts = ["F(a)", "G(a -> X(b))", "a U b", "F(b)", "c U a", "G(!a) | F(c)"]  # F(b): F(a)'s
    dfas = [compile_formula(t) for t in texts]
    got = embedder.embed_dfas(dfas, batch=4)
    graphs = featured_dfa_graphs(dfas, embedder.vectors, trace.monitor_bank)
    store_run_weights(trace, graphs)
    collated = Batch.from_data_list(graphs)
    with torch.no_grad():
        want = model.embed_formulas(collated)
    assert torch.allclose(got, want, atol=1e-5)
    shares = torch.cat([g.monitor for g in graphs]).view(len(dfas), 2, -1).numpy()
    batch = dfa_batch(dfas, embedder.vectors, shares)
    for key in ("node_kind", "flags", "guard", "share", "rejecting", "horizon", "initial",
                "edge_vec", "monitor", "edge_index", "ptr", "batch"):  # fmt: skip
        assert torch.equal(batch[key], collated[key]), key
