"""The exact logic loss: −log P(a sequence drawn from the model's outputs satisfies φ).

The model's outputs are independent across steps given its inputs, so the probability that a
sequence w drawn step by step from P_t satisfies φ is the forward algorithm over φ's DFA:

    α_0 = 1[initial],   α_t(s') = Σ_{(s, l): δ(s, l) = s'} α_{t−1}(s) · P_t(l),
    P(w ⊨ φ) = Σ_{s ∈ F} α_T(s).

Computed in log space: each step scatters the S·L terms log α(s) + log P_t(l) into their target
states as a log-sum-exp per state (O(S·L) per step, not the O(S·L·S) of a transition tensor:
whole-video rule sets reach hundreds of states). Log space keeps a sequence the model is sure
violates φ at a finite loss with a gradient, in float32, where a product of probabilities would
need float64 and a floor (1e-300, −log = 690.8) to stay finite.

The rows of a batch run together without padding: their states are laid end to end in one
vector and their (state, letter) arcs in one list, so a batch with one large rule set and many
small ones costs the arcs it has, not rows × the largest set's arcs. Two reductions keep the
arcs few without changing P(w ⊨ φ) (float rounding aside): arcs into a dead state (no accepting
state reachable from it) are left out, since nothing they carry reaches F; and letters that
lead every state to the same place are one **letter class**, whose arc reads the class's
log-probability (the log-sum-exp of its letters', computed for every step before the walk).
On rules mined from a real event log (11 parts of up to 505 states over 3–251 letters) that
is 76,728 arcs instead of 262,250.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import torch

from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.kept import Kept
from tleaf_cli.losses.packed import NEG, PackedRuleSets
from tleaf_cli.rule_set import RuleSet


def exact_loss(
    letters: torch.Tensor, lengths: torch.Tensor, packed: PackedRuleSets, rows: torch.Tensor
) -> torch.Tensor:
    """−log P(w ⊨ φ_rows[i]) [N] for letter log-probabilities [N, T, L] (`packed.
    letter_log_probs`); steps at or past lengths[i] are not read."""
    n, _, width = letters.shape
    if not n:
        return letters.new_zeros(0)
    arcs = _arcs([packed.rule_sets[j] for j in rows.tolist()], width)
    classes = int(arcs[-1].max()) + 1
    source, letter_class, target, row_of, accepting, initial, member, class_of = (
        torch.as_tensor(a, device=letters.device) for a in arcs
    )
    states = len(row_of)
    alpha = letters.new_full((states,), NEG).index_fill(0, initial, 0.0)
    steps = int(lengths.max())
    running = torch.arange(steps, device=letters.device)[:, None] < lengths[row_of]  # [T, states]
    # every step's class log-probabilities [T, classes] (a log-sum-exp over each class's
    # letters), then every step's arc terms in one gather [T, arcs], unbound once: indexing
    # step t in the loop would give a full-size gradient each
    on_letters = letters[:, :steps].transpose(0, 1).flatten(1).index_select(1, member)
    on_classes = _log_sum_by(on_letters, class_of, classes)
    on_arcs = on_classes.index_select(1, letter_class)
    # the scatters start from these (out of place: each step's result is a new tensor), and
    # gathers are index_select: the same values in fewer operators each way than indexing
    lowest, zeros = letters.new_full((states,), NEG), letters.new_zeros(states)
    for at_t, running_t in zip(on_arcs.unbind(0), running.unbind(0), strict=True):
        terms = alpha.index_select(0, source) + at_t  # [arcs]
        top = lowest.scatter_reduce(0, target, terms.detach(), "amax")
        spread = (terms - top.index_select(0, target)).exp()
        step = top + zeros.scatter_add(0, target, spread).clamp(min=1.0).log()  # reached: >= 1
        alpha = torch.where(running_t, step, alpha)
    final = torch.where(accepting, alpha, letters.new_tensor(NEG))
    return -_log_sum_by(final.unsqueeze(0), row_of, n).squeeze(0)


def _log_sum_by(values: torch.Tensor, group: torch.Tensor, groups: int) -> torch.Tensor:
    """[T, groups]: the log-sum-exp of the columns of `values` [T, M] in each group (`group`
    [M], every group non-empty); a one-column group is its column exactly. Each group's
    largest value is taken out first (detached: it cancels in the gradient), so the sum of
    exponentials is at least 1."""
    index = group.expand_as(values)
    top = values.new_full((values.shape[0], groups), NEG)
    top = top.scatter_reduce(1, index, values.detach(), "amax")
    spread = (values - top.gather(1, index)).exp()
    return top + values.new_zeros(top.shape).scatter_add(1, index, spread).log()


def _arcs(rule_sets: list[RuleSet], width: int) -> tuple[np.ndarray, ...]:
    """The rows' DFAs end to end: each arc's source state, letter class and target state;
    each state's row and acceptance; the rows' initial states; each class member's letter
    (flat index into a step's [rows, width] letters) and class. States and classes of row i
    are numbered from the sum of the earlier rows'."""
    parts = [_arcs_of(r) for r in rule_sets]
    sizes = np.array([len(p.accepting) for p in parts], dtype=np.int64)
    offset = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    classes = np.array([int(p.class_of.max()) + 1 for p in parts], dtype=np.int64)
    class_offset = np.concatenate([[0], np.cumsum(classes)[:-1]])
    arcs = np.array([len(p.source) for p in parts], dtype=np.int64)
    letters = np.array([len(p.class_of) for p in parts], dtype=np.int64)
    state_shift = np.repeat(offset, arcs)
    return (
        np.concatenate([p.source for p in parts]) + state_shift,
        np.concatenate([p.letter_class for p in parts]) + np.repeat(class_offset, arcs),
        np.concatenate([p.target for p in parts]) + state_shift,
        np.repeat(np.arange(len(parts), dtype=np.int64), sizes),
        np.concatenate([p.accepting for p in parts]),
        offset + np.array([p.initial for p in parts], dtype=np.int64),
        np.concatenate([np.arange(k) for k in letters])
        + np.repeat(np.arange(len(parts)) * width, letters),
        np.concatenate([p.class_of for p in parts]) + np.repeat(class_offset, letters),
    )


class _DFAArcs(NamedTuple):
    """One DFA's arcs for the forward algorithm: (source, letter class, target) for every state
    and class whose target is live; its accepting states and initial state; each letter's
    class (the classes numbered in order of their first letter)."""

    source: np.ndarray
    letter_class: np.ndarray
    target: np.ndarray
    accepting: np.ndarray
    initial: int
    class_of: np.ndarray


def _arcs_of(rule_set: RuleSet) -> _DFAArcs:
    """`_DFAArcs` of one rule set's DFA; built once per automaton (they never read the atoms'
    names: a trainer's rule sets from predictions repeat automata over other ingredients)."""
    key = rule_set.dfa.structure
    arcs = _ARCS.get(key)
    return arcs if arcs is not None else _ARCS.keep(key, _dfa_arcs(rule_set.dfa))


_ARCS = Kept(4096)  # `_dfa_arcs` per automaton (`DFA.structure`)


def _dfa_arcs(dfa: DFA) -> _DFAArcs:
    """`_DFAArcs` of a DFA."""
    table = dfa.table.astype(np.int64)  # [S, L]
    live = dfa.live()
    # letters alike: the same target from every state, a dead target counted as one
    seen = np.ascontiguousarray(np.where(live[table], table, -1).T)
    classes: dict[bytes, int] = {}  # a letter's targets -> its class, numbered in letter order
    class_of = np.fromiter(
        (classes.setdefault(row, len(classes)) for row in map(bytes, seen)), np.int64, len(seen)
    )
    representative = np.zeros(len(classes), dtype=np.int64)  # each class's first letter
    representative[class_of[::-1]] = np.arange(len(seen) - 1, -1, -1)
    source, letter_class = np.indices((len(table), len(representative))).reshape(2, -1)
    target = table[source, representative[letter_class]]
    keep = live[target]
    return _DFAArcs(
        source[keep], letter_class[keep], target[keep], dfa.accepting.copy(), dfa.initial, class_of
    )
