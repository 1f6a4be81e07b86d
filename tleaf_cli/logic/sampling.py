"""Words of a DFA: counting them by length, drawing them uniformly, and nearest rejected words.

Counting: `count[t, s]` is the number of words of length t over the allowed letters that lead
from state s to acceptance (to rejection, for the complement):

    count[0, s] = accepting[s],    count[t, s] = sum over letters l of count[t-1, table[s, l]].

Uniform sampling of an accepted word of length L walks forwards from the initial state and, with
r letters still to go, picks letter l with probability count[r-1, next] / count[r, state]: every
accepted word of length L then has probability 1 / count[L, initial]. Counts are float64 (exact
up to 2**53, and a positive count never rounds to zero), each length's row scaled by a power of
two when it grows past 2**512, so long traces over large alphabets do not overflow.

Hard negatives: for an accepted word w, the fewest substitutions that make it rejected, by a
shortest-path over (position, state) with cost 1 per changed letter, and a random one among the
cheapest by walking back through optimal predecessors.
"""

from __future__ import annotations

import numpy as np

from tleaf_cli.logic.dfa import DFA


def one_hot_letters(dfa: DFA) -> np.ndarray:
    """Letter indices that are one-hot (a single atom of the DFA, or none of them)."""
    if dfa.alphabet.kind == "one-hot":
        return np.arange(dfa.alphabet.size)
    return np.array([0] + [1 << k for k in range(len(dfa.atoms))], dtype=np.int64)


class WordSampler:
    """Counts and draws words of one DFA over a set of allowed letters."""

    def __init__(self, dfa: DFA, max_len: int, letters: np.ndarray | None = None) -> None:
        self.dfa = dfa
        self.letters = np.arange(dfa.alphabet.size) if letters is None else np.asarray(letters)
        self.next = dfa.table[:, self.letters].astype(np.int64)  # [states, allowed letters]
        self.max_len = max_len
        self.accepting = self._count(dfa.accepting)
        self.rejecting = self._count(~dfa.accepting)

    def _count(self, final: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Counts per length, each length's row scaled by 2**-exponent so it never overflows."""
        counts = np.zeros((self.max_len + 1, self.dfa.num_states))
        exponent = np.zeros(self.max_len + 1, dtype=np.int64)
        counts[0] = final
        for t in range(1, self.max_len + 1):
            row = counts[t - 1][self.next].sum(axis=1)
            shift = int(np.frexp(row.max())[1]) if row.max() > 2.0**512 else 0
            counts[t] = np.ldexp(row, -shift)
            exponent[t] = exponent[t - 1] + shift
        return counts, exponent

    def counts(self, accept: bool) -> np.ndarray:
        """Words of each length 0..max_len from the initial state that are (not) accepted
        (inf where there are more than float64 can hold)."""
        counts, exponent = self.accepting if accept else self.rejecting
        with np.errstate(over="ignore"):
            return np.ldexp(counts[:, self.dfa.initial], exponent)

    def sample(self, rng: np.random.Generator, length: int, accept: bool, n: int) -> np.ndarray:
        """n words of `length` (letter indices), uniform among the (not) accepted ones."""
        counts, _ = self.accepting if accept else self.rejecting
        if counts[length, self.dfa.initial] == 0:
            raise ValueError(f"no {'accepted' if accept else 'rejected'} word of length {length}")
        state = np.full(n, self.dfa.initial, dtype=np.int64)
        out = np.empty((n, length), dtype=np.int64)
        for t in range(length):
            # One length's row shares one scale, so its ratios are exact completion ratios.
            weights = counts[length - t - 1][self.next[state]]  # [n, letters]
            cum = np.cumsum(weights, axis=1)
            u = rng.random(n) * cum[:, -1]
            pick = (cum <= u[:, None]).sum(axis=1)
            out[:, t] = self.letters[pick]
            state = self.next[state, pick]
        return out

    def nearest_rejected(self, rng: np.random.Generator, word: np.ndarray) -> np.ndarray:
        """A rejected word with the fewest letters changed from `word` (random among ties)."""
        n_states = self.next.shape[0]
        length = len(word)
        inf = np.iinfo(np.int64).max // 4
        cost = np.full((length + 1, n_states), inf, dtype=np.int64)
        cost[0, self.dfa.initial] = 0
        for t in range(length):
            change = (self.letters != word[t]).astype(np.int64)
            step = cost[t][:, None] + change[None, :]  # [states, letters]
            np.minimum.at(cost[t + 1], self.next.ravel(), step.ravel())
        final = np.where(self.dfa.accepting, inf, cost[length])
        best = final.min()
        if best >= inf:
            raise ValueError("no rejected word of this length")
        state = rng.choice(np.flatnonzero(final == best))
        out = np.empty(length, dtype=np.int64)
        for t in range(length - 1, -1, -1):
            change = (self.letters != word[t]).astype(np.int64)
            ok = (self.next == state) & (cost[t][:, None] + change[None, :] == cost[t + 1, state])
            prev, pick = np.nonzero(ok)
            k = rng.integers(len(prev))
            out[t] = self.letters[pick[k]]
            state = prev[k]
        return out
