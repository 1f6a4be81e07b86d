"""The new logic-loss core equals both old implementations on their own cases (kept for the
commit that replaces them; the old copies are deleted after it)."""

from __future__ import annotations

import pytest
import torch

from tleaf_cli.data.knowledge import read_knowledge_base
from tleaf_cli.data.rule_set import KnowledgeRuleSets
from tleaf_cli.embed.encoders import PropositionEncoder
from tleaf_cli.embed.meta_data import GuardVectors
from tleaf_cli.embed.soft import Embedder
from tleaf_cli.embed.train_meta import MetaSettings, build_model
from tleaf_cli.losses import logic_loss, pair_log_probs
from tleaf_cli import losses_old as old
from tleaf_cli.tasks.cooking import packed_rules as cooking_old

ACTIONS = ("cut", "fry", "rinse", "wash")
INGREDIENTS = ("egg", "onion", "milk")
VOCAB = [f"{a}_{i}" for a in ACTIONS for i in INGREDIENTS]
PAIRS = {name: k for k, name in enumerate(VOCAB)}


def embedder() -> Embedder:
    torch.manual_seed(0)
    edge = PropositionEncoder(torch.eye(len(VOCAB)), hidden=16, layers=2, out_dim=8)
    vectors = GuardVectors(edge, sorted(VOCAB))
    model = build_model(MetaSettings(hidden=16, layers=2, out_dim=8), vectors.dim, edge.atom_table)
    return Embedder(model, vectors, {"settings": {"embedder": "dfa"}})


@pytest.fixture
def kb(tmp_path):
    path = tmp_path / "kb.ltl"
    path.write_text(
        "ordering.onion: (!fry_onion U cut_onion) | G !fry_onion\n"
        "affordance.cut_egg: G !cut_egg\n"
        "affordance.cut_milk: G !cut_milk\n"
        "ordering.egg: (!fry_egg U rinse_egg) | G !fry_egg\n"
        "ordering.milk: (!fry_milk U wash_milk) | G !fry_milk\n"
        "ordering.onion2: (!rinse_onion U wash_onion) | G !rinse_onion\n"
    )
    return read_knowledge_base(path)


def videos(seed: int, n: int) -> list[set[str]]:
    g = torch.Generator().manual_seed(seed)
    return [{VOCAB[int(k)] for k in torch.randint(len(VOCAB), (6,), generator=g)} for _ in range(n)]


@pytest.mark.parametrize("per_ingredient", [False, True])
@pytest.mark.parametrize("kind", ["exact", "tleaf", "checker"])
def test_core_equals_action_recognition_losses(kb, kind, per_ingredient) -> None:
    q = embedder() if kind == "tleaf" else None
    old_sets = old.RuleSets(kb, PAIRS, q)
    new_sets = KnowledgeRuleSets(kb, VOCAB, None if q is None else set(q.vectors.index))
    for seed in range(4):
        atoms = videos(seed, 8)
        g = torch.Generator().manual_seed(100 + seed)
        a = (torch.randn((8, 7, len(ACTIONS)), generator=g) * 2).requires_grad_()
        i = (torch.randn((8, 7, len(INGREDIENTS)), generator=g) * 2).requires_grad_()
        lengths = torch.randint(1, 8, (8,), generator=g)
        groups = old_sets.groups_for_videos(atoms, per_ingredient or kind == "checker")
        loss = {"exact": old.exact_loss, "tleaf": old.tleaf_loss, "checker": old.checker_loss}[kind]
        extra = (old_sets,) if kind == "tleaf" else ()
        want = old.grouped(loss, a, i, lengths, groups, *extra)
        new_groups = new_sets.for_atoms(atoms, per_ingredient or kind == "checker")
        owner = torch.tensor([b for b, gs in enumerate(new_groups) for _ in gs], dtype=torch.long)
        flat = [r for gs in new_groups for r in gs]
        assert [r.name for r in flat] == [r.id for gs in groups for r in gs]
        assert all(n.dfa == o.dfa for n, o in zip(flat, [r for gs in groups for r in gs]))
        per_set = logic_loss(
            kind, pair_log_probs(a, i)[owner], flat, lengths[owner], q, reduction="none"
        )
        got = torch.zeros(8).index_add(0, owner, per_set)
        assert torch.allclose(got, want, rtol=1e-6, atol=1e-6), (kind, seed, got, want)
        if kind != "checker":
            ga = torch.autograd.grad(want.sum(), a, retain_graph=True)[0]
            gb = torch.autograd.grad(got.sum(), a)[0]
            assert torch.allclose(ga, gb, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("kind", ["exact", "tleaf"])
def test_core_equals_cooking_packed_losses(kb, kind) -> None:
    """Cooking's float64 tree product on a policy's action log-probs (vocabulary = actions)."""
    q = embedder() if kind == "tleaf" else None
    old_sets = old.RuleSets(kb, PAIRS, q)
    new_sets = KnowledgeRuleSets(kb, VOCAB)
    atoms = [a for a in videos(7, 6)]
    sets = [r for r in old_sets.for_videos(atoms) if r is not None]
    fresh = [r for gs in new_sets.for_atoms(atoms) for r in gs]
    packed = cooking_old.pack_rules(sets, list(range(len(sets))), len(VOCAB), old_sets)
    g = torch.Generator().manual_seed(5)
    log_policy = torch.log_softmax(torch.randn((len(sets), 9, len(VOCAB)), generator=g) * 3, -1)
    log_policy.requires_grad_()
    lengths = torch.randint(1, 10, (len(sets),), generator=g)
    rows = torch.arange(len(sets))
    letters = cooking_old.letter_log_probs(log_policy, packed, rows)
    if kind == "exact":
        want = cooking_old.exact_losses(letters, lengths, packed, rows)
    else:
        from tleaf_cli.embed.soft import soft_trace_vectors

        expected = cooking_old.expected_letter_vectors(letters, packed, rows)
        z = soft_trace_vectors(q.model, expected, lengths)
        want = (z - packed.targets[rows]).pow(2).sum(dim=1)
    got = logic_loss(kind, log_policy, fresh, lengths, q, reduction="none")
    assert torch.allclose(got, want, rtol=1e-5, atol=1e-5), (got, want)
    ga = torch.autograd.grad(want.sum(), log_policy, retain_graph=True)[0]
    gb = torch.autograd.grad(got.sum(), log_policy)[0]
    assert torch.allclose(ga, gb, rtol=1e-4, atol=1e-6)
