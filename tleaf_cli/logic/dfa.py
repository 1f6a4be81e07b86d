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
from functools import reduce

import numpy as np

from tleaf_cli.errors import InputError
from tleaf_cli.logic.alphabet import Alphabet
from tleaf_cli.logic.guards import Guard, cnf_holds, row_guards

# Tables of at most this many entries (states x letters) are minimised in plain Python.
SMALL_TABLE = 4096
# Conjunctions kept by `conjoin_nonempty`, per automata and letter layout (the oldest dropped).
CONJUNCTIONS_KEPT = 4096


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
            rows, initial, accepting = _minimize_small(
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
        live = self.accepting.copy()
        while True:
            grown = live | live[self.table].any(axis=1)
            if np.array_equal(grown, live):
                return live
            live = grown

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


def conjoin_nonempty(dfas: Sequence[DFA]) -> DFA:
    """`DFA.product` of one-hot `dfas` over pairwise disjoint atoms, then `minimize_nonempty`:
    the same DFA (same table, initial state and acceptance), in one pass.

    Each atom belongs to one DFA, so a letter moves only its DFA, on that letter, and every other
    DFA reads its letter 0 ("none of my atoms"). The k-way product is then one breadth-first walk
    over combinations of states, minimised once in plain Python, instead of k - 1 pairwise products
    each minimised with array operations: the per-call cost of numpy dominates on the handful of
    states of a rule set's groups (`rule_set._conjunction`). A product past SMALL_TABLE entries
    takes the pairwise route. The result is the canonical minimal DFA of the conjunction, so it
    does not depend on the route (nor on the order of `dfas`).

    The table is a function of the DFAs' `structure`s and of which (DFA, letter) each sorted
    atom is, not of the atoms' names: a trainer that builds rule sets from predictions meets
    the same rules over other ingredients again and again (a third of its conjunctions are
    new), so small conjunctions are kept under that key (CONJUNCTIONS_KEPT of them) and a
    repeat is a copy.

    Raises InputError for no DFAs, a powerset alphabet, or an atom in two of the DFAs.
    """
    if not dfas:
        raise InputError("conjoin_nonempty needs at least one DFA")
    owner: dict[str, tuple[int, int]] = {}  # atom -> (its DFA, its letter there)
    for g, dfa in enumerate(dfas):
        if dfa.alphabet.kind != "one-hot":
            raise InputError("conjoin_nonempty reads one-hot alphabets only")
        for p, atom in enumerate(dfa.atoms, 1):
            if atom in owner:
                raise InputError(f"atom {atom} is in two of the DFAs (they must be disjoint)")
            owner[atom] = (g, p)
    alphabet = Alphabet(tuple(sorted(owner)), "one-hot")
    letters = [owner[a] for a in alphabet.atoms]
    key = (tuple(d.structure for d in dfas), tuple(letters))
    kept = _CONJUNCTIONS.get(key)
    if kept is None:
        small = _disjoint_product_small(
            [d.table.tolist() for d in dfas],
            [d.initial for d in dfas],
            [d.accepting.tolist() for d in dfas],
            letters,
        )
        if small is None:
            return reduce(lambda a, b: a.product(b, canonical=False), dfas).minimize_nonempty()
        rows, initial, accepting = _nonempty_small(*_minimize_small(*small))
        kept = (np.array(rows, dtype=np.int32), initial, np.array(accepting, dtype=bool))
        if len(_CONJUNCTIONS) >= CONJUNCTIONS_KEPT:
            _CONJUNCTIONS.pop(next(iter(_CONJUNCTIONS)))  # the oldest
        _CONJUNCTIONS[key] = kept
    table, initial, accepting = kept
    return DFA(alphabet, table.copy(), initial, accepting.copy())


# conjoin_nonempty's small conjunctions: (structures, letter layout) -> table, initial, accepting
_CONJUNCTIONS: dict[tuple, tuple[np.ndarray, int, np.ndarray]] = {}


def _disjoint_product_small(
    tables: list[list[list[int]]],
    initials: list[int],
    accepting: list[list[bool]],
    letters: list[tuple[int, int]],
) -> tuple[list[list[int]], int, list[bool]] | None:
    """The reachable synchronous product (conjunction) of DFAs over disjoint one-hot atoms, on
    lists: `letters[j]` = (DFA g, its letter p) of the product's letter j + 1; letter 0 is every
    DFA's letter 0. States are numbered in order of discovery (initial 0); a product state is
    known by its mixed-radix code. Every state with a component in a rejecting sink (`_sinks`)
    is one sink, since a conjunction with a dead part is dead: k rules "G !a" would otherwise
    walk 2**k dead combinations that minimisation merges anyway. None once the table passes
    SMALL_TABLE entries."""
    dead = [_sinks(t, a) for t, a in zip(tables, accepting, strict=True)]
    width = len(letters) + 1
    if any(d[s] for d, s in zip(dead, initials, strict=True)):
        return [[0] * width], 0, [False]
    weights = [1]
    for table in tables[:-1]:
        weights.append(weights[-1] * len(table))
    moves = [(g, p, weights[g]) for g, p in letters]
    ids = {sum(s * w for s, w in zip(initials, weights, strict=True)): 0}
    states = [list(initials)]
    rows: list[list[int]] = []
    for state in states:  # grows while it is walked: breadth-first
        zero = [table[s][0] for table, s in zip(tables, state, strict=True)]
        zero_code = sum(z * w for z, w in zip(zero, weights, strict=True))
        zero_dead = [d[z] for d, z in zip(dead, zero, strict=True)]
        dead_count = sum(zero_dead)
        # per letter: the DFA that moves, its next state, its weight (letter 0 moves none)
        steps = [(0, zero[0], 0)] + [(g, tables[g][state[g]][p], w) for g, p, w in moves]
        row = []
        for g, t, w in steps:
            if dead[g][t] or dead_count - zero_dead[g]:
                row.append(-1)  # the sink, numbered last
                continue
            code = zero_code + (t - zero[g]) * w
            i = ids.get(code)
            if i is None:
                if (len(states) + 2) * width > SMALL_TABLE:  # + 2: this state and the sink
                    return None
                i = ids[code] = len(states)
                nxt = zero.copy()
                nxt[g] = t
                states.append(nxt)
            row.append(i)
        rows.append(row)
    final = [all(acc[s] for acc, s in zip(accepting, state, strict=True)) for state in states]
    sink = len(rows)
    rows = [[sink if i < 0 else i for i in row] for row in rows] + [[sink] * width]
    return rows, 0, [*final, False]


def _sinks(table: list[list[int]], accepting: list[bool]) -> list[bool]:
    """Per state: a rejecting state that every letter leaves in place, so dead (no accepting
    state is reachable). A minimal DFA's one dead state, if it has one, is such a sink."""
    return [
        not a and row.count(s) == len(row)
        for s, (row, a) in enumerate(zip(table, accepting, strict=True))
    ]


def _nonempty_small(
    table: list[list[int]], initial: int, accepting: list[bool]
) -> tuple[list[list[int]], int, list[bool]]:
    """`DFA.minimize_nonempty(minimal=True)` on lists: `table` must be minimal (all states
    reachable, pairwise distinct); the same choice of the initial state's acceptance."""
    after = list(dict.fromkeys(table[initial]))  # reachable in one step or more
    seen = set(after)
    for s in after:
        for t in table[s]:
            if t not in seen:
                seen.add(t)
                after.append(t)
    same_row = sorted(s for s in seen if table[s] == table[initial])
    best: tuple[int, bool, list[int]] | None = None
    for accept_empty in (False, True):
        twin = [s for s in same_row if accepting[s] == accept_empty]
        size = len(seen) + (not twin)
        if best is None or size < best[0]:
            best = (size, accept_empty, twin)
    _, accept_empty, twin = best
    if twin:  # the fresh start is an existing state
        return _renumber_small(table, twin[0], accepting)
    return _renumber_small([*table, table[initial]], len(table), [*accepting, accept_empty])


def _minimize_small(
    table: list[list[int]], initial: int, accepting: list[bool]
) -> tuple[list[list[int]], int, list[bool]]:
    """`DFA.minimize` on lists: reachable states, Moore refinement, breadth-first numbering with
    successors in letter order (the canonical form `_renumber_bfs` gives)."""
    order = [initial]
    seen = {initial}
    for s in order:
        for t in table[s]:
            if t not in seen:
                seen.add(t)
                order.append(t)
    cls = {s: int(accepting[s]) for s in order}
    count = len(set(cls.values()))
    while True:
        ids: dict[tuple, int] = {}
        new = {s: ids.setdefault((cls[s], *[cls[t] for t in table[s]]), len(ids)) for s in order}
        cls = new
        if len(ids) == count:
            break
        count = len(ids)
    # Breadth-first from the initial class, successors in letter order; one row per class.
    rep: dict[int, int] = {}
    for s in order:
        rep.setdefault(cls[s], s)
    number = {cls[initial]: 0}
    queue = [cls[initial]]
    for c in queue:
        for t in table[rep[c]]:
            if cls[t] not in number:
                number[cls[t]] = len(queue)
                queue.append(cls[t])
    rows = [[number[cls[t]] for t in table[rep[c]]] for c in queue]
    return rows, 0, [accepting[rep[c]] for c in queue]


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
        rows, start, acc = _renumber_small(table.tolist(), initial, accepting.tolist())
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


def _renumber_small(
    table: list[list[int]], initial: int, accepting: list[bool]
) -> tuple[list[list[int]], int, list[bool]]:
    """`_renumber_reachable` on lists: breadth-first, successors in letter order."""
    number = {initial: 0}
    order = [initial]
    for s in order:
        for t in table[s]:
            if t not in number:
                number[t] = len(order)
                order.append(t)
    return [[number[t] for t in table[s]] for s in order], 0, [accepting[s] for s in order]


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
