"""Soft decoding: the rules as a weighted prior, between argmax (weight 0) and constrained
decoding (a large weight), the best sequence under score − weight · [breaks the rules] (brute
force), on hand-made outputs; and its pair form on a step recogniser's outputs."""

from __future__ import annotations

import itertools
import math

import pytest
import torch

from tleaf_cli.decode import constrained_decode, soft_choice, soft_decode
from tleaf_cli.knowledge.base import read_knowledge_base
from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
from tleaf_cli.losses import pair_vocabulary
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.tasks.action_recognition.decoding import decode_pairs, soft_pairs

VOCAB = ["rinse", "cook", "wait"]
RINSE_FIRST = RuleSet(["(!cook U rinse) | G !cook"], VOCAB)


def log_probs(rows: list[list[float]]) -> torch.Tensor:
    """[1, T, V] log-probabilities from per-step probabilities."""
    return torch.tensor([rows]).log()


def penalised_best(scores: torch.Tensor, weight: float) -> float:
    """max over every sequence of Σ log p − weight · [the rules reject it] (brute force)."""
    best = -math.inf
    for seq in itertools.product(range(len(VOCAB)), repeat=scores.shape[0]):
        total = float(sum(scores[t, k] for t, k in enumerate(seq)))
        if not RINSE_FIRST.dfa.accepts([{VOCAB[k]} for k in seq]):
            total -= weight
        best = max(best, total)
    return best


def test_soft_decoding_moves_from_argmax_to_constrained_at_the_score_gap() -> None:
    # the model is sure the cook comes first: argmax cook, rinse, wait breaks "rinse first"
    lp = log_probs([[0.2, 0.7, 0.1], [0.6, 0.3, 0.1], [0.1, 0.2, 0.7]])
    argmax = lp.argmax(-1)
    hard = constrained_decode(lp, RINSE_FIRST)
    assert argmax.tolist() == [[1, 0, 2]] and not torch.equal(hard, argmax)
    gap = float((lp[0].gather(1, argmax.T) - lp[0].gather(1, hard.T)).sum())
    assert gap > 0
    assert torch.equal(soft_decode(lp, RINSE_FIRST, 0.0), argmax)
    assert torch.equal(soft_decode(lp, RINSE_FIRST, gap * 0.9), argmax)
    assert torch.equal(soft_decode(lp, RINSE_FIRST, gap * 1.1), hard)
    assert torch.equal(soft_decode(lp, RINSE_FIRST, 1e9), hard)
    assert torch.equal(soft_decode(lp, RINSE_FIRST, math.inf), hard)


def test_soft_decoding_keeps_an_argmax_that_keeps_the_rules() -> None:
    lp = log_probs([[0.7, 0.2, 0.1], [0.3, 0.6, 0.1], [0.1, 0.2, 0.7]])
    for weight in (0.0, 1.0, math.inf):
        assert torch.equal(soft_decode(lp, RINSE_FIRST, weight), lp.argmax(-1))


@pytest.mark.parametrize("seed", range(6))
def test_soft_decoding_is_the_best_sequence_under_the_weighted_prior(seed: int) -> None:
    generator = torch.Generator().manual_seed(seed)
    lp = torch.randn(3, 4, 3, generator=generator).log_softmax(-1)
    lengths = torch.tensor([4, 3, 2])
    for weight in (0.0, 0.3, 1.0, 3.0, 100.0):
        out = soft_decode(lp, RINSE_FIRST, weight, lengths)
        for b, n in enumerate(lengths.tolist()):
            seq = out[b, :n].tolist()
            assert (out[b, n:] == -1).all()
            total = float(sum(lp[b, t, k] for t, k in enumerate(seq)))
            if not RINSE_FIRST.dfa.accepts([{VOCAB[k]} for k in seq]):
                total -= weight
            assert total == pytest.approx(penalised_best(lp[b, :n], weight), abs=1e-5)


def test_soft_choice_leaves_padding() -> None:
    lp = log_probs([[0.2, 0.7, 0.1], [0.6, 0.3, 0.1]])
    hard = torch.tensor([[0, 1]])
    padded = torch.tensor([[0, -1]])
    assert soft_choice(lp, padded, 0.0).tolist() == [[1, -1]]
    assert soft_choice(lp, hard, math.inf).tolist() == [[0, 1]]


def test_soft_pairs_spans_argmax_and_constrained_pair_decoding(tmp_path) -> None:
    kb_path = tmp_path / "kb.ltl"
    kb_path.write_text("ordering.r.before.s1.s2: (!s2_r U s1_r) | G !s2_r\n")
    vocabulary = pair_vocabulary(("s1", "s2", "s3"), ("q", "r"))
    rules = KnowledgeRuleSets(read_knowledge_base(kb_path), vocabulary)
    s1, s2, s3 = (vocabulary.index(f"{a}_r") for a in ("s1", "s2", "s3"))
    generator = torch.Generator().manual_seed(0)
    log_pairs = torch.randn(2, 3, len(vocabulary), generator=generator)
    # video 0: s2 then s1 (out of order, by a clear margin); video 1: by the book
    for b, order in enumerate(([s2, s1, s3], [s1, s2, s3])):
        for t, k in enumerate(order):
            log_pairs[b, t, k] += 6.0
    log_pairs = log_pairs.log_softmax(-1)
    lengths = torch.tensor([3, 3])
    hard, _ = decode_pairs(log_pairs, lengths, rules, top_k=5)
    out = soft_pairs(log_pairs, lengths, rules, 5, (0.0, 1e-3, math.inf))
    assert torch.equal(out[0.0], log_pairs.argmax(-1))
    assert torch.equal(out[math.inf], hard)
    assert out[0.0][0].tolist() == [s2, s1, s3] and hard[0].tolist() != [s2, s1, s3]
    assert out[0.0][1].tolist() == hard[1].tolist() == [s1, s2, s3]
    assert out[1e-3][0].tolist() == [s2, s1, s3]  # a small prior keeps the sure order
