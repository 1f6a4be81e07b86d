"""Ingredient-set pools: the sets the demonstrations show, and a held-out pool they never show.

GAIL trains and is first evaluated on the demonstrated pool (every episode is one of the demos'
ingredient sets, so each has a known expert return). Knowledge should matter most where the
demonstrations say nothing: the rules cover every ingredient, the demos only theirs. The held-out
pool is a fixed, seeded draw of ingredient sets none of which is demonstrated (and none already at
its goal), with the expert's return on each set found by the same A* planner that made the demos.
"""

from __future__ import annotations

from collections.abc import Sequence

import gymnasium as gym
import numpy as np

from tleaf_cli.errors import InputError
from tleaf_cli.tasks.cooking import ENV_ID
from tleaf_cli.tasks.cooking.domain import Domain
from tleaf_cli.tasks.cooking.expert import plan
from tleaf_cli.tasks.cooking.rules import NUM_INGREDIENTS

# The held-out pool is the same for every run and variant: its draw does not depend on the seed.
HELD_OUT_SEED = 2021
MAX_DRAWS = 100_000


def held_out_pool(
    domain: Domain, demonstrated: Sequence[Sequence[str]], size: int, seed: int = HELD_OUT_SEED
) -> list[tuple[str, ...]]:
    """`size` distinct ingredient sets (names in domain order, like the environment's), drawn
    uniformly with a generator seeded by `seed`, none of them in `demonstrated` and none whose
    episode would start at its goal."""
    seen = {tuple(s) for s in demonstrated}
    env = gym.make(ENV_ID, domain=domain).unwrapped
    rng = np.random.default_rng([seed, 18])
    pool: list[tuple[str, ...]] = []
    for _ in range(MAX_DRAWS):
        if len(pool) == size:
            return pool
        chosen = sorted(rng.choice(len(domain.ingredients), NUM_INGREDIENTS, replace=False))
        names = tuple(domain.ingredients[i].name for i in chosen)
        if names in seen:
            continue
        seen.add(names)
        env.reset(options={"ingredients": list(names)})
        if not env.rules.is_goal(env.state):
            pool.append(names)
    raise InputError(f"the domain has fewer than {size} ingredient sets outside the demos")


def expert_returns(domain: Domain, pool: Sequence[Sequence[str]]) -> list[float]:
    """The expert's true-reward return on each ingredient set: a shortest plan (the planner of
    gen-demos, lowest action ids on ties), played in the environment."""
    env = gym.make(ENV_ID, domain=domain)
    returns = []
    for names in pool:
        env.reset(options={"ingredients": list(names)})
        total = 0.0
        for action in plan(env.unwrapped.rules):
            _, reward, terminated, truncated, _ = env.step(action)
            total += float(reward)
            if terminated or truncated:
                break
        returns.append(total)
    return returns
