"""Declare's templates (knowledge/templates.py): every formula parses, and on every trace of up to
five events over a, b, c it says what the template's definition in words says (counted on the
sequence: the definitions of Declare's literature, independent of the formulas)."""

from __future__ import annotations

from itertools import product

import pytest

from tleaf_cli.errors import InputError
from tleaf_cli.knowledge.templates import TEMPLATES, find_template
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.semantics import satisfies


def _positions(w: tuple[str, ...], x: str) -> list[int]:
    return [i for i, e in enumerate(w) if e == x]


def _alternate_response(w) -> bool:
    return all(
        any(w[j] == "b" for j in range(i + 1, len(w)))
        and all(
            w[j] != "a" for j in range(i + 1, next(j for j in range(i + 1, len(w)) if w[j] == "b"))
        )
        if any(w[j] == "b" for j in range(i + 1, len(w)))
        else False
        for i in _positions(w, "a")
    )


def _alternate_precedence(w) -> bool:
    # every b has an a before it, with no other b between that a and it
    for i in _positions(w, "b"):
        before = [j for j in range(i) if w[j] in "ab"]
        if not before or w[before[-1]] != "a":
            return False
    return True


DEFINITIONS = {
    "init": lambda w: w[0] == "a",
    "choice": lambda w: "a" in w or "b" in w,
    "exclusive_choice": lambda w: ("a" in w) != ("b" in w),
    "end": lambda w: w[-1] == "a",
    "responded_existence": lambda w: "a" not in w or "b" in w,
    "co_existence": lambda w: ("a" in w) == ("b" in w),
    "response": lambda w: all("b" in w[i + 1 :] for i in _positions(w, "a")),
    "precedence": lambda w: all("a" in w[:i] for i in _positions(w, "b")),
    "succession": lambda w: (
        all("b" in w[i + 1 :] for i in _positions(w, "a"))
        and all("a" in w[:i] for i in _positions(w, "b"))
    ),
    "alternate_response": _alternate_response,
    "alternate_precedence": _alternate_precedence,
    "alternate_succession": lambda w: _alternate_response(w) and _alternate_precedence(w),
    "chain_response": lambda w: all(i + 1 < len(w) and w[i + 1] == "b" for i in _positions(w, "a")),
    "chain_precedence": lambda w: all(i > 0 and w[i - 1] == "a" for i in _positions(w, "b")),
    "chain_succession": lambda w: (
        all(i + 1 < len(w) and w[i + 1] == "b" for i in _positions(w, "a"))
        and all(i > 0 and w[i - 1] == "a" for i in _positions(w, "b"))
    ),
    "not_responded_existence": lambda w: not ("a" in w and "b" in w),
    "not_co_existence": lambda w: not ("a" in w and "b" in w),
    "not_response": lambda w: all("b" not in w[i + 1 :] for i in _positions(w, "a")),
    "not_precedence": lambda w: all("a" not in w[:i] for i in _positions(w, "b")),
    "not_succession": lambda w: all("b" not in w[i + 1 :] for i in _positions(w, "a")),
    "not_chain_response": lambda w: all(w[i + 1 : i + 2] != ("b",) for i in _positions(w, "a")),
    "not_chain_precedence": lambda w: all(i == 0 or w[i - 1] != "a" for i in _positions(w, "b")),
    "not_chain_succession": lambda w: all(w[i + 1 : i + 2] != ("b",) for i in _positions(w, "a")),
}
COUNTING = {
    "existence": lambda w, n: w.count("a") >= n,
    "absence": lambda w, n: w.count("a") < n,
    "exactly": lambda w, n: w.count("a") == n,
}
TRACES = [w for k in range(1, 6) for w in product("abc", repeat=k)]


def _holds(formula: str, w: tuple[str, ...]) -> bool:
    return satisfies([{e} for e in w], parse(formula))


@pytest.mark.parametrize("key", sorted(DEFINITIONS))
def test_each_relational_or_positional_formula_is_its_definition(key) -> None:
    template = TEMPLATES[key]
    formula = template.ltlf("a", "b" if template.arity == 2 else None)
    wrong = [w for w in TRACES if _holds(formula, w) != DEFINITIONS[key](w)]
    assert wrong == [], (key, formula, wrong[:3])


@pytest.mark.parametrize("key", sorted(COUNTING))
@pytest.mark.parametrize("n", [1, 2, 3])
def test_each_counting_formula_is_its_definition(key, n) -> None:
    formula = TEMPLATES[key].ltlf("a", n=n)
    wrong = [w for w in TRACES if _holds(formula, w) != COUNTING[key](w, n)]
    assert wrong == [], (key, n, formula, wrong[:3])


def test_every_template_is_defined_and_tested() -> None:
    assert set(TEMPLATES) == set(DEFINITIONS) | set(COUNTING)


@pytest.mark.parametrize(
    ("name", "key", "count"),
    [
        ("Chain Response", "chain_response", 1),
        ("Not Co-Existence", "not_co_existence", 1),
        ("Existence2", "existence", 2),
        ("Absence", "absence", 1),
        ("exactly_once", "exactly", 1),
        ("Exactly2", "exactly", 2),
        ("Responded Existence", "responded_existence", 1),
    ],
)
def test_names_as_declare_writes_them(name, key, count) -> None:
    template, n = find_template(name)
    assert (template.key, n) == (key, count)


def test_an_unknown_template_names_the_known_ones() -> None:
    with pytest.raises(InputError, match="Chain Response"):
        find_template("Eventually Maybe")


def test_symmetric_templates_mean_the_same_with_their_arguments_swapped():
    """`Template.symmetric` (the miner takes such templates over unordered pairs) holds where
    swapping a and b gives the same language, on every trace of up to 4 events. The one other
    template whose language is symmetric, Not Responded Existence (F a -> G !b, i.e. not both),
    is activated by a in Declare and pm4py, which mine it per ordered pair: so does tleaf."""
    import itertools

    from tleaf_cli.knowledge.templates import TEMPLATES
    from tleaf_cli.logic.formulas import parse
    from tleaf_cli.logic.semantics import satisfies

    traces = [
        [frozenset({x}) for x in word]
        for n in range(1, 5)
        for word in itertools.product("abc", repeat=n)
    ]
    swapped_alike = set()
    for key, template in TEMPLATES.items():
        if template.arity != 2:
            continue
        one, other = parse(template.ltlf("a", "b")), parse(template.ltlf("b", "a"))
        if all(satisfies(t, one) == satisfies(t, other) for t in traces):
            swapped_alike.add(key)
    symmetric = {k for k, t in TEMPLATES.items() if t.symmetric}
    assert swapped_alike == symmetric | {"not_responded_existence"}
