"""Constrained decoding: accepted by the rules, and the best accepted sequence (brute force)."""

from __future__ import annotations

import itertools

import pytest
import torch

import tleaf_cli as tl
from tleaf_cli.decode import constrained_decode
from tleaf_cli.errors import ArgumentError, RulesError
from tleaf_cli.rule_set import RuleSet

VOCAB = ["rinse", "cut", "cook", "serve", "wait"]
RULES = [
    "(!cook U rinse) | G !cook",  # rinse before cooking
    "F serve",  # serve at some point
    "G(cut -> X cook)",  # every cut is followed by cooking (strong next: not the last step)
    "G(serve -> !X rinse)",  # no rinsing right after serving
]


def brute_force(scores: torch.Tensor, rule_set: RuleSet) -> tuple[float, list[list[int]]]:
    """The best score over accepted sequences, and every accepted sequence reaching it."""
    best, argbest = float("-inf"), []
    for seq in itertools.product(range(len(VOCAB)), repeat=len(scores)):
        if rule_set.dfa.accepts([{VOCAB[k]} for k in seq]):
            s = float(sum(scores[t, k] for t, k in enumerate(seq)))
            if s > best + 1e-5:
                best, argbest = s, [list(seq)]
            elif abs(s - best) <= 1e-5:
                argbest.append(list(seq))
    return best, argbest


def score(scores: torch.Tensor, seq: torch.Tensor) -> float:
    return float(sum(scores[t, int(k)] for t, k in enumerate(seq)))


def test_decoding_is_the_best_accepted_sequence() -> None:
    argmax_violates = 0
    for seed in range(6):
        g = torch.Generator().manual_seed(seed)
        rule_sets = [RuleSet(RULES[: 1 + seed % 3], VOCAB), RuleSet(RULES[1:3], VOCAB), None]
        lengths = torch.tensor([4, 3, 4])
        log_probs = torch.log_softmax(torch.randn((3, 4, len(VOCAB)), generator=g) * 2, -1)
        out = constrained_decode(log_probs, rule_sets, lengths)
        assert out.shape == (3, 4) and out[1, 3] == -1
        for b in (0, 1):
            n = int(lengths[b])
            seq = out[b, :n]
            assert rule_sets[b].dfa.accepts([{VOCAB[int(k)]} for k in seq])
            best, _ = brute_force(log_probs[b, :n], rule_sets[b])
            assert score(log_probs[b, :n], seq) == pytest.approx(best, abs=1e-5)
            greedy = log_probs[b, :n].argmax(-1)
            argmax_violates += not rule_sets[b].dfa.accepts([{VOCAB[int(k)]} for k in greedy])
        assert torch.equal(out[2], log_probs[2].argmax(-1))  # no rules: argmax
    assert argmax_violates >= 3  # the assertions above would fail for argmax decoding


def test_batched_equals_one_by_one_and_public_name() -> None:
    g = torch.Generator().manual_seed(7)
    rule_sets = [RuleSet(RULES[i % 3 : i % 3 + 2], VOCAB) for i in range(6)]
    log_probs = torch.log_softmax(torch.randn((6, 5, len(VOCAB)), generator=g), -1)
    lengths = torch.tensor([5, 2, 3, 5, 4, 1])
    batched = tl.constrained_decode(log_probs, rule_sets, lengths)
    for b in range(6):
        alone = constrained_decode(log_probs[b : b + 1], rule_sets[b], lengths[b : b + 1])
        assert torch.equal(batched[b], alone[0])


def test_unsatisfiable_rules_are_a_clear_error() -> None:
    never = RuleSet(["F serve", "G !serve"], VOCAB)
    with pytest.raises(RulesError, match="sequence 1: no sequence of length 3"):
        constrained_decode(torch.zeros(2, 3, len(VOCAB)), [None, never])
    # satisfiable, but not in one step: cut must be followed by cook, serve must come
    short = RuleSet(["F cut", "F serve"], VOCAB)
    with pytest.raises(tl.TleafError, match="length 1"):
        constrained_decode(torch.zeros(1, 1, len(VOCAB)), short)
    assert constrained_decode(torch.zeros(1, 2, len(VOCAB)), short)[0].tolist() in (
        [1, 3],
        [3, 1],
    )


def test_alive_letters_is_the_primitive() -> None:
    r = RuleSet("(!cook U rinse) | G !cook", VOCAB)
    dfa = r.dfa
    alive = dfa.alive_letters(dfa.initial)
    cook = 1 + r.atoms.index("cook")
    assert not alive[cook] and alive.sum() == dfa.alphabet.size - 1  # cooking first is fatal


def test_action_recognition_decoding_meets_every_relevant_rule(tmp_path) -> None:
    """decode_pairs: rules chosen from the outputs alone; the decoded pairs break none of the
    rules relevant to them (the violation metric), for every candidate budget."""
    from tleaf_cli.knowledge.base import read_knowledge_base
    from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
    from tleaf_cli.losses import pair_log_probs, pair_vocabulary, violates
    from tleaf_cli.tasks.action_recognition.decoding import decode_pairs

    actions, ingredients = ("cut", "fry", "rinse", "wash"), ("egg", "onion", "milk")
    vocab = pair_vocabulary(actions, ingredients)
    (tmp_path / "kb.ltl").write_text(
        "ordering.onion: (!fry_onion U cut_onion) | G !fry_onion\n"
        "affordance.cut_egg: G !cut_egg\n"
        "affordance.cut_milk: G !cut_milk\n"
        "ordering.egg: (!fry_egg U rinse_egg) | G !fry_egg\n"
        "ordering.milk: (!fry_milk U wash_milk) | G !fry_milk\n"
    )
    rules = KnowledgeRuleSets(read_knowledge_base(tmp_path / "kb.ltl"), vocab)
    g = torch.Generator().manual_seed(3)
    a = torch.randn((12, 6, len(actions)), generator=g) * 2
    i = torch.randn((12, 6, len(ingredients)), generator=g) * 2
    log_pairs = pair_log_probs(a, i)
    lengths = torch.randint(2, 7, (12,), generator=g)
    greedy = log_pairs.argmax(-1)

    def violating(pairs: torch.Tensor) -> int:
        seqs = [pairs[b, : int(lengths[b])].numpy() for b in range(12)]
        sets = rules.one_each([{vocab[k] for k in s} for s in seqs])
        kept = [b for b, r in enumerate(sets) if r is not None]
        return int(violates([sets[b] for b in kept], [seqs[b] for b in kept]).sum())

    assert violating(greedy) >= 3
    for top_k in (1, 3, 12):
        decoded, rounds = decode_pairs(log_pairs, lengths, rules, top_k)
        assert violating(decoded) == 0 and rounds >= 1
        assert (decoded[torch.arange(6)[None, :] >= lengths[:, None]] == -1).all()


def test_rule_sets_over_another_vocabulary_of_the_same_size_are_refused() -> None:
    """The decoder would return indices into one vocabulary for rules read in another: refused,
    as tl.Shield and the logic losses refuse it."""
    log_probs = torch.randn(2, 3, len(VOCAB)).log_softmax(-1)
    other = ["wait", "serve", "cook", "cut", "rinse"]
    rules = [RuleSet("F serve", VOCAB), RuleSet("F serve", other, name="reordered")]
    with pytest.raises(ArgumentError, match="rule set reordered is not over the same vocab"):
        constrained_decode(log_probs, rules)
    with pytest.raises(ArgumentError, match="its item 0 is 'wait', not 'rinse'"):
        constrained_decode(log_probs, rules)
    mixed = constrained_decode(log_probs, rules, per_sequence_vocabulary=True)
    for b, r in enumerate(rules):
        assert torch.equal(mixed[b], constrained_decode(log_probs[b : b + 1], r)[0])
