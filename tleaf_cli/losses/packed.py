"""Rule sets as padded tensors, and a model's per-step letter log-probabilities under them.

Several rule sets (each a DFA over the one-hot alphabet of its atoms, a
`tleaf_cli.rule_set.RuleSet`) are padded to K atoms, L = K + 1 letters and S states so that one
tensor operation serves every (sequence, rule set) row of a batch. A row's letter distribution
at step t, from the model's log-probabilities over the vocabulary `log_probs[t]` [V]:

    log P_t(letter k+1) = log_probs[t, index[k]]
    log P_t(letter 0)   = log Σ_{v ∉ index} exp(log_probs[t, v])

(letter 0 as a log-sum of the other items, not as 1 − Σ, which loses every digit when the atoms
hold almost all the mass). Padded letters get log-probability NEG.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import torch

from tleaf_cli import arguments
from tleaf_cli.errors import ArgumentError
from tleaf_cli.rule_set import RuleSet, common_vocabulary

NEG = -1e30  # log of "impossible": finite, so logsumexp and its gradient stay defined


@dataclass(frozen=True)
class PackedRuleSets:
    """Rule sets r = 0..R−1 as tensors over a vocabulary of V items (one device).

    `targets[r, s, l]` is δ_r(s, l), with padded states and letters leading to the sink state S.
    """

    rule_sets: tuple[RuleSet, ...]
    atoms: torch.Tensor  # long [R, K]: vocabulary index of letter k+1 (0 where padded)
    padded: torch.Tensor  # bool [R, K]: letter k+1 does not exist
    inside: torch.Tensor  # bool [R, V]: the vocabulary items that are one of φ_r's atoms
    targets: torch.Tensor  # long [R, S, L]
    initial: torch.Tensor  # long [R]
    accepting: torch.Tensor  # bool [R, S]

    @property
    def num_states(self) -> int:
        return int(self.targets.shape[1])

    @property
    def num_letters(self) -> int:
        return int(self.targets.shape[2])


def rules_per_sequence(
    log_probs: torch.Tensor,
    rules: RuleSet | Sequence[RuleSet | None],
    lengths: torch.Tensor | Sequence[int] | None,
    per_sequence_vocabulary: bool = False,
) -> tuple[torch.Tensor, list[RuleSet | None], torch.Tensor]:
    """The public losses' and decoder's arguments, checked once per call (tleaf_cli/arguments.py):
    `log_probs` [B, T, V] as float32 where it was float16 / bfloat16, one rule set (or None) per
    sequence — `rules` is one for all or one per sequence, all over one vocabulary of V items
    (`rule_set.common_vocabulary`), or with `per_sequence_vocabulary` each over its own — and
    the lengths [B] (default: all T steps) on log_probs' device. ArgumentError (or
    ArgumentTypeError) for what does not fit."""
    log_probs = arguments.log_probs(log_probs)
    batch, steps, vocabulary = log_probs.shape
    per_sequence = arguments.rule_sets(rules, batch, RuleSet)
    distinct = {id(r): r for r in per_sequence if r is not None}.values()
    if not per_sequence_vocabulary:
        common_vocabulary(distinct)  # one vocabulary, item by item, as tl.Shield's
    for r in distinct:
        if len(r.vocabulary) != vocabulary:
            raise ArgumentError(
                "rules",
                f"rule set {r.name} has a vocabulary of {len(r.vocabulary)} items, but "
                f"log_probs has V = {vocabulary}",
            )
    lengths = arguments.lengths(lengths, batch, steps, log_probs.device)
    return log_probs, per_sequence, lengths


def pack_rows(
    rule_sets: Sequence[RuleSet], vocabulary_size: int, device: torch.device
) -> tuple[PackedRuleSets, torch.Tensor]:
    """The distinct rule sets among rows `rule_sets`, packed, and each row's index into them."""
    distinct = list({id(r): r for r in rule_sets}.values())
    position = {id(r): k for k, r in enumerate(distinct)}
    index = torch.tensor([position[id(r)] for r in rule_sets], device=device)
    return pack(distinct, vocabulary_size, device), index


def pack(
    rule_sets: Sequence[RuleSet], vocabulary_size: int, device: torch.device
) -> PackedRuleSets:
    """`rule_sets` (distinct objects) padded into tensors on `device`; recent packs are reused."""
    return _pack(tuple(rule_sets), vocabulary_size, str(device))


@lru_cache(maxsize=256)
def _pack(rule_sets: tuple[RuleSet, ...], vocabulary_size: int, device: str) -> PackedRuleSets:
    n = len(rule_sets)
    k = max(len(r.index) for r in rule_sets)
    states = max(r.dfa.num_states for r in rule_sets)
    atoms = np.zeros((n, k), dtype=np.int64)
    padded = np.ones((n, k), dtype=bool)
    inside = np.zeros((n, vocabulary_size), dtype=bool)
    targets = np.full((n, states, k + 1), states, dtype=np.int64)
    accepting = np.zeros((n, states), dtype=bool)
    for j, r in enumerate(rule_sets):
        size, s = len(r.index), r.dfa.num_states
        atoms[j, :size], padded[j, :size] = r.index, False
        inside[j, r.index] = True
        targets[j, :s, : size + 1] = r.dfa.table
        accepting[j, :s] = r.dfa.accepting
    initial = np.array([r.dfa.initial for r in rule_sets], dtype=np.int64)
    return PackedRuleSets(
        rule_sets,
        *(
            torch.as_tensor(a, device=device)
            for a in (atoms, padded, inside, targets, initial, accepting)
        ),
    )


def letter_log_probs(
    log_probs: torch.Tensor, packed: PackedRuleSets, rows: torch.Tensor
) -> torch.Tensor:
    """[N, T, L] letter log-probabilities of sequences `log_probs` [N, T, V] under rule sets
    `rows` [N] (indices into `packed`); padded letters NEG."""
    others = log_probs.masked_fill(packed.inside[rows, None, :], NEG)
    none = torch.logsumexp(others, dim=-1, keepdim=True)
    index = packed.atoms[rows, None, :].expand(-1, log_probs.shape[1], -1)
    atoms = torch.gather(log_probs, 2, index).masked_fill(packed.padded[rows, None, :], NEG)
    return torch.cat([none, atoms], dim=-1)
