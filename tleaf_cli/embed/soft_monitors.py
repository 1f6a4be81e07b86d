"""Monitor features of soft traces, differentiable (logic/monitors.py gives crisp words').

A soft trace is a distribution P_t over letters at each step, steps independent. A monitor reads
each letter as its class c = p + 2 q (logic.monitors), so step t moves it with the expected
transition Σ_c P_t(class c) · step_c, and its state distribution after the last letter gives the
probability that it accepts the trace — exactly ψ(w) when every P_t is one-hot, and
differentiable in P throughout. Laid out as a trace's crisp features are: these, then zeros
(a trace has no rejected words).

Every trace of a batch and every monitor move together: the letters' classes are one batched
matrix product ([N, T, L] by [N, L, M·4]), and each step is one product of class and state
probabilities ([4, S, M·N]) and one index-add of it into the next states (a monitor's move on a
class is a table: state s goes to one state u); the Python loop runs over the T steps only.
"""

from __future__ import annotations

import numpy as np
import torch

from tleaf_cli.logic.monitors import STATES, MonitorBank


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
    (what a caller that reads the same alphabets again keeps, instead of the classes)."""
    device, dtype = probs.device, probs.dtype
    n, steps, _ = probs.shape
    m = bank.width
    lengths = lengths.to(device)
    # [T, 4, M·N]: each step's class probabilities, (monitor, trace) pairs innermost so that
    # every elementwise product below runs over long contiguous rows
    per_class = torch.bmm(probs, weights.to(device, dtype)).view(n, steps, m, 4)
    per_class = per_class.permute(1, 3, 2, 0).reshape(steps, 4, m * n)
    targets = _targets(bank, n, device)  # [4·S·M·N]: where each (class, state) mass goes
    state = torch.zeros((STATES, m * n), dtype=dtype, device=device)
    state[0] = 1.0
    running = (torch.arange(steps, device=device)[:, None] < lengths).repeat(1, m)  # [T, M·N]
    # unbound once: indexing step t inside the loop would give a full-size gradient per step
    for t, step in enumerate(per_class.unbind(0)):
        mass = step[:, None, :] * state[None, :, :]  # [4, S, M·N]
        moved = state.new_zeros(STATES * m * n).index_add(0, targets, mass.flatten())
        state = torch.where(running[t], moved.view(STATES, m * n), state)
    accepting = torch.as_tensor(bank.accepting.T, dtype=dtype, device=device)  # [S, M]
    accepted = (state.view(STATES, m, n) * accepting[:, :, None]).sum(dim=0).t()  # [N, M]
    accepted = accepted * present.to(device, dtype)
    # in the trace's length range (logic.monitors.MonitorBank.range_of), the others 0
    ranges = ((lengths - 1) * bank.ranges // bank.max_length).clamp(max=bank.ranges - 1)
    at_range = torch.nn.functional.one_hot(ranges, bank.ranges).to(dtype)
    placed = (at_range[:, :, None] * accepted[:, None, :]).flatten(1)
    return torch.cat([placed, torch.zeros_like(placed)], dim=1)


_TARGETS: dict[tuple[int, int, str], torch.Tensor] = {}


def _targets(bank: MonitorBank, traces: int, device: torch.device) -> torch.Tensor:
    """[4·S·M·N] long: for the mass of monitor m on trace n in state s reading class c (laid
    out [c, s, m, n]), its flat index (u, m, n) in the next state distribution [S, M·N], u =
    `bank.tables[m, s, c]`. Kept per (width, traces, device): the tables depend on the bank's
    slots only, and the width on the slots."""
    key = (bank.width, traces, str(device))
    if key not in _TARGETS:
        m = bank.width
        table = torch.as_tensor(bank.tables.transpose(2, 1, 0).copy(), device=device)  # [4, S, M]
        pair = torch.arange(m * traces, device=device).view(m, traces)  # (m, n) -> m·N + n
        _TARGETS[key] = (table[:, :, :, None] * (m * traces) + pair).flatten()
    return _TARGETS[key]
