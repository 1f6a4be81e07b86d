"""Probe automata (`train-meta --probes`): the product forward pass checked by listing words."""

from __future__ import annotations

import itertools

import pytest
import torch
from torch_geometric.data import Batch

from tleaf_cli.embed.automaton import AutomatonEncoder
from tleaf_cli.embed.graphs import EDGE, dfa_graph, trace_graph_batch
from tleaf_cli.embed.probes import ProbeBank
from tleaf_cli.errors import SettingError
from tleaf_cli.logic.compile import compile_formula


def _bank(dim: int, bins: int, max_length: int) -> ProbeBank:
    torch.manual_seed(0)
    bank = ProbeBank(dim, probes=3, states=2, bins=bins, max_length=max_length)
    with torch.no_grad():  # away from the near-identity start, so every letter matters
        bank.transition.weight.normal_()
        bank.start.normal_()
    return bank


def _run(bank: ProbeBank, letters: torch.Tensor) -> list[torch.Tensor]:
    """The probes' state distributions [M, S] after 0..T of these letters' vectors."""
    trans = bank.transition(letters).view(-1, bank.probes, bank.states, bank.states).softmax(-1)
    dist = [bank.start.softmax(dim=-1)]
    for t in trans:
        dist.append(torch.einsum("ms,mst->mt", dist[-1], t))
    return dist


def _features(dist: list[torch.Tensor], bins: int) -> torch.Tensor:
    """A word's features: the mean distribution over each of `bins` parts of positions 0..T
    (zeros for a part no position falls in: a word shorter than the parts), then the
    distribution after the last letter."""
    length = len(dist) - 1
    parts = []
    for b in range(bins):
        inside = [dist[t] for t in range(length + 1) if t * bins // (length + 1) == b]
        parts.append(torch.stack(inside).mean(0) if inside else torch.zeros_like(dist[0]))
    return torch.stack([*parts, dist[-1]])


def _words(dfa, graph, length: int):
    """Every word of `length` letters: (the state it ends in, the edge nodes its run takes)."""
    src, dst = graph.edge_index.tolist()
    node_of = {}  # (state, target state) -> edge node
    for s, e in zip(src, dst, strict=True):
        if graph.node_kind[e] == EDGE:
            node_of[s, dst[src.index(e)]] = e
    for word in itertools.product(range(dfa.alphabet.size), repeat=length):
        state, nodes = dfa.initial, []
        for letter in word:
            nxt = int(dfa.table[state, letter])
            nodes.append(node_of[state, nxt])
            state = nxt
        yield state, nodes


@pytest.mark.parametrize("formula", ["a U b", "G(a -> X b)", "F(a & X !b)"])
@pytest.mark.parametrize("accepted", [True, False])
def test_formula_features_are_the_mean_over_its_words_of_each_length(formula, accepted) -> None:
    """For each length, the uniform mean of the features of the accepted (or rejected) words,
    reading each letter as the vector of the edge node it takes; then the mean over the lengths
    that have such words."""
    dfa = compile_formula(formula)
    graph, _ = dfa_graph(dfa)
    dim, bins, max_length = 5, 2, 4
    graph.edge_vec = torch.randn(graph.num_nodes, dim)
    bank = _bank(dim, bins, max_length)
    batch = Batch.from_data_list([graph])
    ends = batch.flags[:, 1] if accepted else batch.rejecting
    ours = bank(batch, [ends], batch.edge_vec).view(bins + 1, 3, 2)

    per_length = []
    for length in range(1, max_length + 1):
        feats = []
        for state, nodes in _words(dfa, graph, length):
            if bool(dfa.accepting[state]) == accepted:
                feats.append(_features(_run(bank, graph.edge_vec[nodes]), bins))
        if feats:
            per_length.append(torch.stack(feats).mean(0))
    expected = torch.stack(per_length).mean(0)
    assert torch.allclose(ours, expected, atol=1e-5)
    # both end sets in one call: the same features side by side
    both = bank(batch, [batch.flags[:, 1], batch.rejecting], batch.edge_vec)
    alone = [bank(batch, [e], batch.edge_vec) for e in (batch.flags[:, 1], batch.rejecting)]
    assert torch.allclose(both, torch.cat(alone, dim=1))


def test_a_trace_chain_gets_its_own_words_features() -> None:
    """On a batch of trace chains each gets the probes' run on its letters, whatever its length
    (max_length bounds DFAs only)."""
    dim, bins = 4, 3
    bank = _bank(dim, bins, max_length=2)
    lengths = [3, 5, 1]
    batch, edge_nodes = trace_graph_batch(lengths)
    letters = torch.randn(sum(lengths), dim)
    batch.edge_vec = torch.zeros(batch.num_nodes, dim).index_copy(0, edge_nodes, letters)
    ours = bank(batch, [batch.flags[:, 1]], batch.edge_vec).view(len(lengths), bins + 1, 3, 2)
    first = 0
    for k, length in enumerate(lengths):
        expected = _features(_run(bank, letters[first : first + length]), bins)
        assert torch.allclose(ours[k], expected, atol=1e-6)
        first += length
    # and a chain has no rejected runs: zeros
    assert bank(batch, [batch.rejecting], batch.edge_vec).abs().max() == 0


def test_probes_need_a_run_readout() -> None:
    with pytest.raises(SettingError, match="probes"):
        AutomatonEncoder(4, hidden=8, layers=1, out_dim=4, readout="walk", probes=2)


def test_a_q_with_probes_trains_saves_and_reloads_identically(chain, tmp_path) -> None:
    """Through train-meta: the loss falls, the probes' weights move, and the reloaded embedder
    scores the test pairs exactly as train-meta reported."""
    import pyarrow.parquet as pq
    from test_run_readout import _held_out_accuracy

    from tleaf_cli.data.dfa_table import read_dfas
    from tleaf_cli.embed.load import load_embedder
    from tleaf_cli.embed.train_meta import MetaSettings, train_meta

    settings = MetaSettings.preset(
        "paper", hidden=16, layers=1, out_dim=8, epochs=3, patience=3, batch_size=32, lr=3e-3,
        directed=True, readout="runs", bins=2, probes=3, radius_weight=1.0,
    )  # fmt: skip
    metrics = train_meta(chain["dfas"], chain["traces"], chain["edge"], tmp_path / "q", settings)
    assert metrics["history"][-1]["loss"] < metrics["history"][0]["loss"]
    state = torch.load(tmp_path / "q" / "weights.pt", weights_only=True)
    start = ProbeBank(1, 3, 4).transition.bias  # the initial "stay put" bias
    assert not torch.allclose(state["formula.probes.transition.bias"], start)

    q = load_embedder(tmp_path / "q")
    reloaded = _held_out_accuracy(q, chain["dfas"], chain["traces"])
    assert reloaded == pytest.approx(metrics["test"]["triplet_accuracy"], abs=1e-6)
    traces = pq.read_table(chain["traces"]).to_pylist()[:6]
    atoms = {r["formula_id"]: tuple(r["atoms"]) for r in read_dfas(chain["dfas"]).rows}
    z = q.embed_traces([t["trace"] for t in traces], [atoms[t["formula_id"]] for t in traces])
    assert z.std(dim=0).max() > 0  # different traces, different vectors


def test_cli_refuses_probes_without_a_run_readout(chain, tmp_path) -> None:
    from typer.testing import CliRunner

    from tleaf_cli.cli import app

    args = ["train-meta", chain["dfas"], chain["traces"], "--edge", chain["edge"]]
    result = CliRunner().invoke(
        app,
        [str(a) for a in args] + ["-o", str(tmp_path / "q"), "--probes", "4", "--readout", "walk"],
    )
    assert result.exit_code != 0 and "--readout accept or runs" in result.output
    assert not (tmp_path / "q").exists()
