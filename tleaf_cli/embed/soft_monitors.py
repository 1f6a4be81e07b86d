"""Monitor features of soft traces, differentiable (logic/monitors.py gives crisp words').

A soft trace is a distribution P_t over letters at each step, steps independent. A monitor reads
each letter as its class c = p + 2 q (logic.monitors), so step t moves it with the expected
transition Σ_c P_t(class c) · step_c, and its state distribution after the last letter gives the
probability that it accepts the trace — exactly ψ(w) when every P_t is one-hot, and
differentiable in P throughout. Laid out as a trace's crisp features are: these, then zeros
(a trace has no rejected words).

Every trace of a batch and every monitor move together: the letters' classes are one batched
matrix product ([N, T, L] by [N, L, M·4]), and each step is one product and one scatter-add over
[N, M, 4·S] (a monitor's move on class c is a table, so Σ_s state(s) · step_c[s, u] adds each
state's mass into its successor); the Python loop runs over the T steps only.
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
    per_class = torch.bmm(probs, weights.to(device, dtype)).view(n, steps, m, 4, 1)
    tables = _tables(bank, device)  # [M, 4·S]: the state each (class, state) moves to
    index = tables.expand(n, -1, -1)
    state = torch.zeros((n, m, STATES), dtype=dtype, device=device)
    state[:, :, 0] = 1.0
    for t in range(steps):
        mass = (per_class[:, t] * state[:, :, None, :]).flatten(2)  # [N, M, 4·S]
        moved = torch.zeros_like(state).scatter_add(2, index, mass)
        state = torch.where((t < lengths).view(-1, 1, 1), moved, state)
    accepting = torch.as_tensor(bank.accepting, dtype=dtype, device=device)
    accepted = (state * accepting).sum(dim=-1) * present.to(device, dtype)  # [N, M]
    # in the trace's length range (logic.monitors.MonitorBank.range_of), the others 0
    ranges = ((lengths - 1) * bank.ranges // bank.max_length).clamp(max=bank.ranges - 1)
    at_range = torch.nn.functional.one_hot(ranges, bank.ranges).to(dtype)
    placed = (at_range[:, :, None] * accepted[:, None, :]).flatten(1)
    return torch.cat([placed, torch.zeros_like(placed)], dim=1)


_TABLES: dict[tuple[int, str], torch.Tensor] = {}


def _tables(bank: MonitorBank, device: torch.device) -> torch.Tensor:
    """[M, 4·S] long: `bank.tables` [M, S, 4] laid out class-major, on `device`. Kept per
    (width, device): the tables depend on the bank's slots only, and the width on the slots."""
    key = (bank.width, str(device))
    if key not in _TABLES:
        table = np.ascontiguousarray(bank.tables.transpose(0, 2, 1)).reshape(bank.width, -1)
        _TABLES[key] = torch.as_tensor(table, dtype=torch.long, device=device)
    return _TABLES[key]
