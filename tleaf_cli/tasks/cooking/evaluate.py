"""Seeded true-reward evaluation of a policy: returns of episodes on a pool of ingredient sets,
actions drawn from the policy's distribution with a seeded generator, so the same policy gives the
same returns."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import PPO

from tleaf_cli.tasks.cooking.shield import ShieldedActions

# Evaluation episodes on the held-out pool are seeded apart from the demonstrated pool's.
HELD_OUT_SEEDS = 1_000


def evaluate_returns(
    probabilities: Callable[[np.ndarray], np.ndarray],
    env: gym.Env,
    pool: Sequence[tuple[str, ...]],
    episodes: int,
    seed: int,
) -> list[float]:
    """True-reward returns of `episodes` seeded episodes in `env` (`evaluation_env`); episode i
    uses pool[i mod |pool|] and is reset with seed + i, so reusing `env` changes nothing.

    `probabilities(obs)` is the policy's action distribution; the action is drawn from it with a
    generator seeded by (seed, i), so the same policy gives the same returns. In a shielded env
    the distribution is restricted to the actions the rules allow (a masked policy's).
    """
    shielded = isinstance(env, ShieldedActions)
    returns = []
    for i in range(episodes):
        rng = np.random.default_rng([seed, i])
        obs, _ = env.reset(seed=seed + i, options={"ingredients": list(pool[i % len(pool)])})
        total, done = 0.0, False
        while not done:
            p = probabilities(obs)
            if shielded:
                p = p * env.action_masks()
                p = p / p.sum()
            obs, reward, terminated, truncated, _ = env.step(int(rng.choice(len(p), p=p)))
            total += float(reward)
            done = terminated or truncated
        returns.append(total)
    return returns


def policy_probabilities(model: PPO) -> Callable[[np.ndarray], np.ndarray]:
    def probabilities(obs: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            tensor, _ = model.policy.obs_to_tensor(obs)
            p = model.policy.get_distribution(tensor).distribution.probs[0].cpu().numpy()
        p = p.astype(np.float64)
        return p / p.sum()

    return probabilities


def uniform_probabilities(num_actions: int) -> Callable[[np.ndarray], np.ndarray]:
    return lambda obs: np.full(num_actions, 1.0 / num_actions)
