"""A Declare constraint (a template of `knowledge/templates.py` on activities) and its direct
check on a case: one function per template, on the sequence, without automata.

A case is a non-empty sequence of activities, one per step (each an atom: one-hot). The truth is
the template's LTLf formula (`Template.ltlf`); each check here says the same on every case, which
tests/test_declare_checks.py verifies against the formula's meaning (`logic/semantics.py`) on
random logs. The miner (`knowledge/declare.py`) counts with these same checks, on each case's
pairs of activities (`CaseView`: positions, successors and predecessors computed once a case).

**Activation.** A case activates a relational constraint when it contains an activating
activity: `Template.activation`'s argument (a of response.a.b, b of precedence.a.b), and both
arguments where Declare activates by either: the symmetric templates (co-existence, not
co-existence, mined over unordered pairs) and those a case holding only the other argument
breaks (succession, alternate and chain succession: a b without an a breaks them, so b
activates them too). So a case that activates nothing satisfies the constraint (vacuously), and
a constraint's confidence is the share of its activating cases that satisfy it. A template
without activation (the unary ones; choice and exclusive choice, symmetric too) is activated by
every case: its confidence is its support.

**Rule names.** A constraint is named `template.a[.b]` in a `.ltl` file, the template by its key
(`exactly.a`, `not_co_existence.a.b`): the name a `.decl` of the same constraint reads back as.
"""

from __future__ import annotations

import re
from bisect import bisect_right
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache

from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.templates import TEMPLATES, Template
from tleaf_cli.settings.declare import TEMPLATE_ALIASES

# symmetric in a and b (`Template.symmetric`): mined over unordered pairs (a < b)
SYMMETRIC = frozenset(k for k, t in TEMPLATES.items() if t.symmetric)


@dataclass(frozen=True)
class CaseView:
    """What the checks read of one case: each activity's positions (ascending) and the sets of
    activities right after and right before it (None: the case ends / starts there)."""

    case: tuple[str, ...]
    positions: dict[str, list[int]]
    nexts: dict[str, set[str | None]]
    prevs: dict[str, set[str | None]]

    @classmethod
    def of(cls, case: Sequence[str]) -> CaseView:
        if not case:
            raise InputError("a case has at least one event")
        case = tuple(case)
        positions: dict[str, list[int]] = {}
        nexts: dict[str, set[str | None]] = {}
        prevs: dict[str, set[str | None]] = {}
        for i, x in enumerate(case):
            positions.setdefault(x, []).append(i)
            nexts.setdefault(x, set()).add(case[i + 1] if i + 1 < len(case) else None)
            prevs.setdefault(x, set()).add(case[i - 1] if i else None)
        return cls(case, positions, nexts, prevs)


Check = Callable[[CaseView, str, str], bool]


def _between(where: list[int], start: int, end: int) -> bool:
    """Some position of `where` (ascending) lies strictly between `start` and `end`."""
    i = bisect_right(where, start)
    return i < len(where) and where[i] < end


def _response(v: CaseView, a: str, b: str) -> bool:
    pa, pb = v.positions.get(a), v.positions.get(b)
    return pa is None or (pb is not None and pa[-1] < pb[-1])


def _precedence(v: CaseView, a: str, b: str) -> bool:
    pa, pb = v.positions.get(a), v.positions.get(b)
    return pb is None or (pa is not None and pa[0] < pb[0])


def _alternate_response(v: CaseView, a: str, b: str) -> bool:
    """Between each a and the next a (or the end) a b."""
    pa, pb = v.positions.get(a), v.positions.get(b, [])
    if pa is None:
        return True
    ends = [*pa[1:], len(v.case)]
    return all(_between(pb, s, e) for s, e in zip(pa, ends, strict=True))


def _alternate_precedence(v: CaseView, a: str, b: str) -> bool:
    """Between each b and the b before it (or the start) an a."""
    pa, pb = v.positions.get(a, []), v.positions.get(b)
    if pb is None:
        return True
    starts = [-1, *pb[:-1]]
    return all(_between(pa, s, e) for s, e in zip(starts, pb, strict=True))


def _chain_response(v: CaseView, a: str, b: str) -> bool:
    return a not in v.nexts or v.nexts[a] == {b}


def _chain_precedence(v: CaseView, a: str, b: str) -> bool:
    return b not in v.prevs or v.prevs[b] == {a}


def _not_co_existence(v: CaseView, a: str, b: str) -> bool:
    return a not in v.positions or b not in v.positions


def _not_succession(v: CaseView, a: str, b: str) -> bool:
    """No b after an a."""
    pa, pb = v.positions.get(a), v.positions.get(b)
    return pa is None or pb is None or pa[0] > pb[-1]


def _not_chain_succession(v: CaseView, a: str, b: str) -> bool:
    return b not in v.nexts.get(a, ())


CHECKS: dict[str, Check] = {
    "existence": lambda v, a, b: a in v.positions,
    "absence": lambda v, a, b: a not in v.positions,
    "exactly": lambda v, a, b: len(v.positions.get(a, ())) == 1,
    "init": lambda v, a, b: v.case[0] == a,
    "end": lambda v, a, b: v.case[-1] == a,
    "choice": lambda v, a, b: a in v.positions or b in v.positions,
    "exclusive_choice": lambda v, a, b: (a in v.positions) != (b in v.positions),
    "responded_existence": lambda v, a, b: a not in v.positions or b in v.positions,
    "co_existence": lambda v, a, b: (a in v.positions) == (b in v.positions),
    "response": _response,
    "precedence": _precedence,
    "succession": lambda v, a, b: _response(v, a, b) and _precedence(v, a, b),
    "alternate_response": _alternate_response,
    "alternate_precedence": _alternate_precedence,
    "alternate_succession": lambda v, a, b: (
        _alternate_response(v, a, b) and _alternate_precedence(v, a, b)
    ),
    "chain_response": _chain_response,
    "chain_precedence": _chain_precedence,
    "chain_succession": lambda v, a, b: _chain_response(v, a, b) and _chain_precedence(v, a, b),
    "not_responded_existence": _not_co_existence,
    "not_co_existence": _not_co_existence,
    "not_response": _not_succession,
    "not_precedence": _not_succession,
    "not_succession": _not_succession,
    "not_chain_response": _not_chain_succession,
    "not_chain_precedence": _not_chain_succession,
    "not_chain_succession": _not_chain_succession,
}


def template_key(name: str) -> str:
    """A template's key in TEMPLATES (an old name, exactly_once or not_coexistence, replaced);
    InputError for a name that is no template."""
    key = TEMPLATE_ALIASES.get(name, name)
    if key not in TEMPLATES:
        raise InputError(f"unknown Declare template '{name}' (known: {', '.join(TEMPLATES)})")
    return key


@cache
def activating(key: str) -> tuple[int, ...]:
    """The arguments whose occurrence activates the template (module docstring); () for one
    without activation (a unary one, choice, exclusive choice), activated by every case."""
    act = TEMPLATES[key].activation
    if act is None:
        return ()
    if key in SYMMETRIC:
        return (0, 1)
    # a case holding only the other argument: vacuous, or the other activates too
    other = "ab"[1 - act]
    return (act,) if CHECKS[key](CaseView.of((other,)), "a", "b") else (0, 1)


@dataclass(frozen=True)
class Constraint:
    """One template applied to its activities (atoms): `activities` has one atom for a unary
    template, two (a, b) for a relational one. `template` is the key in TEMPLATES (an old name
    is replaced by it); a symmetric template's pair is kept sorted."""

    template: str
    activities: tuple[str, ...]

    def __post_init__(self) -> None:
        key = template_key(self.template)
        object.__setattr__(self, "template", key)
        acts = tuple(self.activities)
        if len(acts) != TEMPLATES[key].arity:
            raise InputError(f"{key} takes {TEMPLATES[key].arity} activities, not {len(acts)}")
        if key in SYMMETRIC:
            acts = tuple(sorted(acts))
        object.__setattr__(self, "activities", acts)

    @property
    def declare(self) -> Template:
        """The template, as templates.py defines it."""
        return TEMPLATES[self.template]

    @property
    def name(self) -> str:
        """The rule's name in a `.ltl` file: `response.assign_seriousness.take_in_charge`."""
        return ".".join((self.template, *self.activities))

    @property
    def formula(self) -> str:
        """The template's LTLf formula (templates.py) on the activities, without the parentheses
        it puts around each one."""
        return tidy(self.declare.ltlf(*self.activities))

    @property
    def activation(self) -> str | None:
        """The formula of 'this case activates the constraint' (None for a unary template)."""
        who = activating(self.template)
        return " | ".join(f"F {self.activities[i]}" for i in who) if who else None

    def activated(self, case: Sequence[str]) -> bool:
        """True when `case` activates the constraint (always, for a unary template)."""
        who = activating(self.template)
        return not who or any(self.activities[i] in case for i in who)

    def holds(self, case: Sequence[str]) -> bool:
        """True when the non-empty `case` (one atom per step) satisfies the constraint; checked
        on the sequence, without automata."""
        return self.holds_on(CaseView.of(case))

    def holds_on(self, view: CaseView) -> bool:
        """`holds` on a case already read into a CaseView."""
        a, *b = self.activities
        return CHECKS[self.template](view, a, b[0] if b else "")


_GROUPED = re.compile(r"(\w?)(\s*)\((!?\w+)\)")


def tidy(formula: str) -> str:
    """`formula` without the parentheses around a lone atom or negated atom: "G((a) -> X F (b))"
    -> "G(a -> X F b)", "((!(b)) U (a)) | G(!(b))" -> "(!b U a) | G !b". The same formula."""
    while True:
        out = _GROUPED.sub(lambda m: f"{m[1]} {m[3]}" if m[1] else m[2] + m[3], formula)
        if out == formula:
            return out
        formula = out
