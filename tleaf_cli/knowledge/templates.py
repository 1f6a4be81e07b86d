"""Declare's templates, each defined once: its name, arity, which argument activates it, and its
LTLf meaning in tleaf's syntax (docs/knowledge.md has the table). Everything else that speaks of
a template — the `.decl` reader, the miner, conformance checking, the docs — reads it from here,
and the formula is the truth the miner's fast counters are tested against.

The meanings are the standard reading of Declare on finite traces (De Giacomo, De Masellis and
Montali, AAAI 2014; Maggi et al., BPM 2011 for the multi-perspective conditions), in tleaf's
LTLf: `X` is the strong next (false at the last step), `WX` the weak next (true there), `F`, `G`,
`U` range over the present and the future. "φ W ψ" (weak until) is written `(φ U ψ) | G φ`.

A template's formula names its arguments `{a}` and `{b}` (and `{n}` is unfolded for the counting
templates); each stands for an *event formula*: an activity's atom, or with MP-Declare conditions
the conjunction of the activity's atom and the condition on its attributes ("Closed done by
Value 3": `closed & org_resource_value_3`). Two different activities never hold at one step (an
event has one activity), which the formulas may rely on: `F b` at a step where `a` holds means a
later b.

**Activation.** A relational template's *activation* is the argument whose occurrence obliges
the other, its *target*: in Response[a, b] each a (activation) asks for a later b (target); in
Precedence[a, b] each b (activation) asks for an earlier a (target). An MP-Declare activation
condition (`|A.attr ...|`) narrows the activation's event formula, a target condition
(`|T.attr ...|`) the target's. A case *activates* a constraint when its activation occurs in it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from tleaf_cli.errors import InputError

# φ W ψ, the weak until, in tleaf's syntax
_WEAK_UNTIL = "(({p}) U ({q})) | G({p})"


def weak_until(p: str, q: str) -> str:
    """`p W q`: p holds until q does, or for ever."""
    return _WEAK_UNTIL.format(p=p, q=q)


@dataclass(frozen=True)
class Template:
    """One Declare template.

    `name`: Declare's (RuM's, Declare4Py's) name, e.g. "Chain Response"; `key`: tleaf's, the
    name in snake case ("chain_response"), the first word of a rule's name in a `.ltl` file.
    `arity`: 1 (an activity) or 2 (two). `activation`: the index of the activating argument
    (0 for a, 1 for b; None for a unary template, activated by every case). `counting`: the
    name takes a count (Existence2, Absence3, Exactly1). `negative`: a "Not ..." template.
    Choice and Exclusive Choice are binary with no activation: like a unary template, every
    case is bound by them. `symmetric`: the formula means the same with a and b swapped, and the
    field counts it once per unordered pair (the miner does too; Not Responded Existence means
    the same swapped, but Declare activates it by a and mines it per ordered pair).
    `activated_by_both`: each argument activates it (the Succession and Co-Existence families,
    Declare4Py's "shortcuts"): an MP-Declare condition has no single event to narrow.
    """

    name: str
    key: str
    arity: int
    formula: str
    activation: int | None = None
    counting: bool = False
    negative: bool = False
    symmetric: bool = False
    activated_by_both: bool = False

    def ltlf(self, a: str, b: str | None = None, n: int = 1) -> str:
        """The template's formula over the event formulas `a` (and `b`), with count `n`."""
        if (b is None) != (self.arity == 1):
            raise InputError(f"{self.name} takes {self.arity} activities, not {2 - (b is None)}")
        if n < 1 or (n > 1 and not self.counting):
            raise InputError(f"{self.name}: no count {n} (counting templates take 1 or more)")
        a, b = f"({a})", None if b is None else f"({b})"
        if self.key == "existence":
            return _at_least(a, n)
        if self.key == "absence":
            return f"!({_at_least(a, n)})"
        if self.key == "exactly":
            return f"({_at_least(a, n)}) & !({_at_least(a, n + 1)})"
        return self.formula.format(a=a, b=b, weak_until=weak_until)


def _at_least(a: str, n: int) -> str:
    """a happens at least n times: F(a & X F(a & ... ))."""
    text = f"F {a}"
    for _ in range(n - 1):
        text = f"F({a} & X {text})"
    return text


def _templates() -> tuple[Template, ...]:
    wu = weak_until
    t = Template
    return (
        t("Existence", "existence", 1, "", counting=True),
        t("Absence", "absence", 1, "", counting=True, negative=True),
        t("Exactly", "exactly", 1, "", counting=True),
        t("Init", "init", 1, "{a}"),
        t("End", "end", 1, "F({a} & last)"),
        t("Choice", "choice", 2, "F {a} | F {b}", symmetric=True),
        t(
            "Exclusive Choice", "exclusive_choice", 2, "(F {a} | F {b}) & !(F {a} & F {b})",
            symmetric=True,
        ),
        t("Responded Existence", "responded_existence", 2, "F {a} -> F {b}", activation=0),
        t(
            "Co-Existence", "co_existence", 2, "F {a} <-> F {b}", activation=0, symmetric=True,
            activated_by_both=True,
        ),
        t("Response", "response", 2, "G({a} -> X F {b})", activation=0),
        t("Precedence", "precedence", 2, wu("!{b}", "{a}"), activation=1),
        t(
            "Succession", "succession", 2,
            "G({a} -> X F {b}) & (" + wu("!{b}", "{a}") + ")", activation=0,
            activated_by_both=True,
        ),
        t("Alternate Response", "alternate_response", 2, "G({a} -> X(!{a} U {b}))", activation=0),
        t(
            "Alternate Precedence", "alternate_precedence", 2,
            "(" + wu("!{b}", "{a}") + ") & G({b} -> WX(" + wu("!{b}", "{a}") + "))",
            activation=1,
        ),
        t(
            "Alternate Succession", "alternate_succession", 2,
            "G({a} -> X(!{a} U {b})) & (" + wu("!{b}", "{a}") + ") & G({b} -> WX("
            + wu("!{b}", "{a}") + "))",
            activation=0, activated_by_both=True,
        ),
        t("Chain Response", "chain_response", 2, "G({a} -> X {b})", activation=0),
        t("Chain Precedence", "chain_precedence", 2, "!{b} & G(X {b} -> {a})", activation=1),
        t(
            "Chain Succession", "chain_succession", 2,
            "G({a} -> X {b}) & !{b} & G(X {b} -> {a})", activation=0, activated_by_both=True,
        ),
        t(
            "Not Responded Existence", "not_responded_existence", 2, "F {a} -> G !{b}",
            activation=0, negative=True,
        ),
        t(
            "Not Co-Existence", "not_co_existence", 2, "!(F {a} & F {b})", activation=0,
            negative=True, symmetric=True, activated_by_both=True,
        ),
        t("Not Response", "not_response", 2, "G({a} -> WX G !{b})", activation=0, negative=True),
        t(
            "Not Precedence", "not_precedence", 2, "G({a} -> WX G !{b})", activation=1,
            negative=True,
        ),
        t(
            "Not Succession", "not_succession", 2, "G({a} -> WX G !{b})", activation=0,
            negative=True, activated_by_both=True,
        ),
        t(
            "Not Chain Response", "not_chain_response", 2, "G({a} -> WX !{b})", activation=0,
            negative=True,
        ),
        t(
            "Not Chain Precedence", "not_chain_precedence", 2, "G({a} -> WX !{b})",
            activation=1, negative=True,
        ),
        t(
            "Not Chain Succession", "not_chain_succession", 2, "G({a} -> WX !{b})",
            activation=0, negative=True, activated_by_both=True,
        ),
    )  # fmt: skip


TEMPLATES: dict[str, Template] = {t.key: t for t in _templates()}

_COUNT = re.compile(r"^(existence|absence|exactly)(\d+)$")


def template_key(name: str) -> str:
    """A template's name as tleaf's key: lower case, words joined by _ ("Co-Existence" ->
    "co_existence", "Chain Response" -> "chain_response")."""
    return re.sub(r"[^a-z0-9]+", "_", name.strip().lower()).strip("_")


def find_template(name: str) -> tuple[Template, int]:
    """The template `name` names (Declare's name or tleaf's key, any case; a counting template
    with its count: "Existence2", "absence3", "Exactly1") and its count (1 without one).
    InputError naming the known templates otherwise."""
    key = template_key(name)
    key = {"exactly_once": "exactly", "coexistence": "co_existence"}.get(key, key)
    key = key.replace("not_coexistence", "not_co_existence")
    count = 1
    match = _COUNT.match(key.replace("_", ""))
    if match is not None and key.replace("_", "") != match.group(1):
        key, count = match.group(1), int(match.group(2))
    if key not in TEMPLATES:
        known = ", ".join(t.name for t in TEMPLATES.values())
        raise InputError(f"{name!r} is not a Declare template (known: {known})")
    return TEMPLATES[key], count
