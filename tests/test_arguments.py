"""The public API checks what it is given (tleaf_cli/arguments.py): each bad argument is a
TleafError naming it, nothing wrong is returned silently, and natural values are accepted."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tleaf_cli as tl
from tleaf_cli.errors import ArgumentError, ArgumentTypeError

VOCAB = ["rinse", "cut", "cook", "serve"]


@pytest.fixture(scope="module")
def rules() -> tl.RuleSet:
    return tl.RuleSet(["(!cook U rinse) | G !cook", "F serve"], VOCAB)


def _log_probs(batch: int = 4, steps: int = 6, seed: int = 0) -> torch.Tensor:
    torch.manual_seed(seed)
    return torch.log_softmax(torch.randn(batch, steps, len(VOCAB)), -1)


# ---- lengths


@pytest.mark.parametrize("kind", ["exact", "checker", "decode"])
@pytest.mark.parametrize(
    ("lengths", "message"),
    [
        ([0, 6, 6, 6], "sequence 0 has length 0: lengths are 1 to T = 6"),
        ([6, 7, 6, 6], "sequence 1 has length 7: lengths are 1 to T = 6"),
        ([6, 6], "one length per sequence, [4], not [2]"),
        ([6.0, 6.0, 6.0, 6.0], "must hold ints"),
        ("6666", "must be a tensor or a sequence of B ints"),
    ],
)
def test_bad_lengths_are_refused_by_every_function(rules, kind, lengths, message) -> None:
    """A length of 0 gave an exact loss of 1e30, past T an IndexError (the checker: a silent
    0), another batch size an IndexError about a mask."""
    lp = _log_probs()
    call = (
        (lambda: tl.constrained_decode(lp, rules, lengths))
        if kind == "decode"
        else (lambda: tl.logic_loss(kind, lp, rules, lengths))
    )
    with pytest.raises(ArgumentError, match="lengths: ") as e:
        call()
    assert message in str(e.value)


def test_lengths_as_a_list_or_an_array_are_the_tensor(rules) -> None:
    lp = _log_probs()
    want = tl.logic_loss("exact", lp, rules, torch.tensor([6, 3, 1, 5]), reduction="none")
    for lengths in ([6, 3, 1, 5], (6, 3, 1, 5), np.array([6, 3, 1, 5])):
        got = tl.logic_loss("exact", lp, rules, lengths, reduction="none")
        assert torch.equal(got, want)
    decoded = tl.constrained_decode(lp, rules, [6, 3, 1, 5])
    assert torch.equal(decoded, tl.constrained_decode(lp, rules, torch.tensor([6, 3, 1, 5])))


# ---- vocabularies, rules


def test_a_repeated_vocabulary_item_is_refused() -> None:
    """It was accepted, and the rules' atom mapped to one copy: the other counted as breaking."""
    with pytest.raises(ArgumentError, match="'cook' appears twice \\(items 0 and 2\\)"):
        tl.RuleSet(["F cook"], ["cook", "cut", "cook"])


@pytest.mark.parametrize("item", ["Cut", "cut onion", "cuisson_é", "", "truefalse", "lastly", 3])
def test_items_that_can_never_be_atoms_are_refused(item) -> None:
    with pytest.raises(ArgumentError, match="vocabulary: item 1"):
        tl.RuleSet(["F cook"], ["cook", item])


@pytest.mark.parametrize(
    ("rules_given", "message"),
    [
        ("F serve", "not a formula string 'F serve'"),
        (["F serve"] * 4, "item 0 must be a tl.RuleSet"),
        (42, "must be a sequence of rule sets"),
    ],
)
def test_rules_of_the_wrong_type_are_refused(rules_given, message) -> None:
    """A formula string gave "7 rule sets for a batch of 4", a list of them an AttributeError."""
    for call in (
        lambda: tl.logic_loss("exact", _log_probs(), rules_given),
        lambda: tl.constrained_decode(_log_probs(), rules_given),
    ):
        with pytest.raises(ArgumentTypeError, match="rules: ") as e:
            call()
        assert message in str(e.value)


def test_a_shield_of_strings_is_refused_and_steps_take_item_names(rules) -> None:
    with pytest.raises(ArgumentTypeError, match=r"rules: must be a tl\.RuleSet"):
        tl.Shield("F serve")
    with pytest.raises(ArgumentTypeError, match="rules: item 0"):
        tl.Shield(["F serve"])
    by_name, by_index = tl.Shield(rules), tl.Shield(rules)
    for action in ("cut", "rinse", "cook"):
        assert by_name.step(action) == by_index.step(VOCAB.index(action))
        assert torch.equal(by_name.state, by_index.state)
    assert by_name.step(np.int64(3)) and by_name.accepting
    with pytest.raises(ArgumentError, match="action: 'fry' is not an item"):
        by_name.step("fry")
    with pytest.raises(ArgumentError, match="action: 4 is outside the vocabulary"):
        by_name.step(4)
    with pytest.raises(ArgumentTypeError, match="action: must be a vocabulary index"):
        by_name.step(1.0)


# ---- values


def test_nan_log_probabilities_are_refused(rules) -> None:
    """A NaN passed, and the loss was NaN."""
    lp = _log_probs()
    lp[2, 3, 1] = float("nan")
    with pytest.raises(ArgumentError, match=r"log_probs: holds nan at \[2, 3, 1\]"):
        tl.logic_loss("exact", lp, rules)
    with pytest.raises(ArgumentError, match="log_probs: holds nan"):
        tl.constrained_decode(lp, rules)


@pytest.mark.parametrize("dtype", [torch.float16, torch.bfloat16])
def test_half_precision_log_probabilities_are_computed_in_float32(rules, dtype) -> None:
    """float16 raised a RuntimeError about overflow, bfloat16 'not normalised'."""
    lp = _log_probs()
    low = lp.to(dtype)
    got = tl.logic_loss("exact", low, rules, reduction="none")
    want = tl.logic_loss("exact", lp, rules, reduction="none")  # the float32 original
    assert got.dtype == torch.float32 and torch.isfinite(got).all()
    torch.testing.assert_close(got, want, rtol=0.03, atol=0.03)  # bfloat16: 8 bits of mantissa
    assert torch.equal(tl.constrained_decode(low, rules), tl.constrained_decode(low.float(), rules))


def test_log_probs_of_the_wrong_type_or_shape_are_refused(rules) -> None:
    with pytest.raises(ArgumentTypeError, match=r"log_probs: must be a torch\.Tensor"):
        tl.logic_loss("exact", _log_probs().numpy(), rules)
    with pytest.raises(ArgumentTypeError, match="log_probs: must be a float tensor"):
        tl.logic_loss("exact", torch.zeros(4, 6, 4, dtype=torch.long), rules)
    with pytest.raises(ArgumentError, match=r"log_probs: must be \[B, T, V\]"):
        tl.logic_loss("exact", _log_probs()[0], rules)


def test_compile_formula_and_check_refuse_what_is_not_a_formula_or_traces() -> None:
    with pytest.raises(ArgumentTypeError, match="text: must be a str, not int"):
        tl.compile_formula(5)
    dfa = tl.compile_formula("F a")
    with pytest.raises(ArgumentTypeError, match="traces: must be a sequence of traces"):
        tl.check(dfa, "a")  # was read letter by letter: [True]
    with pytest.raises(ArgumentTypeError, match=r"traces\[0\]\[0\]: must be a set of atom names"):
        tl.check(dfa, [["a"]])
    with pytest.raises(ArgumentError, match=r"traces\[1\]: is empty"):
        tl.check(dfa, [[{"a"}], []])
    with pytest.raises(ArgumentTypeError, match=r"dfa: must be a tl\.DFA"):
        tl.check("F a", [[{"a"}]])
    assert tl.check(dfa, [[{"a"}], [set(), {"b"}]]).tolist() == [True, False]


def test_load_embedder_refuses_what_is_not_a_path() -> None:
    with pytest.raises(ArgumentTypeError, match="model_dir: must be a path"):
        tl.load_embedder(3)


# ---- every failure a TleafError, every success finite

_ITEMS = st.sampled_from(["rinse", "cut", "cook", "serve", "Cook", "cut onion", ""])
_LENGTHS = st.one_of(
    st.none(),
    st.lists(st.integers(-2, 9), min_size=0, max_size=6),
    st.integers(0, 5),
    st.just("3"),
    st.lists(st.one_of(st.floats(0, 8), st.just(float("nan"))), min_size=4, max_size=4),
)
_VALUES = st.sampled_from([0.0, float("nan"), float("inf"), float("-inf"), 5.0])


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    kind=st.sampled_from(["exact", "checker", "tleaf", "decode", "bogus"]),
    batch=st.integers(1, 4),
    steps=st.integers(1, 5),
    width=st.sampled_from([3, 4, 5]),
    dtype=st.sampled_from(
        [torch.float32, torch.float16, torch.bfloat16, torch.float64, torch.long]
    ),
    lengths=_LENGTHS,
    poke=st.one_of(st.none(), _VALUES),
    as_rules=st.sampled_from(["one", "list", "string", "strings", "short", "none"]),
)
def test_malformed_arguments_raise_tleaf_errors_and_successes_are_finite(
    rules, kind, batch, steps, width, dtype, lengths, poke, as_rules
) -> None:
    torch.manual_seed(batch * 31 + steps)
    lp = torch.log_softmax(torch.randn(batch, steps, width), -1)
    if poke is not None:
        lp[0, 0, 0] = poke
    lp = lp.to(dtype)
    given_rules = {
        "one": rules,
        "list": [rules] * batch,
        "string": "F serve",
        "strings": ["F serve"] * batch,
        "short": [rules] * (batch + 1),
        "none": [None] * batch,
    }[as_rules]
    try:
        if kind == "decode":
            out = tl.constrained_decode(lp, given_rules, lengths)
        else:
            out = tl.logic_loss(kind, lp, given_rules, lengths)
    except tl.TleafError:
        return
    assert torch.isfinite(out.float()).all()


@settings(max_examples=40, deadline=None)
@given(
    vocabulary=st.lists(_ITEMS, max_size=5),
    formulas=st.sampled_from(["F cook", ["F cook"], 3, [3], []]),
)
def test_malformed_rule_sets_raise_tleaf_errors(vocabulary, formulas) -> None:
    try:
        rules = tl.RuleSet(formulas, vocabulary)
    except tl.TleafError:
        return
    assert len(set(rules.vocabulary)) == len(rules.vocabulary) and "cook" in rules.vocabulary
