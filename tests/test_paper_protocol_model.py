"""The authors' q_m (`--encoder authors`, presets paper-code / paper-text): direction, readout,
unit vectors, loss, optimiser settings."""

from __future__ import annotations

import torch
from torch_geometric.data import Batch, Data

from tleaf_cli.embed.graphs import dfa_graph
from tleaf_cli.embed.meta_data import chain_batch
from tleaf_cli.embed.model import build_model
from tleaf_cli.embed.paper_encoder import (
    AuthorsEncoder,
    expected_visits,
    live_nodes,
    sampled_visits,
)
from tleaf_cli.embed.triplets import triplet_loss
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.settings.meta import MetaSettings

EDGE_DIM = 6


def _dfa_batch(*texts: str) -> Batch:
    graphs = []
    for text in texts:
        graph, _ = dfa_graph(compile_formula(text))
        graph.edge_vec = torch.randn(graph.num_nodes, EDGE_DIM)
        graphs.append(graph)
    return Batch.from_data_list(graphs)


def test_sampled_paths_average_to_the_expected_visits():
    torch.manual_seed(0)
    batch = _dfa_batch("a U b", "F(a) & X(b)", "G(a | X(b))")
    encoder = AuthorsEncoder(EDGE_DIM, widths=(8,), steps=4, walk_from="node1")
    start = encoder.start_nodes(batch)
    assert (start == batch.ptr[:-1] + 1).all()
    n = int(batch.num_nodes)
    mean = sum(sampled_visits(batch.edge_index, start, n, 10, 4) for _ in range(2000)) / 20000
    expected = expected_visits(batch.edge_index, start, n, 4)
    assert torch.allclose(mean, expected, atol=0.03)
    assert torch.allclose(expected.sum(), torch.tensor(15.0))  # 3 graphs x 5 nodes a path


def test_walks_start_at_the_initial_state_with_walk_from_initial():
    batch = _dfa_batch("a U b", "F(a)")
    encoder = AuthorsEncoder(EDGE_DIM, widths=(8,), walk_from="initial")
    assert (encoder.start_nodes(batch) == batch.ptr[:-1] + batch.initial).all()


def test_forward_messages_do_not_reach_back():
    """On a trace chain, paths from node 1 of 5 nodes read states 1..3; with messages only
    along the arcs, the fourth letter (the arc out of state 3) cannot change the vector; taken
    both ways, it does."""
    torch.manual_seed(1)
    letters = torch.randn(8, EDGE_DIM)
    changed = letters.clone()
    changed[3] += 1.0  # the fourth step
    for directed, same in ((True, True), (False, False)):
        encoder = AuthorsEncoder(EDGE_DIM, widths=(16, 8), directed=directed).eval()
        a = encoder(chain_batch(encoder, letters, [8]))
        b = encoder(chain_batch(encoder, changed, [8]))
        assert torch.allclose(a, b) == same


def test_paper_code_preset_builds_the_authors_q():
    settings = MetaSettings.preset("paper-code").resolved(3)
    assert settings.preset_name() == "paper-code"
    assert MetaSettings.preset("paper-text").resolved(3).preset_name() == "paper-text"
    assert (settings.lr, settings.weight_decay, settings.batch_size) == (0.01, 5e-4, 256)
    model = build_model(settings, EDGE_DIM, torch.eye(3)).eval()
    widths = [conv.lin.weight.shape[0] for conv in model.trace.convs]
    assert widths == [2048, 512, 256, 200]
    z = model.embed_formulas(_dfa_batch("a U b", "F(a) & F(b)"))
    assert z.shape == (2, 200)
    assert torch.allclose(z.norm(dim=1), torch.ones(2), atol=1e-5)  # unit vectors


def test_euclidean_triplet_loss_is_torchs():
    a, p, n = torch.randn(3, 5, 4).unbind(0)
    want = torch.nn.TripletMarginLoss(margin=1.0, p=2)(a, p, n)
    assert torch.allclose(triplet_loss(a, p, n, 1.0, "euclidean"), want)
    squared = torch.relu((a - p).pow(2).sum(1) - (a - n).pow(2).sum(1) + 1.0).mean()
    assert torch.allclose(triplet_loss(a, p, n, 1.0), squared)


def _trimmed(graph):
    """The graph as spot prints it: the nodes no accepting state can be reached from, and
    their arcs, removed (the rest relabelled in order)."""
    from torch_geometric.utils import subgraph

    keep = live_nodes(graph.edge_index, graph.flags[:, 1] > 0)
    arcs, _ = subgraph(keep, graph.edge_index, relabel_nodes=True, num_nodes=graph.num_nodes)
    fields = {k: graph[k][keep] for k in ("node_kind", "flags", "edge_vec")}
    return Data(**fields, edge_index=arcs, initial=graph.initial, num_nodes=int(keep.sum()))


def test_without_the_dead_state_q_reads_the_trimmed_automaton():
    """`dead_state=False` gives every graph the vector the same encoder gives the graph with
    its dead nodes removed (node 1 then the second live node); live nodes are DFA.live()."""
    torch.manual_seed(2)
    # "a & X(b)": its state 1 (after !a) is dead; "G(a)" has a dead sink; "F(a)" has none
    texts = ("a & X(b)", "G(a)", "F(a)", "a U b")
    full = _dfa_batch(*texts)
    for text, graph in zip(texts, full.to_data_list(), strict=True):
        dfa = compile_formula(text)
        states = live_nodes(graph.edge_index, graph.flags[:, 1] > 0)[: dfa.num_states]
        assert states.tolist() == dfa.live().tolist()
    assert not compile_formula("a & X(b)").live()[1]
    trimmed = Batch.from_data_list([_trimmed(g) for g in full.to_data_list()])
    for walk_from in ("node1", "initial"):
        encoder = AuthorsEncoder(EDGE_DIM, widths=(16, 8), walk_from=walk_from).eval()
        kept = encoder(full)
        encoder.dead_state = False
        dropped = encoder(full)
        encoder.dead_state = True
        assert torch.allclose(dropped, encoder(trimmed), atol=1e-6)
        assert not torch.allclose(kept[:2], dropped[:2])  # the two with a dead state differ
        assert torch.allclose(kept[2], dropped[2])  # F(a) has none
