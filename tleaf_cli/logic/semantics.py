"""LTLf semantics evaluated directly on the parse tree: the reference every DFA is checked against.

A trace is a non-empty finite sequence of letters; a letter is the set of atoms true at that step.
Each subformula becomes a vector of truth values over the trace's positions, computed backwards
for the temporal operators, so one evaluation costs O(|formula| * len(trace)).

n-ary nodes keep ltlf2dfa's meaning: `a -> b -> c` is `(a -> b) -> c`, `a U b U c` is
`a U (b U c)` (likewise R), and `a <-> b <-> c` holds when all operands agree.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence

from tleaf_cli.errors import InputError
from tleaf_cli.logic import ltlf_nodes as ltlf
from tleaf_cli.logic.formulas import check_depth

Trace = Sequence[Collection[str]]


def satisfies(trace: Trace, formula: ltlf.LTLfFormula) -> bool:
    """True when the non-empty `trace` satisfies `formula` at its first position.

    FormulaSyntaxError for a formula nested too deeply to evaluate (the walk recurses)."""
    if len(trace) == 0:
        raise InputError("traces are non-empty")
    check_depth(formula)
    return _eval(formula, trace)[0]


def _eval(f: ltlf.LTLfFormula, w: Trace) -> list[bool]:
    n = len(w)
    # ltlf.LTLfTrue/ltlf.LTLfFalse subclass ltlf.LTLfAtomic, so they are tested first.
    if isinstance(f, ltlf.LTLfTrue):
        return [True] * n
    if isinstance(f, ltlf.LTLfFalse):
        return [False] * n
    if isinstance(f, ltlf.LTLfAtomic):
        name = str(f.s)
        return [name in letter for letter in w]
    if isinstance(f, ltlf.LTLfLast):
        return [i == n - 1 for i in range(n)]
    if isinstance(f, ltlf.LTLfNot):
        return [not v for v in _eval(f.f, w)]
    if isinstance(f, ltlf.LTLfAnd):
        parts = [_eval(g, w) for g in f.formulas]
        return [all(col) for col in zip(*parts, strict=True)]
    if isinstance(f, ltlf.LTLfOr):
        parts = [_eval(g, w) for g in f.formulas]
        return [any(col) for col in zip(*parts, strict=True)]
    if isinstance(f, ltlf.LTLfImplies):
        acc = _eval(f.formulas[0], w)
        for g in f.formulas[1:]:
            acc = [(not a) or b for a, b in zip(acc, _eval(g, w), strict=True)]
        return acc
    if isinstance(f, ltlf.LTLfEquivalence):
        parts = [_eval(g, w) for g in f.formulas]
        return [all(col) or not any(col) for col in zip(*parts, strict=True)]
    if isinstance(f, ltlf.LTLfNext):
        sub = _eval(f.f, w)
        return [i + 1 < n and sub[i + 1] for i in range(n)]
    if isinstance(f, ltlf.LTLfWeakNext):
        sub = _eval(f.f, w)
        return [i + 1 >= n or sub[i + 1] for i in range(n)]
    if isinstance(f, ltlf.LTLfEventually):
        return _backward(_eval(f.f, w), lambda now, later: now or later, end=False)
    if isinstance(f, ltlf.LTLfAlways):
        return _backward(_eval(f.f, w), lambda now, later: now and later, end=True)
    if isinstance(f, ltlf.LTLfUntil):
        right = _eval(f.formulas[-1], w)
        for g in reversed(f.formulas[:-1]):
            left = _eval(g, w)
            right = _until(left, right)
        return right
    if isinstance(f, ltlf.LTLfRelease):
        right = _eval(f.formulas[-1], w)
        for g in reversed(f.formulas[:-1]):
            left = _eval(g, w)
            right = _release(left, right)
        return right
    raise TypeError(f"no semantics for {type(f).__name__}")


def _backward(sub: list[bool], step, end: bool) -> list[bool]:
    out = [False] * len(sub)
    later = end
    for i in range(len(sub) - 1, -1, -1):
        later = out[i] = step(sub[i], later)
    return out


def _until(a: list[bool], b: list[bool]) -> list[bool]:
    """a U b: b now, or a now and a U b from the next position (which must exist)."""
    out = [False] * len(a)
    later = False
    for i in range(len(a) - 1, -1, -1):
        later = out[i] = b[i] or (a[i] and later)
    return out


def _release(a: list[bool], b: list[bool]) -> list[bool]:
    """a R b: b holds up to and including the first a, or to the end of the trace."""
    out = [False] * len(a)
    later = True
    for i in range(len(a) - 1, -1, -1):
        later = out[i] = b[i] and (a[i] or later)
    return out
