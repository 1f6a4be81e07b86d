"""GAIL's discriminator D(s, a) and the VecEnv wrapper that pays its reward instead of the env's.

D is a small MLP on one-hot (observation, action) pairs that outputs the logit of "expert".
It is trained by binary cross-entropy, expert pairs labelled 1 and the policy's 0.

Reward choice: r(s, a) = log D(s, a) = −softplus(−logit) ≤ 0. An episode of Creative Cooking
ends (terminated) when the goal is reached, so a negative reward per step — like the
environment's own −1 — pays the policy to finish; the other common form, −log(1 − D) ≥ 0,
pays it for every step it survives, i.e. to dawdle until the 50-step time limit.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from torch import nn

from tleaf_cli.errors import InputError


class Discriminator(nn.Module):
    """D(s, a): an MLP on [one-hot of each observation entry, one-hot action] -> expert logit."""

    def __init__(self, nvec: np.ndarray, num_actions: int, hidden: int = 64) -> None:
        super().__init__()
        self.register_buffer("nvec", torch.as_tensor(np.asarray(nvec), dtype=torch.long))
        self.num_actions = num_actions
        width = int(self.nvec.sum()) + num_actions
        self.net = nn.Sequential(
            nn.Linear(width, hidden), nn.Tanh(), nn.Linear(hidden, hidden), nn.Tanh()
        )
        self.head = nn.Linear(hidden, 1)

    def encode(self, observations: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """[n, Σ nvec + A] one-hot features of integer observations [n, 12] and actions [n]."""
        obs = observations.long()
        parts = [F.one_hot(obs[:, k], int(n)) for k, n in enumerate(self.nvec.tolist())]
        parts.append(F.one_hot(actions.long().flatten(), self.num_actions))
        return torch.cat(parts, dim=1).float()

    def forward(self, observations: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """Expert logits [n]."""
        return self.head(self.net(self.encode(observations, actions))).squeeze(1)

    @torch.no_grad()
    def reward(
        self, observations: np.ndarray, actions: np.ndarray, form: str = "log_d"
    ) -> np.ndarray:
        """r per pair (float32 [n]): log D(s, a) (`log_d`, see the module docstring) or the
        logit log D − log(1 − D) (`logit`, AIRL's form)."""
        logits = self(torch.as_tensor(observations), torch.as_tensor(actions))
        if form == "logit":
            return logits.numpy().astype(np.float32)
        if form != "log_d":
            raise InputError(f"reward form {form!r}: expected log_d or logit")
        return (-F.softplus(-logits)).numpy().astype(np.float32)


def discriminator_step(
    disc: Discriminator,
    optimizer: torch.optim.Optimizer,
    expert: tuple[torch.Tensor, torch.Tensor],
    policy: tuple[torch.Tensor, torch.Tensor],
    gradient_penalty: float = 0.0,
) -> tuple[float, float, float]:
    """One BCE step on a batch of expert pairs (label 1) and policy pairs (label 0).

    `gradient_penalty` γ adds γ · E‖∇_x logit(x)‖² at points x mixed at random between the
    expert and the policy pairs' one-hot features: a zero-centred penalty on the logit's slope
    (batches of equal size). Without it (γ = 0, plain BCE) D memorises the few expert pairs and
    rewards a handful of actions in every state, feasible or not (docs/cooking.md). Returns
    (loss, accuracy on expert pairs, accuracy on policy pairs) of the batch, the loss without
    the penalty.
    """
    expert_logits = disc(*expert)
    policy_logits = disc(*policy)
    loss = F.binary_cross_entropy_with_logits(
        expert_logits, torch.ones_like(expert_logits)
    ) + F.binary_cross_entropy_with_logits(policy_logits, torch.zeros_like(policy_logits))
    total = loss
    if gradient_penalty > 0:
        x_e, x_p = disc.encode(*expert), disc.encode(*policy)
        mix = torch.rand(len(x_e), 1)
        x = (mix * x_e + (1 - mix) * x_p).requires_grad_(True)
        (grad,) = torch.autograd.grad(disc.head(disc.net(x)).sum(), x, create_graph=True)
        total = loss + gradient_penalty * grad.pow(2).sum(dim=1).mean()
    optimizer.zero_grad()
    total.backward()
    optimizer.step()
    return (
        float(loss.detach()),
        float((expert_logits > 0).float().mean()),
        float((policy_logits < 0).float().mean()),
    )


class DiscriminatorReward(VecEnvWrapper):
    """Replaces each step's reward with the discriminator's r(s, a) = log D(s, a).

    s is the observation the action was chosen in (kept from the previous step or reset; after
    an automatic reset it is the new episode's first observation). The environment's own reward
    goes to `info["env_reward"]`; Monitor wrappers below this one still record true returns.
    """

    def __init__(self, venv: VecEnv, disc: Discriminator, form: str = "log_d") -> None:
        super().__init__(venv)
        self.disc = disc
        self.form = form
        self._obs: np.ndarray | None = None
        self._actions: np.ndarray | None = None

    def reset(self) -> np.ndarray:
        self._obs = self.venv.reset()
        return self._obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)
        self.venv.step_async(actions)

    def step_wait(self):
        obs, env_rewards, dones, infos = self.venv.step_wait()
        rewards = self.disc.reward(self._obs, self._actions, self.form)
        for info, r in zip(infos, env_rewards, strict=True):
            info["env_reward"] = float(r)
        self._obs = obs
        return obs, rewards, dones, infos
