"""The batched exact checker: many traces against one or many DFAs through transition tables.

All DFAs' tables are packed into one flat array, so a trace's current state is a single global
index and one step of every trace is two gathers: `state = flat[row_start[state] + letter]`.
Traces are sorted by length once, so at step t the traces still running are a prefix of the
batch and no per-step masking is needed. The Python loop runs over time steps only (tens), never
over traces or (trace, step) pairs.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence

import numpy as np

from tleaf_cli import arguments
from tleaf_cli.arguments import given
from tleaf_cli.errors import ArgumentTypeError, InputError
from tleaf_cli.logic.dfa import DFA


class PackedDFAs:
    """Several DFAs' tables in one flat array, states numbered globally."""

    def __init__(self, dfas: Sequence[DFA]) -> None:
        sizes = np.array([d.num_states for d in dfas], dtype=np.int64)
        state_base = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        widths = np.concatenate([np.full(d.num_states, d.alphabet.size) for d in dfas])
        self.row_start = np.concatenate([[0], np.cumsum(widths)[:-1]]).astype(np.int64)
        self.flat = np.concatenate(
            [
                (d.table.astype(np.int64) + base).ravel()
                for d, base in zip(dfas, state_base, strict=True)
            ]
        )
        self.initial = state_base + np.array([d.initial for d in dfas], dtype=np.int64)
        self.accepting = np.concatenate([d.accepting for d in dfas])
        self.dfas = list(dfas)

    def check(self, which: np.ndarray, letters: np.ndarray, lengths: np.ndarray) -> np.ndarray:
        """Accept (bool per trace) for trace i, given as letter indices, against DFA which[i].

        `letters` is int [n_traces, max_len] in each trace's own DFA's letter numbering (padding
        ignored), `lengths` the non-empty trace lengths.
        """
        which = np.asarray(which, dtype=np.int64)
        lengths = np.asarray(lengths, dtype=np.int64)
        if len(lengths) and lengths.min() < 1:
            raise InputError("traces are non-empty")
        order = np.argsort(-lengths, kind="stable")
        running = np.searchsorted(-lengths[order], -np.arange(letters.shape[1]), side="left")
        state = self.initial[which[order]]
        steps = letters[order].astype(np.int64)
        for t, k in enumerate(running):
            if k == 0:
                break
            state[:k] = self.flat[self.row_start[state[:k]] + steps[:k, t]]
        out = np.empty(len(order), dtype=bool)
        out[order] = self.accepting[state]
        return out

    def check_traces(
        self, which: Sequence[int], traces: Sequence[Sequence[Collection[str]]]
    ) -> np.ndarray:
        """Like `check`, for traces given as sequences of atom sets."""
        which = np.asarray(which, dtype=np.int64)
        width = max((len(t) for t in traces), default=0)
        letters = np.zeros((len(traces), width), dtype=np.int32)
        lengths = np.zeros(len(traces), dtype=np.int32)
        for k in np.unique(which):
            rows = np.flatnonzero(which == k)
            enc, lens = self.dfas[k].alphabet.encode([traces[r] for r in rows])
            letters[rows, : enc.shape[1]] = enc
            lengths[rows] = lens
        return self.check(which, letters, lengths)


def check(dfa: DFA, traces: Sequence[Sequence[Collection[str]]]) -> np.ndarray:
    """Accept (bool per trace) for each non-empty trace against one DFA: a trace is a sequence
    of letters, a letter the set of atoms true at that step. ArgumentTypeError / ArgumentError
    for a `dfa` that is not a DFA and traces that are not so (a str is never a trace)."""
    if not isinstance(dfa, DFA):
        raise ArgumentTypeError("dfa", f"must be a tl.DFA (tl.compile_formula), not {given(dfa)}")
    traces = arguments.traces(traces)
    return PackedDFAs([dfa]).check_traces(np.zeros(len(traces), dtype=np.int64), traces)
