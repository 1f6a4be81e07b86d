"""The edge embedder q_e: it learns, it is repeatable, and its model directory follows the layout
in docs/design.md."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch
from torch_geometric.data import Batch
from typer.testing import CliRunner

from tleaf_cli.cli import app
from tleaf_cli.embed.atom_features import atom_features
from tleaf_cli.embed.graphs import cnf_graph
from tleaf_cli.embed.load import load_edge_model
from tleaf_cli.embed.proposition_encoder import PropositionEncoder
from tleaf_cli.embed.train_edge import EdgeSettings, train_edge
from tleaf_cli.embed.triplets import triplet_loss

runner = CliRunner()
SMALL = EdgeSettings(hidden=32, out_dim=16, epochs=6, patience=6, per_guard=2, batch_size=64)


@pytest.fixture(scope="module")
def dfas(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("edge")
    src = d / "f.ltl"
    src.write_text(
        "\n".join(
            [
                "G(a -> F b)",
                "(!b U a) | G !b",
                "a U (b & !c)",
                "G(a & b -> X c)",
                "F(a & !b)",
                "G(c -> !a)",
                "(a | b) U c",
                "G(!a | !c) & F b",
                "X(a & c) | G b",
                "F(b & c)",
            ]
        )
        + "\n"
    )
    out = d / "dfas.parquet"
    assert runner.invoke(app, ["compile-dfa", str(src), "-o", str(out)]).exit_code == 0
    return out


def test_encoder_shapes() -> None:
    model = PropositionEncoder(atom_features("abcd", "onehot"), hidden=8, layers=2, out_dim=5)
    batch = Batch.from_data_list([cnf_graph([[1, -2]], [0, 1]), cnf_graph([], [3])])
    assert model(batch).shape == (2, 5)
    assert atom_features("abcd", "random", dim=7).shape == (4, 7)


def test_text_features_put_related_atoms_close() -> None:
    table = atom_features(["cut_tomato", "cut_onion", "fry_egg", "rinse_cabbage"], "text")
    assert table.shape == (4, 384)
    sim = table @ table.t()
    assert torch.allclose(sim.diagonal(), torch.ones(4), atol=1e-5)
    assert sim[0, 1] > sim[0, 3]  # cutting tomato is nearer cutting onion than rinsing cabbage


def test_triplet_loss_is_zero_only_past_the_margin() -> None:
    a, p, n = torch.zeros(1, 2), torch.tensor([[1.0, 0.0]]), torch.tensor([[2.0, 0.0]])
    assert triplet_loss(a, p, n, margin=1.0).item() == 0.0  # 1 - 4 + 1 < 0
    assert triplet_loss(a, n, p, margin=1.0).item() == pytest.approx(4.0)  # 4 - 1 + 1


def test_training_lowers_the_loss_and_beats_chance(dfas: Path, tmp_path: Path) -> None:
    metrics = train_edge(dfas, tmp_path / "m", SMALL)
    curve = metrics["history"]
    assert curve[-1]["loss"] < curve[0]["loss"]
    assert metrics["best"]["heldout_accuracy"] > 0.6  # chance is 0.5


def test_cpu_training_is_repeatable_and_the_directory_is_complete(dfas: Path, tmp_path: Path):
    one = train_edge(dfas, tmp_path / "one", SMALL)
    two = train_edge(dfas, tmp_path / "two", SMALL)
    assert [h["loss"] for h in one["history"]] == [h["loss"] for h in two["history"]]
    w1 = torch.load(tmp_path / "one" / "weights.pt", weights_only=True)
    w2 = torch.load(tmp_path / "two" / "weights.pt", weights_only=True)
    assert all(torch.equal(w1[k], w2[k]) for k in w1)
    config = json.loads((tmp_path / "one" / "config.json").read_text())
    assert config["kind"] == "edge-embedder" and config["vocabulary"] == ["a", "b", "c"]
    assert config["inputs"][0]["sha256"]
    model, _ = load_edge_model(tmp_path / "one")
    assert not model.training


def test_resume_continues_from_the_last_epoch(dfas: Path, tmp_path: Path) -> None:
    short = EdgeSettings(**{**SMALL.__dict__, "epochs": 2})
    train_edge(dfas, tmp_path / "m", short)
    resumed = train_edge(dfas, tmp_path / "m", SMALL, resume=True)
    assert [h["epoch"] for h in resumed["history"]] == list(range(1, 7))


def test_cli_train_edge_and_bad_calls(dfas: Path, tmp_path: Path) -> None:
    out = tmp_path / "cli"
    result = runner.invoke(
        app,
        [
            "train-edge",
            str(dfas),
            "-o",
            str(out),
            "--epochs",
            "2",
            "--hidden",
            "16",
            "--atom-features",
            "random",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "held-out" in result.output and (out / "weights.pt").exists()
    bad = runner.invoke(app, ["train-edge", str(dfas), "--atom-features", "glove"])
    assert bad.exit_code == 2
    assert runner.invoke(app, ["train-edge", str(dfas), "--device", "tpu"]).exit_code == 2
