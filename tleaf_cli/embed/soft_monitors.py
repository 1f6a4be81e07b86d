"""Monitor features of soft traces, differentiable (logic/monitors.py gives crisp words').

A soft trace is a distribution P_t over letters at each step, steps independent. A monitor reads
each letter as its class c = p + 2 q (logic.monitors), so step t moves it with the expected
transition Σ_c P_t(class c) · step_c, and its state distribution after the last letter gives the
probability that it accepts the trace — exactly ψ(w) when every P_t is one-hot, and
differentiable in P throughout. Laid out as a trace's crisp features are: these, then zeros
(a trace has no rejected words).
"""

from __future__ import annotations

import numpy as np
import torch

from tleaf_cli.logic.monitors import STATES, MonitorBank


def monitor_classes(bank: MonitorBank, truth: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
    """[M, letters] each monitor's class of each letter, and [M] whether its atoms exist, for an
    alphabet with atom truth table `truth` [letters, atoms]."""
    classes, present = bank.classes(truth)
    return torch.tensor(classes), torch.tensor(present)  # copies: the bank's are read-only


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
    device = probs.device
    m = bank.width
    step = torch.from_numpy(bank.steps).to(device, probs.dtype)  # [M, 4, S, S]
    onehot = torch.nn.functional.one_hot(classes.to(device), 4).to(probs.dtype)  # [N, M, L, 4]
    per_class = torch.einsum("ntl,nmlc->ntmc", probs, onehot)  # [N, T, M, 4]
    state = probs.new_zeros(len(probs), m, STATES)
    state[:, :, 0] = 1.0
    for t in range(probs.shape[1]):
        moved = torch.einsum("nms,nmc,mcsu->nmu", state, per_class[:, t], step)
        state = torch.where((t < lengths.to(device)).view(-1, 1, 1), moved, state)
    accepting = torch.from_numpy(bank.accepting).to(device, probs.dtype)
    accepted = (state * accepting).sum(dim=-1) * present.to(device, probs.dtype)  # [N, M]
    # in the trace's length range (logic.monitors.MonitorBank.range_of), the others 0
    ranges = [bank.range_of(int(n)) for n in lengths]
    at_range = torch.nn.functional.one_hot(torch.tensor(ranges, device=device), bank.ranges)
    placed = (at_range.to(probs.dtype)[:, :, None] * accepted[:, None, :]).flatten(1)
    return torch.cat([placed, torch.zeros_like(placed)], dim=1)
