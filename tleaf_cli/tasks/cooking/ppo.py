"""GAIL's generator: PPO whose update adds λ · ℓ_logic (`LogicPPO`), or MaskablePPO acting
only among the actions the rules' shield allows (`ShieldedPPO`), and PPO's learning rate."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import torch
import torch.nn.functional as F
from sb3_contrib import MaskablePPO
from stable_baselines3 import PPO
from stable_baselines3.common.utils import explained_variance

from tleaf_cli.settings.gail import GailSettings
from tleaf_cli.tasks.cooking.logic_term import GRADIENT_LOSSES, LogicTerm, rollout_episodes


def ppo_learning_rate(settings: GailSettings) -> float | Callable[[float], float]:
    """SB3's `learning_rate`: the constant `lr`, or a schedule of SB3's progress remaining
    (1 at the first update, 0 at the end) that falls linearly from `lr` to 0 -- the usual PPO
    trick to let a policy that has found the expert settle instead of drifting off again."""
    if settings.lr_schedule == "linear":
        lr = settings.lr
        return lambda progress_remaining: lr * progress_remaining
    return settings.lr


class LogicPPO(PPO):
    """PPO whose update adds λ · ℓ_logic (on whole rollout episodes) to every minibatch's loss.

    The update is SB3's PPO.train written out so the logic term can join the loss: clipped
    surrogate, value loss (clipped by `clip_range_vf` when set), entropy bonus, gradient
    clipping, and SB3's early stop of an update's epochs once the approximate KL divergence
    passes 1.5 · `target_kl` (when set). Per rollout it logs (`logic_log` and SB3's logger)
    the losses, approx_kl, clip_fraction, explained variance and the learning rate used, as SB3
    does.
    """

    def setup_logic(self, logic: LogicTerm | None, lam: float, episodes: int, seed: int) -> None:
        self.logic, self.lam, self.logic_episodes = logic, lam, episodes
        self.logic_rng = np.random.default_rng(seed)
        self.logic_log: list[dict] = []

    def _excluded_save_params(self) -> list[str]:
        # the logic term holds the rule sets and q: saved with the policy they made a tleaf
        # run's policy.zip 142 MB (measured); PPO.load does not need them
        return [*super()._excluded_save_params(), "logic", "logic_rng", "logic_log"]

    def train(self) -> None:
        self.policy.set_training_mode(True)
        self._update_learning_rate(self.policy.optimizer)
        clip_range = self.clip_range(self._current_progress_remaining)
        clip_range_vf = (
            None
            if self.clip_range_vf is None
            else self.clip_range_vf(self._current_progress_remaining)
        )
        buffer = self.rollout_buffer
        episodes = (
            rollout_episodes(
                buffer.observations,
                buffer.actions,
                buffer.episode_starts,
                self.logic.knowledge.domain,
            )
            if self.logic is not None
            else []
        )
        violation_rate = self.logic.violation_rate(episodes) if self.logic is not None else None
        with_gradient = self.logic is not None and self.logic.kind in GRADIENT_LOSSES and episodes
        stats: dict[str, list[float]] = {
            "policy": [], "value": [], "entropy": [], "logic": [], "approx_kl": [], "clip": []
        }  # fmt: skip
        continue_training = True
        for _ in range(self.n_epochs):
            for data in buffer.get(self.batch_size):
                actions = data.actions.long().flatten()
                values, log_prob, entropy = self.policy.evaluate_actions(data.observations, actions)
                advantages = data.advantages
                if self.normalize_advantage and len(advantages) > 1:
                    advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
                ratio = torch.exp(log_prob - data.old_log_prob)
                policy_loss = -torch.min(
                    advantages * ratio,
                    advantages * torch.clamp(ratio, 1 - clip_range, 1 + clip_range),
                ).mean()
                stats["clip"].append(float(((ratio - 1).abs() > clip_range).float().mean()))
                values = values.flatten()
                if clip_range_vf is not None:  # SB3: the value moves at most clip_range_vf
                    values = data.old_values + torch.clamp(
                        values - data.old_values, -clip_range_vf, clip_range_vf
                    )
                value_loss = F.mse_loss(data.returns, values)
                entropy_loss = -entropy.mean()
                loss = policy_loss + self.ent_coef * entropy_loss + self.vf_coef * value_loss
                if with_gradient:
                    picked = self.logic_rng.choice(
                        len(episodes), min(self.logic_episodes, len(episodes)), replace=False
                    )
                    logic = self.logic.loss(self.policy, [episodes[i] for i in picked])
                    loss = loss + self.lam * logic
                    stats["logic"].append(float(logic.detach()))
                with torch.no_grad():  # SB3's approximation of KL(old || new)
                    log_ratio = log_prob - data.old_log_prob
                    approx_kl = float(torch.mean(torch.exp(log_ratio) - 1 - log_ratio))
                stats["approx_kl"].append(approx_kl)
                if self.target_kl is not None and approx_kl > 1.5 * self.target_kl:
                    continue_training = False  # SB3: stop this update before the step
                    break
                self.policy.optimizer.zero_grad()
                loss.backward()
                torch.nn.utils.clip_grad_norm_(self.policy.parameters(), self.max_grad_norm)
                self.policy.optimizer.step()
                stats["policy"].append(float(policy_loss.detach()))
                stats["value"].append(float(value_loss.detach()))
                stats["entropy"].append(float(-entropy_loss.detach()))
            self._n_updates += 1
            if not continue_training:
                break
        record = {
            "steps": int(self.num_timesteps),
            "policy_loss": float(np.mean(stats["policy"])) if stats["policy"] else None,
            "value_loss": float(np.mean(stats["value"])) if stats["value"] else None,
            "entropy": float(np.mean(stats["entropy"])) if stats["entropy"] else None,
            "logic_loss": float(np.mean(stats["logic"])) if stats["logic"] else None,
            "violation_rate": violation_rate,
            "approx_kl": float(np.mean(stats["approx_kl"])),
            "clip_fraction": float(np.mean(stats["clip"])),
            "stopped_early": not continue_training,
            "learning_rate": float(self.policy.optimizer.param_groups[0]["lr"]),
            "explained_variance": float(
                explained_variance(buffer.values.flatten(), buffer.returns.flatten())
            ),
        }
        self.logic_log.append(record)
        for key, value in record.items():
            if key != "steps" and value is not None:
                self.logger.record(f"train/{key}", value)
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")


class ShieldedPPO(MaskablePPO):
    """GAIL's policy acting only among the actions the rules' shield allows: sb3-contrib's
    MaskablePPO, its masks from `ShieldedActions` (the LTLf rules, not the environment's
    feasibility). No logic term; per rollout it logs the same figures as LogicPPO where SB3
    records them."""

    def setup_logic(self, logic: LogicTerm | None, lam: float, episodes: int, seed: int) -> None:
        self.logic_log: list[dict] = []

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "logic_log"]

    def train(self) -> None:
        super().train()
        logged = self.logger.name_to_value
        self.logic_log.append(
            {
                "steps": int(self.num_timesteps),
                **{
                    key: float(logged[f"train/{key}"])
                    for key in ("approx_kl", "clip_fraction", "explained_variance")
                    if f"train/{key}" in logged
                },
                "learning_rate": float(self.policy.optimizer.param_groups[0]["lr"]),
                "logic_loss": None,
                "violation_rate": None,
            }
        )
