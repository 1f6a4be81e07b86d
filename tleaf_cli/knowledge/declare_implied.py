"""Which Declare constraints imply which, on every case: the subsumptions the miner prunes by.

A mined rule implied by another kept rule adds nothing to the knowledge base (their conjunction
means the same without it), so `mine_declare` drops it and keeps the stronger. The implications
are Declare's subsumption hierarchy (Di Ciccio, Maggi, Montali, Mendling, "Resolving
inconsistencies and redundancies in declarative process models", Information Systems 64, 2017)
and what init, end, exactly and absence say of one activity:

- existence(a) under init(a), end(a), exactly(a);
- choice(a, b) under existence(a), existence(b) and exclusive_choice(a, b);
- responded_existence(a, b) under response(a, b), precedence(b, a), co_existence(a, b);
- co_existence(a, b) under succession(a, b) and succession(b, a);
- response(a, b) under succession, alternate_response, chain_response (a, b) and end(b);
- precedence(a, b) under succession, alternate_precedence, chain_precedence (a, b) and init(a);
- succession under alternate_succession, alternate_succession under chain_succession;
- alternate_response under alternate_succession and chain_response; alternate_precedence under
  alternate_succession and chain_precedence; chain_response and chain_precedence under
  chain_succession;
- not_co_existence(a, b) under absence(a), absence(b) and exclusive_choice(a, b);
  not_succession(a, b) under not_co_existence(a, b); not_chain_succession(a, b) under
  not_succession(a, b);
- the templates that repeat another's formula (settings/declare.py's SAME_AS_ANOTHER) under
  it: not_responded_existence under not_co_existence, not_response and not_precedence under
  not_succession, not_chain_response and not_chain_precedence under not_chain_succession.

Each direction is stated once (an equivalence one way only), so no two rules drop each other;
tests/test_declare_checks.py checks every implication on every short case. Implication is
transitive: a rule is dropped when any rule above it, directly or through others, is kept.
"""

from __future__ import annotations

from collections.abc import Iterable
from functools import cache

from tleaf_cli.knowledge.declare_constraints import Constraint

C = Constraint


def stronger(c: Constraint) -> list[Constraint]:
    """The constraints that directly imply `c` on every case (module docstring)."""
    t, (a, *rest) = c.template, c.activities
    if not rest:
        return [C(s, (a,)) for s in ("init", "end", "exactly")] if t == "existence" else []
    b = rest[0]
    above = {
        "responded_existence": [C("response", (a, b)), C("precedence", (b, a)),
                                C("co_existence", (a, b))],
        "co_existence": [C("succession", (a, b)), C("succession", (b, a))],
        "response": [C("succession", (a, b)), C("alternate_response", (a, b)),
                     C("chain_response", (a, b)), C("end", (b,))],
        "precedence": [C("succession", (a, b)), C("alternate_precedence", (a, b)),
                       C("chain_precedence", (a, b)), C("init", (a,))],
        "succession": [C("alternate_succession", (a, b))],
        "alternate_response": [C("alternate_succession", (a, b)), C("chain_response", (a, b))],
        "alternate_precedence": [C("alternate_succession", (a, b)),
                                 C("chain_precedence", (a, b))],
        "alternate_succession": [C("chain_succession", (a, b))],
        "chain_response": [C("chain_succession", (a, b))],
        "chain_precedence": [C("chain_succession", (a, b))],
        "choice": [C("existence", (a,)), C("existence", (b,)), C("exclusive_choice", (a, b))],
        "not_co_existence": [C("absence", (a,)), C("absence", (b,)),
                             C("exclusive_choice", (a, b))],
        "not_succession": [C("not_co_existence", (a, b))],
        "not_chain_succession": [C("not_succession", (a, b))],
        "not_responded_existence": [C("not_co_existence", (a, b))],
        "not_response": [C("not_succession", (a, b))],
        "not_precedence": [C("not_succession", (a, b))],
        "not_chain_response": [C("not_chain_succession", (a, b))],
        "not_chain_precedence": [C("not_chain_succession", (a, b))],
    }  # fmt: skip
    return above.get(t, [])


@cache
def implying(c: Constraint) -> frozenset[Constraint]:
    """Every constraint that implies `c`: those `stronger` names, and those above them."""
    out: set[Constraint] = set()
    for s in stronger(c):
        out |= {s, *implying(s)}
    return frozenset(out)


def redundant(kept: Iterable[Constraint]) -> set[Constraint]:
    """The constraints of `kept` that another constraint of `kept` implies on every case."""
    kept = set(kept)
    return {c for c in kept if implying(c) & kept}
