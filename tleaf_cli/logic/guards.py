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

import numpy as np

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
        raise ValueError(f"expected {alphabet.size} letters, got shape {letters.shape}")
    if letters.all():
        return Guard("true", ())
    if not letters.any():
        return Guard("false", ((),))
    if alphabet.kind == "one-hot":
        return _one_hot_guard(letters, alphabet.atoms)
    n = len(alphabet.atoms)
    dnf, _ = _isop(letters, letters, n)
    off, _ = _isop(~letters, ~letters, n)
    cnf = tuple(sorted((tuple(sorted((-lit for lit in c), key=abs)) for c in off), key=_by_atom))
    dnf = sorted((tuple(sorted(cube, key=abs)) for cube in dnf), key=_by_atom)
    as_dnf = _render(dnf, alphabet.atoms, inner=" & ", outer=" | ")
    as_cnf = _render(cnf, alphabet.atoms, inner=" | ", outer=" & ")
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
                raise ValueError(f"literal {lit} out of range for {len(alphabet.atoms)} atoms")
            sat |= truth[:, k] if lit > 0 else ~truth[:, k]
        out &= sat
    return out


def _one_hot_guard(letters: np.ndarray, atoms: tuple[str, ...]) -> Guard:
    if not letters[0]:
        on = [k for k in range(len(atoms)) if letters[k + 1]]
        return Guard(" | ".join(atoms[k] for k in on), (tuple(k + 1 for k in on),))
    off = [k for k in range(len(atoms)) if not letters[k + 1]]
    return Guard(" & ".join(f"!{atoms[k]}" for k in off), tuple((-(k + 1),) for k in off))


def _by_atom(term: Clause) -> tuple[tuple[int, bool], ...]:
    """Order terms by their atoms, then positive before negative: [[1], [-2, 3]]."""
    return tuple((abs(lit), lit < 0) for lit in term)


def _isop(lower: np.ndarray, upper: np.ndarray, nvars: int) -> tuple[list[Clause], np.ndarray]:
    """Minato-Morreale: cubes covering `lower` inside `upper`, and the function they cover."""
    if not lower.any():
        return [], np.zeros_like(lower)
    if upper.all():
        return [()], np.ones_like(lower)
    top = nvars - 1
    half = 1 << top
    l0, l1, u0, u1 = lower[:half], lower[half:], upper[:half], upper[half:]
    c0, f0 = _isop(l0 & ~u1, u0, top)
    c1, f1 = _isop(l1 & ~u0, u1, top)
    cs, fs = _isop((l0 & ~f0) | (l1 & ~f1), u0 & u1, top)
    lit = top + 1
    cubes = [(*c, -lit) for c in c0] + [(*c, lit) for c in c1] + cs
    return cubes, np.concatenate([f0 | fs, f1 | fs])


def _render(terms, atoms: tuple[str, ...], inner: str, outer: str) -> str:
    parts = []
    for term in terms:
        lits = [atoms[lit - 1] if lit > 0 else f"!{atoms[-lit - 1]}" for lit in term]
        body = inner.join(lits)
        parts.append(f"({body})" if len(lits) > 1 and len(terms) > 1 else body)
    return outer.join(parts)
