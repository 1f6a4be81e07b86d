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

import operator
from collections.abc import Sequence

import numpy as np
import torch

from tleaf_cli import arguments
from tleaf_cli.errors import ArgumentError, ArgumentTypeError, RulesError
from tleaf_cli.rule_set import RuleSet, common_vocabulary


class Shield:
    """A runtime monitor of `rules` for a policy over the rules' vocabulary.

    Args:
        rules: a rule set (`tl.RuleSet`) over the policy's actions, or several over the same
            vocabulary: an action is then allowed when every one allows it. That is the shield
            of their conjunction whenever each stays satisfiable on its own, as for safety rules
            (never taking an action always meets them), without building the product automaton;
            all of them advance together, in one tensor operation per step.
        device: where its tensors live (the policy's device; default the CPU): `allowed()`
            is a mask there.

    Raises RulesError when a rule set has no satisfying sequence (nothing could be allowed).
    """

    def __init__(
        self, rules: RuleSet | Sequence[RuleSet], device: torch.device | str = "cpu"
    ) -> None:
        self.rule_sets = arguments.rule_sets(rules, None, RuleSet)
        self.vocabulary = common_vocabulary(self.rule_sets)
        size = len(self.vocabulary)
        for r in self.rule_sets:
            if not r.satisfiable:
                raise RulesError(f"rule set {r.name}: no sequence satisfies it; nothing to allow")
        self._position = {item: i for i, item in enumerate(self.vocabulary)}
        states = max(r.dfa.num_states for r in self.rule_sets)
        n = len(self.rule_sets)
        # built in numpy, moved to `device` once
        following = np.zeros((n, states, size), dtype=np.int64)  # state after each action
        live = np.zeros((n, states), dtype=bool)  # acceptance still reachable
        accepting = np.zeros((n, states), dtype=bool)
        for k, r in enumerate(self.rule_sets):
            s = r.dfa.num_states
            following[k, :s] = r.dfa.table[:, r.letters(np.arange(size))]
            live[k, :s] = r.dfa.live()
            accepting[k, :s] = r.dfa.accepting
        self.device = torch.device(device)
        self._next = torch.as_tensor(following, device=self.device)
        self._live = torch.as_tensor(live, device=self.device)
        self._accepting = torch.as_tensor(accepting, device=self.device)
        self._rows = torch.arange(n, device=self.device)
        self._allowed = torch.gather(  # [R, S, V]: the action leads to a live state
            self._live[:, None, :].expand(-1, states, -1), 2, self._next
        )
        initial = [r.dfa.initial for r in self.rule_sets]
        self._initial = torch.tensor(initial, dtype=torch.long, device=self.device)
        self.state = self._initial.clone()  # [R]

    def reset(self) -> None:
        """Back to the start of an episode (every DFA's initial state)."""
        self.state = self._initial.clone()

    def allowed(self) -> torch.Tensor:
        """BoolTensor [V]: the actions after which the rules can still be met."""
        return self._allowed[self._rows, self.state].all(dim=0)

    def step(self, action: int | str) -> bool:
        """Advance on the chosen action: its vocabulary index (an int, a numpy integer or a
        one-element tensor) or its item name. True while the rules can still be met (False once
        an action outside `allowed()` was taken)."""
        index = self._index(action)
        self.state = self._next[self._rows, self.state, index]
        return bool(self._live[self._rows, self.state].all())

    def _index(self, action: int | str) -> int:
        """The vocabulary index of `action` (ArgumentError / ArgumentTypeError otherwise)."""
        if isinstance(action, str):
            if action not in self._position:
                raise ArgumentError(
                    "action",
                    f"{action!r} is not an item of the vocabulary ({len(self.vocabulary)} items)",
                )
            return self._position[action]
        try:
            if isinstance(action, bool):
                raise TypeError
            index = operator.index(action)  # int, numpy integer, one-element integer tensor
        except TypeError:
            raise ArgumentTypeError(
                "action",
                f"must be a vocabulary index or an item name, not {arguments.given(action)}",
            ) from None
        if not 0 <= index < len(self.vocabulary):
            raise ArgumentError(
                "action", f"{index} is outside the vocabulary of {len(self.vocabulary)} items"
            )
        return index

    @property
    def accepting(self) -> bool:
        """Whether the actions taken so far satisfy the rules (were the episode to end now)."""
        return bool(self._accepting[self._rows, self.state].all())
