"""Monitor features of soft traces, differentiable (logic/monitors.py gives crisp words').

A soft trace is a distribution P_t over letters at each step, steps independent. A monitor reads
each letter as its class c = p + 2 q (logic.monitors), so step t moves it with the expected
transition Σ_c P_t(class c) · step_c, and its state distribution after the last letter gives the
probability that it accepts the trace — exactly ψ(w) when every P_t is one-hot, and
differentiable in P throughout. Laid out as a trace's crisp features are: these, then zeros
(a trace has no rejected words).

Every (trace, monitor) pair whose atoms the trace's alphabet has moves together, the others
being 0: the letters' classes are one batched matrix product ([N, T, L] by [N, L, M·4]), and
each step is one product of class and state probabilities over the pairs' state slots ([4,
slots]: each pair holds only the states its monitor uses) and one index-add of it into the next
states (a monitor's move on a class is a table: state s goes to one state u); the Python loop
runs over the T steps only.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import torch

from tleaf_cli.logic.monitors import MonitorBank


def monitor_classes(bank: MonitorBank, truth: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
    """[M, letters] each monitor's class of each letter, and [M] whether its atoms exist, for an
    alphabet with atom truth table `truth` [letters, atoms]."""
    classes, present = bank.classes(truth)
    # copies, on the CPU: the bank's arrays are read-only
    return torch.tensor(classes, device="cpu"), torch.tensor(present, device="cpu")


def class_weights(classes: torch.Tensor, dtype: torch.dtype) -> torch.Tensor:
    """[..., L, M·4]: 1 where letter l is of class c for monitor m (column m·4 + c), from classes
    [..., M, L]; a soft trace's class probabilities are then `probs @ class_weights`."""
    onehot = torch.nn.functional.one_hot(classes.long(), 4).to(dtype)  # [..., M, L, 4]
    return onehot.transpose(-3, -2).flatten(-2)


def soft_monitor_features(
    bank: MonitorBank,
    probs: torch.Tensor,
    lengths: torch.Tensor,
    classes: torch.Tensor,
    present: torch.Tensor,
) -> torch.Tensor:
    """[N, 2 R F] for soft traces `probs` [N, T, letters] (rows past `lengths` [N] ignored), trace n
    read with `classes` [N, M, letters] and `present` [N, M] (`monitor_classes` of its
    alphabet, padded letters with any class: their probability is 0)."""
    weights = class_weights(classes.to(probs.device), probs.dtype)
    return soft_monitor_features_weighted(bank, probs, lengths, weights, present)


def soft_monitor_features_weighted(
    bank: MonitorBank,
    probs: torch.Tensor,
    lengths: torch.Tensor,
    weights: torch.Tensor,
    present: torch.Tensor,
) -> torch.Tensor:
    """`soft_monitor_features` with each trace's classes given as `class_weights` [N, L, M·4]
    (what a caller that reads the same alphabets again keeps, instead of the classes).

    Only the (trace, monitor) pairs whose atoms the trace's alphabet has are run: the others'
    features are 0 whatever the trace (a rule set of k atoms fills 7 k + 18 k (k − 1) of the
    bank's monitors, a seventh of a 10-slot bank's at k = 4)."""
    device, dtype = probs.device, probs.dtype
    n, steps, _ = probs.shape
    m = bank.width
    lengths = lengths.to(device)
    trace, monitor = present.to(device).bool().nonzero(as_tuple=True)  # the P pairs run
    slots = _Slots.of(bank, monitor)
    # [T, 4, slots]: each step's class probabilities per state slot (one product per trace for
    # all its monitors, then each pair's value on each of its slots), slots innermost so that
    # every elementwise product below runs over one long contiguous row
    per_class = torch.bmm(probs, weights.to(device, dtype)).view(n, steps, m, 4)
    per_class = per_class[trace, :, monitor].permute(1, 2, 0)[:, :, slots.pair]
    state = (slots.state == 0).to(dtype)  # every monitor starts in its state 0
    running = (torch.arange(steps, device=device)[:, None] < lengths[trace])[:, slots.pair]
    # unbound once: indexing step t inside the loop would give a full-size gradient per step
    for t, step in enumerate(per_class.unbind(0)):
        mass = step * state[None, :]  # [4, slots]
        moved = torch.zeros_like(state).index_add(0, slots.targets, mass.flatten())
        state = torch.where(running[t], moved, state)
    per_pair = state.new_zeros(len(trace)).index_add(0, slots.pair, state * slots.accepting)
    accepted = torch.zeros((n, m), dtype=dtype, device=device).index_put((trace, monitor), per_pair)
    # in the trace's length range (logic.monitors.MonitorBank.range_of), the others 0
    ranges = ((lengths - 1) * bank.ranges // bank.max_length).clamp(max=bank.ranges - 1)
    at_range = torch.nn.functional.one_hot(ranges, bank.ranges).to(dtype)
    placed = (at_range[:, :, None] * accepted[:, None, :]).flatten(1)
    return torch.cat([placed, torch.zeros_like(placed)], dim=1)


class _Slots(NamedTuple):
    """The state slots of P (trace, monitor) pairs laid end to end, each pair with as many as
    its monitor uses (`MonitorBank.sizes`: 2 or 3 for most, not the 5 the bank pads to)."""

    pair: torch.Tensor  # [slots] the pair a slot belongs to
    state: torch.Tensor  # [slots] the monitor state it holds
    targets: torch.Tensor  # [4 · slots] where the mass of (class c, slot) goes, c-major
    accepting: torch.Tensor  # [slots] float, 1 where the state accepts

    @classmethod
    def of(cls, bank: MonitorBank, monitor: torch.Tensor) -> _Slots:
        device = monitor.device
        sizes = torch.as_tensor(bank.sizes, device=device)[monitor]
        start = torch.cumsum(sizes, 0) - sizes
        pair = torch.repeat_interleave(torch.arange(len(monitor), device=device), sizes)
        state = torch.arange(len(pair), device=device) - start[pair]
        table = torch.as_tensor(bank.tables, device=device)  # [M, S, 4]
        moved_to = table[monitor[pair], state]  # [slots, 4]: the next state on each class
        targets = (start[pair][:, None] + moved_to).t().flatten()
        accepting = torch.as_tensor(bank.accepting, device=device)[monitor[pair], state]
        return cls(pair, state, targets, accepting.float())
