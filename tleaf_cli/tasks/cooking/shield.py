"""The cooking knowledge base as a shield for an episode's actions (`tl.Shield` per rule).

For an episode's ingredients, every rule of `knowledge.knowledge_base` (affordances, orderings,
mixture rules included) becomes a `tl.Shield` over the episode's action names (one atom per
action id); an action is allowed when every rule's shield allows it. Every rule here is a safety
property that some sequence always meets (never taking its action), so the conjunction can still
be met exactly when each rule can: the AND of the per-rule masks is the shield of the whole rule
set, without building its product automaton (hundreds of rules per episode).

Built only from the LTLf rules — never from the environment's feasibility; `tests/test_shield.py`
compares the two on random rollouts (the rules are sound, so every feasible action is allowed;
what they allow beyond feasibility is what LTLf over first occurrences cannot say, docs/cooking.md).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch

from tleaf_cli.data.compile_dfas import CompileSettings
from tleaf_cli.data.rule_set import RuleSet, compile_rules
from tleaf_cli.shield import Shield
from tleaf_cli.tasks.cooking.domain import Domain
from tleaf_cli.tasks.cooking.knowledge import knowledge_base


class CookingShield:
    """`reset()`, `allowed()` [V] and `step(action)` for one episode, over its action names."""

    def __init__(
        self,
        domain: Domain,
        ingredients: Sequence[str],
        action_names: Sequence[str],
        compile_settings: CompileSettings | None = None,
    ) -> None:
        rules = knowledge_base(domain, ingredients)
        compile_rules([r.formula for r in rules], compile_settings)  # one batch
        self.rule_names = [r.name for r in rules]
        self.shields = [
            Shield(RuleSet(r.formula, action_names, r.name, compile_settings)) for r in rules
        ]

    def reset(self) -> None:
        for shield in self.shields:
            shield.reset()

    def allowed(self) -> torch.Tensor:
        """BoolTensor [V]: the actions every rule still allows."""
        out = self.shields[0].allowed()
        for shield in self.shields[1:]:
            out &= shield.allowed()
        return out

    def step(self, action: int) -> bool:
        """Advance every rule on the action; True while every rule can still be met."""
        return all([shield.step(action) for shield in self.shields])
