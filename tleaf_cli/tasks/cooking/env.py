"""The Creative Cooking environment (Gymnasium 1.x), after the paper's appendix.

Each episode samples 5 of the domain's ingredients uniformly without replacement (kept in domain
order, so a set of ingredients has one observation) beside the special `mixture`.

Observation: `MultiDiscrete([I + 2, S + 1] * 6)`, 12 integers
`(mixture idx, mixture status, ingr1 idx, status1, ..., ingr5 idx, status5)`: ingredient indices
are 1..I in domain order, 0 is an empty slot (its ingredient went into the mixture or onto
another ingredient), and the mixture is always I + 1; statuses are 1 (raw) .. S (post-processed)
and 0 for an empty slot or an empty mixture.

Action: `Discrete(n)` over (action, slot) for unary and (action, slot1, slot2) for binary actions,
slots 0 (mixture) .. 5 (see `rules.ActionCodec`; `decode_action` / `encode_action`), the same ids
in every episode; `action_names` gives this episode's atoms (`wash_lettuce`).

Reward: -1 per step, another -1 when the action is infeasible (the state stays as it is), and +20
on the step that reaches the goal (that step earns +19). `terminated` at the goal; `truncated`
only through the TimeLimit wrapper of the registered `tleaf/CreativeCooking-v0` (50 steps).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from tleaf_cli.errors import InputError
from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, Domain, load_domain
from tleaf_cli.tasks.cooking.render import render_text
from tleaf_cli.tasks.cooking.rules import NUM_INGREDIENTS, NUM_SLOTS, ActionCodec, EpisodeRules

STEP_REWARD = -1.0
INFEASIBLE_REWARD = -1.0  # on top of the step's
GOAL_REWARD = 20.0


class CreativeCookingEnv(gym.Env):
    """Prepare five sampled ingredients until each (and the mixture) is at its required status.

    `domain`: a Domain or the path of a domain TOML file (default examples/creative_cooking.toml).
    `reset(options={"ingredients": [...five names...]})` fixes the episode's ingredients.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["ansi"], "render_fps": 4}

    def __init__(
        self, domain: Domain | str | Path | None = None, render_mode: str | None = None
    ) -> None:
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise InputError(f"render_mode must be None or 'ansi', not {render_mode!r}")
        self.domain = (
            domain if isinstance(domain, Domain) else load_domain(domain or DEFAULT_DOMAIN)
        )
        self.render_mode = render_mode
        self.codec = ActionCodec(self.domain)
        self.action_space = spaces.Discrete(self.codec.n)
        slot_space = [self.domain.mixture_index + 1, len(self.domain.statuses) + 1]
        self.observation_space = spaces.MultiDiscrete(slot_space * NUM_SLOTS)
        self.rules: EpisodeRules | None = None
        self.state: tuple[int, ...] = ()
        self.last: tuple[str, bool] | None = None  # (action name, feasible) of the last step
        self.steps = 0
        self.episode_return = 0.0

    # -- Gymnasium API -------------------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        names = (options or {}).get("ingredients")
        while True:  # an episode already at its goal (only ready ingredients) is drawn again
            ingredients = self._pick(names)
            self.rules = EpisodeRules(self.domain, ingredients, self.codec)
            self.state = self.rules.initial_state()
            if names is not None or not self.rules.is_goal(self.state):
                break
        self.last, self.steps, self.episode_return = None, 0, 0.0
        return self._observation(), self._info()

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self.rules is None:
            raise RuntimeError("call reset() before step()")
        action = int(action)
        nxt = self.rules.step(self.state, action)
        feasible = nxt is not None
        reward = STEP_REWARD + (0.0 if feasible else INFEASIBLE_REWARD)
        if feasible:
            self.state = nxt
        terminated = self.rules.is_goal(self.state)
        if terminated:
            reward += GOAL_REWARD
        self.last = (self.rules.action_name(action), feasible)
        self.steps += 1
        self.episode_return += reward
        info = self._info() | {"feasible": feasible, "action_name": self.last[0]}
        return self._observation(), reward, terminated, False, info

    def render(self) -> str | None:
        if self.render_mode != "ansi" or self.rules is None:
            return None
        return render_text(self.rules, self.state, self.last, self.steps, self.episode_return)

    # -- helpers for planners, imitation learning and tests ------------------------------------

    def action_masks(self) -> np.ndarray:
        """Feasible actions in the current state (bool per action id)."""
        return np.array(self.rules.feasible(self.state), dtype=bool)

    @property
    def ingredients(self) -> tuple[str, ...]:
        """This episode's ingredient names, slots 1..5."""
        return tuple(i.name for i in self.rules.ingredients)

    @property
    def action_names(self) -> tuple[str, ...]:
        """This episode's atom for every action id (`wash_lettuce`, `top_with_beef_salt`)."""
        return self.rules.action_names

    def knowledge_base(self):
        """The LTLf rules (affordances, orderings) for this episode's ingredients."""
        from tleaf_cli.tasks.cooking.knowledge import knowledge_base

        return knowledge_base(self.domain, self.ingredients)

    def _pick(self, names: Sequence[str] | None):
        if names is None:
            chosen = self.np_random.choice(len(self.domain.ingredients), NUM_INGREDIENTS, False)
            return [self.domain.ingredients[i] for i in sorted(chosen)]
        unknown = [n for n in names if n not in self.domain.by_name]
        if unknown or len(set(names)) != NUM_INGREDIENTS or len(names) != NUM_INGREDIENTS:
            raise InputError(
                f"options['ingredients'] must name {NUM_INGREDIENTS} distinct ingredients of the "
                f"domain (unknown: {unknown or 'none'})"
            )
        return sorted((self.domain.by_name[n] for n in names), key=lambda i: i.index)

    def _observation(self) -> np.ndarray:
        indices = (self.domain.mixture_index, *(i.index for i in self.rules.ingredients))
        obs = []
        for slot, index in enumerate(indices):
            status = self.state[slot]
            # An empty ingredient slot shows (0, 0); the mixture keeps its index, status 0.
            obs += [index if status or slot == 0 else 0, status]
        return np.array(obs, dtype=np.int64)

    def _info(self) -> dict[str, Any]:
        return {"ingredients": self.ingredients}
