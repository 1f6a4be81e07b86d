"""GAIL with a logic loss on Creative Cooking (paper Sec. VII): `tleaf train-task cooking`.

Read top to bottom:

1. The demos (gen-demos) give the expert (s, a) pairs and the POOL of ingredient sets: every
   training and evaluation episode is one of the demos' sets, so each has a known expert return.
2. The generator is SB3's PPO on `tleaf/CreativeCooking-v0` (n_envs copies), whose rewards are
   replaced by the discriminator's r(s, a) = log D(s, a) (`DiscriminatorReward`).
3. After each rollout (`GailCallback._on_rollout_end`, callbacks.py) D takes `disc_steps` BCE
   steps: expert pairs from the demos against the rollout's pairs.
4. PPO's update (`LogicPPO.train`, ppo.py) minimises, per minibatch,
       ℓ_PPO + λ · ℓ_logic,
   ℓ_PPO SB3's clipped surrogate + vf_coef · value loss − ent_coef · entropy, and ℓ_logic the
   logic term (logic_term.py) on `logic_episodes` episodes of the same rollout drawn at random
   for that minibatch (whole episodes, as the rules read sequences). checker has no gradient:
   its value (the rollout's violation rate) is logged, and the updates are those of `none`.
5. Every `eval_every` environment steps the policy plays `eval_episodes` seeded episodes with
   the TRUE environment reward (actions sampled from π with a seeded generator; the ingredient
   set of evaluation episode i is pool[i mod |pool|]), and one episode on each of `held_out`
   ingredient sets no demo shows (pools.py, evaluate.py); the curve goes to metrics.json.

Outputs (run_files.py): config.json, metrics.json, policy.zip (SB3 `PPO.load`-able),
discriminator.pt.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.utils import set_random_seed
from stable_baselines3.common.vec_env import VecNormalize

from tleaf_cli.data.artifacts import check_writable
from tleaf_cli.data.compile_dfas import CompileSettings
from tleaf_cli.errors import SettingError
from tleaf_cli.settings.gail import PAPER_LAMBDA, GailSettings
from tleaf_cli.tasks.cooking.behaviour_cloning import behaviour_cloning
from tleaf_cli.tasks.cooking.callbacks import GailCallback
from tleaf_cli.tasks.cooking.demo_episodes import read_demo_episodes
from tleaf_cli.tasks.cooking.discriminator import Discriminator, DiscriminatorReward
from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, load_domain
from tleaf_cli.tasks.cooking.environments import evaluation_env, training_env
from tleaf_cli.tasks.cooking.evaluate import (
    HELD_OUT_SEEDS,
    evaluate_returns,
    policy_probabilities,
    uniform_probabilities,
)
from tleaf_cli.tasks.cooking.logic_term import CookingKnowledge, LogicTerm
from tleaf_cli.tasks.cooking.pools import expert_returns, held_out_pool
from tleaf_cli.tasks.cooking.ppo import LogicPPO, ShieldedPPO, ppo_learning_rate
from tleaf_cli.tasks.cooking.run_files import run_metrics, write_run
from tleaf_cli.training.lambdas import RunSetup, resolve_lambda_source
from tleaf_cli.training.loop import device_for


def train_gail(
    demos: str | Path,
    out_dir: str | Path,
    settings: GailSettings,
    embedder_dir: str | Path | None = None,
    compile_settings: CompileSettings | None = None,
    update: Callable[[int, int], None] = lambda done, total: None,
    on_setup: Callable[[RunSetup], None] | None = None,
) -> dict:
    """Train one GAIL run (a variant and a seed); write the run directory; return metrics.

    The run's λ and where it came from (`tasks.lambda_source`: the settings' `lam`; with `lam`
    None q's recommended λ for tleaf, otherwise the paper's; unused without a logic loss) go to
    `on_setup` before the first update and to metrics.json ("lambda")."""
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
    asks_q = embedder is not None and settings.lam is None  # q's λ is read only when used
    lam = resolve_lambda_source(
        settings.lam,
        used=settings.logic_loss != "none",
        recommended=embedder.recommended_lambda if asks_q else None,
        default=PAPER_LAMBDA,
    )
    settings = replace(settings, lam=lam.value)
    if on_setup is not None:
        on_setup(RunSetup(lam))
    knowledge = CookingKnowledge(domain, embedder, compile_settings)
    logic = LogicTerm(settings.logic_loss, knowledge) if settings.logic_loss != "none" else None

    venv = make_vec_env(
        lambda: training_env(domain, pool, settings.shield, compile_settings),
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

    metrics = run_metrics(expert, pool, settings, callback, model, seconds)
    metrics["lambda"] = lam.as_dict()
    uniform = evaluate(uniform_probabilities(venv.action_space.n), evaluation_env(domain))
    metrics["random_return"] = float(np.mean(uniform["demonstrated"]))
    if held_out:
        metrics["held_out_pool"] = [list(p) for p in held_out]
        metrics["expert_return_held_out"] = float(np.mean(expert_returns(domain, held_out)))
        metrics["random_return_held_out"] = float(np.mean(uniform["held_out"]))
    eval_env.close()
    write_run(out_dir, demos, embedder_dir, settings, pool, model, disc, metrics)
    venv.close()
    return metrics
