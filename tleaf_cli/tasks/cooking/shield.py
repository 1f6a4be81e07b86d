"""The cooking knowledge base as a shield for an episode's actions (one `tl.Shield`, a rule set
per rule).

For an episode's ingredients, every rule of `knowledge.knowledge_base` (affordances, orderings,
mixture rules included) becomes a rule set over the episode's action names (one atom per action
id), and one `tl.Shield` follows them all: an action is allowed when every rule allows it.
Every rule here is a safety property that some sequence always meets (never taking its action),
so the conjunction can still be met exactly when each rule can: the AND of the masks is the
shield of the whole rule set, without its product automaton (hundreds of rules per episode).

Built only from the LTLf rules — never from the environment's feasibility; `tests/test_shield.py`
compares the two on random rollouts (the rules are sound, so every feasible action is allowed;
what they allow beyond feasibility is what LTLf over first occurrences cannot say, docs/cooking.md).
"""

from __future__ import annotations

from collections.abc import Sequence

import gymnasium as gym
import numpy as np

from tleaf_cli.data.compile_dfas import CompileSettings
from tleaf_cli.rule_set import RuleSet, compile_rules
from tleaf_cli.shield import Shield
from tleaf_cli.tasks.cooking.domain import Domain
from tleaf_cli.tasks.cooking.knowledge import knowledge_base


def cooking_shield(
    domain: Domain,
    ingredients: Sequence[str],
    action_names: Sequence[str],
    compile_settings: CompileSettings | None = None,
) -> Shield:
    """The shield of an episode's rules over its action names: one rule set per KB rule."""
    rules = knowledge_base(domain, ingredients)
    compile_rules([r.formula for r in rules], compile_settings)  # one batch
    return Shield([RuleSet(r.formula, action_names, r.name, compile_settings) for r in rules])


class ShieldedActions(gym.Wrapper):
    """The environment with `action_masks()` from the rules' shield (not its own feasibility):
    what sb3-contrib's MaskablePPO reads each step. The shield follows every action taken and
    starts afresh at each reset; one shield per ingredient set is built and kept."""

    def __init__(self, env: gym.Env, compile_settings: CompileSettings | None = None) -> None:
        super().__init__(env)
        self.compile_settings = compile_settings
        self._shields: dict[tuple[str, ...], Shield] = {}
        self.shield: Shield | None = None

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        game = self.env.unwrapped
        key = tuple(game.ingredients)
        if key not in self._shields:
            self._shields[key] = cooking_shield(
                game.domain, key, game.action_names, self.compile_settings
            )
        self.shield = self._shields[key]
        self.shield.reset()
        return obs, info

    def step(self, action):
        self.shield.step(int(action))
        return self.env.step(action)

    def action_masks(self) -> np.ndarray:
        """bool [actions]: the actions the rules still allow."""
        return self.shield.allowed().numpy()
