"""A shield: a runtime monitor that tells a policy which actions keep the rules satisfiable.

A policy acting step by step over a one-hot vocabulary (its actions) is shielded by a rule set:
the shield follows the rule set's DFA along the chosen actions, and before each step
`allowed()` is the mask of the actions after which the rules can still be met — the DFA's
`alive_letters` of its current state, spread over the vocabulary (every item outside the rules'
atoms is letter 0). A policy that only takes allowed actions never reaches a state from which
the rules are lost; with an action mask (sb3-contrib's MaskablePPO reads one per step) that is
enforced during learning too.

"Can still be met" has no horizon: an allowed action keeps some accepted continuation, of any
length; an episode cut short may still end unsatisfied (a rule like `F serve` unmet).
"""

from __future__ import annotations

import torch

from tleaf_cli.data.rule_set import RuleSet
from tleaf_cli.errors import InputError, RulesError


class Shield:
    """A runtime monitor of `rules` for a policy over `rules.vocabulary`.

    Args:
        rules: the rule set (`tl.RuleSet`) over the policy's actions.

    Raises RulesError when no sequence satisfies the rules (nothing could ever be allowed).
    """

    def __init__(self, rules: RuleSet) -> None:
        if not rules.satisfiable:
            raise RulesError(f"rule set {rules.name}: no sequence satisfies it; nothing to allow")
        self.rules = rules
        dfa = rules.dfa
        self._live = dfa.live()  # bool [S]: acceptance still reachable
        live = torch.as_tensor(self._live)
        table = torch.as_tensor(dfa.table, dtype=torch.long)  # [S, L]
        letter_of = torch.as_tensor(rules.letters(range(len(rules.vocabulary))))  # [V]
        self._next = table[:, letter_of]  # [S, V]: the state after each action
        self._allowed = live[self._next]  # [S, V]
        self.state = dfa.initial

    def reset(self) -> None:
        """Back to the start of an episode (the DFA's initial state)."""
        self.state = self.rules.dfa.initial

    def allowed(self) -> torch.Tensor:
        """BoolTensor [V]: the actions after which the rules can still be met."""
        return self._allowed[self.state].clone()

    def step(self, index: int) -> bool:
        """Advance on the chosen action (a vocabulary index); True while the rules can still
        be met (False once an action outside `allowed()` was taken)."""
        if not 0 <= int(index) < self._next.shape[1]:
            raise InputError(f"action {index} is outside the vocabulary of {self._next.shape[1]}")
        self.state = int(self._next[self.state, int(index)])
        return bool(self._live[self.state])

    @property
    def accepting(self) -> bool:
        """Whether the actions taken so far satisfy the rules (were the episode to end now)."""
        return bool(self.rules.dfa.accepting[self.state])
