"""Random LTLf formulas of an exact syntax-tree size over an exact number of distinct atoms.

Size counts the nodes of the syntax tree: every operator occurrence and every atom occurrence is
one node, parentheses are not nodes. `G(a -> F b)` has size 5 (G, ->, a, F, b). Formulas are
printed fully parenthesised, so ltlf2dfa's n-ary grouping quirks never change what was drawn.
"""

from __future__ import annotations

import random
from collections.abc import Sequence

from tleaf_cli.errors import InputError

UNARY: tuple[str, ...] = ("!", "X", "WX", "F", "G")
BINARY: tuple[str, ...] = ("&", "|", "->", "<->", "U", "R")


def random_formula(
    rng: random.Random,
    atoms: Sequence[str],
    size: int,
    unary: Sequence[str] = UNARY,
    binary: Sequence[str] = BINARY,
    max_tries: int = 1000,
) -> str:
    """A formula of exactly `size` nodes that uses every atom in `atoms` at least once."""
    if size < 1:
        raise InputError("size must be at least 1")
    if size < 2 * len(atoms) - 1:
        raise InputError(f"a tree of size {size} cannot hold {len(atoms)} distinct atoms")
    for _ in range(max_tries):
        text, used = _tree(rng, list(atoms), size, unary, binary)
        if used == set(atoms):
            return text
    raise InputError(f"no formula of size {size} over {len(atoms)} atoms in {max_tries} tries")


def _tree(rng, atoms, size, unary, binary) -> tuple[str, set[str]]:
    if size == 1:
        a = rng.choice(atoms)
        return a, {a}
    if size == 2 or rng.random() < 0.35:
        op = rng.choice(unary)
        sub, used = _tree(rng, atoms, size - 1, unary, binary)
        return f"{op}({sub})" if op != "!" else f"!({sub})", used
    left = rng.randint(1, size - 2)
    op = rng.choice(binary)
    a, ua = _tree(rng, atoms, left, unary, binary)
    b, ub = _tree(rng, atoms, size - 1 - left, unary, binary)
    return f"({a} {op} {b})", ua | ub


def syntax_tree_size(formula) -> int:
    """Nodes of a parsed formula's tree, counted as in `random_formula` (n-ary ops count n-1)."""
    children = getattr(formula, "formulas", None)
    if children is not None:
        return len(children) - 1 + sum(syntax_tree_size(c) for c in children)
    child = getattr(formula, "f", None)
    if child is not None:
        return 1 + syntax_tree_size(child)
    return 1
