"""Temporal monitors: small fixed automata over one or two literals, and the share of a DFA's
words that each one accepts.

A monitor reads a word through two Boolean inputs per letter, p = atom i holds and q = atom j
holds (i, j are positions in the formula's sorted atoms; i = j for the one-atom monitors), and
says whether a simple temporal pattern occurred. The patterns are the building blocks of the
formulas people and the generator write (LTLf's F, G, U, X and the ends of the trace):

    one atom p   F p,  G p,  p at letter 1, 2, 3,  p at the last letter, at the one before
    atoms p, q   p U q,  F(p & X q),  G(p -> X q),  G(p -> F q)   (ordered pairs, each literal
                 either sign), and F(p & q) (unordered pairs, each sign)

A trace w gets ψ(w): 1 where a monitor accepts it, else 0. A DFA A gets, for its accepted words
and for its rejected ones, the share that each monitor accepts,

    μ(A) = mean over lengths T of P(monitor accepts w | w uniform among the accepted words of
           length T)

over the lengths 1..max_length that have such words, computed exactly by a forward pass through
the product of A and the monitors (no sampling). The DFA's own language is a Boolean function of
where its words lead; these shares describe it by patterns every formula shares, so a formula
never seen in training is described in the same coordinates as the ones that were, and a trace
sits in them too. With the shares of accepted and of rejected words, "is ψ(w) nearer the
accepted mean than the rejected one" already decides membership for most formulas
(docs/results/model_checking.md measures how often).

With R length ranges (`ranges`), the shares are kept per range of word length (lengths
1..max_length cut in R equal ranges) and a word fills its own length's range: a trace is then
compared with the formula's words of about its own length.

Atoms are taken by position: slot k is the DFA's k-th atom (its alphabet's sorted atoms); a
DFA with fewer atoms than `slots` leaves the missing slots' features at 0, one with more
ignores the extra atoms. Numpy only (logic never imports torch).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from tleaf_cli.logic.dfa import DFA
from tleaf_cli.logic.kept import Kept
from tleaf_cli.logic.letter_walks import rest_walk, table_walk

STATES = 5  # every monitor padded to this many states (the positional ones need 5)
# raise whenever `MonitorBank.of_dfa` computes other shares from the same bank and DFA: the
# on-disk cache of shares (data/monitor_cache.py) keys on it
SHARES_VERSION = 1
# `MonitorBank.of_dfa` results kept per bank (a trainer's rule sets repeat a few dozen automata
# over ever new atoms): 1,024 of 13 KB each for a 10-slot bank
SHARES_KEPT = 1024
# `of_dfa` builds the DFA's one-hot moves [letters, n, n] densely up to this many entries; a
# larger DFA over a one-hot alphabet walks its table instead (a recipe's conjunction of 25
# precedence rules: 12,401 states over 24 letters, 27.5 GiB dense)
DENSE_MOVES = 1 << 24

# Templates: (transition rows [states][class], accepting states); class = p + 2 q of a letter.
_ONE_ATOM: dict[str, tuple[list[list[int]], list[int]]] = {
    "F": ([[0, 1, 0, 1], [1, 1, 1, 1]], [1]),
    "G": ([[1, 0, 1, 0], [1, 1, 1, 1]], [0]),
    # p at letter k (1-based): states 0..k-1 count letters, then yes (k) / no (k + 1)
    "at1": ([[2, 1, 2, 1], [1, 1, 1, 1], [2, 2, 2, 2]], [1]),
    "at2": ([[1, 1, 1, 1], [3, 2, 3, 2], [2, 2, 2, 2], [3, 3, 3, 3]], [2]),
    "at3": (
        [[1, 1, 1, 1], [2, 2, 2, 2], [4, 3, 4, 3], [3, 3, 3, 3], [4, 4, 4, 4]],
        [3],
    ),
    "last": ([[0, 1, 0, 1], [0, 1, 0, 1]], [1]),
    # states: (p at the letter before the last, p at the last) as 2 * before + last
    "before_last": (
        [[0, 1, 0, 1], [2, 3, 2, 3], [0, 1, 0, 1], [2, 3, 2, 3]],
        [2, 3],
    ),
}
_TWO_ATOMS: dict[str, tuple[list[list[int]], list[int]]] = {
    # 0 undecided, 1 true, 2 false
    "U": ([[2, 0, 1, 1], [1, 1, 1, 1], [2, 2, 2, 2]], [1]),
    # 0 nothing pending, 1 the last letter had p, 2 found p then q
    "F_and_X": ([[0, 1, 0, 1], [0, 1, 2, 2], [2, 2, 2, 2]], [2]),
    # 0 fine, 1 p at the last letter (q owed next), 2 failed; strong next: owed at the end fails
    "G_X": ([[0, 1, 0, 1], [2, 2, 0, 1], [2, 2, 2, 2]], [0]),
    # 0 nothing owed, 1 a p still waits for a q
    "G_F": ([[0, 1, 0, 0], [1, 1, 0, 0]], [0]),
}
_TOGETHER: tuple[list[list[int]], list[int]] = ([[0, 0, 0, 1], [1, 1, 1, 1]], [1])  # F(p & q)


@dataclass(frozen=True)
class Monitor:
    """One monitor: its pattern, the atom slots (i, j) and signs it reads, its tables."""

    name: str
    slots: tuple[int, int]
    signs: tuple[bool, bool]  # True: the atom itself; False: its negation
    table: np.ndarray  # int [STATES, 4]: next state on class p + 2 q
    accepting: np.ndarray  # bool [STATES]

    def __str__(self) -> str:
        p, q = (("" if s else "!") + f"x{k}" for s, k in zip(self.signs, self.slots, strict=True))
        return f"{self.name}({p})" if self.slots[0] == self.slots[1] else f"{self.name}({p},{q})"


def _padded(rows: list[list[int]], accepting: list[int]) -> tuple[np.ndarray, np.ndarray]:
    table = np.tile(np.arange(STATES)[:, None], (1, 4))  # padding states stay put
    table[: len(rows)] = rows
    acc = np.zeros(STATES, dtype=bool)
    acc[accepting] = True
    return table, acc


class MonitorBank:
    """The monitors over `slots` atom positions, and their features of DFAs and of words.

    Args:
        slots: K, how many of a formula's atoms (by position) the monitors read.
        max_length: the longest words of a DFA counted.
        ranges: R, ranges of word length kept apart: lengths 1..max_length cut in R equal
            ranges (longer words in the last); a DFA gets its shares per range, a word fills
            its own length's range and leaves the others 0.

    `width` = 7 K + 18 K (K - 1) monitors; `features` = R · width per set of words.
    """

    def __init__(self, slots: int, max_length: int = 12, ranges: int = 1) -> None:
        self.slots, self.max_length, self.ranges = slots, max_length, ranges
        monitors = []
        for i in range(slots):
            for name, (rows, acc) in _ONE_ATOM.items():
                monitors.append(Monitor(name, (i, i), (True, True), *_padded(rows, acc)))
        for (i, j), signs in itertools.product(
            itertools.permutations(range(slots), 2), itertools.product((True, False), repeat=2)
        ):
            for name, (rows, acc) in _TWO_ATOMS.items():
                monitors.append(Monitor(name, (i, j), signs, *_padded(rows, acc)))
            if i < j:
                monitors.append(Monitor("F_and", (i, j), signs, *_padded(*_TOGETHER)))
        self.monitors = monitors
        self.tables = np.stack([m.table for m in monitors])  # [M, S, 4]
        self.accepting = np.stack([m.accepting for m in monitors])  # [M, S]
        # [M]: how many states each monitor uses (its template's; the rest is padding that no
        # state reaches), so that a walk can skip the padding
        reach = np.zeros((len(monitors), STATES), dtype=bool)
        reach[:, 0] = True
        for _ in range(STATES):
            m, s = np.nonzero(reach)
            reach[m[:, None], self.tables[m, s]] = True
        self.sizes = STATES - np.argmax(reach[:, ::-1], axis=1)  # 1 + the last state reached
        # steps[m, c, s, s'] = 1 where monitor m goes s -> s' on class c
        self.steps = np.zeros((len(monitors), 4, STATES, STATES))
        mm, ss, cc = np.meshgrid(*(np.arange(k) for k in self.tables.shape), indexing="ij")
        self.steps[mm, cc, ss, self.tables[mm, ss, cc]] = 1.0
        # the most states any monitor state is entered from, over all classes (2 for these
        # templates): how many edges in a soft walk lays out per state (embed/soft_monitors.py)
        self.in_edges = int(self.steps.any(axis=1).sum(axis=1).max())
        self._classes: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}  # per alphabet
        self._layouts: dict[tuple, _Layout] = {}  # per alphabet
        self._plans: dict[tuple, _OneHotPlan | None] = {}  # per one-hot alphabet
        self._shares = Kept(SHARES_KEPT)  # `of_dfa` per automaton

    @property
    def width(self) -> int:
        return len(self.monitors)

    @property
    def features(self) -> int:
        return self.ranges * self.width

    def range_of(self, length: int) -> int:
        """The length range a word of `length` letters falls in."""
        return min(self.ranges - 1, (length - 1) * self.ranges // self.max_length)

    def names(self) -> list[str]:
        return [str(m) for m in self.monitors]

    def classes(self, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """[M, letters]: each monitor's input class on each letter (truth: [letters, atoms]);
        and [M]: whether the monitor's atoms exist in this alphabet. Computed once per
        alphabet (read-only arrays): a traces file holds tens of thousands of words over a few
        alphabets, and this is most of the cost of `of_word`."""
        key = _alphabet_key(truth)
        if key not in self._classes:
            self._classes[key] = self._compute_classes(truth)
        return self._classes[key]

    def _compute_classes(self, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        atoms = truth.shape[1]
        slots = np.array([m.slots for m in self.monitors])  # [M, 2]
        signs = np.array([m.signs for m in self.monitors])
        present = (slots < atoms).all(axis=1)
        padded = np.concatenate([truth, np.zeros((len(truth), 1), dtype=bool)], axis=1)
        columns = np.where(slots < atoms, slots, atoms)  # absent atoms read a False column
        p = signs[:, :1] == padded[:, columns[:, 0]].T
        q = signs[:, 1:] == padded[:, columns[:, 1]].T
        classes = p.astype(np.int64) + 2 * q.astype(np.int64)
        for array in (classes, present):
            array.setflags(write=False)
        return classes, present

    def of_word(self, truth: np.ndarray, letters: Sequence[int]) -> np.ndarray:
        """[features] float32: in the word's length range, 1 where a monitor accepts the word
        (letter indices of an alphabet whose atom truth table is `truth`, [letters, atoms]),
        else 0; the other ranges 0."""
        classes, present = self.classes(truth)
        rows = np.arange(len(self.monitors))
        state = np.zeros(len(self.monitors), dtype=np.int64)
        for letter in letters:
            state = self.tables[rows, state, classes[:, letter]]
        out = np.zeros((self.ranges, self.width), dtype=np.float32)
        out[self.range_of(len(letters))] = self.accepting[rows, state] & present
        return out.ravel()

    def of_dfa(self, dfa: DFA, *, general: bool = False) -> np.ndarray:
        """[2, features] float32: the share of the DFA's accepted (row 0) and rejected (row 1)
        words that each monitor accepts, per length range the mean over its lengths with such
        words (0 where there are none).

        Over a one-hot alphabet a monitor tells only three kinds of letter apart (its two
        atoms' letters and the rest), which `_hits_one_hot` exploits (3-11x faster on the
        action-recognition rule sets); other alphabets, or `general=True` (the tests' oracle),
        go through `_hits_general`. Both give the same shares up to float rounding."""
        truth = dfa.alphabet.truth()
        # the shares read the DFA's table and its alphabet's truth table, never the atoms'
        # names: rule sets over other atoms with the same automaton share them
        key = (dfa.structure, general)
        if key in self._shares:
            return self._shares[key].copy()
        _, present = self.classes(truth)
        a, n = dfa.alphabet.size, dfa.num_states
        plan = None if general or dfa.alphabet.kind != "one-hot" else self._one_hot_plan(truth)
        ends = np.stack([dfa.accepting, ~dfa.accepting]).astype(float)  # [2, n]
        if plan is not None and a * n * n > DENSE_MOVES:  # the table's walk, never [a, n, n]
            at = [np.eye(1, n, dfa.initial)[0]]  # P(at u after t uniform letters)
            into, rows = dfa.table.ravel(), np.repeat(np.arange(n), a)  # u --letter--> v
            for _ in range(self.max_length):
                at.append(np.bincount(into, weights=at[-1][rows], minlength=n) / a)
            mass = np.stack(at[1:]) @ ends.T  # [lengths, 2]
            hit = self._hits_one_hot(dfa, plan, ends, table_walk(dfa.table))
        else:
            # the DFA alone: P(at u after t uniform letters), for each length's accepted mass
            onehot = np.zeros((a, n, n))
            onehot[np.arange(a)[:, None], np.arange(n)[None, :], dfa.table.T] = 1.0
            step = onehot.mean(axis=0)
            at = [np.eye(n)[dfa.initial]]
            for _ in range(self.max_length):
                at.append(at[-1] @ step)
            mass = np.stack(at[1:]) @ ends.T  # [lengths, 2]
            if plan is not None:
                hit = self._hits_one_hot(dfa, plan, ends, rest_walk(onehot.sum(axis=0)))
            else:
                hit = self._hits_general(dfa, onehot, ends)
        shares = self._averaged(hit, mass, present)
        self._shares.keep(key, shares)
        return shares.copy()

    def _hits_general(self, dfa: DFA, onehot: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """[lengths, 2, M]: P(a uniform word of length t + 1 ends in the DFA's accepting
        (row 0) / rejecting (row 1) states and monitor m accepts it), for any alphabet.

        Monitors that read the same literals move alike on the DFA's letters: per group of
        them, moves[c, u, u'] = the share of letters of class c that take state u to u'. All
        present monitors then go through the product with the DFA at once, one batched
        product per letter of the word."""
        layout = self._layout(dfa.alphabet.truth())
        n = dfa.num_states
        hit = np.zeros((self.max_length, 2, self.width))
        if len(layout.members):
            members, group, slot = layout.members, layout.group, layout.slot
            groups, size = layout.step.shape[:2]
            # moves[g, v, (c, u)]: the share of letters of class c that take state u to v
            moves = np.einsum("gca,auv->gvcu", layout.by_class, onehot, optimize=True)
            moves = moves.reshape(groups, n, 4 * n)
            alpha = np.zeros((groups, size, n, STATES))  # P(DFA at u, monitor at s)
            alpha[group, slot, dfa.initial, 0] = 1.0
            for t in range(self.max_length):
                monitor_moved = alpha[:, :, None] @ layout.step  # [g, slot, c, u, s']
                stacked = monitor_moved.transpose(0, 2, 3, 1, 4).reshape(groups, 4 * n, -1)
                alpha = (moves @ stacked).reshape(groups, n, size, STATES).transpose(0, 2, 1, 3)
                ends_at = (alpha * layout.accepting).sum(axis=-1)[group, slot]  # [members, n]
                hit[t][:, members] = ends @ ends_at.T
        return hit

    def _hits_one_hot(self, dfa: DFA, plan: _OneHotPlan, ends: np.ndarray, walk) -> np.ndarray:
        """`_hits_general`'s hits over a one-hot alphabet, by a backward pass over the rows of
        `_one_hot_plan`; `walk`: B -> sum_v counts[u, v] B[..., v], where `counts[u, v]` is how
        many letters take u to v (`rest_walk`, `table_walk`).

        beta_t[r, e, u] = P(a uniform word of t letters read from DFA state u and monitor state
        r ends in the DFA's end e (accepting / rejecting) with the monitor accepting). A monitor
        reading atoms i, j moves on class R for every letter but its atoms' letters I and J, so

            beta_{t+1}[r, e, u] = (sum_v counts[u, v] beta_t[R(r), e, v]
                                   + beta_t[I(r), e, I(u)] - beta_t[R(r), e, I(u)]
                                   + beta_t[J(r), e, J(u)] - beta_t[R(r), e, J(u)]) / letters

        ("the rest" is all letters minus I and J): one matrix product with `counts` for all
        rows, and row and column gathers, where the general path builds moves per class and
        group and transposes the product state each letter. hit[t][e, m] = beta_{t+1} at
        monitor m's start row and the DFA's initial state. The subtractions lose at most a few
        ulps of beta, itself at most the DFA's own mass from u, so a share (hit / mass) keeps
        its relative precision."""
        n, letters = dfa.num_states, dfa.alphabet.size
        rows = len(plan.accepting)
        table = dfa.table.T.astype(np.intp)  # [letters, n]
        terms = []  # (rows, the rows' I (J) letter's next rows, flat index of (r, e, I(u)))
        for rows, letter, follow in (
            (plan.first_rows, plan.first_letter, plan.first),
            (plan.second_rows, plan.second_letter, plan.second),
        ):
            jump = table[letter[rows]]  # [rows, n]
            at = np.arange(jump.shape[0] * 2).reshape(-1, 2, 1) * n
            terms.append((rows, follow[rows], plan.rest[rows], at + jump[:, None, :]))
        beta = plan.accepting[:, None, None] * ends[None]  # [rows, 2, n]
        hit = np.zeros((self.max_length, 2, self.width))
        for t in range(self.max_length):
            moved = walk(beta[plan.rest])
            for rows, follow, rest, flat in terms:
                moved[rows] += (beta[follow] - beta[rest]).take(flat)
            beta = moved
            beta /= letters
            hit[t][:, plan.members] = beta[plan.start, :, dfa.initial].T
        return hit

    def _one_hot_plan(self, truth: np.ndarray) -> _OneHotPlan | None:
        """How `_hits_one_hot` runs the present monitors over a one-hot alphabet (truth: its
        [letters, atoms] table), built once per alphabet; None where a monitor reads more
        than three classes of letter (not a one-hot alphabet).

        A row is a monitor state reachable from its start on this alphabet's letters; the
        states that never leave (on all its classes) are shared by every monitor: row 0 is
        "rejected for good" (stays 0), row 1 "accepted for good" (the DFA's own walk). The
        pair monitors keep 7.5 rows on average instead of 22.5 padded states."""
        key = _alphabet_key(truth)
        if key in self._plans:
            return self._plans[key]
        classes, present = self.classes(truth)
        members = np.flatnonzero(present)
        slots = np.array([m.slots for m in self.monitors], dtype=np.intp).reshape(-1, 2)[members]
        first_letter, second_letter = slots[:, 0] + 1, slots[:, 1] + 1  # letter k + 1: atom k
        kind = classes[members]  # [m, letters]
        rest, first, second = (
            np.take_along_axis(kind, c[:, None], axis=1)[:, 0]
            for c in (np.zeros_like(first_letter), first_letter, second_letter)
        )
        others = np.ones(kind.shape, dtype=bool)
        for letter in (first_letter, second_letter):
            others[np.arange(len(members)), letter] = False
        if (
            truth[0].any()
            or truth.shape[0] != truth.shape[1] + 1
            or (kind != rest[:, None])[others].any()
        ):
            self._plans[key] = None
            return None
        # a one-atom monitor has no second letter: its J term must vanish (J moves as R)
        second = np.where(slots[:, 0] == slots[:, 1], rest, second)
        tables = self.tables[members]  # [m, S, 4]
        moves = np.stack([tables[np.arange(len(members)), :, c] for c in (rest, first, second)])
        reach = np.zeros((len(members), STATES), dtype=bool)  # [m, S]
        reach[:, 0] = True
        for _ in range(STATES):
            reached = reach.copy()
            for move in moves:  # [m, S]
                m, s = np.nonzero(reach)
                reached[m, move[m, s]] = True
            reach = reached
        stays = (moves == np.arange(STATES)).all(axis=0)
        accepting = self.accepting[members]
        row = np.full((len(members), STATES), -1, dtype=np.intp)
        row[stays & ~accepting] = 0
        row[stays & accepting] = 1
        own = reach & ~stays
        row[own] = 2 + np.arange(own.sum())
        m, s = np.nonzero(own)
        follows = np.stack([np.concatenate([[0, 1], row[m, move[m, s]]]) for move in moves])
        letters = np.stack([np.concatenate([[0, 0], x[m]]) for x in (first_letter, second_letter)])
        # rows whose I (J) letter moves the monitor elsewhere than the rest do: I-only rows,
        # then I and J, then J-only, then neither, so that each term is a slice of rows
        moved_by = follows[1:] != follows[0]  # [2, rows]
        kind_of_row = np.select(
            [moved_by[0] & ~moved_by[1], moved_by[0], moved_by[1]], [0, 1, 2], 3
        )
        order = np.argsort(kind_of_row, kind="stable")
        renamed = np.empty_like(order)
        renamed[order] = np.arange(len(order))
        bounds = np.cumsum(np.bincount(kind_of_row, minlength=4))
        plan = _OneHotPlan(
            members=members,
            start=renamed[row[:, 0]],
            accepting=np.concatenate([[0.0, 1.0], accepting[m, s]])[order],
            rest=renamed[follows[0, order]],
            first=renamed[follows[1, order]],
            second=renamed[follows[2, order]],
            first_letter=letters[0, order],
            second_letter=letters[1, order],
            first_rows=slice(0, int(bounds[1])),
            second_rows=slice(int(bounds[0]), int(bounds[2])),
        )
        self._plans[key] = plan
        return plan

    def _averaged(self, hit: np.ndarray, mass: np.ndarray, present: np.ndarray) -> np.ndarray:
        """`of_dfa`'s result from the hits [lengths, 2, M] and the DFA's own mass [lengths, 2]
        of accepted / rejected words: shares per length, averaged per length range."""
        share = np.where(mass[:, :, None] > 0, hit / np.where(mass > 0, mass, 1)[:, :, None], 0)
        # [lengths, R]: 1 where length t + 1 falls in range r; sums over each range's lengths
        in_range = np.eye(self.ranges)[[self.range_of(t + 1) for t in range(self.max_length)]]
        out = np.einsum("tew,tr->erw", share, in_range)
        counted = ((mass > 0).T.astype(float) @ in_range)[:, :, None]
        out = out / np.maximum(counted, 1) * present
        return out.reshape(2, -1).astype(np.float32)

    def _layout(self, truth: np.ndarray) -> _Layout:
        """How `of_dfa` lays the present monitors out for an alphabet, built once per alphabet:
        monitors that read the same literals (equal class rows) share a group, so that the
        DFA's moves per class are built once per group; each has a slot in its group."""
        key = _alphabet_key(truth)
        if key in self._layouts:
            return self._layouts[key]
        classes, present = self.classes(truth)
        members = np.flatnonzero(present)
        group = slot = members
        groups = size = 0
        if len(members):
            _, group = np.unique(classes[members], axis=0, return_inverse=True)
            group = group.reshape(-1)
            order = np.argsort(group, kind="stable")
            starts = np.concatenate([[0], np.cumsum(np.bincount(group))[:-1]])
            slot = np.empty_like(group)
            slot[order] = np.arange(len(group)) - starts[group[order]]
            groups, size = group.max() + 1, slot.max() + 1
        letters = classes.shape[1]
        # by_class[g, c, a] = 1/letters where letter a is of class c for group g's monitors
        by_class = np.zeros((groups, 4, letters))
        by_class[group[:, None], classes[members], np.arange(letters)] = 1.0 / letters
        # the monitors' moves and accepting states laid out [group, slot] (unused slots never
        # move and accept nothing)
        step = np.zeros((groups, size, 4, STATES, STATES))
        step[group, slot] = self.steps[members]
        accepting = np.zeros((groups, size, 1, STATES))
        accepting[group, slot, 0] = self.accepting[members]
        layout = _Layout(members, group, slot, by_class, step, accepting)
        self._layouts[key] = layout
        return layout


class _Layout(NamedTuple):
    """A bank's present monitors for one alphabet, as `MonitorBank.of_dfa` runs them."""

    members: np.ndarray  # [m] the present monitors
    group: np.ndarray  # [m] each one's group (monitors reading the same literals)
    slot: np.ndarray  # [m] its place in its group
    by_class: np.ndarray  # [groups, 4, letters]: 1/letters where a letter is of class c
    step: np.ndarray  # [groups, slots, 4, S, S]: the monitors' moves on each class
    accepting: np.ndarray  # [groups, slots, 1, S]


class _OneHotPlan(NamedTuple):
    """A bank's present monitors over one one-hot alphabet, as `_hits_one_hot` runs them: rows
    0 and 1 are the shared "rejected" / "accepted for good" states, then each monitor's other
    reachable states."""

    members: np.ndarray  # [m] the present monitors
    start: np.ndarray  # [m] each one's start row
    accepting: np.ndarray  # [rows] 1.0 where the row's state accepts
    rest: np.ndarray  # [rows] the row after a letter of neither atom (class R)
    first: np.ndarray  # [rows] the row after the first atom's letter (I)
    second: np.ndarray  # [rows] the row after the second atom's letter (J)
    first_letter: np.ndarray  # [rows] the letter I (0 for the shared rows: they never move)
    second_letter: np.ndarray  # [rows] the letter J
    first_rows: slice  # the rows that I moves elsewhere than R (the others' I term is 0)
    second_rows: slice  # the rows that J moves elsewhere than R


def _alphabet_key(truth: np.ndarray) -> tuple:
    """A dictionary key for an alphabet, from its atom truth table [letters, atoms]."""
    return truth.shape, truth.tobytes()
