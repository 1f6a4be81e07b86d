"""Declare constraints mined from cases: every template of `knowledge/templates.py` that applies
to one activity or a pair, measured on a log's cases, kept by support and confidence.

A case is a finite sequence of activities, one per step; here each activity is a formula atom
(`data.activity_names.activity_atoms`), so a step makes exactly one atom true (one-hot). A
template's meaning is its LTLf formula in templates.py; a constraint (`declare_constraints`) is
a template on its activities, checked on a case by one direct check per template, tested
against the formula.

**Templates.** By default the ten tleaf has always mined (settings/declare.py's
DEFAULT_TEMPLATES): existence, absence, exactly, init, end,
response, precedence, succession, chain_response, not_co_existence.
`ALL_TEMPLATES` adds choice, exclusive_choice, responded_existence, co_existence, the
alternate and chain templates, not_succession and not_chain_succession: pm4py's 18 discovery
templates, end and the two choices. The five negative templates that repeat another's formula on
two activities are mined only when named. Counting templates are mined at count 1 (Existence,
Absence, Exactly1): at least once, never, exactly once.

**Measures.** A constraint's *support* is the share of cases that satisfy it (vacuously too: a
case without a satisfies response(a, b)). A relational constraint is *activated* by a case that
contains an activating activity (`declare_constraints.activating`: response: a, precedence: b,
succession and the co-existences: a or b), and its *confidence* is the share of the activated
cases that satisfy it. Unary templates have no activation: their confidence is their support.

**Mining** (`mine_declare`) measures every template on every activity (every ordered pair of
different activities; unordered for the symmetric choices and co-existences) over the cases,
in one pass: each case is read once (`CaseView`) and checked on the pairs of activities it
contains; a case that lacks one of the pair settles it by presence alone (the checks' verdict on
a one-activity case). It keeps a constraint when its support ≥ `min_support`, its confidence ≥
`min_confidence` and (relational) it is activated by at least `min_activated` cases: a rule no
case activates is satisfied trivially. Then it drops rules implied by another kept rule on every
case, keeping the strongest (`declare_implied`: response and precedence under succession,
response under chain_response or end(b), ...).

Rules that each hold on most cases can together hold on few: on a log of hundreds of activities
thousands of rules pass 90 % support, and their conjunction holds on under a tenth of the cases,
so a decoder asked for a continuation that satisfies them all finds none for most prefixes.
`min_joint_support` keeps the knowledge base usable as a whole: the rules are taken by falling
support (ties in template and activity order) and one is kept only while the kept rules' conjunction
still holds on that share of the cases (greedy: not the largest such set, a simple one).

`declare_text` gives the rules as the text of a `.ltl` formula file (docs/formulas.md): one
named rule a line, `template.a[.b]: formula`, its measured support and confidence in a comment
on its line; `holding_shares` measures mined rules on other cases (a test split). Writing the
file, with its header, is `log_knowledge.mine_log`'s (a `.decl` is `decl_writer`'s).

Every public function checks its arguments first (`mining_arguments`): ArgumentError or
ArgumentTypeError naming the argument, never a rule set mined from a wrong value.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from tleaf_cli.errors import InputError
from tleaf_cli.knowledge import mining_arguments as check
from tleaf_cli.knowledge.declare_constraints import (
    CHECKS,
    SYMMETRIC,
    CaseView,
    Constraint,
    activating,
)
from tleaf_cli.knowledge.declare_implied import redundant
from tleaf_cli.knowledge.templates import TEMPLATES
from tleaf_cli.settings.declare import (
    ALL_TEMPLATES,
    DECLARE_TEMPLATES,
    DEFAULT_TEMPLATES,
    TEMPLATE_ALIASES,
)

# ALL_TEMPLATES, DEFAULT_TEMPLATES and Constraint are this module's too (imported from here)
__all__ = ["ALL_TEMPLATES", "DEFAULT_TEMPLATES", "Constraint"]


@dataclass(frozen=True)
class Measured:
    """A constraint and what the cases say of it: `cases` in all, `activated` of them, and
    `satisfied` (all cases that satisfy it, vacuously too: every case that does not activate
    it)."""

    constraint: Constraint
    cases: int
    activated: int
    satisfied: int

    @property
    def support(self) -> float:
        return self.satisfied / self.cases

    @property
    def confidence(self) -> float:
        """Share of the activated cases that satisfy it (its support for a unary template)."""
        if self.constraint.declare.arity == 1:
            return self.support
        vacuous = self.cases - self.activated
        return (self.satisfied - vacuous) / self.activated if self.activated else 1.0


def measure_declare(
    cases: Sequence[Sequence[str]],
    templates: Iterable[str] = DEFAULT_TEMPLATES,
    activities: Iterable[str] | None = None,
) -> list[Measured]:
    """Every constraint of `templates` (keys of templates.TEMPLATES, or the old names
    exactly_once, not_coexistence) over `activities` (default: those in `cases`, sorted),
    measured on `cases`: one pass over the cases, each checked only on the activities and pairs
    it contains (a pair a case lacks is settled by the per-activity counts)."""
    cases = check.cases(cases)
    keys = check.templates(templates, DECLARE_TEMPLATES, TEMPLATE_ALIASES)
    if activities is not None:
        activities = check.names(activities, "activities", "activities (str)")
    if not cases:
        raise InputError("no cases to mine constraints from")
    if any(len(c) == 0 for c in cases):
        raise InputError("a case has at least one event")
    unary = [(k, CHECKS[k]) for k in keys if TEMPLATES[k].arity == 1]
    binary = [(k, CHECKS[k], k in SYMMETRIC) for k in keys if TEMPLATES[k].arity == 2]
    has = Counter[str]()  # cases containing a
    both = Counter[tuple[str, str]]()  # cases containing a and b
    held = {k: Counter[str | tuple[str, str]]() for k in keys}  # ... that satisfy k
    for case in cases:
        view = CaseView.of(case)
        present = list(view.positions)
        has.update(present)
        for k, holds in unary:
            held[k].update(a for a in present if holds(view, a, ""))
        if not binary:
            continue
        for a in present:
            for b in present:
                if a == b:
                    continue
                both[a, b] += 1
                for k, holds, symmetric in binary:
                    if not (symmetric and b < a) and holds(view, a, b):
                        held[k][a, b] += 1
    n = len(cases)
    names = sorted(has) if activities is None else sorted(set(activities))
    out: list[Measured] = []
    for k in keys:
        lone = _lone_verdicts(k)
        if TEMPLATES[k].arity == 1:
            for a in names:
                sat = held[k][a] + (n - has[a]) * lone[0]
                out.append(Measured(Constraint(k, (a,)), n, n, sat))
            continue
        who = activating(k)
        for a in names:
            for b in names:
                if a == b or (k in SYMMETRIC and b < a):
                    continue
                na, nb, nab = has[a], has[b], both[a, b]
                sat = (
                    held[k][a, b]
                    + (n - na - nb + nab) * lone[0]
                    + (na - nab) * lone[1]
                    + (nb - nab) * lone[2]
                )
                act = {(): n, (0,): na, (1,): nb, (0, 1): na + nb - nab}[who]
                out.append(Measured(Constraint(k, (a, b)), n, act, sat))
    return out


def _lone_verdicts(key: str) -> tuple[bool, bool, bool]:
    """The template's verdict on a case that holds neither of its activities, only a, only b:
    set by presence alone (the check on a one-activity case)."""
    holds = CHECKS[key]
    neither, only_a, only_b = (holds(CaseView.of((x,)), "a", "b") for x in ("z", "a", "b"))
    return neither, only_a, only_b


def passing(
    measured: Sequence[Measured], min_support: float, min_confidence: float, min_activated: int
) -> tuple[list[Measured], list[Measured], list[Measured]]:
    """The constraints of `measured` that pass the thresholds in turn: support; support and
    confidence; and (relational) at least `min_activated` activating cases too, which are the
    rules `mine_declare` keeps before it drops redundant ones. Says why few or none were mined."""
    supported = [m for m in measured if m.support >= min_support]
    confident = [m for m in supported if m.confidence >= min_confidence]
    activated = [
        m
        for m in confident
        if m.constraint.declare.arity == 1 or m.activated >= max(min_activated, 1)
    ]
    return supported, confident, activated


def mine_declare(
    cases: Sequence[Sequence[str]],
    *,
    min_support: float = 0.9,
    min_confidence: float = 0.9,
    min_activated: int = 1,
    min_joint_support: float = 0.0,
    templates: Iterable[str] = DEFAULT_TEMPLATES,
    activities: Iterable[str] | None = None,
) -> list[Measured]:
    """The Declare constraints that `cases` support (module docstring), in template order, then
    activity order; redundant ones dropped, then (`min_joint_support` > 0) those that would take
    the conjunction's support below it. ArgumentError / ArgumentTypeError naming the argument
    for a value that is not what the signature says (a NaN share, templates as one string)."""
    check.share(min_support, "min_support")
    check.share(min_confidence, "min_confidence")
    check.share(min_joint_support, "min_joint_support")
    check.count(min_activated, "min_activated", 0)
    measured = measure_declare(cases, templates, activities)
    kept = passing(measured, min_support, min_confidence, min_activated)[-1]
    drop = redundant(m.constraint for m in kept)
    kept = [m for m in kept if m.constraint not in drop]
    if min_joint_support > 0:
        jointly = _jointly_holding(kept, cases, min_joint_support)
        kept = [m for m in kept if m.constraint in jointly]
    return kept


def _jointly_holding(
    mined: Sequence[Measured], cases: Sequence[Sequence[str]], share: float
) -> set[Constraint]:
    """The rules of `mined` kept by falling support (stable: ties in their order) while the
    kept rules' conjunction holds on at least `share` of `cases`."""
    need = share * len(cases)
    alive = [CaseView.of(c) for c in cases]  # the cases every kept rule holds on
    kept: set[Constraint] = set()
    for m in sorted(mined, key=lambda m: -m.support):
        still = [c for c in alive if m.constraint.holds_on(c)]
        if len(still) >= need:
            kept.add(m.constraint)
            alive = still
    return kept


def holding_shares(
    rules: Iterable[Constraint], cases: Sequence[Sequence[str]]
) -> tuple[list[float], float]:
    """Per rule, the share of `cases` that satisfy it, and the share that satisfy them all (nan
    without cases): each rule checked once on each case."""
    rules = list(rules)
    cases = check.cases(cases)
    if not cases:
        return [float("nan")] * len(rules), float("nan")
    views = [CaseView.of(c) for c in cases]
    holds = [[r.holds_on(v) for v in views] for r in rules]
    every = sum(all(column) for column in zip(*holds, strict=True)) if rules else len(cases)
    return [sum(row) / len(cases) for row in holds], every / len(cases)


def declare_text(mined: Sequence[Measured], header: Iterable[str] = ()) -> str:
    """The `.ltl` text of mined rules: `header` lines as comments, then one rule a line with its
    support and confidence (and activated cases) in a comment."""
    lines = [f"# {h}" if h else "#" for h in header]
    width = max((len(m.constraint.name) for m in mined), default=0)
    for m in mined:
        c = m.constraint
        note = f"support {m.support:.4f}"
        if c.declare.arity == 2:
            note += f", confidence {m.confidence:.4f}, activated {m.activated}/{m.cases}"
        lines.append(f"{c.name + ':':<{width + 1}} {c.formula}  # {note}")
    return "\n".join(lines) + "\n"
