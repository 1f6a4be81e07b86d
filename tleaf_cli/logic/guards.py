"""Edge guards: a set of letters written as a propositional formula, as text and as CNF.

A DFA edge (src, dst) is taken on a set of letters. tleaf stores that set two ways: `cnf`, clauses
of signed 1-based indices into the DFA's atoms (`[]` is true), for the graph embedders; and `text`
in ltlf2dfa's propositional syntax for people.

Powerset alphabet: the set is a truth table over 2**n letters. Its cover is the irredundant sum
of products of Minato and Morreale (ISOP): for a table f split on its top variable x into
f0 (x false) and f1 (x true),

    ISOP(f) = !x & ISOP(f0 minus f1) | x & ISOP(f1 minus f0) | ISOP(what is left, within f0 & f1),

which never lists a cube covered by the others. The CNF is the negated ISOP of the complement.
The text is whichever of the DNF and the CNF is shorter. This replaces ltlf2dfa's sympy
`simplify` (seconds to minutes per edge) with array operations (microseconds).

One-hot alphabet: exactly one domain atom holds per step, so a guard is either "one of these
atoms" (`a | b`, when the empty letter is not in the set) or "none of those atoms" (`!a & !b`,
when it is) — exact under the one-hot assumption, and what the `--one-hot` stages rely on.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from tleaf_cli.errors import InputError
from tleaf_cli.logic.alphabet import Alphabet

Clause = tuple[int, ...]


@dataclass(frozen=True)
class Guard:
    """A guard's readable text and its CNF (clauses of signed 1-based atom indices)."""

    text: str
    cnf: tuple[Clause, ...]


def guard_for(letters: np.ndarray, alphabet: Alphabet) -> Guard:
    """The guard that holds exactly on the letters where the bool vector `letters` is True."""
    letters = np.asarray(letters, dtype=bool)
    if letters.shape != (alphabet.size,):
        raise InputError(f"expected {alphabet.size} letters, got shape {letters.shape}")
    if letters.all():
        return Guard("true", ())
    if not letters.any():
        return Guard("false", ((),))
    if alphabet.kind == "one-hot":
        return _one_hot_guard(letters, alphabet.atoms)
    on = int.from_bytes(np.packbits(letters, bitorder="little").tobytes(), "little")
    return _powerset_guard(on, alphabet.atoms)


@lru_cache(maxsize=1 << 16)
def _powerset_guard(on: int, atoms: tuple[str, ...]) -> Guard:
    """The guard of the letter set `on` (bit i = letter i); cached, as product DFAs repeat
    the same letter sets on many edges (12,362 distinct among 29,596 edges, measured)."""
    n = len(atoms)
    off_set = ((1 << (1 << n)) - 1) ^ on
    dnf, _ = _isop(on, on, n)
    off, _ = _isop(off_set, off_set, n)
    # ISOP lists each cube's literals in atom order and its cubes in an order fixed by the
    # function alone, so the result is canonical without sorting.
    cnf = tuple(tuple(-lit for lit in cube) for cube in off)
    as_dnf = _render(dnf, atoms, inner=" & ", outer=" | ")
    as_cnf = _render(cnf, atoms, inner=" | ", outer=" & ")
    return Guard(as_cnf if len(as_cnf) < len(as_dnf) else as_dnf, cnf)


def cnf_holds(cnf: tuple[Clause, ...] | list[list[int]], alphabet: Alphabet) -> np.ndarray:
    """Bool vector over the alphabet's letters: where the CNF is true."""
    truth = alphabet.truth()
    out = np.ones(alphabet.size, dtype=bool)
    for clause in cnf:
        sat = np.zeros(alphabet.size, dtype=bool)
        for lit in clause:
            k = abs(lit) - 1
            if not 0 <= k < len(alphabet.atoms):
                raise InputError(f"literal {lit} out of range for {len(alphabet.atoms)} atoms")
            sat |= truth[:, k] if lit > 0 else ~truth[:, k]
        out &= sat
    return out


def _one_hot_guard(letters: np.ndarray, atoms: tuple[str, ...]) -> Guard:
    if not letters[0]:
        on = [k for k in range(len(atoms)) if letters[k + 1]]
        return Guard(" | ".join(atoms[k] for k in on), (tuple(k + 1 for k in on),))
    off = [k for k in range(len(atoms)) if not letters[k + 1]]
    return Guard(" & ".join(f"!{atoms[k]}" for k in off), tuple((-(k + 1),) for k in off))


@lru_cache(maxsize=1 << 16)
def _isop(lower: int, upper: int, nvars: int) -> tuple[tuple[Clause, ...], int]:
    """Minato-Morreale on truth tables held as int bitsets (bit i = letter i): the cubes covering
    `lower` inside `upper`, and the function they cover. Memoised: DFAs repeat subfunctions."""
    full = (1 << (1 << nvars)) - 1
    if lower == 0:
        return (), 0
    if upper == full:
        return ((),), full
    top = nvars - 1
    half = 1 << top
    mask = (1 << half) - 1
    l0, l1, u0, u1 = lower & mask, lower >> half, upper & mask, upper >> half
    c0, f0 = _isop(l0 & (mask ^ u1), u0, top)
    c1, f1 = _isop(l1 & (mask ^ u0), u1, top)
    cs, fs = _isop((l0 & (mask ^ f0)) | (l1 & (mask ^ f1)), u0 & u1, top)
    lit = top + 1
    cubes = tuple((*c, -lit) for c in c0) + tuple((*c, lit) for c in c1) + cs
    return cubes, (f0 | fs) | ((f1 | fs) << half)


def _render(terms, atoms: tuple[str, ...], inner: str, outer: str) -> str:
    parts = []
    for term in terms:
        lits = [atoms[lit - 1] if lit > 0 else f"!{atoms[-lit - 1]}" for lit in term]
        body = inner.join(lits)
        parts.append(f"({body})" if len(lits) > 1 and len(terms) > 1 else body)
    return outer.join(parts)
