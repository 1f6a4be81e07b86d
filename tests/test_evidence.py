"""The monitors' naive-Bayes block (`train-meta --evidence`, embed/evidence.py): its squared
distance against the naive-Bayes score computed directly, and a q with it trained, reloaded and
read by soft traces."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from tleaf_cli.embed.evidence import MonitorEvidence
from tleaf_cli.logic.monitors import MonitorBank


def _naive_bayes(shares: np.ndarray, psi: np.ndarray, in_range: np.ndarray) -> float:
    """Σ over the word's range of ψ log(a / r) + (1 − ψ) log((1 − a) / (1 − r))."""
    a, r = np.clip(shares[0], 1e-3, 1 - 1e-3), np.clip(shares[1], 1e-3, 1 - 1e-3)
    terms = psi * np.log(a / r) + (1 - psi) * np.log((1 - a) / (1 - r))
    return float((terms * in_range).sum())


def test_the_blocks_distance_falls_with_the_naive_bayes_score() -> None:
    bank = MonitorBank(2, max_length=6, ranges=2)
    evidence = MonitorEvidence(bank, scale=float(np.exp(1.4))).double().requires_grad_(False)
    rng = np.random.default_rng(0)
    f = bank.features
    shares = rng.uniform(0, 1, size=(5, 2, f)) * (rng.uniform(size=(5, 2, f)) < 0.8)
    lengths = rng.integers(1, 10, size=40)  # words past max_length 6 too: the last range
    psi = np.zeros((40, f))
    in_range = np.zeros((40, f))
    for i, t in enumerate(lengths):
        k = bank.range_of(int(t)) * bank.width
        in_range[i, k : k + bank.width] = 1
        psi[i, k : k + bank.width] = rng.integers(0, 2, size=bank.width)
    z_f = evidence.formulas(torch.from_numpy(shares.reshape(5, -1)))
    monitor = torch.from_numpy(np.concatenate([psi, np.zeros_like(psi)], axis=1))
    z_t = evidence.traces(monitor, torch.from_numpy(lengths))
    gamma2 = float(np.exp(1.4))
    torch.testing.assert_close(z_f.norm(dim=1), torch.full((5,), gamma2**0.5, dtype=torch.float64))
    torch.testing.assert_close(z_t.norm(dim=1), torch.full((40,), gamma2**0.5, dtype=torch.float64))
    d = torch.cdist(z_f, z_t).pow(2).numpy()  # [5, 40]
    for j in range(5):
        score = np.array([_naive_bayes(shares[j], psi[i], in_range[i]) for i in range(40)])
        # d = γ² (2 − 2 s / (‖u‖ M)): affine in the score with a negative slope, 2γ² at s = 0
        slope, intercept = np.polyfit(score, d[j], 1)
        assert slope < 0 and intercept == pytest.approx(2 * gamma2, rel=1e-5)
        np.testing.assert_allclose(d[j], intercept + slope * score, rtol=1e-5, atol=1e-6)
        assert ((d[j] < 2 * gamma2) == (score > 0)).all()


@pytest.fixture(scope="module")
def evidence_q(chain, tmp_path_factory):
    """A small q with monitors and their evidence block, trained through train-meta."""
    from tleaf_cli.embed.train_meta import MetaSettings, train_meta

    out = tmp_path_factory.mktemp("q") / "m"
    settings = MetaSettings.preset(
        "paper", hidden=16, layers=1, out_dim=8, epochs=3, patience=3, batch_size=32, lr=3e-3,
        directed=True, readout="runs", bins=2, monitors=3, monitor_ranges=2, evidence=True,
        radius_weight=1.0,
    )  # fmt: skip
    metrics = train_meta(chain["dfas"], chain["traces"], chain["edge"], out, settings)
    return out, metrics


def test_a_q_with_evidence_reloads_identically_and_reads_soft_traces(chain, evidence_q) -> None:
    from test_run_readout import _held_out_accuracy

    from tleaf_cli.embed.load import load_embedder

    out, metrics = evidence_q
    q = load_embedder(out)
    assert q.model.evidence is not None
    reloaded = _held_out_accuracy(q, chain["dfas"], chain["traces"])
    assert reloaded == pytest.approx(metrics["test"]["triplet_accuracy"], abs=1e-6)
    atoms = ("a", "b", "c")
    trace = [{"b"}, set(), {"a"}, {"c"}, {"a"}]
    crisp = q.embed_traces([trace], [atoms], one_hot=True)[0]
    assert len(crisp) == 8 + q.model.evidence.dim
    probs = torch.tensor([[0.0, 1, 0], [0, 0, 0], [1, 0, 0], [0, 0, 1], [1, 0, 0]])
    soft = q.embed_soft_trace(probs, atoms, domain="one-hot")
    torch.testing.assert_close(soft, crisp, atol=1e-5, rtol=1e-5)


def test_sphere_bounds_the_learned_part_and_leaves_the_block(chain, evidence_q) -> None:
    """`--sphere` with `--evidence` (the model-checking pipeline's q): the learned part at unit
    length, the block unchanged at γ, for formulas and traces alike."""
    from tleaf_cli.data.dfa_table import dfa_from_row, read_dfas
    from tleaf_cli.embed.load import load_embedder

    q = load_embedder(evidence_q[0])
    dfas = [dfa_from_row(r) for r in read_dfas(chain["dfas"]).rows[:4]]
    atoms = ("a", "b", "c")
    traces = [[{"b"}, set(), {"a"}], [{"c"}], [{"a"}, {"a"}, {"b"}, set()]]
    free = [q.embed_dfas(dfas), q.embed_traces(traces, [atoms] * 3, one_hot=True)]
    q.model.sphere = True
    bounded = [q.embed_dfas(dfas), q.embed_traces(traces, [atoms] * 3, one_hot=True)]
    gamma = float(q.model.evidence.log_scale.exp())
    for z, z_free in zip(bounded, free, strict=True):
        k = z.shape[1] - q.model.evidence.dim  # the learned part's width
        assert not torch.allclose(z_free[:, :k].norm(dim=1), torch.ones(len(z)))
        torch.testing.assert_close(z[:, :k].norm(dim=1), torch.ones(len(z)))
        torch.testing.assert_close(z[:, k:], z_free[:, k:])
        torch.testing.assert_close(z[:, k:].norm(dim=1), torch.full((len(z),), gamma))


def test_cli_refuses_evidence_without_monitors(chain, chain_cli, tmp_path) -> None:
    args = ["train-meta", chain["dfas"], chain["traces"], "--edge", chain["edge"]]
    result = chain_cli(*args, "-o", tmp_path / "q", "--monitors", "0", "--evidence")
    assert result.exit_code != 0 and "--evidence: only with --monitors" in result.output
    assert not (tmp_path / "q").exists()
