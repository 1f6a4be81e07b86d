"""The exact loss's forward algorithm in fewer operators (gathers by index_select, the scatters
out of place from constants made once) gives the values and gradients of the implementation
it replaced, kept here, to the bit."""

from __future__ import annotations

import torch

import tleaf_cli as tl
from tleaf_cli.losses.exact import _arcs, exact_loss
from tleaf_cli.losses.packed import NEG, letter_log_probs, pack_rows


def reference_exact_loss(letters, lengths, packed, rows):
    """exact_loss as it was: indexing, and the scatters' starting tensors made every step."""
    n, _, width = letters.shape
    arcs = _arcs([packed.rule_sets[j] for j in rows.tolist()], width)
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


def test_exact_loss_is_the_indexing_implementation_to_the_bit():
    vocabulary = ["a", "b", "c", "d"]
    texts = ["G(a -> F(b))", "F(c) & G(!d)", "a U b", "G(a -> X(c))"]
    rules = [tl.RuleSet(text, vocabulary) for text in texts]
    chosen = [rules[i % len(rules)] for i in range(7)]
    packed, rows = pack_rows(chosen, len(vocabulary), torch.device("cpu"))
    lengths = torch.tensor([9, 5, 7, 9, 1, 3, 8])
    logits = torch.randn(7, 9, 4, generator=torch.Generator().manual_seed(0), requires_grad=True)
    out = []
    for loss in (exact_loss, reference_exact_loss):
        letters = letter_log_probs(torch.log_softmax(logits, -1), packed, rows)
        value = loss(letters, lengths, packed, rows)
        (grad,) = torch.autograd.grad(value.sum(), logits)
        out.append((value, grad))
    (got, got_grad), (want, want_grad) = out
    assert torch.isfinite(got).all() and got.abs().sum() > 0 and got_grad.abs().sum() > 0
    assert torch.equal(got, want)
    assert torch.equal(got_grad, want_grad)
