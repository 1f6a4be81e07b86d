"""Behaviour cloning: a warm start of GAIL's policy on the demos' (s, a) pairs."""

from __future__ import annotations

import torch
from stable_baselines3 import PPO

from tleaf_cli.settings.gail import GailSettings


def behaviour_cloning(
    model: PPO, expert_obs: torch.Tensor, expert_actions: torch.Tensor, settings: GailSettings
) -> list[float]:
    """Warm start: `bc_steps` full-batch Adam steps (lr `bc_lr`) of −log π(a | s) on the demos'
    pairs, before GAIL's first rollout. Only the policy's head and shared layers move (the value
    net sits apart in SB3's MlpPolicy). Returns the loss per step."""
    obs = expert_obs.float()
    actions = expert_actions.long()
    optimizer = torch.optim.Adam(model.policy.parameters(), lr=settings.bc_lr)
    model.policy.set_training_mode(True)
    losses = []
    for _ in range(settings.bc_steps):
        _, log_prob, _ = model.policy.evaluate_actions(obs, actions)
        loss = -log_prob.mean()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        losses.append(float(loss.detach()))
    model.policy.set_training_mode(False)
    return losses
