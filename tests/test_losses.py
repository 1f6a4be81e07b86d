"""Logic losses: exact against brute force, tleaf's gradients, the checker, the rule-set cache."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import torch

from tleaf_cli.data.knowledge import read_knowledge_base
from tleaf_cli.embed.encoders import PropositionEncoder
from tleaf_cli.embed.meta_data import GuardVectors
from tleaf_cli.embed.soft import Embedder
from tleaf_cli.embed.train_meta import MetaSettings, build_model
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.losses import (
    RuleSet,
    RuleSets,
    checker_loss,
    exact_loss,
    grouped,
    no_logic_loss,
    pair_log_probs,
    tleaf_loss,
)

ACTIONS = ("cut", "fry", "rinse")
INGREDIENTS = ("egg", "onion")
PAIRS = {f"{a}_{i}": k * len(INGREDIENTS) + j for k, a in enumerate(ACTIONS) for j, i in
         enumerate(INGREDIENTS)}  # fmt: skip
NAMES = {v: k for k, v in PAIRS.items()}


def rule_set(formula: str) -> RuleSet:
    dfa = compile_formula(formula, "one-hot")
    pairs = torch.tensor([PAIRS[a] for a in dfa.atoms])
    return RuleSet(formula, formula, 1, dfa, pairs, True)


def logits(batch: int, steps: int, seed: int) -> tuple[torch.Tensor, torch.Tensor]:
    g = torch.Generator().manual_seed(seed)
    a = torch.randn((batch, steps, len(ACTIONS)), generator=g) * 2
    i = torch.randn((batch, steps, len(INGREDIENTS)), generator=g) * 2
    return a.requires_grad_(), i.requires_grad_()


def brute_force_accept(r: RuleSet, a: torch.Tensor, i: torch.Tensor, steps: int) -> float:
    """P(accept): sum over every pair sequence of its probability times acceptance."""
    p = pair_log_probs(a, i).exp().detach().numpy()
    total = 0.0
    for seq in itertools.product(range(len(PAIRS)), repeat=steps):
        if r.dfa.accepts([{NAMES[k]} for k in seq]):
            total += math.prod(p[t, k] for t, k in enumerate(seq))
    return total


def test_exact_loss_is_the_brute_force_probability() -> None:
    sets = [
        rule_set("G(cut_onion -> F fry_onion)"),
        None,
        rule_set("(!fry_egg U rinse_egg) & G !cut_egg"),
    ]
    a, i = logits(3, 4, seed=1)
    lengths = torch.tensor([4, 2, 3])
    loss = exact_loss(a, i, lengths, sets)
    assert loss[1].item() == 0.0
    for b in (0, 2):
        steps = int(lengths[b])
        want = brute_force_accept(sets[b], a[b, :steps], i[b, :steps], steps)
        assert 0.0 < want < 1.0
        assert loss[b].item() == pytest.approx(-math.log(want), rel=1e-4)
    loss.sum().backward()
    assert a.grad[0].abs().sum() > 0 and a.grad[1].abs().sum() == 0  # no rule, no gradient


def test_exact_loss_stays_finite_when_confidently_wrong() -> None:
    a = torch.full((1, 6, len(ACTIONS)), -200.0)
    a[0, :, 0] = 200.0  # certain of "cut" at every step
    i = torch.full((1, 6, len(INGREDIENTS)), -200.0)
    i[0, :, 0] = 200.0  # ... of "egg": the sequence cut_egg x 6, which G !cut_egg forbids
    a.requires_grad_()
    loss = exact_loss(a, i, torch.tensor([6]), [rule_set("G !cut_egg")])
    loss.sum().backward()
    assert torch.isfinite(loss).all() and loss.item() > 100
    assert torch.isfinite(a.grad).all()
    assert a.grad[0, :, 0].sum() > 0  # still a push away from "cut", however sure the model is


def test_checker_loss_is_the_exact_checker_and_has_no_gradient() -> None:
    sets = [rule_set("G(cut_onion -> F fry_onion)"), rule_set("F rinse_egg"), None]
    for seed in range(5):
        a, i = logits(3, 5, seed)
        loss = checker_loss(a, i, torch.tensor([5, 3, 4]), sets)
        assert loss.grad_fn is None and not loss.requires_grad
        best = pair_log_probs(a, i).argmax(-1)
        for b, n in enumerate([5, 3]):
            trace = [{NAMES[int(k)]} for k in best[b, :n]]
            assert loss[b].item() == float(not sets[b].dfa.accepts(trace))
        assert loss[2].item() == 0.0


def test_no_logic_loss_is_zero() -> None:
    a, _ = logits(4, 3, seed=0)
    assert torch.equal(no_logic_loss(a), torch.zeros(4))


def untrained_embedder() -> Embedder:
    """q with random weights over the pair atoms: enough to check that gradients flow."""
    vocabulary = sorted(PAIRS)
    torch.manual_seed(0)
    edge = PropositionEncoder(torch.eye(len(vocabulary)), hidden=16, layers=2, out_dim=8)
    vectors = GuardVectors(edge, vocabulary)
    settings = MetaSettings(hidden=16, layers=2, out_dim=8)
    model = build_model(settings, vectors.dim, edge.atom_table)
    return Embedder(model, vectors, {"settings": {"embedder": "dfa"}})


@pytest.fixture
def kb(tmp_path):
    path = tmp_path / "kb.ltl"
    path.write_text(
        "ordering.onion: (!fry_onion U cut_onion) | G !fry_onion\n"
        "affordance.cut_egg: G !cut_egg\n"
        "ordering.egg: (!fry_egg U rinse_egg) | G !fry_egg\n"
    )
    return read_knowledge_base(path)


def test_tleaf_loss_sends_gradients_into_the_model(kb) -> None:
    rules = RuleSets(kb, PAIRS, untrained_embedder())
    torch.manual_seed(0)
    h = torch.nn.Linear(4, len(ACTIONS) + len(INGREDIENTS))
    x = torch.randn(2, 5, 4)
    out = h(x)
    a, i = out[..., : len(ACTIONS)], out[..., len(ACTIONS) :]
    sets = rules.for_videos([{"fry_onion", "cut_onion", "cut_egg"}, {"rinse_egg", "fry_egg"}])
    assert all(s is not None for s in sets)
    loss = tleaf_loss(a, i, torch.tensor([5, 4]), sets, rules)
    assert (loss > 0).all()
    loss.sum().backward()
    assert h.weight.grad.abs().sum() > 0 and h.bias.grad.abs().sum() > 0
    assert all(p.grad is None for p in rules.embedder.model.parameters())  # q stays frozen


def test_rule_sets_compile_each_set_once(kb) -> None:
    rules = RuleSets(kb, PAIRS)
    videos = [{"fry_onion", "cut_onion"}, {"cut_onion", "fry_onion", "rinse_onion"}, {"cut_egg"}]
    first = rules.for_videos(videos)
    assert rules.compiled == 2  # the first two videos share a rule set
    assert first[0] is first[1] and first[0].num_rules == 1
    again = rules.for_videos([*reversed(videos), {"fry_egg"}])
    assert rules.compiled == 2 and again[0] is first[2]
    assert again[3] is None  # no rule has all its atoms present
    assert rules.for_videos([{"fry_egg", "rinse_egg", "cut_egg"}])[0].num_rules == 2
    assert rules.compiled == 3


def test_same_rule_set_same_vector(kb) -> None:
    rules = RuleSets(kb, PAIRS, untrained_embedder())
    r = rules.for_videos([{"cut_egg"}])[0]
    assert rules.formula_vector(r) is rules.formula_vector(r)
    assert np.isfinite(rules.formula_vector(r).numpy()).all()


def test_rule_set_dfa_is_the_conjunctions_dfa(kb) -> None:
    """The product of the rules' DFAs is the minimal DFA MONA gives for the conjunction."""
    rules = RuleSets(kb, PAIRS)
    r = rules.for_videos([{"fry_egg", "rinse_egg", "cut_egg", "fry_onion", "cut_onion"}])[0]
    assert r.num_rules == 3
    direct = compile_formula(r.formula, "one-hot")
    assert r.dfa.atoms == direct.atoms and r.dfa.equivalent(direct)
    assert r.dfa.num_states == direct.num_states


def test_rule_sets_per_ingredient_split_the_conjunction(kb) -> None:
    rules = RuleSets(kb, PAIRS)
    atoms = {"fry_egg", "rinse_egg", "cut_egg", "fry_onion", "cut_onion"}
    whole = rules.for_videos([atoms])[0]
    (parts,) = rules.groups_for_videos([atoms], per_ingredient=True)
    assert [r.num_rules for r in parts] == [2, 1]  # egg (affordance + ordering), onion
    assert [sorted({a.split("_")[1] for a in r.dfa.atoms}) for r in parts] == [["egg"], ["onion"]]
    assert sum(r.num_rules for r in parts) == whole.num_rules
    assert all(r.dfa.num_states <= whole.dfa.num_states for r in parts)
    assert rules.groups_for_videos([{"fry_egg"}], per_ingredient=True) == [[]]


def test_grouped_loss_is_the_sum_over_a_videos_rule_sets(kb) -> None:
    rules = RuleSets(kb, PAIRS)
    videos = [{"fry_egg", "rinse_egg", "cut_egg", "fry_onion", "cut_onion"}, {"rinse_egg"}]
    groups = rules.groups_for_videos(videos, per_ingredient=True)
    a, i = logits(2, 4, seed=3)
    lengths = torch.tensor([4, 3])
    loss = grouped(exact_loss, a, i, lengths, groups)
    assert loss[1].item() == 0.0 and groups[1] == []
    alone = [exact_loss(a[:1], i[:1], lengths[:1], [r])[0] for r in groups[0]]
    assert len(alone) == 2 and loss[0].item() == pytest.approx(sum(x.item() for x in alone))
    # one set per video: the same as calling the loss directly
    whole = rules.for_videos(videos)
    direct = exact_loss(a, i, lengths, whole)
    assert torch.allclose(
        grouped(exact_loss, a, i, lengths, [[r] if r else [] for r in whole]), direct
    )
