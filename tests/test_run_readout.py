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
    among them, their nodes counted into parts of the run, each part normalised to sum to 1."""
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


def _held_out_accuracy(q, dfas_path, traces_path) -> float:
    """Triplet accuracy of q on the test split's fixed pairs (each formula's satisfying traces
    zipped with its violating ones in file order, as train-meta pairs them)."""
    from tleaf_cli.data.dfa_table import read_dfas
    from tleaf_cli.data.traces import read_traces
    from tleaf_cli.embed.triplets import triplet_accuracy

    rows = {r["formula_id"]: r for r in read_dfas(dfas_path).rows if r["error"] is None}
    sides: dict[str, dict[bool, list]] = {}
    for t in read_traces(traces_path).to_pylist():
        if t["split"] == "test" and t["formula_id"] in rows:
            sides.setdefault(t["formula_id"], {True: [], False: []})[t["label"]].append(t["trace"])
    fids, pos, neg = [], [], []
    for fid, s in sides.items():
        for sat, bad in zip(s[True], s[False], strict=False):
            fids.append(fid)
            pos.append(sat)
            neg.append(bad)
    z_f = q.embed_formula_rows([rows[f] for f in fids])
    atoms = [tuple(rows[f]["atoms"]) for f in fids]
    return triplet_accuracy(z_f, q.embed_traces(pos, atoms), q.embed_traces(neg, atoms))


@pytest.fixture(scope="module")
def low_set(tmp_path_factory, chain_cli) -> dict:
    """150 synthetic low-tier formulas, 8 pairs each, and a q_e trained briefly on them."""
    from tleaf_cli.embed.train_edge import EdgeSettings, train_edge

    d = tmp_path_factory.mktemp("low")
    p = {"ltl": d / "f.ltl", "dfas": d / "dfas.parquet", "traces": d / "t.parquet", "edge": d / "e"}
    assert chain_cli("gen-formulas", "--tier", "low", "-n", 150, "-o", p["ltl"]).exit_code == 0
    assert chain_cli("compile-dfa", p["ltl"], "-o", p["dfas"]).exit_code == 0
    made = chain_cli(
        "gen-traces", p["dfas"], "-o", p["traces"], "--per-formula", 8, "--split", "0.7,0.1,0.2"
    )
    assert made.exit_code == 0
    train_edge(p["dfas"], p["edge"], EdgeSettings(hidden=32, out_dim=16, epochs=3, per_guard=2))
    return p


@pytest.mark.slow
def test_a_small_q_separates_held_out_traces_and_reloads_identically(low_set, tmp_path) -> None:
    """q trained on the tiny chain ranks satisfying traces of formulas it never saw nearer than
    violating ones, well above an untrained q of the same shape; reloaded from its folder it
    scores exactly what train-meta reported."""
    from tleaf_cli.embed.load import load_embedder
    from tleaf_cli.embed.train_meta import MetaSettings, train_meta

    settings = MetaSettings.preset(
        "paper", hidden=32, layers=2, out_dim=16, batch_size=32, lr=3e-3, directed=True,
        readout="runs", bins=3, epochs=12, patience=12, schedule="cosine",
    )  # fmt: skip
    trained = train_meta(
        low_set["dfas"], low_set["traces"], low_set["edge"], tmp_path / "q", settings
    )
    untrained = train_meta(
        low_set["dfas"], low_set["traces"], low_set["edge"], tmp_path / "u",
        MetaSettings(**{**settings.__dict__, "lr": 0.0, "epochs": 1}),
    )  # fmt: skip
    ours = trained["test"]["triplet_accuracy"]
    # 240 held-out pairs: 0.62 is almost four standard errors above chance; the untrained q of
    # the same shape scores 0.59 (the readout alone already says something about the language),
    # ours 0.65 (0.68 before q_m's batched step, whose float rounding moves this 12-epoch run)
    assert ours >= 0.62 and ours > untrained["test"]["triplet_accuracy"] + 0.04
    reloaded = _held_out_accuracy(load_embedder(tmp_path / "q"), low_set["dfas"], low_set["traces"])
    assert reloaded == pytest.approx(ours, abs=1e-6)  # float32 mean vs float64 sum; 1 pair = 0.004


def test_a_chain_longer_than_max_length_is_still_read_to_its_end() -> None:
    """DFAs are read up to max_length letters; a trace (a video of 15 steps, say) always whole —
    cut at max_length it would have no accepted run and every trace would get the same vector."""
    encoder = AutomatonEncoder(4, hidden=8, layers=1, out_dim=4, readout="runs", max_length=12)
    for batch in (trace_graph_batch([15, 3])[0], Batch.from_data_list([trace_graph(15)])):
        r = encoder.run_weights(batch)
        accepted = r[0, :31]  # bins 1: the accepted part of the 15-letter chain
        assert torch.allclose(accepted, torch.full((31,), 1 / 31))
        assert not r[1].any()  # no rejected runs
    dfa_batch = Batch.from_data_list([dfa_graph(compile_formula("F a"))[0]])
    assert torch.equal(
        encoder.run_weights(dfa_batch),
        torch.cat(
            [
                _weights(dfa_batch, e, max_length=12, bins=1)
                for e in (dfa_batch.flags[:, 1], dfa_batch.rejecting)
            ]
        ),
    )


def test_chain_weights_per_length_equal_the_batch_computation() -> None:
    """The soft-trace path reuses each length's chain weights: exactly the batched values."""
    from tleaf_cli.embed.automaton import AutomatonEncoder
    from tleaf_cli.embed.graphs import trace_graph_batch

    for readout in ("accept", "runs"):
        encoder = AutomatonEncoder(4, hidden=8, layers=1, out_dim=4, readout=readout, bins=3)
        lengths = [5, 1, 12, 5, 3]
        batch, _ = trace_graph_batch(lengths)
        want = encoder.run_weights(batch).t()
        got = encoder.chain_run_weights(lengths)
        assert got.shape == want.shape and torch.equal(got, want)
        assert torch.equal(encoder.chain_run_weights([3, 12]), torch.cat([want[-7:], want[14:39]]))


def test_radius_classifier_learns_one_radius_between_the_two_sides() -> None:
    """RadiusClassifier alone: satisfying points within ~0.5 of their anchors, violating ones
    ~2 away (squared distances ~0.25 and ~4); its loss moves r between them."""
    from tleaf_cli.embed.radius import RadiusClassifier

    torch.manual_seed(0)
    anchor = torch.randn(256, 8)
    direction = torch.nn.functional.normalize(torch.randn(256, 8), dim=1)
    pos, neg = anchor + 0.5 * direction, anchor + 2.0 * direction
    classifier = RadiusClassifier(radius=8.0)  # starts with everything inside
    optimiser = torch.optim.Adam(classifier.parameters(), lr=0.05)
    for _ in range(300):
        optimiser.zero_grad()
        classifier.loss(anchor, pos, neg).backward()
        optimiser.step()
    assert 0.25 < classifier.radius.item() < 4.0
    assert (classifier(anchor, pos) > 0).all() and (classifier(anchor, neg) < 0).all()


def test_radius_loss_is_trained_saved_and_loaded(low_set, tmp_path) -> None:
    """--radius-weight: train-meta fits the radius with q and saves it; the loaded q has it."""
    from tleaf_cli.embed.load import load_embedder
    from tleaf_cli.embed.train_meta import MetaSettings, train_meta

    settings = MetaSettings.preset(
        "paper", hidden=32, layers=2, out_dim=16, batch_size=32, lr=3e-3, directed=True,
        readout="runs", bins=3, epochs=2, patience=2, radius_weight=1.0,
    )  # fmt: skip
    train_meta(low_set["dfas"], low_set["traces"], low_set["edge"], tmp_path / "r", settings)
    radius = load_embedder(tmp_path / "r").model.radius.radius.item()
    assert radius != pytest.approx(settings.margin)  # trained, not left where it started
    state = torch.load(tmp_path / "r" / "weights.pt", weights_only=True)
    assert state["radius.radius"].item() == radius


@pytest.mark.parametrize("readout", ["walk", "runs"])
def test_chain_batch_embeds_traces_as_their_collated_graphs_do(readout: str) -> None:
    """train-meta and `Embedder.embed_traces` batch traces with `chain_batch` (tensor ops, no
    Data per trace); each trace gets the vector its own chain graph gets when collated."""
    from tleaf_cli.embed.meta_data import chain_batch

    torch.manual_seed(0)
    lengths = [3, 1, 5, 2]
    letters = torch.randn(sum(lengths), 4)
    encoder = AutomatonEncoder(4, hidden=8, layers=2, out_dim=5, readout=readout, bins=2,
                               directed=True).eval()  # fmt: skip
    graphs = []
    for i, length in enumerate(lengths):
        g = trace_graph(length)
        g.edge_vec = torch.zeros(g.num_nodes, 4)
        g.edge_vec[g.node_kind == EDGE] = letters[sum(lengths[:i]) : sum(lengths[: i + 1])]
        graphs.append(g)
    want = encoder(Batch.from_data_list(graphs))
    got = encoder(chain_batch(encoder, letters, lengths))
    assert torch.allclose(got, want, atol=1e-5)
