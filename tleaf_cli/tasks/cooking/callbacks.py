"""GAIL's callback into SB3's loop: the discriminator's updates after each rollout, and the
seeded true-reward evaluations every `eval_every` environment steps (the learning curve)."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback

from tleaf_cli.settings.gail import GailSettings
from tleaf_cli.tasks.cooking.discriminator import Discriminator, discriminator_step


class GailCallback(BaseCallback):
    """Discriminator updates after each rollout; seeded true-reward evaluations every N steps."""

    def __init__(
        self,
        disc: Discriminator,
        expert_obs: torch.Tensor,
        expert_actions: torch.Tensor,
        settings: GailSettings,
        evaluate: Callable[[], dict[str, list[float]]],
        update: Callable[[int, int], None],
    ) -> None:
        super().__init__()
        self.disc = disc
        self.optimizer = torch.optim.Adam(disc.parameters(), lr=settings.disc_lr)
        self.expert_obs, self.expert_actions = expert_obs, expert_actions
        self.settings = settings
        self.rng = np.random.default_rng([settings.seed, 1])
        self.evaluate = evaluate
        self.update = update
        self.curve: list[dict] = []
        self.disc_log: list[dict] = []
        self.started = time.perf_counter()
        self.next_eval = 0

    def record(self) -> None:
        returns = self.evaluate()  # pool name -> returns
        point: dict = {
            "steps": int(self.num_timesteps),
            "mean_return": float(np.mean(returns["demonstrated"])),
            "returns": returns["demonstrated"],
        }
        if "held_out" in returns:
            point["held_out_mean_return"] = float(np.mean(returns["held_out"]))
            point["held_out_returns"] = returns["held_out"]
        point["seconds"] = round(time.perf_counter() - self.started, 2)
        self.curve.append(point)
        self.next_eval += self.settings.eval_every
        self.update(min(self.num_timesteps, self.settings.total_steps), self.settings.total_steps)

    def _on_training_start(self) -> None:
        self.record()

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next_eval:
            self.record()
        return True

    def _on_rollout_end(self) -> None:
        buffer = self.model.rollout_buffer
        obs = torch.as_tensor(buffer.observations.reshape(-1, buffer.observations.shape[-1]))
        actions = torch.as_tensor(buffer.actions.reshape(-1))
        s = self.settings
        for _ in range(s.disc_steps):
            e = self.rng.integers(len(self.expert_obs), size=s.disc_batch)
            p = self.rng.integers(len(obs), size=s.disc_batch)
            loss, acc_e, acc_p = discriminator_step(
                self.disc,
                self.optimizer,
                (self.expert_obs[e], self.expert_actions[e]),
                (obs[p], actions[p]),
                s.disc_gp,
            )
        true_returns = [ep["r"] for ep in self.model.ep_info_buffer]
        self.disc_log.append(
            {
                "steps": int(self.num_timesteps),
                "disc_loss": loss,
                "disc_expert_accuracy": acc_e,
                "disc_policy_accuracy": acc_p,
                "train_return": float(np.mean(true_returns)) if true_returns else None,
            }
        )
