"""The exact loss's forward algorithm in fewer operators (gathers by index_select, the scatters
out of place from constants made once) and over fewer arcs (none into dead states, letters
alike as one class) gives the values and gradients of the implementation it replaced, kept
here: every (state, letter) arc, indexing, the scatters' starting tensors made every step."""

from __future__ import annotations

import numpy as np
import torch

import tleaf_cli as tl
from tleaf_cli.losses.exact import _arcs, exact_loss
from tleaf_cli.losses.packed import NEG, letter_log_probs, pack_rows


def reference_arcs(rule_sets, width):
    """Every (state, letter) arc of the rows' DFAs end to end, as `_arcs` was."""
    parts = []
    for r in rule_sets:
        table = r.dfa.table.astype(np.int64)
        source, letter = np.indices(table.shape).reshape(2, -1)
        parts.append((source, letter, table.ravel(), r.dfa.accepting.copy(), r.dfa.initial))
    sizes = np.array([len(p[3]) for p in parts], dtype=np.int64)
    offset = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    arcs = np.array([len(p[0]) for p in parts], dtype=np.int64)
    state_shift = np.repeat(offset, arcs)
    letter_shift = np.repeat(np.arange(len(parts), dtype=np.int64) * width, arcs)
    return (
        np.concatenate([p[0] for p in parts]) + state_shift,
        np.concatenate([p[1] for p in parts]) + letter_shift,
        np.concatenate([p[2] for p in parts]) + state_shift,
        np.repeat(np.arange(len(parts), dtype=np.int64), sizes),
        np.concatenate([p[3] for p in parts]),
        offset + np.array([p[4] for p in parts], dtype=np.int64),
    )


def reference_exact_loss(letters, lengths, packed, rows):
    """exact_loss as it was: every arc, indexing, the scatters' starting tensors every step."""
    n, _, width = letters.shape
    arcs = reference_arcs([packed.rule_sets[j] for j in rows.tolist()], width)
    source, letter, target, row_of, accepting, initial = (torch.as_tensor(a) for a in arcs)
    states = len(row_of)
    alpha = letters.new_full((states,), NEG).index_fill(0, initial, 0.0)
    steps = int(lengths.max())
    running = torch.arange(steps)[:, None] < lengths[row_of]
    on_arcs = letters[:, :steps].transpose(0, 1).flatten(1)[:, letter]
    for t, at_t in enumerate(on_arcs.unbind(0)):
        terms = alpha[source] + at_t
        top = letters.new_full((states,), NEG).scatter_reduce(0, target, terms.detach(), "amax")
        sums = letters.new_zeros(states).scatter_add(0, target, (terms - top[target]).exp())
        step = top + sums.clamp(min=1.0).log()
        alpha = torch.where(running[t], step, alpha)
    final = torch.where(accepting, alpha, letters.new_tensor(NEG))
    top = letters.new_full((n,), NEG).scatter_reduce(0, row_of, final.detach(), "amax")
    total = letters.new_zeros(n).scatter_add(0, row_of, (final - top[row_of]).exp())
    return -(top + total.log())


def test_exact_loss_is_the_implementation_it_replaced():
    vocabulary = ["a", "b", "c", "d"]
    # dead states (G(!d), a U b), letters alike (a and b in the last two), and neither
    texts = ["G(a -> F(b))", "F(c) & G(!d)", "a U b", "G(a -> X(c))", "G((a | b) -> F(c))",
             "F(a | b) & G(!d)"]  # fmt: skip
    rules = [tl.RuleSet(text, vocabulary) for text in texts]
    chosen = [rules[i % len(rules)] for i in range(9)]
    packed, rows = pack_rows(chosen, len(vocabulary), torch.device("cpu"))
    lengths = torch.tensor([9, 5, 7, 9, 1, 3, 8, 6, 9])
    logits = torch.randn(9, 9, 4, generator=torch.Generator().manual_seed(0), requires_grad=True)
    out = []
    for loss in (exact_loss, reference_exact_loss):
        letters = letter_log_probs(torch.log_softmax(logits, -1), packed, rows)
        value = loss(letters, lengths, packed, rows)
        (grad,) = torch.autograd.grad(value.sum(), logits)
        out.append((value, grad))
    (got, got_grad), (want, want_grad) = out
    assert torch.isfinite(got).all() and got.abs().sum() > 0 and got_grad.abs().sum() > 0
    torch.testing.assert_close(got, want, rtol=1e-5, atol=1e-6)
    torch.testing.assert_close(got_grad, want_grad, rtol=1e-5, atol=1e-6)
    # fewer arcs than (state, letter) pairs, and some letters share a class
    mine, full = _arcs(chosen, 5), reference_arcs(chosen, 5)
    assert len(mine[0]) < len(full[0])
    assert mine[-1].max() + 1 < len(mine[-1])


def test_a_formula_no_word_satisfies_costs_the_same_as_before():
    """No live state at all (φ unsatisfiable): no arcs, the loss −log 0 as before."""
    rule = tl.RuleSet("G(a) & F(!a)", ["a", "b"])
    packed, rows = pack_rows([rule], 2, torch.device("cpu"))
    logits = torch.randn(1, 4, 2, generator=torch.Generator().manual_seed(1))
    letters = letter_log_probs(torch.log_softmax(logits, -1), packed, rows)
    lengths = torch.tensor([4])
    got = exact_loss(letters, lengths, packed, rows)
    assert len(_arcs([rule], 3)[0]) == 0
    assert torch.equal(got, reference_exact_loss(letters, lengths, packed, rows))
