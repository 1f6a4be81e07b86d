"""How the cooking knowledge base as a shield compares with the environment's feasibility.

Random rollouts of the SYNTHETIC Creative Cooking environment (feasible actions drawn uniformly,
30 steps at most, episodes seeded 0..N-1): per step, the actions the environment finds feasible
and the actions the rules' shield allows (tasks/cooking/shield.py), and which allowed actions are
infeasible. docs/cooking.md reports the figures.

    python benchmarks/cooking_shield_mask.py [EPISODES]
"""

from __future__ import annotations

import collections
import sys
import time

import gymnasium as gym
import numpy as np
import torch

import tleaf_cli.tasks.cooking  # noqa: F401  (registers the environment)
from tleaf_cli.tasks.cooking.shield import cooking_shield

env = gym.make("tleaf/CreativeCooking-v0").unwrapped
rng = np.random.default_rng(0)
stats = collections.Counter()
gaps = collections.Counter()
t = time.perf_counter()
for ep in range(int(sys.argv[1]) if len(sys.argv) > 1 else 20):
    env.reset(seed=ep)
    names = env.action_names
    assert len(set(names)) == len(names), "action names repeat"
    shield = cooking_shield(env.domain, env.ingredients, names)
    shield.reset()
    for _ in range(30):
        feasible = torch.as_tensor(env.action_masks())
        allowed = shield.allowed()
        stats["steps"] += 1
        stats["feasible"] += int(feasible.sum())
        stats["allowed"] += int(allowed.sum())
        stats["feasible_not_allowed"] += int((feasible & ~allowed).sum())
        stats["allowed_not_feasible"] += int((allowed & ~feasible).sum())
        for a in torch.nonzero(allowed & ~feasible).flatten().tolist()[:3]:
            gaps[names[a].split("_")[0]] += 1
        choice = int(rng.choice(torch.nonzero(feasible).flatten().numpy()))
        shield.step(choice)
        _, _, term, trunc, _ = env.step(choice)
        if term or trunc:
            break
print(dict(stats), "%.1fs" % (time.perf_counter() - t))
print("allowed but infeasible, by action:", gaps.most_common(8))
