"""The DFA type: a complete transition table over an alphabet's letters.

`table[s, i]` is the state reached from state s on letter i (see `alphabet.py` for letter
numbering). A table makes running, products and minimisation array operations, and the guards
people read are derived from it (`guards.py`), never the other way round.

Traces are non-empty, so the empty word is a don't-care: `minimize_nonempty` picks whichever
acceptance of the initial state gives fewer states.
"""

from __future__ import annotations

import hashlib
from collections.abc import Collection, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from tleaf_cli.errors import InputError
from tleaf_cli.logic.alphabet import Alphabet
from tleaf_cli.logic.guards import Guard, cnf_holds, row_guards
from tleaf_cli.logic.small_tables import minimize_table, product_table, renumber_table

# Tables of at most this many entries (states x letters) are minimised in plain Python.
SMALL_TABLE = 4096


@dataclass(frozen=True, eq=False)
class DFA:
    """A complete deterministic automaton; states are 0..num_states-1."""

    alphabet: Alphabet
    table: np.ndarray  # int32 [num_states, alphabet.size]
    initial: int
    accepting: np.ndarray  # bool [num_states]

    def __post_init__(self) -> None:
        table = np.ascontiguousarray(self.table, dtype=np.int32)
        accepting = np.asarray(self.accepting, dtype=bool)
        n = table.shape[0]
        if table.ndim != 2 or table.shape[1] != self.alphabet.size:
            raise InputError(f"table must be [states, {self.alphabet.size}], got {table.shape}")
        if accepting.shape != (n,) or not 0 <= self.initial < n:
            raise InputError("accepting/initial do not match the table")
        if n and (table.min() < 0 or table.max() >= n):
            raise InputError("table points outside the states")
        object.__setattr__(self, "table", table)
        object.__setattr__(self, "accepting", accepting)

    @property
    def atoms(self) -> tuple[str, ...]:
        return self.alphabet.atoms

    @property
    def num_states(self) -> int:
        return int(self.table.shape[0])

    @property
    def structure(self) -> tuple:
        """The automaton up to its atoms' names, hashable and small (the table and accepting
        states as a 16-byte digest): what is computed from the table alone (monitor shares,
        graph layouts, readout weights) can be kept under it for every DFA that differs only
        in the names of its atoms."""
        digest = hashlib.blake2b(self.table.tobytes(), digest_size=16)
        digest.update(self.accepting.tobytes())
        kind, atoms = self.alphabet.kind, len(self.atoms)
        return kind, atoms, self.table.shape, self.initial, digest.digest()

    # ------------------------------------------------------------------ running
    def run(self, letters: Sequence[int] | np.ndarray) -> int:
        """The state reached from the initial state on letter indices."""
        s = self.initial
        for i in letters:
            s = int(self.table[s, i])
        return s

    def accepts(self, trace: Sequence[Collection[str]]) -> bool:
        """Whether the non-empty trace (a sequence of sets of true atoms) is accepted."""
        if len(trace) == 0:
            raise InputError("traces are non-empty")
        return bool(self.accepting[self.run([self.alphabet.index(x) for x in trace])])

    # ------------------------------------------------------------ construction
    @classmethod
    def from_guards(
        cls,
        alphabet: Alphabet,
        num_states: int,
        initial: int,
        accepting: Collection[int],
        edges: Sequence[tuple[int, int, Sequence[Sequence[int]]]],
    ) -> DFA:
        """Rebuild the table from (src, dst, cnf) edges, which must cover each letter once."""
        table = np.full((num_states, alphabet.size), -1, dtype=np.int32)
        for src, dst, cnf in edges:
            hit = cnf_holds(cnf, alphabet)
            row = table[src]
            if (row[hit] >= 0).any():
                raise InputError(f"state {src}: guards overlap (the DFA is not deterministic)")
            row[hit] = dst
        holes = np.argwhere(table < 0)
        if len(holes):
            s, i = holes[0]
            letter = sorted(alphabet.letter(int(i)))
            raise InputError(f"state {s}: no edge for letter {letter} (the DFA is not complete)")
        acc = np.zeros(num_states, dtype=bool)
        acc[list(accepting)] = True
        return cls(alphabet, table, initial, acc)

    # ---------------------------------------------------------------- algebra
    def complement(self) -> DFA:
        return DFA(self.alphabet, self.table, self.initial, ~self.accepting).minimize()

    def product(self, other: DFA, mode: str = "and", canonical: bool = True) -> DFA:
        """Synchronous product over the union of both alphabets' atoms; `mode` and/or/xor.
        Minimal; `canonical=False` skips the breadth-first numbering (see `minimize`)."""
        combine = {"and": np.logical_and, "or": np.logical_or, "xor": np.logical_xor}[mode]
        if self.alphabet.kind != other.alphabet.kind:
            raise InputError("cannot combine DFAs over a powerset and a one-hot alphabet")
        union = Alphabet(tuple(sorted(set(self.atoms) | set(other.atoms))), self.alphabet.kind)
        ta = self.table[:, self.alphabet.lift(union)]
        tb = other.table[:, other.alphabet.lift(union)]
        nb = other.num_states
        if self.num_states * nb * union.size <= SMALL_TABLE:  # lists: numpy's per-call cost
            rows, accepting = product_table(
                ta.tolist(),
                tb.tolist(),
                (self.initial, other.initial),
                self.accepting.tolist(),
                other.accepting.tolist(),
                combine,
            )
            return DFA(union, np.array(rows, dtype=np.int32), 0, accepting).minimize(canonical)
        ids = np.full(self.num_states * nb, -1, dtype=np.int64)
        start = self.initial * nb + other.initial
        ids[start] = 0
        order = [start]
        rows = []
        frontier = np.array([start], dtype=np.int64)
        while len(frontier):
            nxt = ta[frontier // nb].astype(np.int64) * nb + tb[frontier % nb]
            rows.append(nxt)
            fresh = np.unique(nxt[ids[nxt] < 0])
            ids[fresh] = np.arange(len(order), len(order) + len(fresh))
            order.extend(fresh.tolist())
            frontier = fresh
        pairs = np.array(order, dtype=np.int64)
        table = ids[np.vstack(rows)]
        accepting = combine(self.accepting[pairs // nb], other.accepting[pairs % nb])
        return DFA(union, table, 0, accepting).minimize(canonical)

    def intersect(self, other: DFA) -> DFA:
        return self.product(other, "and")

    def equivalent(self, other: DFA) -> bool:
        """Same language (the empty word included) over the union of their atoms."""
        return not self.product(other, "xor").accepting.any()

    # ----------------------------------------------------------- minimisation
    def minimize(self, canonical: bool = True) -> DFA:
        """The minimal DFA of the same language, states numbered in breadth-first order.

        Moore's partition refinement on the reachable part; two DFAs of one language over one
        alphabet come out identical (same table), so equality of tables decides equivalence.
        Small tables (most rules) are refined in plain Python, large ones with array operations:
        the same result, at a fraction of numpy's per-call cost on a handful of states.
        `canonical=False` leaves the states in an arbitrary order (initial state 0 or not): for
        a DFA that is minimised again or renumbered later, e.g. a step of a chain of products.
        """
        if self.table.size <= SMALL_TABLE:
            rows, initial, accepting = minimize_table(
                self.table.tolist(), self.initial, self.accepting.tolist()
            )
            return DFA(self.alphabet, np.array(rows, dtype=np.int32), initial, accepting)
        reach = self._reachable()
        remap = np.full(self.num_states, -1, dtype=np.int64)
        remap[reach] = np.arange(len(reach))
        table = remap[self.table[reach]]
        accepting = self.accepting[reach]
        cls = accepting.astype(np.int64)
        count = len(np.unique(cls))
        while True:
            new = _row_classes(np.column_stack([cls, cls[table]]))
            new_count = int(new.max()) + 1
            cls = new
            if new_count == count:
                break
            count = new_count
        rep = np.zeros(count, dtype=np.int64)
        rep[cls] = np.arange(len(cls))
        quotient = cls[table[rep]]
        start = int(cls[remap[self.initial]])
        if not canonical:
            return DFA(self.alphabet, quotient, start, accepting[rep])
        return _renumber_bfs(self.alphabet, quotient, start, accepting[rep])

    def minimize_nonempty(self, minimal: bool = False) -> DFA:
        """Minimal DFA for the non-empty traces of this language (`minimal`: self already is a
        minimal DFA, which saves minimising it again).

        The initial state gets a fresh copy (so its acceptance only decides the empty word), and of
        the two choices of that acceptance the one with fewer states is kept; on a tie, the empty
        word is rejected. In a minimal DFA that choice needs no refinement: the states reachable
        in one step or more stay pairwise distinct, and the fresh start merges with one of them
        exactly when it has the same acceptance and the same row.
        """
        dfa = self if minimal else self.minimize()
        table, start = dfa.table, dfa.initial
        after = np.zeros(dfa.num_states, dtype=bool)  # reachable in one step or more
        frontier = np.unique(table[start])
        after[frontier] = True
        while len(frontier):
            nxt = np.unique(table[frontier])
            frontier = nxt[~after[nxt]]
            after[frontier] = True
        kept = np.flatnonzero(after)
        same_row = kept[(table[kept] == table[start]).all(axis=1)]
        best = None
        for accept_empty in (False, True):
            twin = same_row[dfa.accepting[same_row] == accept_empty]
            size = len(kept) + (len(twin) == 0)
            if best is None or size < best[0]:
                best = (size, accept_empty, twin)
        _, accept_empty, twin = best
        if len(twin):  # the fresh start is an existing state
            return _renumber_reachable(dfa.alphabet, table, int(twin[0]), dfa.accepting)
        n = dfa.num_states
        table = np.vstack([table, table[start][None, :]])
        accepting = np.append(dfa.accepting, accept_empty)
        return _renumber_reachable(dfa.alphabet, table, n, accepting)

    def live(self) -> np.ndarray:
        """bool [S]: the states from which some accepting state can be reached (in ≥ 0 steps)."""
        return self.reaches(self.accepting)

    def reaches(self, targets: np.ndarray) -> np.ndarray:
        """bool [S]: the states from which some state of `targets` (bool [S]) can be reached in
        zero or more steps."""
        reach = np.asarray(targets, dtype=bool).copy()
        while True:
            grown = reach | reach[self.table].any(axis=1)
            if np.array_equal(grown, reach):
                return reach
            reach = grown

    def alive_letters(self, state: int) -> np.ndarray:
        """bool [letters]: the letters after which, from `state`, the language can still be met
        (some continuation, possibly empty, is accepted). The primitive of constrained decoding
        and of shields: a letter outside it commits a sequence to violating the DFA."""
        return self.live()[self.table[state]]

    def _reachable(self) -> np.ndarray:
        seen = np.zeros(self.num_states, dtype=bool)
        seen[self.initial] = True
        frontier = np.array([self.initial])
        while len(frontier):
            nxt = np.unique(self.table[frontier])
            frontier = nxt[~seen[nxt]]
            seen[frontier] = True
        return np.flatnonzero(seen)

    # ---------------------------------------------------------------- edges
    def edges(self) -> Iterator[tuple[int, int, np.ndarray]]:
        """(src, dst, letters) for every pair of states joined by at least one letter."""
        for src in range(self.num_states):
            row = self.table[src]
            for dst in np.unique(row):
                yield src, int(dst), row == dst

    def guarded_edges(self) -> list[tuple[int, int, Guard]]:
        """(src, dst, guard) in (src, dst) order."""
        return [
            (src, dst, guard)
            for src in range(self.num_states)
            for dst, guard in row_guards(self.table[src], self.alphabet)
        ]

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, DFA):
            return NotImplemented
        return (
            self.alphabet == other.alphabet
            and self.initial == other.initial
            and np.array_equal(self.table, other.table)
            and np.array_equal(self.accepting, other.accepting)
        )

    __hash__ = None  # type: ignore[assignment]


def _row_classes(rows: np.ndarray) -> np.ndarray:
    """Class index per row, equal rows equal classes.

    Wide rows (large alphabets) are hashed to one 64-bit number each and grouped by it, then every
    row is compared with its group's first: when a hash collision put different rows together
    (never seen; possible), the exact route runs instead. The exact route compares rows as raw
    bytes (memcmp), much faster than np.unique(axis=0)'s column-by-column sort on wide tables.
    """
    rows = np.ascontiguousarray(rows)
    if rows.shape[1] > HASHED_ROW_WIDTH:
        keys = rows.astype(np.uint64) @ _row_weights(rows.shape[1])  # wraps modulo 2**64
        _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
        inverse = inverse.reshape(-1)
        if np.array_equal(rows, rows[first[inverse]]):
            return inverse.astype(np.int64)
    keys = rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()
    _, inverse = np.unique(keys, return_inverse=True)
    return inverse.reshape(-1).astype(np.int64)


# Rows wider than this are grouped by a hash first (_row_classes).
HASHED_ROW_WIDTH = 64


def _row_weights(width: int) -> np.ndarray:
    """Fixed odd 64-bit multipliers, one per column, for row hashes."""
    rng = np.random.default_rng(width)
    return rng.integers(0, 2**63, size=width, dtype=np.uint64) * np.uint64(2) + np.uint64(1)


def _successors_in_letter_order(table: np.ndarray) -> list[list[int]]:
    """For each state, its distinct successors in order of the first letter leading there."""
    n = table.shape[0]
    order = np.argsort(table, axis=1, kind="stable")
    ranked = np.take_along_axis(table, order, axis=1)
    first = np.ones_like(ranked, dtype=bool)
    first[:, 1:] = ranked[:, 1:] != ranked[:, :-1]
    rows, cols = np.nonzero(first)
    letters = order[rows, cols]
    by_letter = np.lexsort((letters, rows))
    succ: list[list[int]] = [[] for _ in range(n)]
    for r, dst in zip(
        rows[by_letter].tolist(), ranked[rows, cols][by_letter].tolist(), strict=True
    ):
        succ[r].append(dst)
    return succ


def _renumber_reachable(
    alphabet: Alphabet, table: np.ndarray, initial: int, accepting: np.ndarray
) -> DFA:
    """`_renumber_bfs` of the states reachable from `initial` only."""
    if table.size <= SMALL_TABLE:
        rows, start, acc = renumber_table(table.tolist(), initial, accepting.tolist())
        return DFA(alphabet, np.array(rows, dtype=np.int32), start, acc)
    seen = np.zeros(len(table), dtype=bool)
    seen[initial] = True
    frontier = np.array([initial])
    while len(frontier):
        nxt = np.unique(table[frontier])
        frontier = nxt[~seen[nxt]]
        seen[frontier] = True
    reach = np.flatnonzero(seen)
    remap = np.full(len(table), -1, dtype=np.int64)
    remap[reach] = np.arange(len(reach))
    return _renumber_bfs(alphabet, remap[table[reach]], int(remap[initial]), accepting[reach])


def _renumber_bfs(
    alphabet: Alphabet, table: np.ndarray, initial: int, accepting: np.ndarray
) -> DFA:
    """Renumber states in breadth-first order from `initial`, successors in letter order."""
    succ = _successors_in_letter_order(table)
    order = [initial]
    pos = {initial: 0}
    head = 0
    while head < len(order):
        for s in succ[order[head]]:
            if s not in pos:
                pos[s] = len(order)
                order.append(s)
        head += 1
    perm = np.array(order, dtype=np.int64)
    inverse = np.empty(len(table), dtype=np.int64)
    inverse[perm] = np.arange(len(perm))
    return DFA(alphabet, inverse[table[perm]], 0, accepting[perm])
