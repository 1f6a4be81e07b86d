"""Monitor features of soft traces, differentiable (logic/monitors.py gives crisp words').

A soft trace is a distribution P_t over letters at each step, steps independent. A monitor reads
each letter as its class c = p + 2 q (logic.monitors), so step t moves it with the expected
transition Σ_c P_t(class c) · step_c, and its state distribution after the last letter gives the
probability that it accepts the trace — exactly ψ(w) when every P_t is one-hot, and
differentiable in P throughout. Laid out as a trace's crisp features are: these, then zeros
(a trace has no rejected words).

What depends on the alphabet only is built once per alphabet (`AlphabetWalk`): which monitors
its atoms fill, the state slots they use (2 or 3 for most, not the 5 the bank pads to), and the
edges between slots that its letters take, each with a 0/1 column of the letters that take it.
A batch is then one matrix product per alphabet (every step's edge weights, [T, edges]) and,
per step, one gather, product and index-add over all traces' edges together (`_Walk`, with its
backward written out): the Python loop runs over the T steps only.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
import torch

from tleaf_cli.logic.monitors import MonitorBank


def monitor_classes(bank: MonitorBank, truth: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
    """[M, letters] each monitor's class of each letter, and [M] whether its atoms exist, for an
    alphabet with atom truth table `truth` [letters, atoms]."""
    classes, present = bank.classes(truth)
    # copies, on the CPU: the bank's arrays are read-only
    return torch.tensor(classes, device="cpu"), torch.tensor(present, device="cpu")


class AlphabetWalk(NamedTuple):
    """The soft monitor walk of one alphabet's traces: the state slots of the monitors its atoms
    fill, laid end to end (each monitor with as many as it uses, `MonitorBank.sizes`), and each
    slot's edges in: one per slot that some letter leads to it from, weighted at each step by
    the probability of the letters that take it (an edge merges the classes that lead to the
    same state). No monitor state is entered from more than `bank.in_edges` states (2 for its
    templates), so the edges are laid out as [in_edges, slots], the k-th edge into each slot
    (a slot with fewer has edges of weight 0): a step is then a gather, a product and a sum,
    with no scatter."""

    weights: torch.Tensor  # [letters, in_edges · slots] 1 where the letter takes the edge
    source: torch.Tensor  # [in_edges · slots] the slot an edge leaves
    start: torch.Tensor  # [slots] 1 at each monitor's state 0
    accepting: torch.Tensor  # [slots] 1 where the state accepts
    monitor: torch.Tensor  # [slots] the bank's monitor each slot belongs to

    @property
    def letters(self) -> int:
        return self.weights.shape[0]

    @property
    def slots(self) -> int:
        return self.start.shape[0]

    @property
    def in_edges(self) -> int:
        return self.source.shape[0] // self.slots if self.slots else 0

    @classmethod
    def of(cls, bank: MonitorBank, classes: torch.Tensor, present: torch.Tensor) -> AlphabetWalk:
        """The walk of an alphabet whose monitors read classes [M, letters] and whose atoms
        fill the monitors `present` [M] (`monitor_classes`)."""
        monitors = torch.as_tensor(present).bool().cpu().nonzero(as_tuple=True)[0]
        sizes = torch.as_tensor(bank.sizes)[monitors]
        first = torch.cumsum(sizes, 0) - sizes  # each monitor's first slot
        pair = torch.repeat_interleave(torch.arange(len(monitors)), sizes)
        state = torch.arange(len(pair)) - first[pair]
        monitor = monitors[pair]
        slots = len(pair)
        # [slots, letters]: the state each letter leads each slot to
        letter_classes = torch.as_tensor(classes).cpu()[monitor].long()
        moved = torch.as_tensor(bank.tables)[monitor, state].gather(1, letter_classes)
        # the edges, ordered by the slot they enter: (target slot, source slot) pairs
        target = first[pair][:, None] + moved  # [slots, letters]
        edges = torch.unique(target * slots + torch.arange(slots)[:, None])
        into, source = edges // slots, edges % slots
        rank = torch.arange(len(edges)) - torch.searchsorted(into, into)  # k-th edge into
        width = bank.in_edges
        laid = rank * slots + into  # the edge's place in [in_edges, slots]
        sources = torch.arange(slots).repeat(width)  # padding edges read their own slot
        sources[laid] = source
        weights = torch.zeros(letter_classes.shape[1], width * slots)
        weights[:, laid] = (target[source] == into[:, None]).t().float()
        accepting = torch.as_tensor(bank.accepting)[monitor, state]
        return cls(weights, sources, (state == 0).float(), accepting.float(), monitor)

    def to(self, device: torch.device | str) -> AlphabetWalk:
        return AlphabetWalk(*(t.to(device) for t in self))


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
    walks: dict[bytes, AlphabetWalk] = {}
    per_trace = []
    for c, p in zip(classes.cpu(), present.cpu(), strict=True):
        key = c.numpy().tobytes() + p.numpy().tobytes()
        if key not in walks:
            walks[key] = AlphabetWalk.of(bank, c, p).to(probs.device)
        per_trace.append(walks[key])
    return soft_monitor_walk(bank, probs, lengths, per_trace)


def soft_monitor_walk(
    bank: MonitorBank,
    probs: torch.Tensor,
    lengths: torch.Tensor,
    walks: Sequence[AlphabetWalk],
) -> torch.Tensor:
    """`soft_monitor_features` with trace n read by `walks[n]` (`AlphabetWalk.of(bank, ...)`, on
    probs' device: what a caller that reads the same alphabets again keeps). Trace n's letters
    beyond walks[n].letters must have probability 0.

    Only the monitors whose atoms a trace's alphabet has are run: the others' features are 0
    whatever the trace (a rule set of k atoms fills 7 k + 18 k (k − 1) of the bank's
    monitors, a seventh of a 10-slot bank's at k = 4)."""
    device, dtype = probs.device, probs.dtype
    n, steps, _ = probs.shape
    lengths = lengths.to(device)
    groups: dict[int, list[int]] = {}  # traces by walk (alphabet); those with no monitor read 0
    for row, walk in enumerate(walks):
        if walk.slots:
            groups.setdefault(id(walk), []).append(row)
    if not groups:
        return probs.new_zeros((n, 2 * bank.features))
    # traces one after the other, those of one alphabet together; edge weights [T, in_edges,
    # slots] from one product per alphabet
    order = [row for rows in groups.values() for row in rows]
    laid = [walks[row] for row in order]
    slots = torch.tensor([w.slots for w in laid], device=device)
    width = laid[0].in_edges
    weights = []
    for rows in groups.values():
        walk = walks[rows[0]]
        letters = probs[rows, :, : walk.letters].transpose(0, 1)  # [T, traces, letters]
        per_edge = (letters @ walk.weights.to(dtype)).view(steps, len(rows), width, walk.slots)
        weights.append(per_edge.transpose(1, 2).flatten(2))  # [T, in_edges, traces · slots]
    shift = torch.repeat_interleave(torch.cumsum(slots, 0) - slots, slots)
    rows = torch.tensor(order, device=device)
    running = torch.arange(steps, device=device)[:, None] < lengths[rows].repeat_interleave(slots)
    source = torch.cat([w.source.view(width, w.slots) for w in laid], dim=1) + shift
    state = _Walk.apply(
        torch.cat(weights, dim=2),
        source.flatten(),
        torch.cat([w.start for w in laid]).to(dtype),
        running.to(dtype),
    )
    column = torch.repeat_interleave(rows * bank.width, slots)
    column = column + torch.cat([w.monitor for w in laid])
    accepting = torch.cat([w.accepting for w in laid]).to(dtype)
    accepted = state.new_zeros(n * bank.width).index_add(0, column, state * accepting)
    # in the trace's length range (logic.monitors.MonitorBank.range_of), the others 0
    ranges = ((lengths - 1) * bank.ranges // bank.max_length).clamp(max=bank.ranges - 1)
    at_range = torch.nn.functional.one_hot(ranges, bank.ranges).to(dtype)
    placed = (at_range[:, :, None] * accepted.view(n, bank.width)[:, None, :]).flatten(1)
    return torch.cat([placed, torch.zeros_like(placed)], dim=1)


class _Walk(torch.autograd.Function):
    """The states after the last step [slots] of a walk from `start` [slots] whose step t moves
    into each slot u the mass Σ_k weights[t, k, u] · state[source[k, u]] (its k-th edge in),
    for the slots where `running[t]` is 1 (the others keep theirs: `running` is 0 or 1).
    Written out backwards so that a step costs a few operations both ways (autograd's own
    graph of the loop had twice as many), and the weights' gradient comes out as one product
    after the loop."""

    @staticmethod
    def forward(
        ctx: Any,
        weights: torch.Tensor,
        source: torch.Tensor,
        start: torch.Tensor,
        running: torch.Tensor,
    ) -> torch.Tensor:
        steps, width, slots = weights.shape
        keep = 1 - running
        state = start
        # [T, in_edges, slots]: the state each edge reads at each step (what the weights'
        # gradient multiplies), written in place step by step; every step's slices taken once
        read = weights.new_empty((steps, width, slots))
        per_step = zip(weights, read, keep, running, strict=True)
        for weights_t, read_t, keep_t, running_t in per_step:
            torch.index_select(state, 0, source, out=read_t.view(-1))
            moved = (weights_t * read_t).sum(dim=0)  # over the slots' edges in
            state = torch.addcmul(state * keep_t, moved, running_t)
        ctx.save_for_backward(weights, source, read, running)
        return state

    @staticmethod
    @torch.autograd.function.once_differentiable
    def backward(ctx: Any, grad: torch.Tensor) -> tuple[torch.Tensor | None, ...]:
        weights, source, read, running = ctx.saved_tensors
        keep = 1 - running
        into = torch.empty_like(running)  # [T, slots]: the gradient of each step's moved mass
        for t in range(weights.shape[0] - 1, -1, -1):
            torch.mul(grad, running[t], out=into[t])
            grad = (grad * keep[t]).index_add_(0, source, (weights[t] * into[t]).flatten())
        return read * into[:, None, :], None, None, None
