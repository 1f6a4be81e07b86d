"""Declare constraints: the process-mining field's rule templates, as LTLf, mined from cases.

A case is a finite sequence of activities, one per step; here each activity is a formula atom
(`data.activity_names.activity_atoms`), so a step makes exactly one atom true (one-hot). The
templates, in tleaf's syntax, on finite traces (LTLf; the standard Declare-as-LTLf reading of
De Giacomo, Maggi et al.), for activities a ≠ b:

    existence(a)          F a                      a happens
    absence(a)            G !a                     a never happens
    exactly_once(a)       F a & G(a -> WX G !a)    a happens once
    init(a)               a                        the case starts with a
    end(a)                F(a & last)              the case ends with a
    response(a, b)        G(a -> F b)              every a is followed, later, by some b
    precedence(a, b)      (!b U a) | G !b          no b before the first a
    succession(a, b)      response & precedence
    chain_response(a, b)  G(a -> X b)              every a is immediately followed by b
    not_coexistence(a, b) !(F a & F b)             never both in one case

Response is Declare's □(a → ◇b) with ◇ including the present; since a and b are different
activities and a step holds one activity, `F b` at a step where a holds is `X F b` (strictly
later): the two formulas agree on every case. `X` is the strong next: a case whose last step is
a violates chain_response(a, b).

**Measures.** A constraint's *support* is the share of cases that satisfy it (vacuously too: a
case without a satisfies response(a, b)). A relational constraint is *activated* by a case in
which its activating activity occurs (response, chain_response: a; precedence: b; succession,
not_coexistence: a or b), and its *confidence* is the share of the activated cases that satisfy
it. Unary templates have no activation: their confidence is their support.

**Mining** (`mine_declare`) measures every template on every activity (every ordered pair of
different activities; unordered for not_coexistence) over the training cases, checking the
sequences directly (first/last positions, successors: no automata), and keeps a constraint when
its support ≥ `min_support`, its confidence ≥ `min_confidence` and (relational) it is activated
by at least `min_activated` cases: a rule no case activates is satisfied trivially. Then it drops
rules implied by another kept rule on every case, keeping the strongest: response and precedence
under succession, response under chain_response or end(b), precedence under init(a), existence
under init, end or exactly_once, not_coexistence under absence of either activity.

Rules that each hold on most cases can together hold on few: on a log of hundreds of activities
thousands of rules pass 90 % support, and their conjunction holds on under a tenth of the cases,
so a decoder asked for a continuation that satisfies them all finds none for most prefixes.
`min_joint_support` keeps the knowledge base usable as a whole: the rules are taken by falling
support (ties in template and activity order) and one is kept only while the kept rules' conjunction
still holds on that share of the cases (greedy: not the largest such set, a simple one).

`declare_text` gives the rules as the text of a `.ltl` formula file (docs/formulas.md): one
named rule a line, `template.a[.b]: formula`, its measured support and confidence in a comment
on its line; `holding_shares` measures mined rules on other cases (a test split). Writing the
file, with its header, is `log_knowledge.mine_log`'s.

Every public function checks its arguments first (`mining_arguments`): ArgumentError or
ArgumentTypeError naming the argument, never a rule set mined from a wrong value.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from tleaf_cli.errors import InputError
from tleaf_cli.knowledge import mining_arguments as check

UNARY = ("existence", "absence", "exactly_once", "init", "end")
BINARY = (
    "response",
    "precedence",
    "succession",
    "chain_response",
    "not_coexistence",
)
TEMPLATES = UNARY + BINARY

_FORMULAS = {
    "existence": "F {a}",
    "absence": "G !{a}",
    "exactly_once": "F {a} & G({a} -> WX G !{a})",
    "init": "{a}",
    "end": "F({a} & last)",
    "response": "G({a} -> F {b})",
    "precedence": "(!{b} U {a}) | G !{b}",
    "succession": "G({a} -> F {b}) & ((!{b} U {a}) | G !{b})",
    "chain_response": "G({a} -> X {b})",
    "not_coexistence": "!(F {a} & F {b})",
}
# Which activities activate a relational template (the case must contain one of them).
_ACTIVATORS = {
    "response": "a",
    "precedence": "b",
    "succession": "ab",
    "chain_response": "a",
    "not_coexistence": "ab",
}


@dataclass(frozen=True)
class Constraint:
    """One template applied to its activities (atoms): `activities` has one atom for a unary
    template, two (a, b) for a relational one."""

    template: str
    activities: tuple[str, ...]

    @property
    def name(self) -> str:
        """The rule's name in a `.ltl` file: `response.assign_seriousness.take_in_charge`."""
        return ".".join((self.template, *self.activities))

    @property
    def formula(self) -> str:
        """The LTLf formula in tleaf's syntax (the module docstring's table)."""
        a, *rest = self.activities
        return _FORMULAS[self.template].format(a=a, b=rest[0] if rest else "")

    @property
    def activation(self) -> str | None:
        """The formula of 'this case activates the constraint' (None for a unary template)."""
        who = _ACTIVATORS.get(self.template)
        if who is None:
            return None
        return " | ".join(f"F {self.activities['ab'.index(x)]}" for x in who)

    def activated(self, case: Sequence[str]) -> bool:
        """True when `case` activates the constraint (always, for a unary template)."""
        who = _ACTIVATORS.get(self.template)
        if who is None:
            return True
        return any(self.activities["ab".index(x)] in case for x in who)

    def holds(self, case: Sequence[str]) -> bool:
        """True when the non-empty `case` (one atom per step) satisfies the constraint; checked
        on the sequence, without automata."""
        if not case:
            raise InputError("a case has at least one event")
        t, a = self.template, self.activities[0]
        if t == "existence":
            return a in case
        if t == "absence":
            return a not in case
        if t == "exactly_once":
            return case.count(a) == 1
        if t == "init":
            return case[0] == a
        if t == "end":
            return case[-1] == a
        b = self.activities[1]
        first, last = _first_last(case)
        if t == "response":
            return a not in last or last[a] < last.get(b, -1)
        if t == "precedence":
            return b not in first or first[b] > first.get(a, len(case))
        if t == "succession":
            return Constraint("response", (a, b)).holds(case) and Constraint(
                "precedence", (a, b)
            ).holds(case)
        if t == "chain_response":
            return all(case[i + 1] == b for i in range(len(case) - 1) if case[i] == a) and (
                case[-1] != a
            )
        if t == "not_coexistence":
            return not (a in first and b in first)
        raise InputError(f"unknown Declare template '{t}' (known: {', '.join(TEMPLATES)})")


@dataclass(frozen=True)
class Measured:
    """A constraint and what the cases say of it: `cases` in all, `activated` of them, and
    `satisfied` (all cases that satisfy it, vacuously too)."""

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
        if self.constraint.template in UNARY:
            return self.support
        vacuous = self.cases - self.activated
        return (self.satisfied - vacuous) / self.activated if self.activated else 1.0


def _first_last(case: Sequence[str]) -> tuple[dict[str, int], dict[str, int]]:
    first: dict[str, int] = {}
    last: dict[str, int] = {}
    for i, x in enumerate(case):
        first.setdefault(x, i)
        last[x] = i
    return first, last


def measure_declare(
    cases: Sequence[Sequence[str]],
    templates: Iterable[str] = TEMPLATES,
    activities: Iterable[str] | None = None,
) -> list[Measured]:
    """Every constraint of `templates` over `activities` (default: those in `cases`, sorted)
    measured on `cases`: one pass over the cases, each looking only at the pairs of activities
    it contains (a pair a case lacks is settled by the per-activity counts)."""
    cases = check.cases(cases)
    templates = check.templates(templates, TEMPLATES)
    if activities is not None:
        activities = check.names(activities, "activities", "activities (str)")
    if not cases:
        raise InputError("no cases to mine constraints from")
    if any(len(c) == 0 for c in cases):
        raise InputError("a case has at least one event")
    n = len(cases)
    has = Counter[str]()  # cases containing a
    once = Counter[str]()
    starts = Counter[str]()
    ends = Counter[str]()
    both = Counter[tuple[str, str]]()  # cases containing a and b
    resp = Counter[tuple[str, str]]()  # ... with the last a before the last b
    prec = Counter[tuple[str, str]]()  # ... with the first a before the first b
    succ = Counter[tuple[str, str]]()  # ... both
    chain = Counter[tuple[str, str]]()  # cases where every a is followed at once by b
    for case in cases:
        first, last = _first_last(case)
        counts = Counter(case)
        starts[case[0]] += 1
        ends[case[-1]] += 1
        nexts: dict[str, set[str | None]] = {}
        for i, x in enumerate(case):
            nexts.setdefault(x, set()).add(case[i + 1] if i + 1 < len(case) else None)
        for a, k in counts.items():
            has[a] += 1
            once[a] += k == 1
            following = nexts[a]
            if len(following) == 1:
                (b,) = following
                if b is not None and b != a:
                    chain[a, b] += 1
            for b in first:
                if b == a:
                    continue
                both[a, b] += 1
                r = last[a] < last[b]
                p = first[a] < first[b]
                resp[a, b] += r
                prec[a, b] += p
                succ[a, b] += r and p
    names = sorted(has) if activities is None else sorted(set(activities))
    out: list[Measured] = []
    for t in templates:
        if t in UNARY:
            for a in names:
                sat = {
                    "existence": has[a],
                    "absence": n - has[a],
                    "exactly_once": once[a],
                    "init": starts[a],
                    "end": ends[a],
                }[t]
                out.append(Measured(Constraint(t, (a,)), n, n, sat))
            continue
        for a in names:
            for b in names:
                if a == b or (t == "not_coexistence" and b < a):
                    continue
                na, nb, nab = has[a], has[b], both[a, b]
                if t == "response":
                    act, ok = na, resp[a, b]
                elif t == "precedence":
                    act, ok = nb, prec[a, b]
                elif t == "succession":
                    act, ok = na + nb - nab, succ[a, b]
                elif t == "chain_response":
                    act, ok = na, chain[a, b]
                else:  # not_coexistence
                    act, ok = na + nb - nab, na + nb - 2 * nab
                out.append(Measured(Constraint(t, (a, b)), n, act, n - act + ok))
    return out


def _redundant(kept: set[Constraint]) -> set[Constraint]:
    """The kept constraints that another kept constraint implies on every case."""
    out: set[Constraint] = set()
    for c in kept:
        t, acts = c.template, c.activities
        a = acts[0]
        b = acts[1] if len(acts) > 1 else None
        stronger: list[Constraint] = []
        if t == "existence":
            stronger = [Constraint(s, (a,)) for s in ("init", "end", "exactly_once")]
        elif t == "response":
            stronger = [
                Constraint("succession", (a, b)),
                Constraint("chain_response", (a, b)),
                Constraint("end", (b,)),
            ]
        elif t == "precedence":
            stronger = [Constraint("succession", (a, b)), Constraint("init", (a,))]
        elif t == "not_coexistence":
            stronger = [Constraint("absence", (a,)), Constraint("absence", (b,))]
        if any(s in kept for s in stronger):
            out.add(c)
    return out


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
        if m.constraint.template in UNARY or m.activated >= max(min_activated, 1)
    ]
    return supported, confident, activated


def mine_declare(
    cases: Sequence[Sequence[str]],
    *,
    min_support: float = 0.9,
    min_confidence: float = 0.9,
    min_activated: int = 1,
    min_joint_support: float = 0.0,
    templates: Iterable[str] = TEMPLATES,
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
    drop = _redundant({m.constraint for m in kept})
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
    alive = list(cases)  # the cases every kept rule holds on
    kept: set[Constraint] = set()
    for m in sorted(mined, key=lambda m: -m.support):
        still = [c for c in alive if m.constraint.holds(c)]
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
    holds = [[r.holds(c) for c in cases] for r in rules]
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
        if c.template in BINARY:
            note += f", confidence {m.confidence:.4f}, activated {m.activated}/{m.cases}"
        lines.append(f"{c.name + ':':<{width + 1}} {c.formula}  # {note}")
    return "\n".join(lines) + "\n"
