"""Walks of a DFA's letters as gathers: B -> sum_v counts[u, v] B[..., v], where counts[u, v] is
how many letters take state u to state v, without the dense [letters, n, n] moves a large
automaton cannot afford (`logic/monitors.py`'s backward pass over a DFA and its monitors)."""

from __future__ import annotations

import numpy as np


def rest_walk(counts: np.ndarray):
    """B -> sum_v counts[u, v] B[..., v] for B [rows, 2, n]: one dense product for small DFAs;
    for large ones, where a state's letters lead to few distinct states, a gather per distinct
    successor (counts has at most that many nonzeros per row)."""
    n = len(counts)
    succ = [np.flatnonzero(r) for r in counts]
    most = max(len(x) for x in succ)
    if n <= 16 * most:
        transposed = np.ascontiguousarray(counts.T)
        return lambda b: (b.reshape(-1, n) @ transposed).reshape(b.shape)
    nxt = np.stack([np.pad(x, (0, most - len(x)), constant_values=x[0]) for x in succ], 1)
    weight = np.take_along_axis(counts, nxt.T, axis=1).T  # [most, n]
    for k, x in enumerate(succ):
        weight[len(x) :, k] = 0.0
    return lambda b: sum(b[..., nxt[k]] * weight[k] for k in range(most))


def table_walk(table: np.ndarray):
    """`rest_walk`'s gather form read off a DFA's table [n, letters] (table[u, c]: the state
    letter c takes u to), without the [n, n] counts: per state its distinct successors in
    increasing order (padded with the first, weight 0) and how many letters lead to each."""
    n = len(table)
    succ = np.sort(table, axis=1)
    new = np.ones(succ.shape, dtype=bool)
    new[:, 1:] = succ[:, 1:] != succ[:, :-1]
    rank = np.cumsum(new, axis=1) - 1  # each letter's successor's place among the distinct
    most = int(rank[:, -1].max()) + 1
    nxt = np.repeat(succ[:, :1].T, most, axis=0)  # [most, n]
    states = np.broadcast_to(np.arange(n)[:, None], succ.shape)
    nxt[rank[new], states[new]] = succ[new]
    weight = np.zeros((most, n))
    np.add.at(weight, (rank.ravel(), states.ravel()), 1.0)
    return lambda b: sum(b[..., nxt[k]] * weight[k] for k in range(most))
