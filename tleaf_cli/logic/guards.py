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
from tleaf_cli.logic.alphabet import MAX_POWERSET_ATOMS, Alphabet

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
    if alphabet.kind == "one-hot":
        if letters.all():
            return Guard("true", ())
        if not letters.any():
            return Guard("false", ((),))
        return _one_hot_guard(letters, alphabet.atoms)
    on = int.from_bytes(np.packbits(letters, bitorder="little").tobytes(), "little")
    known = _known_guards(alphabet.atoms)
    guard = known.get(on)
    if guard is None:
        guard = known[on] = powerset_guard(on, alphabet.atoms)
    return guard


def row_guards(row: np.ndarray, alphabet: Alphabet) -> list[tuple[int, Guard]]:
    """(successor, guard) for each distinct entry of one DFA table row, successors ascending:
    the guards of one state's edges, with the letter sets cut out in one array operation."""
    successors = np.unique(row)
    hits = row[None, :] == successors[:, None]
    atoms = alphabet.atoms
    if alphabet.kind == "one-hot":
        return [(int(d), guard_for(hit, alphabet)) for d, hit in zip(successors, hits, strict=True)]
    packed = np.packbits(hits, axis=1, bitorder="little")
    width, raw = packed.shape[1], packed.tobytes()
    known = _known_guards(atoms)
    if len(known) > MAX_KNOWN_GUARDS:
        known.clear()
    out = []
    for k, d in enumerate(successors.tolist()):
        on = int.from_bytes(raw[k * width : (k + 1) * width], "little")
        guard = known.get(on)
        if guard is None:
            guard = known[on] = powerset_guard(on, atoms)
        out.append((d, guard))
    return out


# Guards remembered per alphabet: product DFAs repeat the same letter sets on many edges (12,362
# distinct among 29,596 edges of the 12-atom chain, measured).
MAX_KNOWN_GUARDS = 1 << 16


@lru_cache(maxsize=64)
def _known_guards(atoms: tuple[str, ...]) -> dict[int, Guard]:
    return {}


def clear_caches() -> None:
    """Forget every guard and cover computed so far (for benchmarks that time them cold)."""
    _known_guards.cache_clear()
    _isop.cache_clear()
    _term_widths.cache_clear()


def powerset_guard(on: int, atoms: tuple[str, ...]) -> Guard:
    """The guard of the letter set `on` (bit i = letter i) over a powerset alphabet."""
    n = len(atoms)
    full = (1 << (1 << n)) - 1
    if on == full:
        return Guard("true", ())
    if on == 0:
        return Guard("false", ((),))
    dnf, _ = _cover(on, on, n, 1)
    cnf, _ = _cover(full ^ on, full ^ on, n, -1)  # the complement's cover, literals negated
    # ISOP lists each cube's literals in atom order and its cubes in an order fixed by the
    # function alone, so the result is canonical without sorting. Only the shorter text is
    # written out; lengths are counted first.
    if _rendered_length(cnf, atoms, 3) < _rendered_length(dnf, atoms, 3):
        return Guard(_render(cnf, atoms, inner=" | ", outer=" & "), cnf)
    return Guard(_render(dnf, atoms, inner=" & ", outer=" | "), cnf)


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


_FULL = [(1 << (1 << n)) - 1 for n in range(MAX_POWERSET_ATOMS + 1)]  # all letters of n atoms
_TRUE_COVER: tuple[Clause, ...] = ((),)


def _cover(lower: int, upper: int, nvars: int, sign: int) -> tuple[tuple[Clause, ...], int]:
    """Minato-Morreale ISOP on truth tables held as int bitsets (bit i = letter i): the cubes
    covering `lower` inside `upper`, and the function they cover. Literals are multiplied by
    `sign` (-1 turns a cover of the complement into CNF clauses)."""
    if lower == 0:
        return (), 0
    if upper == _FULL[nvars]:
        return _TRUE_COVER, upper
    return _isop(lower, upper, nvars, sign)


@lru_cache(maxsize=1 << 16)  # entries hold truth tables of up to 2**16 bits: memory bounded
def _isop(lower: int, upper: int, nvars: int, sign: int) -> tuple[tuple[Clause, ...], int]:
    """`_cover` past its two trivial cases (lower is not empty, upper not everything), memoised:
    DFAs repeat subfunctions. The trivial cases are decided inline, before a call: a third of
    the calls, each a cache entry keyed on a large int otherwise."""
    top = nvars - 1
    half = 1 << top
    mask = _FULL[top]
    l0, l1, u0, u1 = lower & mask, lower >> half, upper & mask, upper >> half
    part = l0 & ~u1
    if part == 0:
        c0, f0 = (), 0
    else:
        c0, f0 = (_TRUE_COVER, mask) if u0 == mask else _isop(part, u0, top, sign)
    part = l1 & ~u0
    if part == 0:
        c1, f1 = (), 0
    else:
        c1, f1 = (_TRUE_COVER, mask) if u1 == mask else _isop(part, u1, top, sign)
    part, both = (l0 & ~f0) | (l1 & ~f1), u0 & u1
    if part == 0:
        cs, fs = (), 0
    else:
        cs, fs = (_TRUE_COVER, mask) if both == mask else _isop(part, both, top, sign)
    if c0 or c1:
        negative, positive = (-nvars * sign,), (nvars * sign,)
        cs = tuple([c + negative for c in c0] + [c + positive for c in c1]) + cs
    return cs, (f0 | fs) | ((f1 | fs) << half)


def _rendered_length(terms, atoms: tuple[str, ...], joiner: int) -> int:
    """len(_render(terms, ...)) for joiners of length `joiner`, without building the text."""
    widths = _term_widths(atoms)
    total = joiner * (len(terms) - 1)
    parens = len(terms) > 1
    for term in terms:
        width = widths.get(term)
        if width is None:
            literals = _literal_widths(atoms)
            width = sum(literals[lit] for lit in term) + joiner * max(len(term) - 1, 0)
            width = widths[term] = width + (2 if len(term) > 1 else 0)
        total += width if parens or len(term) < 2 else width - 2
    return total


@lru_cache(maxsize=64)
def _term_widths(atoms: tuple[str, ...]) -> dict[tuple[int, ...], int]:
    """Per alphabet, a cache of rendered term widths (parentheses included when it has two
    literals or more); products repeat terms on many edges."""
    return {}


@lru_cache(maxsize=64)
def _literal_widths(atoms: tuple[str, ...]) -> dict[int, int]:
    """Characters each literal takes: `a` for k+1, `!a` for -(k+1)."""
    widths = {k + 1: len(a) for k, a in enumerate(atoms)}
    widths.update({-lit: width + 1 for lit, width in list(widths.items())})
    return widths


def _render(terms, atoms: tuple[str, ...], inner: str, outer: str) -> str:
    parts = []
    for term in terms:
        lits = [atoms[lit - 1] if lit > 0 else f"!{atoms[-lit - 1]}" for lit in term]
        body = inner.join(lits)
        parts.append(f"({body})" if len(lits) > 1 and len(terms) > 1 else body)
    return outer.join(parts)
