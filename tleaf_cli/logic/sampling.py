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

Once-each words (`once_each_words`): orders of the DFA's atoms, each read exactly once, with a few
"none" letters — the shape of a labelled video under its own rule set. Not uniform: accepted
ones come from a random walk that avoids dead states, rejected ones from swapping two atoms of
an accepted word or from a random order.
"""

from __future__ import annotations

import numpy as np

from tleaf_cli.errors import InputError
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
            raise InputError(f"no {'accepted' if accept else 'rejected'} word of length {length}")
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
            raise InputError("no rejected word of this length")
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


def once_each_words(
    dfa: DFA, rng: np.random.Generator, n: int, max_none: int = 0, tries: int = 50
) -> tuple[list[np.ndarray], list[tuple[np.ndarray, str]]]:
    """Up to n distinct accepted words, and up to n distinct rejected ones with their source
    ("hard" or "uniform"), that read every atom of the DFA exactly once (its one-hot letters, in
    some order) and up to `max_none` "none" letters.

    The shape of an action-recognition video: each (action, ingredient) pair of the video happens
    once, and the video's rule set has exactly those atoms. Accepted words come from a random
    walk that only takes atoms leading to a state from which acceptance is still reachable;
    rejected ones are a satisfying word with two atoms swapped (hard negatives) or a random order.
    """
    letters = one_hot_letters(dfa)
    none, atoms = int(letters[0]), letters[1:]
    live = _coaccessible(dfa, letters)
    final = set(np.flatnonzero(dfa.accepting).tolist())
    accepted: dict[bytes, np.ndarray] = {}
    rejected: dict[bytes, tuple[np.ndarray, str]] = {}
    for _ in range(tries * n):
        if len(accepted) >= n and len(rejected) >= n:
            break
        order, state = [], dfa.initial
        left = list(rng.permutation(atoms))
        while left:
            ok = [a for a in left if live[dfa.table[state, a]]]
            pick = ok[0] if ok else left[0]  # nowhere safe: the word will be rejected
            left.remove(pick)
            order.append(pick)
            state = dfa.table[state, pick]
        word = _with_none(np.array(order, dtype=np.int64), none, max_none, rng)
        if dfa.run(word) in final:
            accepted.setdefault(word.tobytes(), word)
        else:
            rejected.setdefault(word.tobytes(), (word, "uniform"))
        if accepted:
            base = list(accepted.values())[rng.integers(len(accepted))].copy()
            spots = np.flatnonzero(base != none)
            if len(spots) >= 2:
                i, j = rng.choice(spots, size=2, replace=False)
                base[[i, j]] = base[[j, i]]
                if dfa.run(base) not in final:
                    rejected.setdefault(base.tobytes(), (base, "hard"))
        shuffled = _with_none(rng.permutation(atoms), none, max_none, rng)
        if dfa.run(shuffled) not in final:
            rejected.setdefault(shuffled.tobytes(), (shuffled, "uniform"))
    return list(accepted.values())[:n], list(rejected.values())[:n]


def _coaccessible(dfa: DFA, letters: np.ndarray) -> np.ndarray:
    """bool [states]: some word over `letters` leads from the state to acceptance."""
    live = dfa.accepting.copy()
    while True:
        grown = live | live[dfa.table[:, letters]].any(axis=1)
        if (grown == live).all():
            return live
        live = grown


def _with_none(word: np.ndarray, none: int, max_none: int, rng: np.random.Generator):
    """`word` with 0..max_none "none" letters inserted at random places."""
    extra = int(rng.integers(0, max_none + 1))
    out = np.insert(word, rng.integers(0, len(word) + 1, size=extra), none)
    return out.astype(np.int64)
