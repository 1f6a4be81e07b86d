"""Products, minimisation and renumbering of small DFA tables as plain Python lists.

Most rules have a handful of states: on such tables numpy's per-call cost dominates, so
`DFA.product`, `DFA.minimize` and `conjunction.conjoin_nonempty` run these list versions below
`dfa.SMALL_TABLE` entries. Each gives the same canonical result as its array counterpart in
`dfa.py` (breadth-first numbering, successors in letter order; a product once minimised);
tests/test_dfa.py compares them.
"""

from __future__ import annotations

from collections.abc import Callable


def minimize_table(
    table: list[list[int]], initial: int, accepting: list[bool]
) -> tuple[list[list[int]], int, list[bool]]:
    """`DFA.minimize` on lists: reachable states, Moore refinement, breadth-first numbering with
    successors in letter order (the canonical form `dfa._renumber_bfs` gives)."""
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


def nonempty_table(
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
        return renumber_table(table, twin[0], accepting)
    return renumber_table([*table, table[initial]], len(table), [*accepting, accept_empty])


def renumber_table(
    table: list[list[int]], initial: int, accepting: list[bool]
) -> tuple[list[list[int]], int, list[bool]]:
    """`dfa._renumber_reachable` on lists: breadth-first, successors in letter order."""
    number = {initial: 0}
    order = [initial]
    for s in order:
        for t in table[s]:
            if t not in number:
                number[t] = len(order)
                order.append(t)
    return [[number[t] for t in table[s]] for s in order], 0, [accepting[s] for s in order]


def product_table(
    left: list[list[int]],
    right: list[list[int]],
    initials: tuple[int, int],
    accepting: list[bool],
    other_accepting: list[bool],
    combine: Callable[[bool, bool], object],
) -> tuple[list[list[int]], list[bool]]:
    """`DFA.product` on lists, before minimisation: the reachable pairs of states of two tables
    over the same letters (each already lifted to the union alphabet), numbered in order of
    discovery from the initial pair (state 0), and each pair's acceptance by `combine`."""
    ids = {initials: 0}
    pairs = [initials]
    rows = []
    for a, b in pairs:  # grows while it is walked: breadth-first
        row = []
        for pair in zip(left[a], right[b], strict=True):
            i = ids.get(pair)
            if i is None:
                i = ids[pair] = len(pairs)
                pairs.append(pair)
            row.append(i)
        rows.append(row)
    return rows, [bool(combine(accepting[a], other_accepting[b])) for a, b in pairs]
