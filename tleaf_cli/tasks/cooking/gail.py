"""GAIL with a logic loss on Creative Cooking (paper Sec. VII): `tleaf train-task cooking`.

Read top to bottom:

1. The demos (gen-demos) give the expert (s, a) pairs and the POOL of ingredient sets: every
   training and evaluation episode is one of the demos' sets, so each has a known expert return.
2. The generator is SB3's PPO on `tleaf/CreativeCooking-v0` (n_envs copies), whose rewards are
   replaced by the discriminator's r(s, a) = log D(s, a) (`DiscriminatorReward`).
3. After each rollout (`GailCallback._on_rollout_end`) D takes `disc_steps` BCE steps: expert
   pairs from the demos against the rollout's pairs.
4. PPO's update (`LogicPPO.train`) minimises, per minibatch,
       ℓ_PPO + λ · ℓ_logic,
   ℓ_PPO SB3's clipped surrogate + vf_coef · value loss − ent_coef · entropy, and ℓ_logic the
   logic term (logic_term.py) on `logic_episodes` episodes of the same rollout drawn at random
   for that minibatch (whole episodes, as the rules read sequences). checker has no gradient:
   its value (the rollout's violation rate) is logged, and the updates are those of `none`.
5. Every `eval_every` environment steps the policy plays `eval_episodes` seeded episodes with
   the TRUE environment reward (actions sampled from π with a seeded generator; the ingredient
   set of evaluation episode i is pool[i mod |pool|]), and one episode on each of `held_out`
   ingredient sets no demo shows (pools.py); the curve goes to metrics.json.

Outputs: config.json, metrics.json, policy.zip (SB3 `PPO.load`-able), discriminator.pt.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, replace
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
import torch.nn.functional as F
from sb3_contrib import MaskablePPO
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.utils import explained_variance, set_random_seed
from stable_baselines3.common.vec_env import VecNormalize

from tleaf_cli.data.artifacts import (
    atomic_path,
    check_writable,
    describe_inputs,
    relative_to,
    write_text_atomic,
)
from tleaf_cli.data.compile_dfas import CompileSettings
from tleaf_cli.embed.training import device_for
from tleaf_cli.errors import SettingError
from tleaf_cli.settings.gail import (  # noqa: F401  (GailSettings, LR_SCHEDULES: re-exported)
    GAIL_LAMBDA,
    LR_SCHEDULES,
    GailSettings,
)
from tleaf_cli.tasks.cooking import ENV_ID
from tleaf_cli.tasks.cooking.demo_episodes import DemoEpisode, read_demo_episodes
from tleaf_cli.tasks.cooking.discriminator import (
    Discriminator,
    DiscriminatorReward,
    discriminator_step,
)
from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, Domain, load_domain
from tleaf_cli.tasks.cooking.logic_term import (
    GRADIENT_LOSSES,
    CookingKnowledge,
    LogicTerm,
    rollout_episodes,
)
from tleaf_cli.tasks.cooking.pools import expert_returns, held_out_pool
from tleaf_cli.tasks.cooking.shield import ShieldedActions


def ppo_learning_rate(settings: GailSettings) -> float | Callable[[float], float]:
    """SB3's `learning_rate`: the constant `lr`, or a schedule of SB3's progress remaining
    (1 at the first update, 0 at the end) that falls linearly from `lr` to 0 -- the usual PPO
    trick to let a policy that has found the expert settle instead of drifting off again."""
    if settings.lr_schedule == "linear":
        lr = settings.lr
        return lambda progress_remaining: lr * progress_remaining
    return settings.lr


# Evaluation episodes on the held-out pool are seeded apart from the demonstrated pool's.
HELD_OUT_SEEDS = 1_000


# --------------------------------------------------------------------------- environments


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


# --------------------------------------------------------------------------- PPO + logic


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


def _training_env(
    domain: Domain,
    pool: Sequence[tuple[str, ...]],
    shield: bool,
    compile_settings: CompileSettings | None,
) -> gym.Env:
    """One training environment: episodes drawn from `pool`, masked by the rules with `shield`."""
    env = IngredientPool(gym.make(ENV_ID, domain=domain), pool)
    return ShieldedActions(env, compile_settings) if shield else env


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


# --------------------------------------------------------------------------- GAIL loop


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


def train_gail(
    demos: str | Path,
    out_dir: str | Path,
    settings: GailSettings,
    embedder_dir: str | Path | None = None,
    compile_settings: CompileSettings | None = None,
    update: Callable[[int, int], None] = lambda done, total: None,
) -> dict:
    """Train one GAIL run (a variant and a seed); write the run directory; return metrics."""
    settings.check()
    device_for(settings.device)  # SettingError where cuda is asked for and absent
    settings = replace(settings, domain=Path(settings.domain or DEFAULT_DOMAIN))
    out_dir = Path(out_dir)
    check_writable(out_dir / "metrics.json")
    if settings.logic_loss == "tleaf" and embedder_dir is None:
        raise SettingError("embedder", "the tleaf loss needs an embedder (a train-meta folder)")
    domain = load_domain(settings.domain)
    expert = read_demo_episodes(demos, domain)
    pool = list(dict.fromkeys(e.ingredients for e in expert))
    held_out = held_out_pool(domain, pool, settings.held_out) if settings.held_out else []
    set_random_seed(settings.seed)
    torch.set_num_threads(settings.threads)  # tiny MLPs: more threads only contend

    embedder = None
    if settings.logic_loss == "tleaf":
        from tleaf_cli.embed.load import load_embedder

        embedder = load_embedder(embedder_dir)
    if settings.lam is None:  # the λ that fits q (train-meta wrote it), or the paper's
        lam = embedder.recommended_lambda if embedder is not None else GAIL_LAMBDA
        settings = replace(settings, lam=lam)
    knowledge = CookingKnowledge(domain, embedder, compile_settings)
    logic = LogicTerm(settings.logic_loss, knowledge) if settings.logic_loss != "none" else None

    venv = make_vec_env(
        lambda: _training_env(domain, pool, settings.shield, compile_settings),
        n_envs=settings.n_envs,
        seed=settings.seed,
    )
    disc = Discriminator(venv.observation_space.nvec, venv.action_space.n, settings.disc_hidden)
    model = (ShieldedPPO if settings.shield else LogicPPO)(
        "MlpPolicy",
        # log D is unbounded below: scale it by the running std of the discounted return, or the
        # value loss's gradient dominates the clipped gradient norm and the policy never moves
        VecNormalize(
            DiscriminatorReward(venv, disc, settings.reward), norm_obs=False, gamma=settings.gamma
        ),
        learning_rate=ppo_learning_rate(settings),
        n_steps=settings.n_steps,
        batch_size=settings.batch_size,
        n_epochs=settings.n_epochs,
        target_kl=settings.target_kl,
        clip_range_vf=settings.clip_range_vf,
        gamma=settings.gamma,
        ent_coef=settings.ent_coef,
        policy_kwargs={"net_arch": [settings.hidden, settings.hidden]},
        seed=settings.seed,
        device=settings.device,
        verbose=0,
    )
    model.setup_logic(logic, settings.lam, settings.logic_episodes, settings.seed)

    eval_seed = 10_000 + settings.seed
    expert_obs = torch.as_tensor(np.concatenate([e.observations for e in expert]))
    expert_actions = torch.as_tensor(np.concatenate([e.actions for e in expert]))
    if settings.bc_steps > 0:
        behaviour_cloning(model, expert_obs, expert_actions, settings)
    eval_env = evaluation_env(domain, settings.shield, compile_settings)

    def evaluate(probabilities: Callable, env: gym.Env) -> dict[str, list[float]]:
        """Returns on the demonstrated pool and, one episode per set, on the held-out pool."""
        out = {
            "demonstrated": evaluate_returns(
                probabilities, env, pool, settings.eval_episodes, eval_seed
            )
        }
        if held_out:
            seed = eval_seed + HELD_OUT_SEEDS
            out["held_out"] = evaluate_returns(probabilities, env, held_out, len(held_out), seed)
        return out

    callback = GailCallback(
        disc,
        expert_obs,
        expert_actions,
        settings,
        lambda: evaluate(policy_probabilities(model), eval_env),
        update,
    )
    started = time.perf_counter()
    model.learn(total_timesteps=settings.total_steps, callback=callback)
    if callback.curve[-1]["steps"] < model.num_timesteps:
        callback.record()
    seconds = time.perf_counter() - started

    metrics = _metrics(expert, pool, settings, callback, model, seconds)
    uniform = evaluate(uniform_probabilities(venv.action_space.n), evaluation_env(domain))
    metrics["random_return"] = float(np.mean(uniform["demonstrated"]))
    if held_out:
        metrics["held_out_pool"] = [list(p) for p in held_out]
        metrics["expert_return_held_out"] = float(np.mean(expert_returns(domain, held_out)))
        metrics["random_return_held_out"] = float(np.mean(uniform["held_out"]))
    eval_env.close()
    _write_run(out_dir, demos, embedder_dir, settings, pool, model, disc, metrics)
    venv.close()
    return metrics


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


def variant_name(settings: GailSettings) -> str:
    """How eval cooking groups a run: its logic loss, or `shield` for a shielded run."""
    return "shield" if settings.shield else settings.logic_loss


def _metrics(
    expert: list[DemoEpisode],
    pool: list[tuple[str, ...]],
    settings: GailSettings,
    callback: GailCallback,
    model: LogicPPO,
    seconds: float,
) -> dict:
    """The evaluation curve with the expert's return on the same ingredient sets beside it."""
    by_set = {}
    for e in expert:
        by_set.setdefault(e.ingredients, []).append(e.episode_return)
    eval_sets = [pool[i % len(pool)] for i in range(settings.eval_episodes)]
    return {
        "variant": variant_name(settings),
        "seed": settings.seed,
        "curve": callback.curve,
        "expert_return": float(np.mean([np.mean(by_set[s]) for s in eval_sets])),
        "expert_return_all_demos": float(np.mean([e.episode_return for e in expert])),
        "final_return": callback.curve[-1]["mean_return"],
        "rollouts": [{**d, **u} for d, u in zip(callback.disc_log, model.logic_log, strict=False)],
        "environment_steps": int(model.num_timesteps),
        "seconds": round(seconds, 2),
        "reward": "log D(s, a) (discriminator), true env reward for evaluation only",
    }


def _write_run(out_dir, demos, embedder_dir, settings, pool, model, disc, metrics) -> None:
    inputs = describe_inputs([demos, settings.domain])
    if embedder_dir is not None:
        inputs += describe_inputs([Path(embedder_dir) / "config.json"])
    config = {
        "task": "cooking-gail",
        "env": ENV_ID,
        "settings": {k: str(v) if isinstance(v, Path) else v for k, v in asdict(settings).items()},
        "pool": [list(p) for p in pool],
        "embedder": None if embedder_dir is None else str(Path(embedder_dir).resolve()),
        "embedder_relative": None if embedder_dir is None else relative_to(out_dir, embedder_dir),
        "inputs": inputs,
        "data": "synthetic: Creative Cooking environment built from the paper's appendix",
    }
    tmp = atomic_path(out_dir / "policy.zip")
    try:
        with open(tmp, "wb") as f:
            model.save(f)
        tmp.replace(out_dir / "policy.zip")
    finally:
        tmp.unlink(missing_ok=True)
    tmp = atomic_path(out_dir / "discriminator.pt")
    try:
        torch.save(disc.state_dict(), tmp)
        tmp.replace(out_dir / "discriminator.pt")
    finally:
        tmp.unlink(missing_ok=True)
    write_text_atomic(out_dir / "config.json", json.dumps(config, indent=2))
    write_text_atomic(out_dir / "metrics.json", json.dumps(metrics, indent=2))
