"""The environments GAIL's policy trains and is evaluated in: Creative Cooking episodes drawn from
a pool of ingredient sets (the demos'), masked by the rules' shield where a run asks for it."""

from __future__ import annotations

from collections.abc import Sequence

import gymnasium as gym
import numpy as np

from tleaf_cli.data.compile_dfas import CompileSettings
from tleaf_cli.tasks.cooking import ENV_ID
from tleaf_cli.tasks.cooking.domain import Domain
from tleaf_cli.tasks.cooking.shield import ShieldedActions


class IngredientPool(gym.Wrapper):
    """Each reset draws its five ingredients from `pool` (a seeded choice)."""

    def __init__(self, env: gym.Env, pool: Sequence[tuple[str, ...]]) -> None:
        super().__init__(env)
        self.pool = list(pool)
        self.rng = np.random.default_rng(0)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        chosen = self.pool[int(self.rng.integers(len(self.pool)))]
        return self.env.reset(seed=seed, options={"ingredients": list(chosen)})


def evaluation_env(
    domain: Domain, shield: bool = False, compile_settings: CompileSettings | None = None
) -> gym.Env:
    """The environment evaluations run in; with `shield`, masked by the rules (`ShieldedActions`,
    whose shields, one per ingredient set, are then built once for every evaluation)."""
    env = gym.make(ENV_ID, domain=domain)
    return ShieldedActions(env, compile_settings) if shield else env


def training_env(
    domain: Domain,
    pool: Sequence[tuple[str, ...]],
    shield: bool,
    compile_settings: CompileSettings | None,
) -> gym.Env:
    """One training environment: episodes drawn from `pool`, masked by the rules with `shield`."""
    env = IngredientPool(gym.make(ENV_ID, domain=domain), pool)
    return ShieldedActions(env, compile_settings) if shield else env
