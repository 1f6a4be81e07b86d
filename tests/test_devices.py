"""The losses, constrained decoding and the shield keep their tensors on the inputs' device.

A GPU is not always there, so two checks: a small training run (every logic loss, constrained
decoding) and the shield on CUDA where it exists, else the CPU; and, on any machine, the same
calls with the *default* device set to `meta` while the inputs stay on the CPU — a tensor made
without `device=` (and from no tensor) then lands on meta, and mixing it with the CPU inputs,
or reading it, fails. What this does not catch: a tensor built on the CPU on purpose and never
moved to the inputs' device (the CPU is the inputs' device here).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch
from test_losses import VOCAB, log_probs, monitored_embedder
from torch.overrides import TorchFunctionMode
from torch.utils._pytree import tree_flatten

from tleaf_cli.decode import constrained_decode
from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
from tleaf_cli.losses import logic_loss, pair_vocabulary
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.shield import Shield
from tleaf_cli.tasks.action_recognition.activities import read_activities
from tleaf_cli.tasks.action_recognition.decoding import decode_pairs

DEVICE = "cuda" if torch.cuda.is_available() else "cpu"
RULES = [
    "(!fry_onion U cut_onion) | G !fry_onion",
    "G !cut_egg",
    "(!fry_egg U rinse_egg) | G !fry_egg",
]


@pytest.fixture
def kb(tmp_path: Path):
    from tleaf_cli.knowledge.base import read_knowledge_base

    path = tmp_path / "kb.ltl"
    names = ["ordering.onion", "affordance.cut_egg", "ordering.egg"]
    path.write_text("".join(f"{n}: {r}\n" for n, r in zip(names, RULES, strict=True)))
    return read_knowledge_base(path)


class DefaultDevice(TorchFunctionMode):
    """`torch.device(name)` as a default device for the factories that read it: a tensor made
    from no tensor (torch.zeros(shape), torch.tensor(list), torch.arange(n), ...) without
    `device=` lands on `name`. Factories given a tensor (torch.sparse_coo_tensor(indices,
    values), torch.as_tensor(t)) keep its device, as they do without a default device
    (torch's own context would move them too)."""

    def __init__(self, name: str) -> None:
        super().__init__()
        self.device = torch.device(name)

    def __torch_function__(self, func, types, args=(), kwargs=None):
        kwargs = dict(kwargs or {})
        if (
            func in _device_constructors()
            and kwargs.get("device") is None
            and not any(isinstance(a, torch.Tensor) for a in tree_flatten((args, kwargs))[0])
        ):
            kwargs["device"] = self.device
        return func(*args, **kwargs)


def _device_constructors() -> set:
    from torch.utils._device import _device_constructors as constructors

    return constructors()


def test_logic_losses_decoding_and_shield_make_no_tensor_on_the_default_device(
    kb, monkeypatch
) -> None:
    """Exact, tleaf and checker losses (and gradients), decoding and the shield with the default
    device `meta` and CPU inputs: the same values as without, on the CPU.

    One exception, outside these paths: `embed.graphs.trace_graph_batch` builds the chains'
    template on the default device by design and `meta_data.chain_batch` moves it to the
    letters' device; here it is built on the CPU."""
    from tleaf_cli.embed import automaton, meta_data

    template = meta_data.trace_graph_batch

    def on_cpu(lengths):
        with torch.device("cpu"):
            return template(lengths)

    monkeypatch.setattr(meta_data, "trace_graph_batch", on_cpu)
    monkeypatch.setattr(automaton, "trace_graph_batch", on_cpu)
    q = monitored_embedder()
    rules = KnowledgeRuleSets(kb, VOCAB, set(q.vectors.index))
    atoms = [{"fry_onion", "cut_onion", "cut_egg"}, {"rinse_egg", "fry_egg"}, set()]
    sets = rules.one_each(atoms)
    lp = log_probs(len(atoms), 5, seed=1)
    lengths = torch.tensor([5, 3, 4])
    want = {k: logic_loss(k, lp, sets, lengths, q, "none") for k in ("exact", "tleaf", "checker")}
    decoded = constrained_decode(lp, sets, lengths)
    with DefaultDevice("meta"):  # nothing the calls make may land there
        for kind, value in want.items():
            got = logic_loss(kind, lp, sets, lengths, q, "none")
            assert got.device.type == "cpu"
            torch.testing.assert_close(got, value)
            if kind != "checker":
                (grad,) = torch.autograd.grad(got.sum(), lp)
                assert grad.device.type == "cpu" and bool(grad.abs().sum() > 0)
        assert torch.equal(constrained_decode(lp, sets, lengths), decoded)
        pairs, rounds = decode_pairs(lp.detach(), lengths, rules, top_k=3)
        assert pairs.device.type == "cpu" and rounds >= 1
        shield = Shield([RuleSet(r, VOCAB) for r in RULES], device="cpu")
        assert not bool(shield.allowed()[VOCAB.index("cut_egg")])
        assert shield.step("rinse_egg") and bool(shield.allowed()[VOCAB.index("fry_egg")])


def test_shield_on_the_device() -> None:
    shield = Shield([RuleSet(r, VOCAB) for r in RULES], device=DEVICE)
    allowed = shield.allowed()
    assert allowed.device.type == DEVICE and not bool(allowed[VOCAB.index("fry_onion")])
    assert shield.step(VOCAB.index("cut_onion"))
    assert bool(shield.allowed()[VOCAB.index("fry_onion")])
    assert shield.step("fry_onion") and shield.accepting


@pytest.mark.parametrize("loss", ["none", "tleaf", "exact", "checker"])
def test_train_task_runs_on_the_device(loss: str, tmp_path: Path, monkeypatch) -> None:
    """A small action-recognition run with each loss and constrained decoding on CUDA (the CPU
    where there is none); tleaf with q's monitors and evidence block."""
    from typer.testing import CliRunner

    from tleaf_cli.cli import app
    from tleaf_cli.embed import load as embed_load
    from tleaf_cli.tasks.action_recognition import train

    data, kb_path = tmp_path / "act.parquet", tmp_path / "kb.ltl"
    args = ["--actions", 3, "--ingredients", 2, "--feature-dim", 8, "--train", 8, "--val", 4]
    args += ["--test", 4, "--min-steps", 3, "--max-steps", 6, "--seed", 1]
    result = CliRunner().invoke(
        app, ["gen-activities", "-o", str(data), "--kb-out", str(kb_path), *map(str, args)]
    )
    assert result.exit_code == 0, result.output
    activities = read_activities(data)
    vocabulary = pair_vocabulary(activities.actions, activities.ingredients)
    # train imports load_embedder where the tleaf loss needs it: patched at its source
    monkeypatch.setattr(embed_load, "load_embedder", lambda _: monitored_embedder(vocabulary))
    settings = train.TaskSettings(
        logic_loss=loss, lam=1.0, hidden=8, head_hidden=4, epochs=2, device=DEVICE,
        decode="constrained", decode_top_k=3,
    )  # fmt: skip
    embedder = tmp_path if loss == "tleaf" else None
    metrics = train.train_action_recognition(data, kb_path, embedder, tmp_path / "run", settings)
    assert len(metrics["history"]) == 2
    assert metrics["test"]["constrained"]["violation_fraction"] == 0
    if loss in ("tleaf", "exact"):
        assert all(h["logic_loss"] > 0 for h in metrics["history"])
    config = json.loads((tmp_path / "run" / "config.json").read_text())
    assert config["settings"]["device"] == DEVICE
