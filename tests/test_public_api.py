"""The public API of docs/design.md ("Python API"): `import tleaf_cli as tl`, a test per name,
and the README's own-model example run as written."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

import tleaf_cli as tl

ROOT = Path(__file__).parent.parent


def readme_block(heading: str) -> str:
    """The first ```python block after `heading` in README.md."""
    text = (ROOT / "README.md").read_text()
    match = re.search(rf"{re.escape(heading)}.*?```python\n(.*?)```", text, re.S)
    assert match, f"README has no python block after {heading!r}"
    return match.group(1)


def test_the_public_names_are_there_and_import_torch_lazily() -> None:
    assert set(tl.__all__) == {
        "compile_formula", "DFA", "check", "RuleSet", "logic_loss", "load_embedder", "TleafError",
        "constrained_decode", "Shield", "read_log", "read_rules", "check_cases",
        "load_run",
    }  # fmt: skip
    code = "import sys, tleaf_cli as tl; tl.TleafError; tl.DFA; print('torch' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"  # the CLI's start-up does not pay for torch
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        tl.nothing  # noqa: B018


def test_readme_own_model_example_runs_and_removes_the_violations() -> None:
    block = readme_block("## Use the loss in your own model")
    assert len(block.strip().splitlines()) <= 15
    setup, _ = block.split("for step in", 1)
    untrained: dict = {}
    exec(setup, untrained)  # the model before training: many sequences break the rules
    log_probs = torch.log_softmax(untrained["model"](untrained["x"]), dim=-1)
    before = tl.logic_loss("checker", log_probs, untrained["rules"]).item()
    assert before > 0.3
    trained: dict = {}
    exec(block, trained)
    assert trained["loss"].item() < 0.05
    assert tl.logic_loss("checker", trained["log_probs"], trained["rules"]).item() == 0.0


def test_readme_compile_and_check_example() -> None:
    namespace: dict = {}
    exec(readme_block("## A first run"), namespace)
    dfa = namespace["dfa"]
    assert isinstance(dfa, tl.DFA)
    assert dfa.accepts([{"cut_onion"}, {"fry_onion"}])
    assert tl.check(dfa, [[{"cut_onion"}], [{"fry_onion"}]]).tolist() == [False, True]


@pytest.mark.parametrize("alphabet", ["powerset", "one-hot"])
def test_compile_formula_gives_a_minimal_dfa_over_the_alphabet(alphabet) -> None:
    dfa = tl.compile_formula("(!cook U rinse) | G !cook", alphabet=alphabet)
    assert dfa.alphabet.kind == alphabet and dfa.atoms == ("cook", "rinse")
    assert dfa == dfa.minimize_nonempty()
    assert dfa.accepts([{"rinse"}, {"cook"}]) and not dfa.accepts([{"cook"}, {"rinse"}])


def test_check_is_batched_and_exact() -> None:
    dfa = tl.compile_formula("F serve", alphabet="one-hot")
    traces = [[{"cut"}, {"serve"}], [{"cut"}], [{"serve"}], [set(), set(), {"serve"}]]
    got = tl.check(dfa, traces)
    assert isinstance(got, np.ndarray) and got.dtype == bool
    assert got.tolist() == [dfa.accepts(t) for t in traces] == [True, False, True, True]


def test_rule_set_is_one_dfa_over_the_vocabulary() -> None:
    vocab = ["rinse", "cut", "cook", "serve"]
    rules = tl.RuleSet(["(!cook U rinse) | G !cook", "F serve"], vocab)
    assert set(rules.atoms) == {"cook", "rinse", "serve"}
    assert [vocab[i] for i in rules.index] == list(rules.atoms)
    assert rules.satisfiable
    accepted = [["rinse", "cook", "serve"], ["cut", "serve"]]
    rejected = [["cook", "rinse", "serve"], ["rinse", "cook"]]
    for seq, want in [(s, True) for s in accepted] + [(s, False) for s in rejected]:
        assert rules.dfa.accepts([{a} for a in seq]) == want


def test_logic_loss_kinds_on_a_batch() -> None:
    vocab = ["rinse", "cut", "cook", "serve"]
    rules = tl.RuleSet("(!cook U rinse) | G !cook", vocab)
    good = torch.tensor([[0, 2, 3]])  # rinse, cook, serve
    bad = torch.tensor([[2, 0, 3]])  # cook before rinse
    sure = torch.full((2, 3, 4), -30.0).scatter(2, torch.cat([good, bad])[..., None], 0.0)
    sure = torch.log_softmax(sure, -1)
    exact = tl.logic_loss("exact", sure, [rules, rules], reduction="none")
    assert exact[0].item() < 1e-6 and exact[1].item() > 10
    checker = tl.logic_loss("checker", sure, [rules, None], reduction="none")
    assert checker.tolist() == [0.0, 0.0]
    assert tl.logic_loss("checker", sure, rules, reduction="sum").item() == 1.0


def test_load_embedder_and_the_tleaf_loss_through_the_public_api(chain, tmp_path) -> None:
    from tleaf_cli.embed.train_meta import MetaSettings, train_meta

    meta = tmp_path / "meta"
    train_meta(
        chain["dfas"], chain["traces"], chain["edge"], meta,
        MetaSettings.preset("paper", hidden=16, out_dim=8, layers=2, epochs=1, steps=4),
    )  # fmt: skip
    q = tl.load_embedder(meta)
    vocab = sorted(q.vectors.index)[:4]
    rules = tl.RuleSet(f"F {vocab[0]}", vocab)
    logits = torch.randn(3, 5, len(vocab), requires_grad=True)
    loss = tl.logic_loss("tleaf", torch.log_softmax(logits, -1), rules, embedder=q)
    loss.backward()
    assert loss.item() > 0 and logits.grad.abs().sum() > 0


def test_every_library_error_is_a_tleaf_error() -> None:
    with pytest.raises(tl.TleafError):
        tl.compile_formula("G (a &")
    with pytest.raises(tl.TleafError):
        tl.RuleSet("F stir", ["rinse", "cut"])
    with pytest.raises(tl.TleafError):
        tl.logic_loss("exact", torch.zeros(2, 3), tl.RuleSet("F cut", ["rinse", "cut"]))
    with pytest.raises(tl.TleafError):
        tl.load_embedder(Path("no/such/model"))
