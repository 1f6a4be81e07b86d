"""tl.Shield: the allowed actions are exactly those after which some continuation is accepted."""

from __future__ import annotations

import itertools
import random

import pytest
import torch

import tleaf_cli as tl
from tleaf_cli.errors import ArgumentError, RulesError

VOCAB = ["rinse", "cut", "cook", "serve", "wait"]


def completable(rules: tl.RuleSet, prefix: list[int], horizon: int = 4) -> bool:
    """Brute force: some continuation of at most `horizon` steps makes the prefix accepted."""
    for n in range(horizon + 1):
        for rest in itertools.product(range(len(VOCAB)), repeat=n):
            seq = prefix + list(rest)
            if seq and rules.dfa.accepts([{VOCAB[k]} for k in seq]):
                return True
    return False


@pytest.mark.parametrize(
    "formulas",
    [
        ["(!cook U rinse) | G !cook"],
        ["G !cut", "F serve"],
        ["(!cook U rinse) | G !cook", "G(cut -> X cook)", "F serve"],
    ],
)
def test_allowed_actions_are_those_that_keep_the_rules_satisfiable(formulas) -> None:
    rules = tl.RuleSet(formulas, VOCAB)
    shield = tl.Shield(rules)
    rng = random.Random(0)
    for _ in range(5):
        shield.reset()
        prefix: list[int] = []
        for _ in range(4):
            allowed = shield.allowed()
            assert allowed.dtype == torch.bool and allowed.shape == (len(VOCAB),)
            for v in range(len(VOCAB)):
                assert bool(allowed[v]) == completable(rules, [*prefix, v]), (prefix, v)
            choice = rng.choice(torch.nonzero(allowed).flatten().tolist())
            assert shield.step(choice)  # an allowed action keeps the rules satisfiable
            prefix.append(choice)
        assert shield.accepting == rules.dfa.accepts([{VOCAB[k]} for k in prefix])


def test_a_forbidden_action_is_reported_and_the_state_follows_it() -> None:
    shield = tl.Shield(tl.RuleSet("(!cook U rinse) | G !cook", VOCAB))
    assert not shield.allowed()[VOCAB.index("cook")]
    assert shield.step(VOCAB.index("cook")) is False
    assert not shield.allowed().any()  # nothing can repair it
    shield.reset()
    assert shield.step(VOCAB.index("rinse")) and shield.allowed().all()


def test_unsatisfiable_rules_and_bad_actions_are_clear_errors() -> None:
    with pytest.raises(RulesError, match="no sequence satisfies"):
        tl.Shield(tl.RuleSet(["F serve", "G !serve"], VOCAB))
    with pytest.raises(tl.TleafError, match="outside the vocabulary"):
        tl.Shield(tl.RuleSet("F serve", VOCAB)).step(9)


def test_the_cooking_shield_allows_every_feasible_action_on_random_rollouts() -> None:
    """The shield is built from the LTLf rules alone; the rules are sound, so every action the
    environment finds feasible is allowed. They say less than the environment (first
    occurrences only): some allowed actions are infeasible (docs/cooking.md gives the figures)."""
    import gymnasium as gym
    import numpy as np

    import tleaf_cli.tasks.cooking  # noqa: F401  (registers the environment)
    from tleaf_cli.tasks.cooking.shield import cooking_shield

    env = gym.make("tleaf/CreativeCooking-v0").unwrapped
    rng = np.random.default_rng(0)
    allowed_not_feasible = 0
    for episode in range(2):
        env.reset(seed=episode)
        names = env.action_names
        assert len(set(names)) == len(names)  # one atom per action id
        shield = cooking_shield(env.domain, env.ingredients, names)
        shield.reset()
        for _ in range(20):
            feasible = torch.as_tensor(env.action_masks())
            allowed = shield.allowed()
            assert not (feasible & ~allowed).any()  # sound: nothing feasible is blocked
            allowed_not_feasible += int((allowed & ~feasible).sum())
            action = int(rng.choice(torch.nonzero(feasible).flatten().numpy()))
            assert shield.step(action)
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                break
    assert allowed_not_feasible > 0  # the rules do not pin feasibility down (reported)


def test_rule_sets_over_other_vocabularies_are_refused_with_where_they_differ() -> None:
    other = ["rinse", "cut", "cook", "wait", "serve"]  # the same items, two swapped
    rules = [tl.RuleSet("F serve", VOCAB), tl.RuleSet("F serve", other, name="swapped")]
    with pytest.raises(ArgumentError, match="its item 3 is 'wait', not 'serve'"):
        tl.Shield(rules)
    with pytest.raises(ArgumentError, match="5 items, not 4"):
        tl.Shield([tl.RuleSet("F serve", VOCAB[:4]), tl.RuleSet("F serve", VOCAB)])
