"""The four RV-LTL verdicts of a running case (logic/verdicts.py) against a brute force over
continuations: on every rule of examples/helpdesk.decl and on 1,000 random formulas, the verdict
of the DFA's state after a prefix equals what LTLf's semantics says of the prefix followed by
every continuation up to a length past which no new state can be reached."""

from __future__ import annotations

import itertools
import random
from pathlib import Path

import pytest

from tleaf_cli.data.random_formulas import random_formula
from tleaf_cli.knowledge.rule_files import read_rule_file
from tleaf_cli.logic.compile import compile_formula
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.semantics import satisfies
from tleaf_cli.logic.verdicts import Verdict, state_verdicts

ROOT = Path(__file__).resolve().parent.parent


def brute_force(formula: str, prefix: list[frozenset], letters: list[frozenset], bound: int):
    """The verdict by the semantics: the prefix alone, and with every continuation of 1 to
    `bound` letters."""
    parsed = parse(formula)
    now = satisfies(prefix, parsed)
    later = [
        satisfies(prefix + list(rest), parsed)
        for n in range(1, bound + 1)
        for rest in itertools.product(letters, repeat=n)
    ]
    if now:
        return Verdict.PERMANENTLY_SATISFIED if all(later) else Verdict.TEMPORARILY_SATISFIED
    return Verdict.TEMPORARILY_VIOLATED if any(later) else Verdict.PERMANENTLY_VIOLATED


def dfa_verdict(dfa, prefix: list[frozenset]) -> Verdict:
    state = dfa.initial
    for letter in prefix:
        state = int(dfa.table[state, dfa.alphabet.index(letter)])
    return Verdict(int(state_verdicts(dfa)[state]))


def test_every_rule_of_the_helpdesk_model() -> None:
    """One-hot letters (an event is one activity), every prefix of up to three events."""
    seen = set()
    for source in read_rule_file(ROOT / "examples" / "helpdesk.decl"):
        dfa = compile_formula(source.text, "one-hot")
        letters = [dfa.alphabet.letter(i) for i in range(dfa.alphabet.size)]
        bound = max(dfa.num_states - 1, 1)  # a shortest path to any state is this long at most
        for n in range(1, 4):
            for prefix in itertools.product(letters, repeat=n):
                got = dfa_verdict(dfa, list(prefix))
                assert got == brute_force(source.text, list(prefix), letters, bound), (
                    source.formula_id,
                    prefix,
                )
                seen.add(got)
    assert seen == set(Verdict)  # the model's rules meet all four


def test_a_thousand_random_formulas() -> None:
    rng = random.Random(11)
    checked, seen = 0, set()
    while checked < 1000:
        atoms = ["a", "b"][: rng.randint(1, 2)]
        formula = random_formula(rng, atoms, rng.randint(2 * len(atoms) - 1, 7))
        dfa = compile_formula(formula)
        if dfa.num_states > 5:  # the brute force's bound must pass every state
            continue
        letters = [dfa.alphabet.letter(i) for i in range(dfa.alphabet.size)]
        prefix = [rng.choice(letters) for _ in range(rng.randint(1, 3))]
        got = dfa_verdict(dfa, prefix)
        assert got == brute_force(formula, prefix, letters, dfa.num_states - 1), (formula, prefix)
        seen.add(got)
        checked += 1
    assert seen == set(Verdict)


@pytest.mark.parametrize(
    ("verdict", "words", "final", "satisfied"),
    [
        (Verdict.PERMANENTLY_SATISFIED, "permanently satisfied", True, True),
        (Verdict.TEMPORARILY_SATISFIED, "temporarily satisfied", False, True),
        (Verdict.TEMPORARILY_VIOLATED, "temporarily violated", False, False),
        (Verdict.PERMANENTLY_VIOLATED, "permanently violated", True, False),
    ],
)
def test_the_verdicts_words(verdict: Verdict, words: str, final: bool, satisfied: bool) -> None:
    assert (str(verdict), verdict.final, verdict.satisfied) == (words, final, satisfied)
