"""Graph batches built with tensor indexing (`embed.batches`) equal collated ones, and the
encoders read them to the same vectors."""

import pytest
import torch
from torch_geometric.data import Batch

from tleaf_cli.embed.automaton import AutomatonEncoder
from tleaf_cli.embed.batches import GraphStore, join
from tleaf_cli.embed.graphs import dfa_graph, trace_graph
from tleaf_cli.logic.compile import compile_formula


def _graphs():
    graphs = [trace_graph(n) for n in (3, 1, 5, 2)]
    graphs += [
        dfa_graph(compile_formula(f, engine="progression"))[0] for f in ("a U b", "G(a -> X b)")
    ]
    for k, g in enumerate(graphs):
        g.monitor = torch.full((1, 4), float(k))
        g.edge_vec = torch.randn(g.num_nodes, 6, generator=torch.Generator().manual_seed(k))
        g.horizon = torch.tensor([0])
        g.run_weights = torch.rand(g.num_nodes, 2)
    return graphs


@pytest.mark.parametrize("ids", [[2, 0, 2], [5, 4, 1, 3, 0], [1]])
def test_select_is_the_collated_batch(ids):
    graphs = _graphs()
    selected = GraphStore(graphs).select(ids)
    collated = Batch.from_data_list([graphs[i] for i in ids])
    for key in (
        "edge_index",
        "ptr",
        "batch",
        "node_kind",
        "flags",
        "edge_vec",
        "initial",
        "monitor",
        "run_weights",
    ):
        assert torch.equal(selected[key], collated[key]), key
    assert selected.num_nodes == collated.num_nodes


def test_a_field_neither_per_node_nor_per_graph_is_refused():
    graphs = _graphs()[:2]
    graphs[0].odd = torch.zeros(2)  # two rows: neither one per node (7) nor one per graph
    graphs[1].odd = torch.zeros(2)
    with pytest.raises(ValueError, match="odd"):
        GraphStore(graphs)


def test_join_is_the_batch_of_both_lists():
    graphs = _graphs()
    joined = join(Batch.from_data_list(graphs[:2]), Batch.from_data_list(graphs[2:]))
    collated = Batch.from_data_list(graphs)
    for key in ("edge_index", "ptr", "batch", "node_kind", "edge_vec", "initial", "monitor"):
        assert torch.equal(joined[key], collated[key]), key


@pytest.mark.parametrize("directed,readout", [(True, "runs"), (False, "walk")])
def test_an_encoder_gives_each_graph_its_own_vector_in_any_batch(directed, readout):
    """GCN layers over the once-normalised sparse adjacency, the readout in one product: a
    graph's vector does not depend on which graphs share its batch."""
    torch.manual_seed(0)
    encoder = AutomatonEncoder(
        6, hidden=8, layers=2, out_dim=5, directed=directed, readout=readout, bins=1
    )
    graphs = _graphs()
    together = encoder(GraphStore(graphs).select(range(len(graphs))))
    alone = torch.cat([encoder(Batch.from_data_list([g])) for g in graphs])
    assert torch.allclose(together, alone, atol=1e-5)


def test_the_normalised_layer_is_gcnconv_with_its_gradients():
    """NormalisedGCNConv over gcn_adjacency(edge_index) computes what GCNConv computes from
    edge_index, forwards and backwards, with GCNConv's own weights."""
    from torch_geometric.nn import GCNConv

    from tleaf_cli.embed.graphs import gcn_adjacency
    from tleaf_cli.embed.layers import NormalisedGCNConv

    torch.manual_seed(0)
    edge_index = torch.tensor([[0, 1, 1, 2, 3, 4], [1, 2, 3, 0, 4, 4]])
    reference, layer = GCNConv(5, 3), NormalisedGCNConv(5, 3)
    layer.load_state_dict(reference.state_dict())
    x = torch.randn(6, 5)
    xs = [x.clone().requires_grad_() for _ in range(2)]
    out_ref = reference(xs[0], edge_index)
    out = layer(xs[1], gcn_adjacency(edge_index, 6))
    assert torch.allclose(out, out_ref, atol=1e-6)
    weights = torch.randn(6, 3)
    (out_ref * weights).sum().backward()
    (out * weights).sum().backward()
    assert torch.allclose(xs[0].grad, xs[1].grad, atol=1e-6)
    assert torch.allclose(reference.lin.weight.grad, layer.lin.weight.grad, atol=1e-6)
