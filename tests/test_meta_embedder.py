"""The meta embedder q_m, its syntax baseline, soft traces, and `tleaf embed`."""

from __future__ import annotations

from pathlib import Path

import pyarrow.parquet as pq
import pytest
import torch
from torch_geometric.data import Batch
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.embed.automaton import walk_distributions, walk_weights
from tleaf_cli.embed.load import load_embedder
from tleaf_cli.embed.meta_data import featured_trace_graph
from tleaf_cli.embed.train_meta import MetaSettings, train_meta

runner = CliRunner()
# the paper's q, small (the soft-trace and schedule tests read its walk readout)
SMALL_META = MetaSettings.preset(
    "paper", hidden=32, layers=2, out_dim=16, epochs=6, patience=6, batch_size=32, lr=3e-3
)


def cli(*args) -> object:
    return runner.invoke(app, [str(a) for a in args])


def test_walk_distributions_follow_a_chain_step_by_step() -> None:
    # chain 0 -> 1 -> 2: after k steps the walker is at node min(k, 2)
    p = walk_distributions(torch.tensor([[0, 1], [1, 2]]), torch.tensor([0]), 3, steps=4)
    assert torch.equal(p.argmax(dim=1), torch.tensor([0, 1, 2, 2, 2]))
    assert torch.allclose(p.sum(dim=1), torch.ones(5))


@pytest.mark.parametrize("options", [{"readout": "steps"}, {"directed": True}])
def test_encoder_options_tell_a_trace_from_its_reverse(chain, options) -> None:
    from tleaf_cli.embed.automaton import AutomatonEncoder
    from tleaf_cli.embed.load import load_edge_model
    from tleaf_cli.embed.meta_data import GuardVectors

    edge, config = load_edge_model(chain["edge"])
    vectors = GuardVectors(edge, config["vocabulary"])
    torch.manual_seed(0)
    encoder = AutomatonEncoder(vectors.dim, hidden=16, layers=2, out_dim=8, **options).eval()
    atoms = ("a", "b", "c")
    trace = [{"a"}, {"b"}, {"c"}, set()]
    forward, backward = (
        encoder(_batch(featured_trace_graph(t, atoms, vectors))) for t in (trace, trace[::-1])
    )
    assert forward.shape == (1, 8) and torch.isfinite(forward).all()
    assert not torch.allclose(forward, backward, atol=1e-4)


def test_walk_readout_starts_at_the_initial_state_and_sums_to_one() -> None:
    # chain 0 -> 1 -> 2 (2 has no way out: the walker stays)
    edge_index = torch.tensor([[0, 1], [1, 2]])
    r = walk_weights(edge_index, torch.tensor([0]), 3, steps=3)
    assert torch.allclose(r, torch.tensor([1, 1, 2]) / 4)
    assert torch.isclose(r.sum(), torch.tensor(1.0))


def test_dfa_embedder_learns_and_writes_a_loadable_model(chain, tmp_path: Path) -> None:
    """The default q (preset best), small, learns and reloads."""
    small = MetaSettings(hidden=32, layers=2, out_dim=16, epochs=6, batch_size=32, lr=3e-3)
    metrics = train_meta(chain["dfas"], chain["traces"], chain["edge"], tmp_path / "m", small)
    curve = metrics["history"]
    assert curve[-1]["loss"] < curve[0]["loss"]
    assert metrics["test"]["pairs"] > 0 and 0.0 <= metrics["test"]["triplet_accuracy"] <= 1.0
    assert max(h["train_accuracy"] for h in curve) > 0.6  # above chance on what it trains on
    embedder = load_embedder(tmp_path / "m")
    assert embedder.kind == "dfa"


def test_syntax_baseline_trains_through_the_same_code(chain, tmp_path: Path) -> None:
    settings = MetaSettings(**{**SMALL_META.__dict__, "embedder": "syntax", "epochs": 2})
    metrics = train_meta(chain["dfas"], chain["traces"], chain["edge"], tmp_path / "s", settings)
    assert len(metrics["history"]) == 2 and "test" in metrics


@pytest.fixture(scope="module")
def embedder(chain, tmp_path_factory):
    out = tmp_path_factory.mktemp("q") / "m"
    settings = MetaSettings(**{**SMALL_META.__dict__, "epochs": 1})
    train_meta(chain["dfas"], chain["traces"], chain["edge"], out, settings)
    return load_embedder(out), out


def test_one_hot_soft_trace_equals_the_discrete_trace(embedder) -> None:
    q, _ = embedder
    atoms = ("a", "b", "c")
    trace = [{"b"}, set(), {"a"}]
    probs = torch.tensor([[0.0, 1, 0], [0, 0, 0], [1, 0, 0]])
    for domain in ("one-hot", "powerset"):
        graph = featured_trace_graph(trace, atoms, q.vectors, one_hot=domain == "one-hot")
        discrete = q.model.embed_traces(_batch(graph))[0]
        soft = q.embed_soft_trace(probs, atoms, domain=domain)
        assert torch.allclose(soft, discrete, atol=1e-5), domain


def test_soft_trace_gradients_are_finite_nonzero_and_match_finite_differences(embedder) -> None:
    q, _ = embedder
    atoms = ("a", "b", "c")
    columns = ["a", "b", "c", "zzz"]  # a domain atom outside the formula: the empty letter
    logits = torch.randn(4, 4, dtype=torch.float32, generator=torch.Generator().manual_seed(0))
    target = torch.randn(q.model.trace.head.out_features)

    def loss_of(z):
        probs = torch.softmax(z, dim=1)
        return (q.embed_soft_trace(probs, atoms, columns) - target).pow(2).sum()

    z = logits.clone().requires_grad_(True)
    loss_of(z).backward()
    grad = z.grad
    assert torch.isfinite(grad).all() and grad.abs().sum() > 0
    eps = 1e-2
    for i, j in [(0, 0), (1, 2), (3, 3)]:
        bumped = logits.clone()
        bumped[i, j] += eps
        lowered = logits.clone()
        lowered[i, j] -= eps
        numeric = (loss_of(bumped) - loss_of(lowered)) / (2 * eps)
        assert numeric.item() == pytest.approx(grad[i, j].item(), rel=0.05, abs=1e-3)


def test_embed_is_deterministic_for_dfas_and_traces(chain, embedder, tmp_path: Path) -> None:
    _, model_dir = embedder
    for source in (chain["dfas"], chain["traces"]):
        a, b = tmp_path / "a.parquet", tmp_path / "b.parquet"
        assert cli("embed", model_dir, source, "-o", a).exit_code == 0
        assert cli("embed", model_dir, source, "-o", b).exit_code == 0
        ta, tb = pq.read_table(a), pq.read_table(b)
        assert ta.equals(tb)
        assert ta.schema.field("vector").type.list_size == 16
        assert set(ta.column("kind").to_pylist()) in ({"dfa"}, {"trace"})
    assert cli("embed", model_dir, chain["ltl"], "-o", tmp_path / "x.parquet").exit_code == 2


def _batch(graph):
    return Batch.from_data_list([graph])


def test_pull_brings_satisfying_traces_onto_their_formula(chain, tmp_path: Path) -> None:
    """Same seed and data: with --pull the test split's satisfying traces lie nearer their
    formula than without; violating ones stay farther than satisfying ones (the margin)."""
    test = {}
    for pull in (0.0, 1.0):
        settings = MetaSettings(**{**SMALL_META.__dict__, "epochs": 3, "pull": pull})
        metrics = train_meta(
            chain["dfas"], chain["traces"], chain["edge"], tmp_path / f"p{pull}", settings
        )
        test[pull] = metrics["test"]
    assert test[1.0]["satisfying_distance"] < 0.5 * test[0.0]["satisfying_distance"]
    assert test[1.0]["violating_distance"] > test[1.0]["satisfying_distance"]


def test_cosine_schedule_ends_at_zero_and_is_checkpointed(chain, tmp_path: Path) -> None:
    settings = MetaSettings(**{**SMALL_META.__dict__, "epochs": 3, "schedule": "cosine"})
    train_meta(chain["dfas"], chain["traces"], chain["edge"], tmp_path / "c", settings)
    state = torch.load(tmp_path / "c" / "checkpoint.pt", weights_only=False)
    assert state["scheduler"]["last_epoch"] == 3
    assert state["optimiser"]["param_groups"][0]["lr"] == pytest.approx(0.0, abs=1e-12)
    constant = MetaSettings(**{**SMALL_META.__dict__, "epochs": 1})
    train_meta(chain["dfas"], chain["traces"], chain["edge"], tmp_path / "k", constant)
    state = torch.load(tmp_path / "k" / "checkpoint.pt", weights_only=False)
    assert state["optimiser"]["param_groups"][0]["lr"] == pytest.approx(SMALL_META.lr)


@pytest.mark.skipif(torch.cuda.is_available(), reason="checks the message where CUDA is absent")
def test_device_cuda_without_cuda_is_a_clean_usage_error(chain, tmp_path: Path) -> None:
    result = cli(
        "train-meta", chain["dfas"], chain["traces"], "--edge", chain["edge"],
        "-o", tmp_path / "m", "--device", "cuda", "--epochs", 1,
    )  # fmt: skip
    assert result.exit_code == 2
    assert "cuda" in result.output and "Traceback" not in result.output
    assert not (tmp_path / "m" / "weights.pt").exists()


def test_a_moved_tree_and_a_copied_meta_folder_still_load(chain, tmp_path: Path) -> None:
    """The meta folder records its edge model relative to itself and absolute: a whole tree moved
    elsewhere loads through the relative path, a meta folder copied alone through the absolute
    one, and both embed exactly as before."""
    import shutil

    tree = tmp_path / "out"
    shutil.copytree(chain["edge"], tree / "edge")
    settings = MetaSettings(**{**SMALL_META.__dict__, "epochs": 1})
    train_meta(chain["dfas"], chain["traces"], tree / "edge", tree / "meta", settings)
    atoms, trace = ("a", "b", "c"), [{"a"}, {"b", "c"}]
    before = load_embedder(tree / "meta").embed_traces([trace], [atoms])
    moved = tmp_path / "elsewhere" / "out"
    shutil.copytree(tree, moved)
    shutil.rmtree(tree)  # the recorded absolute path is gone: only the relative one can work
    assert torch.equal(load_embedder(moved / "meta").embed_traces([trace], [atoms]), before)
    alone = tmp_path / "alone" / "meta"
    shutil.copytree(moved / "meta", alone)
    shutil.copytree(moved / "edge", tree / "edge")  # the absolute path exists again
    assert torch.equal(load_embedder(alone).embed_traces([trace], [atoms]), before)


@pytest.mark.parametrize("one_hot", [False, True])
def test_trace_inputs_equal_the_one_by_one_features(chain, one_hot) -> None:
    """The batched reading of many traces gives each trace the letter vectors and monitor
    features the one-trace functions give it."""
    from tleaf_cli.embed.load import load_edge_model
    from tleaf_cli.embed.meta_data import (
        GuardVectors,
        trace_inputs,
        trace_letter_vectors,
        trace_monitor_features,
    )
    from tleaf_cli.logic.monitors import MonitorBank

    edge, config = load_edge_model(chain["edge"])
    vectors = GuardVectors(edge, config["vocabulary"])
    bank = MonitorBank(2, 6, 2)
    traces = [[{"a"}, {"b"}, set()], [{"c"}], [set(), {"a"}, {"a"}, {"b"}]]
    if not one_hot:
        traces.append([{"a", "b"}, {"a", "c"}])
    atoms = [("a", "b", "c"), ("a", "c"), ("a", "b"), ("a", "b", "c")][: len(traces)]
    letters, monitor = trace_inputs(traces, atoms, [one_hot] * len(traces), vectors, bank)
    for k, (trace, a) in enumerate(zip(traces, atoms, strict=True)):
        assert torch.equal(letters[k], trace_letter_vectors(trace, a, vectors, one_hot))
        expected = trace_monitor_features(trace, a, bank, one_hot).float()
        assert torch.equal(monitor[k], expected)
