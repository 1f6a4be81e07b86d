"""The conjunction of rules over disjoint atoms, as one product walk.

A rule set's groups of rules share no atoms (`rule_set._conjunction`), so their product DFA is a
walk over combinations of states in which each letter moves one group. Kept here apart from the
DFA type: it is the rule sets' fast path, with its own cache.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import reduce

import numpy as np

from tleaf_cli.errors import InputError
from tleaf_cli.logic.alphabet import Alphabet
from tleaf_cli.logic.dfa import DFA, SMALL_TABLE
from tleaf_cli.logic.kept import Kept
from tleaf_cli.logic.small_tables import minimize_table, nonempty_table

# Conjunctions kept by `conjoin_nonempty`, per automata and letter layout (the oldest dropped).
CONJUNCTIONS_KEPT = 4096


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
        rows, initial, accepting = nonempty_table(*minimize_table(*small))
        kept = (np.array(rows, dtype=np.int32), initial, np.array(accepting, dtype=bool))
        _CONJUNCTIONS.keep(key, kept)
    table, initial, accepting = kept
    return DFA(alphabet, table.copy(), initial, accepting.copy())


# conjoin_nonempty's small conjunctions: (structures, letter layout) -> table, initial, accepting
_CONJUNCTIONS = Kept(CONJUNCTIONS_KEPT)


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
