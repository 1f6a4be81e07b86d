"""Alphabets: which letters a DFA reads, and how a letter (a set of atoms) becomes a column index.

Two kinds, as in docs/design.md:

* `powerset` — every subset of the atoms is a letter; letter i has atom k true iff bit k of i is
  set (atoms in sorted order). 2**n letters, so it is limited to MAX_POWERSET_ATOMS atoms.
* `one-hot` — exactly one atom of the domain holds at each step, so over the DFA's own atoms a
  letter is a single atom or none of them: index 0 is the empty letter, index k+1 is atoms[k].

Atoms outside the alphabet are ignored when a letter is encoded: they belong to the domain, not to
this formula, and cannot change its truth.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from tleaf_cli.errors import InputError

AlphabetKind = Literal["powerset", "one-hot"]
ALPHABET_KINDS: tuple[AlphabetKind, ...] = ("powerset", "one-hot")
MAX_POWERSET_ATOMS = 16


class LetterError(InputError, ValueError):
    """A letter that the alphabet cannot read (e.g. two of its atoms at once under one-hot)."""


@dataclass(frozen=True)
class Alphabet:
    """The letters over `atoms` (sorted, distinct) of the given kind."""

    atoms: tuple[str, ...]
    kind: AlphabetKind = "powerset"
    _index: dict[str, int] = field(init=False, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        if list(self.atoms) != sorted(set(self.atoms)):
            raise InputError("alphabet atoms must be sorted and distinct")
        if self.kind not in ALPHABET_KINDS:
            raise InputError(f"alphabet kind must be one of {ALPHABET_KINDS}, not {self.kind!r}")
        if self.kind == "powerset" and len(self.atoms) > MAX_POWERSET_ATOMS:
            raise LetterError(
                f"a powerset alphabet over {len(self.atoms)} atoms has 2^{len(self.atoms)} letters "
                f"(limit {MAX_POWERSET_ATOMS} atoms); use the one-hot alphabet for large domains"
            )
        object.__setattr__(self, "_index", {a: k for k, a in enumerate(self.atoms)})

    @property
    def size(self) -> int:
        n = len(self.atoms)
        return 1 << n if self.kind == "powerset" else n + 1

    def index(self, letter: Collection[str]) -> int:
        """Column index of a letter; atoms not in the alphabet are ignored."""
        ks = [self._index[a] for a in letter if a in self._index]
        if self.kind == "powerset":
            return sum(1 << k for k in set(ks))
        if len(set(ks)) > 1:
            names = sorted({self.atoms[k] for k in ks})
            raise LetterError(f"letter {{{', '.join(names)}}} is not one-hot: at most one atom")
        return ks[0] + 1 if ks else 0

    def letter(self, i: int) -> frozenset[str]:
        """The atoms true in letter `i`."""
        if self.kind == "powerset":
            return frozenset(a for k, a in enumerate(self.atoms) if i >> k & 1)
        return frozenset() if i == 0 else frozenset({self.atoms[i - 1]})

    def truth(self) -> np.ndarray:
        """Bool matrix [size, n_atoms]: which atoms are true in each letter."""
        n = len(self.atoms)
        if self.kind == "powerset":
            ids = np.arange(self.size, dtype=np.int64)[:, None]
            return (ids >> np.arange(n, dtype=np.int64)[None, :] & 1).astype(bool)
        return np.vstack([np.zeros((1, n), bool), np.eye(n, dtype=bool)])

    def lift(self, other: Alphabet) -> np.ndarray:
        """For each letter of the larger alphabet `other`, the index of its restriction to self."""
        if other.kind != self.kind:
            raise InputError(f"cannot combine a {self.kind} and a {other.kind} alphabet")
        missing = set(self.atoms) - set(other.atoms)
        if missing:
            raise InputError(f"atoms {sorted(missing)} are not in the target alphabet")
        position = {a: k for k, a in enumerate(other.atoms)}
        if self.kind == "powerset":  # gather each of self's atoms' bits from other's letters
            ids = np.arange(other.size, dtype=np.int64)
            out = np.zeros(other.size, dtype=np.int64)
            for j, atom in enumerate(self.atoms):
                out |= (ids >> position[atom] & 1) << j
            return out
        out = np.zeros(other.size, dtype=np.int64)  # one-hot: other's atom k+1 -> self's or none
        for j, atom in enumerate(self.atoms):
            out[position[atom] + 1] = j + 1
        return out

    def encode(self, traces: Sequence[Sequence[Collection[str]]]) -> tuple[np.ndarray, np.ndarray]:
        """Traces as a padded letter matrix int32 [n_traces, max_len] plus int32 lengths.

        Padding is -1. Letters are looked up once per distinct letter, not once per step.
        """
        lengths = np.fromiter((len(t) for t in traces), dtype=np.int32, count=len(traces))
        width = int(lengths.max()) if len(traces) else 0
        out = np.full((len(traces), width), -1, dtype=np.int32)
        seen: dict[frozenset[str], int] = {}
        for row, trace in enumerate(traces):
            for col, letter in enumerate(trace):
                key = letter if isinstance(letter, frozenset) else frozenset(letter)
                idx = seen.get(key)
                if idx is None:
                    idx = seen[key] = self.index(key)
                out[row, col] = idx
        return out, lengths
