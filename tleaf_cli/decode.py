"""Constrained decoding: the most probable sequence that satisfies the rules.

A model's per-step log-probabilities over a one-hot vocabulary (`log_probs` [B, T, V]) score a
sequence v_1..v_T by Σ_t log_probs[t, v_t]; argmax decoding picks each step's best item and may
break the rules. `constrained_decode` picks, per sequence, the highest-scoring sequence the rule
set's DFA accepts — a Viterbi pass over steps × DFA states:

    δ_0(s) = 0 if s is initial else −∞,
    δ_t(s') = max_{(s, l): δ(s, l) = s'} δ_{t−1}(s) + score_t(l),
    best = max_{s ∈ F} δ_T(s), then back along the maximising (s, l).

Letters are the rule set's (letter k+1 = atom k, letter 0 = every other item), so a step has
L = k + 1 choices, not V: letter 0's score is the best other item's log-probability and it
decodes to that item. The pass is batched over sequences and rule sets as tensors (the padded
tables of `losses.packed`); the Python loop runs over steps only. Ties go to the smallest
(state, letter) index, so decoding is deterministic.

What it guarantees: the output is accepted by each sequence's rule set, and no accepted
sequence scores higher. What it does not: rules not given are not enforced, and a wrong rule
set gives confidently wrong outputs (docs/decoding.md). `soft_decode` uses the rules as a
weighted prior instead (score − weight · [breaks them]), between argmax (weight 0) and
constrained decoding (a large weight), for sequences that people perform against the rules.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch

from tleaf_cli.errors import RulesError
from tleaf_cli.losses.packed import PackedRuleSets, pack_rows, rules_per_sequence
from tleaf_cli.rule_set import RuleSet


def constrained_decode(
    log_probs: torch.Tensor,
    rules: RuleSet | Sequence[RuleSet | None],
    lengths: torch.Tensor | None = None,
    *,
    per_sequence_vocabulary: bool = False,
) -> torch.Tensor:
    """Per sequence, the vocabulary indices [B, T] of the most probable sequence its rules
    accept (argmax where its rules are None; −1 past a length).

    Args:
        log_probs: float [B, T, V], per-step log-probabilities (or any per-step scores).
        rules: one RuleSet for every sequence, or a list of B RuleSets (None: no rules).
        lengths: long [B]; default: all T steps.
        per_sequence_vocabulary: the rule sets are over one vocabulary, item by item (else
            ArgumentError); True where each sequence names its items by its own rule set's.

    Raises RulesError naming the sequence when no sequence of its length meets its rules, and
    InputError for shapes or rule sets that do not fit `log_probs`.
    """
    log_probs, per_sequence, lengths = rules_per_sequence(
        log_probs, rules, lengths, per_sequence_vocabulary
    )
    _, steps, vocabulary = log_probs.shape
    device = log_probs.device
    with torch.no_grad():
        scores = log_probs.detach().float()
        out = scores.argmax(dim=-1)
        rows = [b for b, r in enumerate(per_sequence) if r is not None]
        if rows:
            chosen = [per_sequence[b] for b in rows]
            packed, index = pack_rows(chosen, vocabulary, device)
            which = torch.tensor(rows, device=device)
            out[which] = _viterbi(scores[which], lengths[which], packed, index, chosen, rows)
        past = torch.arange(steps, device=device)[None, :] >= lengths[:, None]
        return out.masked_fill(past, -1)


def _viterbi(
    scores: torch.Tensor,
    lengths: torch.Tensor,
    packed: PackedRuleSets,
    index: torch.Tensor,
    rule_sets: Sequence[RuleSet],
    owners: Sequence[int],
) -> torch.Tensor:
    """[N, T] best accepted item sequences of `scores` [N, T, V] under rule sets `index` [N]."""
    n, steps, _ = scores.shape
    device = scores.device
    states, letters = packed.num_states, packed.num_letters
    # each letter's best item and score: letter 0 the best item outside φ's atoms
    others = scores.masked_fill(packed.inside[index, None, :], float("-inf"))
    other_score, other_item = others.max(dim=-1)  # [N, T]
    atoms = packed.atoms[index, None, :].expand(-1, steps, -1)  # [N, T, K]
    atom_score = torch.gather(scores, 2, atoms).masked_fill(
        packed.padded[index, None, :], float("-inf")
    )
    letter_score = torch.cat([other_score[..., None], atom_score], dim=-1)  # [N, T, L]
    letter_item = torch.cat([other_item[..., None], atoms], dim=-1)

    targets = packed.targets[index].flatten(1)  # [N, S·L]: δ(s, l), sink S for padding
    flat = torch.arange(states * letters, device=device).expand(n, -1)
    delta = scores.new_full((n, states), float("-inf"))
    delta[torch.arange(n, device=device), packed.initial[index]] = 0.0
    back = []  # per step, [N, S]: the flat (s, l) each state was best reached by
    for t in range(int(lengths.max())):
        terms = (delta[:, :, None] + letter_score[:, t, None, :]).flatten(1)  # [N, S·L]
        top = scores.new_full((n, states + 1), float("-inf"))
        top = top.scatter_reduce(1, targets, terms, "amax")
        hit = terms == top.gather(1, targets)
        first = torch.full((n, states + 1), states * letters, device=device)
        first = first.scatter_reduce(1, targets, torch.where(hit, flat, states * letters), "amin")
        running = (t < lengths)[:, None]
        delta = torch.where(running, top[:, :states], delta)
        back.append(first[:, :states].clamp(max=states * letters - 1))

    final = delta.masked_fill(~packed.accepting[index], float("-inf"))
    best, state = final.max(dim=1)
    stuck = torch.nonzero(torch.isinf(best)).flatten().tolist()
    if stuck:
        i = stuck[0]
        raise RulesError(
            f"sequence {owners[i]}: no sequence of length {int(lengths[i])} satisfies rule set "
            f"{rule_sets[i].name} ({len(stuck)} such sequence(s) in the batch)"
        )
    out = torch.full((n, steps), -1, dtype=torch.long, device=device)
    rows = torch.arange(n, device=device)
    for t in range(len(back) - 1, -1, -1):
        running = t < lengths
        arc = back[t].gather(1, state[:, None]).squeeze(1)  # flat (s, l) into `state` at t
        letter = arc % letters
        out[:, t] = torch.where(running, letter_item[rows, t, letter], out[:, t])
        state = torch.where(running, arc // letters, state)
    return out


def sequence_scores(log_probs: torch.Tensor, items: torch.Tensor) -> torch.Tensor:
    """Σ_t log_probs[b, t, items[b, t]] per sequence [B], over the steps where items ≥ 0."""
    picked = log_probs.detach().float().gather(2, items.clamp(min=0)[..., None]).squeeze(-1)
    return picked.masked_fill(items < 0, 0.0).sum(dim=1)


def soft_choice(log_probs: torch.Tensor, hard: torch.Tensor, weight: float) -> torch.Tensor:
    """The rules as a weighted prior: per sequence, the sequence maximising
    Σ_t log p(v_t) − weight · [it breaks the rules], given `hard` [B, T] (−1 past a length), the
    best sequence that keeps them (`constrained_decode`'s).

    The best sequence that breaks them scores at most the argmax's, and is the argmax when the
    argmax breaks them; so the answer is the argmax when its score minus `weight` reaches the
    hard decoding's, else the hard decoding: weight 0 gives argmax decoding, a weight above
    every score gap gives constrained decoding, and a person who did a step out of order keeps
    it where the model is sure of it by more than `weight` (log-probability)."""
    argmax = log_probs.argmax(dim=-1).masked_fill(hard < 0, -1)
    keep = sequence_scores(log_probs, argmax) - weight >= sequence_scores(log_probs, hard)
    return torch.where(keep[:, None], argmax, hard)


def soft_decode(
    log_probs: torch.Tensor,
    rules: RuleSet | Sequence[RuleSet | None],
    weight: float,
    lengths: torch.Tensor | None = None,
    *,
    per_sequence_vocabulary: bool = False,
) -> torch.Tensor:
    """`soft_choice` between argmax and `constrained_decode` at `weight` (≥ 0)."""
    hard = constrained_decode(
        log_probs, rules, lengths, per_sequence_vocabulary=per_sequence_vocabulary
    )
    return soft_choice(log_probs, hard, weight)
