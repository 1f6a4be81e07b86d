"""The logic-loss core: exact against brute force, tleaf's gradients, the checker, rule sets."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
import pytest
import torch

from tleaf_cli.embed.embedder import Embedder
from tleaf_cli.embed.meta_data import GuardVectors
from tleaf_cli.embed.model import build_model
from tleaf_cli.embed.proposition_encoder import PropositionEncoder
from tleaf_cli.errors import ArgumentError, InputError, SettingError, TleafError
from tleaf_cli.knowledge.base import read_knowledge_base
from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.losses import logic_loss, pair_log_probs, pair_vocabulary, violates
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.settings.meta import MetaSettings

ACTIONS = ("cut", "fry", "rinse")
INGREDIENTS = ("egg", "onion")
VOCAB = pair_vocabulary(ACTIONS, INGREDIENTS)


def log_probs(batch: int, steps: int, seed: int) -> torch.Tensor:
    """Pair log-probabilities from two random heads (the action recogniser's shape)."""
    g = torch.Generator().manual_seed(seed)
    a = torch.randn((batch, steps, len(ACTIONS)), generator=g) * 2
    i = torch.randn((batch, steps, len(INGREDIENTS)), generator=g) * 2
    return pair_log_probs(a, i).detach().requires_grad_()


def brute_force_accept(r: RuleSet, lp: torch.Tensor) -> float:
    """P(accept): the sum over every sequence of its probability times the DFA's acceptance."""
    p = lp.exp().detach().numpy()
    total = 0.0
    for seq in itertools.product(range(len(VOCAB)), repeat=len(p)):
        if r.dfa.accepts([{VOCAB[k]} for k in seq]):
            total += math.prod(p[t, k] for t, k in enumerate(seq))
    return total


def test_pair_vocabulary_is_the_order_of_pair_log_probs() -> None:
    a = torch.randn(1, 1, len(ACTIONS))
    i = torch.randn(1, 1, len(INGREDIENTS))
    lp = pair_log_probs(a, i)[0, 0]
    la, li = torch.log_softmax(a[0, 0], -1), torch.log_softmax(i[0, 0], -1)
    assert VOCAB[3] == "fry_onion"
    assert lp[3].item() == pytest.approx((la[1] + li[1]).item())
    assert lp.exp().sum().item() == pytest.approx(1.0)


def test_exact_loss_is_the_brute_force_probability() -> None:
    sets = [
        RuleSet("G(cut_onion -> F fry_onion)", VOCAB),
        None,
        RuleSet(["!fry_egg U rinse_egg", "G !cut_egg"], VOCAB),
    ]
    lp = log_probs(3, 4, seed=1)
    lengths = torch.tensor([4, 2, 3])
    loss = logic_loss("exact", lp, sets, lengths, reduction="none")
    assert loss[1].item() == 0.0
    for b in (0, 2):
        want = brute_force_accept(sets[b], lp[b, : int(lengths[b])])
        assert 0.0 < want < 1.0
        assert loss[b].item() == pytest.approx(-math.log(want), rel=1e-4)
    loss.sum().backward()
    assert lp.grad[0].abs().sum() > 0 and lp.grad[1].abs().sum() == 0  # no rule, no gradient
    assert lp.grad[2, 3:].abs().sum() == 0  # steps past a length are not read
    # the gradient of −log P(accept), P written out as the sum over accepted sequences
    for b in (0, 2):
        n = int(lengths[b])
        one = lp[b, :n].detach().clone().requires_grad_()
        accepted = [
            seq
            for seq in itertools.product(range(len(VOCAB)), repeat=n)
            if sets[b].dfa.accepts([{VOCAB[k]} for k in seq])
        ]
        rows = torch.tensor(accepted)  # [sequences, n]
        p = one.gather(1, rows.t()).sum(dim=0).exp().sum()  # Σ_w Π_t P_t(w_t)
        (grad,) = torch.autograd.grad(-p.log(), one)
        torch.testing.assert_close(lp.grad[b, :n], grad, rtol=1e-4, atol=1e-6)


def test_batched_equals_one_by_one_and_reductions() -> None:
    rules = [RuleSet("G(cut_onion -> F fry_onion)", VOCAB), RuleSet("F rinse_egg", VOCAB)] * 3
    lp = log_probs(6, 5, seed=2)
    lengths = torch.tensor([5, 4, 3, 2, 1, 5])
    batched = logic_loss("exact", lp, rules, lengths, reduction="none")
    alone = [
        logic_loss("exact", lp[b : b + 1], rules[b], lengths[b : b + 1], reduction="sum")
        for b in range(6)
    ]
    assert torch.allclose(batched, torch.stack(alone), rtol=1e-6)
    assert logic_loss("exact", lp, rules, lengths).item() == pytest.approx(batched.mean().item())
    assert logic_loss("exact", lp, rules, lengths, reduction="sum").item() == pytest.approx(
        batched.sum().item()
    )
    one = RuleSet("F rinse_egg", VOCAB)  # one rule set for every sequence
    assert torch.allclose(
        logic_loss("exact", lp, one, lengths, reduction="none"),
        logic_loss("exact", lp, [one] * 6, lengths, reduction="none"),
    )


def test_exact_loss_stays_finite_when_confidently_wrong() -> None:
    logits = torch.full((1, 6, len(VOCAB)), -400.0)
    logits[0, :, VOCAB.index("cut_egg")] = 400.0  # certain of cut_egg at every step
    logits.requires_grad_()
    loss = logic_loss("exact", torch.log_softmax(logits, -1), RuleSet("G !cut_egg", VOCAB))
    loss.backward()
    assert torch.isfinite(loss) and loss.item() > 100
    assert torch.isfinite(logits.grad).all()
    assert logits.grad[0, :, VOCAB.index("cut_egg")].sum() > 0  # a push away, however sure


def test_unsatisfiable_rules_give_no_signal() -> None:
    never = RuleSet(["F cut_egg", "G !cut_egg"], VOCAB)
    assert not never.satisfiable
    lp = log_probs(2, 3, seed=0)
    loss = logic_loss("exact", lp, [never, RuleSet("F cut_egg", VOCAB)], reduction="none")
    assert loss[0].item() == 0.0 and loss[1].item() > 0


def test_checker_loss_is_the_exact_checker_and_has_no_gradient() -> None:
    sets = [RuleSet("G(cut_onion -> F fry_onion)", VOCAB), RuleSet("F rinse_egg", VOCAB), None]
    for seed in range(5):
        lp = log_probs(3, 5, seed)
        loss = logic_loss("checker", lp, sets, torch.tensor([5, 3, 4]), reduction="none")
        assert loss.grad_fn is None
        best = lp.argmax(-1)
        for b, n in enumerate([5, 3]):
            trace = [{VOCAB[int(k)]} for k in best[b, :n]]
            assert loss[b].item() == float(not sets[b].dfa.accepts(trace))
            assert violates([sets[b]], [best[b, :n].numpy()])[0] == (loss[b].item() == 1.0)
        assert loss[2].item() == 0.0


def test_rule_set_is_the_conjunctions_dfa_over_the_vocabulary() -> None:
    r = RuleSet(["G !cut_egg", "(!fry_egg U rinse_egg) | G !fry_egg"], VOCAB)
    direct = compile_formula("G !cut_egg & ((!fry_egg U rinse_egg) | G !fry_egg)", "one-hot")
    assert r.atoms == direct.atoms and r.dfa.equivalent(direct)
    assert r.dfa.num_states == direct.num_states
    assert [VOCAB[k] for k in r.index] == list(r.atoms)
    seq = np.array([VOCAB.index("rinse_onion"), VOCAB.index("cut_egg")])
    assert r.letters(seq).tolist() == [0, 1 + r.atoms.index("cut_egg")]


def test_rule_set_errors_name_what_is_wrong() -> None:
    with pytest.raises(InputError, match="stir_egg"):
        RuleSet("G !stir_egg", VOCAB)
    with pytest.raises(InputError, match="rule 'G !!'"):
        RuleSet("G !!", VOCAB)
    lp = log_probs(2, 3, seed=0)
    with pytest.raises(SettingError, match="kind"):
        logic_loss("fuzzy", lp, RuleSet("F cut_egg", VOCAB))  # type: ignore[arg-type]
    with pytest.raises(SettingError, match="embedder"):
        logic_loss("tleaf", lp, RuleSet("F cut_egg", VOCAB))
    with pytest.raises(ArgumentError, match="3 rule sets for a batch of 2"):
        logic_loss("exact", lp, [RuleSet("F cut_egg", VOCAB)] * 3)
    with pytest.raises(TleafError, match="vocabulary of 2 items"):
        logic_loss("exact", lp, RuleSet("F cut_egg", ["cut_egg", "fry_egg"]))


def untrained_embedder() -> Embedder:
    """q with random weights over the pair atoms: enough to check that gradients flow."""
    vocabulary = sorted(VOCAB)
    torch.manual_seed(0)
    edge = PropositionEncoder(torch.eye(len(vocabulary)), hidden=16, layers=2, out_dim=8)
    vectors = GuardVectors(edge, vocabulary)
    settings = MetaSettings.preset("paper", hidden=16, layers=2, out_dim=8)
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
    q = untrained_embedder()
    rules = KnowledgeRuleSets(kb, VOCAB, set(q.vectors.index))
    torch.manual_seed(0)
    h = torch.nn.Linear(4, len(ACTIONS) + len(INGREDIENTS))
    out = h(torch.randn(2, 5, 4))
    lp = pair_log_probs(out[..., : len(ACTIONS)], out[..., len(ACTIONS) :])
    sets = rules.one_each([{"fry_onion", "cut_onion", "cut_egg"}, {"rinse_egg", "fry_egg"}])
    assert all(s is not None for s in sets)
    loss = logic_loss("tleaf", lp, sets, torch.tensor([5, 4]), q, reduction="none")
    assert (loss > 0).all()
    loss.sum().backward()
    assert h.weight.grad.abs().sum() > 0 and h.bias.grad.abs().sum() > 0
    assert all(p.grad is None for p in q.model.parameters())  # q stays frozen


def test_tleaf_of_a_one_hot_trace_is_the_discrete_traces_distance(kb) -> None:
    """A certain model's soft trace is its discrete trace: q(w̃) = q(w)."""
    q = untrained_embedder()
    r = RuleSet("(!fry_egg U rinse_egg) | G !fry_egg", VOCAB)
    trace = ["rinse_egg", "cut_onion", "fry_egg"]
    lp = torch.full((1, 3, len(VOCAB)), -1e4)
    for t, a in enumerate(trace):
        lp[0, t, VOCAB.index(a)] = 0.0
    got = logic_loss("tleaf", torch.log_softmax(lp, -1), r, embedder=q)
    z_trace = q.embed_traces([[{a} if a in r.atoms else set() for a in trace]], [r.atoms], [True])
    z_rules = q.embed_dfas([r.dfa])
    assert got.item() == pytest.approx((z_trace - z_rules).pow(2).sum().item(), rel=1e-4)


def test_knowledge_rule_sets_build_each_set_once(kb) -> None:
    rules = KnowledgeRuleSets(kb, VOCAB)
    videos = [{"fry_onion", "cut_onion"}, {"cut_onion", "fry_onion", "rinse_onion"}, {"cut_egg"}]
    first = rules.one_each(videos)
    assert rules.compiled == 2  # the first two videos share a rule set
    assert first[0] is first[1] and len(first[0].formulas) == 1
    again = rules.one_each([*reversed(videos), {"fry_egg"}])
    assert rules.compiled == 2 and again[0] is first[2]
    assert again[3] is None  # no rule has all its atoms present
    assert len(rules.one_each([{"fry_egg", "rinse_egg", "cut_egg"}])[0].formulas) == 2
    assert rules.compiled == 3


def test_same_rule_set_same_vector(kb) -> None:
    q = untrained_embedder()
    r = KnowledgeRuleSets(kb, VOCAB).one_each([{"cut_egg"}])[0]
    first, letters = q.rule_set_vectors([r])
    again, _ = q.rule_set_vectors([r])
    assert torch.equal(first, again) and np.isfinite(first.numpy()).all()
    assert letters.shape[:2] == (1, len(r.atoms) + 1)


def test_rule_sets_per_ingredient_split_the_conjunction(kb) -> None:
    rules = KnowledgeRuleSets(kb, VOCAB)
    atoms = {"fry_egg", "rinse_egg", "cut_egg", "fry_onion", "cut_onion"}
    whole = rules.one_each([atoms])[0]
    (parts,) = rules.for_atoms([atoms], per_ingredient=True)
    assert [len(r.formulas) for r in parts] == [2, 1]  # egg (affordance + ordering), onion
    assert [sorted({a.split("_")[1] for a in r.atoms}) for r in parts] == [["egg"], ["onion"]]
    assert sum(len(r.formulas) for r in parts) == len(whole.formulas)
    assert all(r.dfa.num_states <= whole.dfa.num_states for r in parts)
    assert rules.for_atoms([{"fry_egg"}], per_ingredient=True) == [[]]
    # the conjunction's loss is no larger than the sum of its parts' (P(φ) ≥ ... per part)
    lp = log_probs(1, 4, seed=3)
    split = logic_loss("exact", lp.expand(2, -1, -1), parts, reduction="sum")
    assert logic_loss("exact", lp, whole).item() >= split.item() - 1e-5


def monitored_embedder(atoms: Sequence[str] = VOCAB) -> Embedder:
    """q with random weights over `atoms` and the default preset's parts: temporal monitors
    over 3 atom slots in 3 length ranges, the runs readout, the naive-Bayes evidence block."""
    vocabulary = sorted(atoms)
    torch.manual_seed(0)
    edge = PropositionEncoder(torch.eye(len(vocabulary)), hidden=16, layers=2, out_dim=8)
    vectors = GuardVectors(edge, vocabulary)
    settings = MetaSettings.preset(
        "best", hidden=16, layers=2, out_dim=8, monitors=3, max_length=6
    ).resolved(3)
    model = build_model(settings, vectors.dim, edge.atom_table)
    return Embedder(model, vectors, {"settings": {"embedder": "dfa"}})


def tleaf_one_by_one(q: Embedder, lp: torch.Tensor, r: RuleSet, length: int) -> torch.Tensor:
    """The T-LEAF loss of one sequence, computed step by step with nothing batched or kept:
    the letter distribution from the vocabulary's probabilities, the monitors' state
    distributions moved by the dense transition tensors `bank.steps`, q_m on one chain."""
    from tleaf_cli.embed.meta_data import chain_batch
    from tleaf_cli.logic.alphabet import Alphabet

    p = lp[:length].exp()
    outside = torch.ones(len(VOCAB), dtype=torch.bool)
    outside[torch.as_tensor(r.index)] = False
    none = p[:, outside].sum(dim=1, keepdim=True)  # the other items' mass (the real path's)
    letters = torch.cat([none, p[:, torch.as_tensor(r.index)]], dim=1)  # none, atoms
    expected = letters @ q.letter_vectors(r.atoms, "one-hot")[1]
    bank = q.model.trace.monitor_bank
    classes, present = bank.classes(Alphabet(r.atoms, "one-hot").truth())
    steps = torch.as_tensor(bank.steps, dtype=torch.float32)  # [M, 4, S, S]
    state = torch.zeros(bank.width, steps.shape[-1])
    state[:, 0] = 1.0
    for t in range(length):
        # [M, 4]: the probability of each class, per monitor (a letter's class is per monitor)
        per_class = torch.stack(
            [(letters[t] * torch.as_tensor(classes == c)).sum(dim=1) for c in range(4)], dim=1
        )
        state = torch.einsum("ms,mc,mcsu->mu", state, per_class, steps)
    accepted = (state * torch.tensor(bank.accepting)).sum(dim=1) * torch.tensor(present)
    placed = torch.zeros(bank.ranges, bank.width)
    placed[bank.range_of(length)] = accepted
    monitor = torch.cat([placed.flatten(), torch.zeros(bank.features)])[None]
    z_trace = q.model.embed_traces(chain_batch(q.model.trace, expected, [length], monitor))
    return (z_trace[0] - q.embed_dfas([r.dfa])[0]).pow(2).sum()


def test_tleaf_loss_and_gradient_equal_the_one_by_one_computation(kb) -> None:
    """Batched rows of rule sets of 1 to 5 atoms (more than q's 3 monitor slots), of several
    lengths, and a row without rules: the loss and its gradient are the step-by-step
    reference's, to float tolerance."""
    q = monitored_embedder()
    rules = KnowledgeRuleSets(kb, VOCAB, set(q.vectors.index))
    atoms = [
        {"fry_onion", "cut_onion", "cut_egg"},
        {"rinse_egg", "fry_egg"},
        {"cut_egg"},
        {"fry_onion", "cut_onion", "cut_egg", "rinse_egg", "fry_egg"},
        set(),
        {"rinse_egg", "fry_egg"},
    ]
    sets = rules.one_each(atoms)
    assert sets[4] is None and len({len(r.atoms) for r in sets if r is not None}) == 4
    lengths = torch.tensor([5, 4, 1, 6, 3, 2])
    lp = log_probs(len(atoms), 6, seed=5)
    got = logic_loss("tleaf", lp, sets, lengths, q, reduction="none")
    (grad,) = torch.autograd.grad(got.sum(), lp)
    lp_ref = lp.detach().clone().requires_grad_()
    want = torch.stack(
        [
            torch.zeros(()) if r is None else tleaf_one_by_one(q, lp_ref[b], r, int(lengths[b]))
            for b, r in enumerate(sets)
        ]
    )
    (grad_ref,) = torch.autograd.grad(want.sum(), lp_ref)
    assert got[4] == 0 and (want[[0, 1, 2, 3, 5]] > 0).all()
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-4)
    torch.testing.assert_close(grad, grad_ref, rtol=1e-3, atol=1e-5)
    # again, every rule set now kept by q: the same values
    torch.testing.assert_close(logic_loss("tleaf", lp, sets, lengths, q, reduction="none"), got)


def test_rule_set_dfa_is_the_chained_product_of_its_formulas() -> None:
    """Formulas grouped by shared atoms, each group's product kept: the same DFA as the
    product of all formulas in order (minimal, canonical), for groups joined by a later
    formula and for formulas without atoms."""
    from tleaf_cli.rule_set import _COMPILED

    formulas = [
        "G !cut_egg",
        "(!fry_egg U rinse_egg) | G !fry_egg",
        "F fry_onion",
        "true",
        "G(cut_onion -> X rinse_onion)",
        "(!fry_onion U cut_onion) | G !fry_onion",
        "F rinse_egg -> F cut_onion",  # joins the egg and onion groups
    ]
    for count in range(1, len(formulas) + 1):
        for chosen in itertools.islice(itertools.combinations(formulas, count), 12):
            got = RuleSet(list(chosen), VOCAB).dfa
            timeout = next(t for f, t in _COMPILED if f == chosen[0])
            want = _COMPILED[(chosen[0], timeout)]
            for f in chosen[1:]:
                want = want.intersect(_COMPILED[(f, timeout)])
            assert got == want.minimize_nonempty(), chosen


def test_knowledge_rule_sets_are_kept_per_atom_set(kb) -> None:
    """The same atoms give the same RuleSet objects and the same count of rules left out,
    whether the sets are derived again or read from what was kept."""
    known = set(VOCAB) - {"cut_egg"}
    rules = KnowledgeRuleSets(kb, VOCAB, known)
    videos = [{"cut_egg", "rinse_egg", "fry_egg"}, {"cut_egg"}, {"fry_onion", "cut_onion"}]
    first = rules.one_each(videos)
    skipped = rules.skipped_rules
    assert skipped == 2  # the affordance rule on cut_egg, in the first two videos
    again = rules.one_each([*videos, videos[0]])
    assert [a is b for a, b in zip(again, first, strict=False)] == [True] * 3
    assert again[3] is first[0] and rules.skipped_rules == skipped + 3
    assert [r.name for r in rules.rules(videos[0])] == ["ordering.egg"]
    assert rules.skipped_rules == skipped + 4


def test_rule_sets_and_training_need_no_mona(tmp_path, monkeypatch) -> None:
    """Rules progression compiles need no `mona` on PATH: a rule set, and a train-task run with
    the exact loss; their DFAs are MONA's."""
    from tleaf_cli.logic import mona
    from tleaf_cli.tasks.action_recognition.train import TaskSettings, train_action_recognition

    formulas = ["(!fry_onion U cut_onion) | G !fry_onion", "G(cut_egg -> X rinse_onion)"]
    want = [compile_formula(f, "one-hot", engine="mona") for f in formulas]
    monkeypatch.setenv("PATH", str(tmp_path))  # no mona there
    mona.mona_version.cache_clear()
    with pytest.raises(TleafError, match="mona"):
        mona.mona_binary()
    for f, dfa in zip(formulas, want, strict=True):
        assert RuleSet(f, VOCAB).dfa == dfa.minimize_nonempty()
    from typer.testing import CliRunner

    from tleaf_cli.cli import app

    data, kb = tmp_path / "act.parquet", tmp_path / "kb.ltl"
    args = ["--actions", 3, "--ingredients", 2, "--feature-dim", 8, "--train", 8, "--val", 4]
    args += ["--test", 4, "--min-steps", 3, "--max-steps", 6, "--seed", 2]
    result = CliRunner().invoke(
        app, ["gen-activities", "-o", str(data), "--kb-out", str(kb), *map(str, args)]
    )
    assert result.exit_code == 0, result.output
    settings = TaskSettings(logic_loss="exact", lam=1.0, hidden=8, head_hidden=4, epochs=1)
    metrics = train_action_recognition(data, kb, None, tmp_path / "run", settings)
    assert metrics["history"][0]["logic_loss"] > 0
    mona.mona_version.cache_clear()


@pytest.mark.parametrize("kind", ["exact", "checker"])
def test_rule_sets_over_another_vocabulary_of_the_same_size_are_refused(kind: str) -> None:
    """Two vocabularies of V items in another order would read log_probs' item k as another
    action: the loss refuses them, naming the rule set and the first item that differs, as
    tl.Shield does (one check, rule_set.common_vocabulary)."""
    lp = log_probs(2, 3, seed=0)
    shuffled = list(reversed(VOCAB))
    first, other = RuleSet("F cut_egg", VOCAB), RuleSet("F cut_egg", shuffled, name="reversed")
    with pytest.raises(
        ArgumentError, match="rule set reversed is not over the same vocabulary"
    ) as e:
        logic_loss(kind, lp, [first, other])
    assert f"its item 0 is {shuffled[0]!r}, not {VOCAB[0]!r}" in str(e.value)
    assert logic_loss(kind, lp, [first, RuleSet("G !fry_egg", VOCAB)]).shape == ()
    # where each sequence names its items by its own rule set (Creative Cooking's episodes),
    # the caller says so, and each row is read by its own vocabulary
    mixed = logic_loss(kind, lp, [first, other], reduction="none", per_sequence_vocabulary=True)
    alone = [
        logic_loss(kind, lp[b : b + 1], r, reduction="none") for b, r in enumerate([first, other])
    ]
    assert torch.allclose(mixed, torch.cat(alone))
