"""The logic losses of tleaf_cli/losses.py, batched over one ingredient set's rule sets.

GAIL's logic term (logic_term.py) scores every minibatch: a few rollout episodes against the
rule sets of their ingredients, 16 times per rollout. losses.exact_loss and losses.tleaf_loss
rebuild their per-video tensors (letter indices, padded transition tables, trace graphs) at every
call, one Python loop iteration per video; on Creative Cooking that bookkeeping, not the
arithmetic, was most of a run's time. Here the same quantities are computed from tensors built
once per ingredient set (`PackedRules`), for all (episode, rule set) rows at once:

* letter log-probabilities: column 0 = log Σ_{actions outside φ's atoms} π(a|s_t), column k+1 =
  log π(atoms[k]|s_t), exactly as `losses.letter_log_probs` (a log-sum, not 1 − Σ);
* exact: −log P(w ⊨ φ) by the forward algorithm, written as a product of the per-step transition
  matrices M_t[s, s'] = Σ_{l: δ(s, l) = s'} P_t(l), multiplied pairwise in a tree (log₂ T batched
  matrix products instead of T sequential steps), in float64 probabilities: each M_t is
  row-stochastic (a complete DFA), so the products cannot overflow, and float64 keeps
  P(accept) > 0 far below float32's range (it is clamped at 1e-300, −log = 690.8);
* tleaf: ‖q(A_φ) − q(w̃)‖², every row's soft trace through q_m at once
  (`embed.soft.soft_trace_vectors`), q(A_φ) and q_e of the letters taken from the RuleSets cache
  once per ingredient set.

The results equal losses.exact_loss / losses.tleaf_loss row by row (tested, values and gradients).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import torch

from tleaf_cli.losses_old import NEG, RuleSet, RuleSets

TINY = 1e-300  # P(accept) floor of the float64 forward algorithm (−log = 690.8)


@dataclass(frozen=True)
class PackedRules:
    """Rule sets r = 0..R−1 over the same action ids, padded to K atoms, L = K + 1 letters and S
    states. `slots[r]` is the episode slot (1..5) whose ingredient rule set r belongs to."""

    slots: tuple[int, ...]
    atoms: torch.Tensor  # long [R, K]: action id of letter k+1 (0 where padded)
    padded: torch.Tensor  # bool [R, K]: letter k+1 does not exist
    outside: torch.Tensor  # float [R, A]: 0 for actions outside φ_r's atoms, NEG for its atoms
    moves: torch.Tensor  # float64 [R, L, S, S]: 1 where δ_r(s, l) = s'
    initial: torch.Tensor  # long [R]
    accepting: torch.Tensor  # float64 [R, S]
    letter_vectors: torch.Tensor | None  # float [R, L, d_e]: q_e of each letter (tleaf)
    targets: torch.Tensor | None  # float [R, d]: q(A_φr) (tleaf)


def pack_rules(
    sets: Sequence[RuleSet], slots: Sequence[int], num_actions: int, cache: RuleSets | None
) -> PackedRules:
    """Pad `sets` (satisfiable rule sets over action ids) into tensors; with `cache` holding an
    embedder, also their q_e letter vectors and q(A_φ) (for tleaf)."""
    k = max(len(r.pairs) for r in sets)
    states = max(r.dfa.num_states for r in sets)
    n = len(sets)
    atoms = torch.zeros((n, k), dtype=torch.long)
    padded = torch.ones((n, k), dtype=torch.bool)
    outside = torch.zeros((n, num_actions))
    moves = torch.zeros((n, k + 1, states, states), dtype=torch.float64)
    accepting = torch.zeros((n, states), dtype=torch.float64)
    for j, r in enumerate(sets):
        size = len(r.pairs)
        atoms[j, :size], padded[j, :size] = r.pairs, False
        outside[j, r.pairs] = NEG
        table = torch.as_tensor(r.dfa.table, dtype=torch.long)  # [states, letters]
        s = r.dfa.num_states
        for letter in range(size + 1):
            moves[j, letter, torch.arange(s), table[:, letter]] = 1.0
        accepting[j, :s] = torch.as_tensor(r.dfa.accepting, dtype=torch.float64)
    initial = torch.tensor([r.dfa.initial for r in sets], dtype=torch.long)
    letter_vectors = targets = None
    if cache is not None and cache.embedder is not None:
        cache.embed(list(sets))
        first = cache.letter_vectors(sets[0])
        letter_vectors = first.new_zeros((n, k + 1, first.shape[1]))
        for j, r in enumerate(sets):
            letter_vectors[j, : len(r.pairs) + 1] = cache.letter_vectors(r)
        targets = torch.stack([cache.formula_vector(r) for r in sets])
    return PackedRules(
        tuple(slots), atoms, padded, outside, moves, initial, accepting, letter_vectors, targets
    )


def letter_log_probs(log_policy: torch.Tensor, rules: PackedRules, rows: torch.Tensor):
    """[N, T, L] letter log-probabilities of episodes' action log-probs `log_policy` [N, T, A]
    against rule sets `rows` [N] (indices into `rules`); padded letters get NEG."""
    outside = torch.logsumexp(log_policy + rules.outside[rows, None, :], dim=-1, keepdim=True)
    index = rules.atoms[rows, None, :].expand(-1, log_policy.shape[1], -1)
    inside = torch.gather(log_policy, 2, index)
    inside = inside.masked_fill(rules.padded[rows, None, :], NEG)
    return torch.cat([outside, inside], dim=-1)


def exact_losses(
    letters: torch.Tensor, lengths: torch.Tensor, rules: PackedRules, rows: torch.Tensor
) -> torch.Tensor:
    """−log P(w ⊨ φ) [N] for letter log-probs [N, T, L] (steps ≥ lengths[i] ignored)."""
    n, steps, _ = letters.shape
    states = rules.moves.shape[-1]
    p = letters.double().exp()
    matrices = torch.einsum("ntl,nlsr->ntsr", p, rules.moves[rows])  # [N, T, S, S]
    eye = torch.eye(states, dtype=matrices.dtype).expand(n, steps, states, states)
    beyond = torch.arange(steps)[None, :] >= lengths[:, None]
    matrices = torch.where(beyond[..., None, None], eye, matrices)
    while matrices.shape[1] > 1:  # M_1 M_2 ... M_T, multiplied pairwise
        if matrices.shape[1] % 2:
            matrices = torch.cat([matrices, eye[:, :1]], dim=1)
        matrices = matrices[:, 0::2] @ matrices[:, 1::2]
    start = matrices[torch.arange(n), 0, rules.initial[rows]]  # [N, S]: state after T steps
    accept = (start * rules.accepting[rows]).sum(dim=1)
    return -torch.log(accept.clamp(min=TINY)).to(letters.dtype)


def expected_letter_vectors(
    letters: torch.Tensor, rules: PackedRules, rows: torch.Tensor
) -> torch.Tensor:
    """[N, T, d_e]: Σ_l P_t(l) q_e(l), the edge-node vectors of the soft traces w̃."""
    return letters.exp() @ rules.letter_vectors[rows]
