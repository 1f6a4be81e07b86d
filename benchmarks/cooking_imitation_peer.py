"""Peer measurement: the `imitation` library's GAIL (v1.0.1) on tleaf's Creative Cooking.

Not a tleaf dependency (imitation pins gymnasium 0.29): run it in a scratch venv, with the
repository on PYTHONPATH so tleaf's own environment, demo reader and evaluation are imported
unchanged (from the repository root):

    python3.11 -m venv /tmp/peer-venv
    /tmp/peer-venv/bin/pip install torch==2.13.0
    /tmp/peer-venv/bin/pip install imitation==1.0.1 sb3-contrib==2.2.1 ltlf2dfa==2.0.0 typer \
        networkx torch_geometric==2.8.1
    OMP_NUM_THREADS=1 PYTHONPATH=$PWD PYTHONDONTWRITEBYTECODE=1 \
        /tmp/peer-venv/bin/python benchmarks/cooking_imitation_peer.py SEED [TOTAL_STEPS]

(measured with imitation 1.0.1, gymnasium 0.29.1, SB3 2.2.1, torch 2.13.0 CPU; results in
docs/results/cooking.md).

Same as tleaf's train_gail (tleaf_cli/tasks/cooking/train.py):
  * demos: out/cooking-v2/demos.parquet read with read_demo_episodes; the pool is the distinct
    ingredient sets of the demos; training envs are IngredientPool(gym.make(ENV_ID, domain=...))
    in SB3's make_vec_env with 4 envs seeded `seed`; set_random_seed(seed), 1 torch thread.
  * evaluation: tleaf's evaluate_returns with tleaf's policy_probabilities(model) (actions
    sampled from pi with a seeded generator), eval seed 10_000 + seed, 8 episodes on the
    demonstrated pool, and one episode on each of the 8 held_out_pool sets with seed
    10_000 + seed + HELD_OUT_SEEDS; at step 0 and whenever num_timesteps reaches the next multiple
    of 4096 *inside the rollout* (an SB3 callback like tleaf's GailCallback._on_step), plus a final
    point after training.
Peer (imitation's GAIL tutorial settings):
  PPO MlpPolicy, 4 envs x n_steps 256, gamma 0.95, lr 4e-4, n_epochs 5, batch 64, ent_coef 0;
  GAIL with BasicRewardNet(normalize_input_layer=RunningNorm), demo_batch_size 16,
  gen_replay_buffer_capacity 512, n_disc_updates_per_round 8, allow_variable_horizon=True.
  MultiDiscrete observations need no flattening by hand: both SB3's policy and imitation's
  reward net go through SB3's preprocess_obs, which one-hot encodes each of the 12 components
  (sum(nvec) = 354 inputs) and the Discrete(234) action.
"""

from __future__ import annotations

import json
import math
import os
import resource
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from imitation.algorithms.adversarial.gail import GAIL
from imitation.data import types
from imitation.data.wrappers import RolloutInfoWrapper
from imitation.rewards.reward_nets import BasicRewardNet
from imitation.util import logger as imit_logger
from imitation.util.networks import RunningNorm
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback, CallbackList
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.utils import set_random_seed
from stable_baselines3.ppo import MlpPolicy

from tleaf_cli.tasks.cooking import ENV_ID
from tleaf_cli.tasks.cooking.demo_episodes import read_demo_episodes
from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, load_domain
from tleaf_cli.tasks.cooking.environments import IngredientPool, evaluation_env
from tleaf_cli.tasks.cooking.evaluate import (
    HELD_OUT_SEEDS,
    evaluate_returns,
    policy_probabilities,
    uniform_probabilities,
)
from tleaf_cli.tasks.cooking.pools import expert_returns, held_out_pool

# The demos (tleaf gen-demos --episodes 4 --seed 0) and where curves go: $PEER_DEMOS, $PEER_OUT.
DEMOS = Path(os.environ.get("PEER_DEMOS", "out/cooking-v2/demos.parquet"))
OUT = Path(os.environ.get("PEER_OUT", "out/cooking_imitation_peer"))

SETTINGS = {
    "n_envs": 4,
    "n_steps": 256,
    "gamma": 0.95,
    "learning_rate": 4e-4,
    "n_epochs": 5,
    "batch_size": 64,
    "ent_coef": 0.0,
    "policy": "MlpPolicy (SB3 default net_arch: 64x64 tanh, separate pi/vf)",
    "reward_net": "BasicRewardNet(normalize_input_layer=RunningNorm), state+action (defaults)",
    "demo_batch_size": 16,
    "gen_replay_buffer_capacity": 512,
    "n_disc_updates_per_round": 8,
    "allow_variable_horizon": True,
    "eval_every": 4096,
    "eval_episodes": 8,
    "held_out": 8,
}


def demo_trajectories(expert, domain) -> list[types.Trajectory]:
    """imitation Trajectories from tleaf's DemoEpisodes. A demo stores the observation before
    each action (T rows); imitation wants T + 1 observations, so the episode is replayed in the
    environment to get the final one (the replay also checks that the stored observations and
    returns are what the environment gives, and that each demo ends at the goal)."""
    env = gym.make(ENV_ID, domain=domain)
    out = []
    for e in expert:
        obs, _ = env.reset(options={"ingredients": list(e.ingredients)})
        observations, total, terminated = [obs], 0.0, False
        for t, action in enumerate(e.actions):
            assert np.array_equal(observations[-1], e.observations[t]), (e.ingredients, t)
            obs, reward, terminated, _truncated, _ = env.step(int(action))
            observations.append(obs)
            total += float(reward)
        assert terminated and total == e.episode_return, (e.ingredients, total, terminated)
        out.append(
            types.Trajectory(
                obs=np.stack(observations).astype(np.int64),
                acts=e.actions.astype(np.int64),
                infos=np.array([{}] * len(e.actions)),
                terminal=True,
            )
        )
    env.close()
    return out


class Evaluate(BaseCallback):
    """tleaf's GailCallback evaluation schedule: at training start (step 0 only) and in _on_step
    whenever num_timesteps >= next_eval (multiples of eval_every)."""

    def __init__(self, evaluate, curve_path: Path, meta: dict) -> None:
        super().__init__()
        self.evaluate = evaluate
        self.curve_path = curve_path
        self.meta = meta
        self.curve: list[dict] = []
        self.next_eval = 0
        self.wall0 = time.perf_counter()
        self.cpu0 = time.process_time()

    def record(self) -> None:
        returns = self.evaluate()
        train_returns = [ep["r"] for ep in self.model.ep_info_buffer]
        point = {
            "steps": int(self.num_timesteps),
            "mean_return": float(np.mean(returns["demonstrated"])),
            "returns": returns["demonstrated"],
            "held_out_mean_return": float(np.mean(returns["held_out"])),
            "held_out_returns": returns["held_out"],
            "train_true_return_last100": float(np.mean(train_returns)) if train_returns else None,
            "wall_s": round(time.perf_counter() - self.wall0, 2),
            "cpu_s": round(time.process_time() - self.cpu0, 2),
        }
        self.curve.append(point)
        self.next_eval += SETTINGS["eval_every"]
        print(
            f"step {point['steps']:7d} demo {point['mean_return']:8.3f} "
            f"held-out {point['held_out_mean_return']:8.3f} "
            f"train {point['train_true_return_last100']} "
            f"wall {point['wall_s']:7.1f} cpu {point['cpu_s']:7.1f}",
            flush=True,
        )
        self.write()

    def write(self, **extra) -> None:
        tmp = self.curve_path.with_suffix(".tmp")
        tmp.write_text(json.dumps({**self.meta, **extra, "curve": self.curve}, indent=1))
        tmp.replace(self.curve_path)

    def _on_training_start(self) -> None:  # called at every round's learn(): step 0 only
        if self.num_timesteps >= self.next_eval:
            self.record()

    def _on_step(self) -> bool:
        if self.num_timesteps >= self.next_eval:
            self.record()
        return True


def main() -> None:
    seed = int(sys.argv[1])
    total_steps = int(sys.argv[2]) if len(sys.argv) > 2 else 300_000
    torch.set_num_threads(1)
    domain = load_domain(DEFAULT_DOMAIN)
    expert = read_demo_episodes(DEMOS, domain)
    pool = list(dict.fromkeys(e.ingredients for e in expert))
    held_out = held_out_pool(domain, pool, SETTINGS["held_out"])
    set_random_seed(seed)

    venv = make_vec_env(
        lambda: RolloutInfoWrapper(IngredientPool(gym.make(ENV_ID, domain=domain), pool)),
        n_envs=SETTINGS["n_envs"],
        seed=seed,
    )
    learner = PPO(
        env=venv,
        policy=MlpPolicy,
        n_steps=SETTINGS["n_steps"],
        batch_size=SETTINGS["batch_size"],
        ent_coef=SETTINGS["ent_coef"],
        learning_rate=SETTINGS["learning_rate"],
        gamma=SETTINGS["gamma"],
        n_epochs=SETTINGS["n_epochs"],
        seed=seed,
        device="cpu",
    )
    reward_net = BasicRewardNet(
        observation_space=venv.observation_space,
        action_space=venv.action_space,
        normalize_input_layer=RunningNorm,
    )
    log_dir = OUT / f"imitation-log-s{seed}"
    gail_trainer = GAIL(
        demonstrations=demo_trajectories(expert, domain),
        demo_batch_size=SETTINGS["demo_batch_size"],
        gen_replay_buffer_capacity=SETTINGS["gen_replay_buffer_capacity"],
        n_disc_updates_per_round=SETTINGS["n_disc_updates_per_round"],
        venv=venv,
        gen_algo=learner,
        reward_net=reward_net,
        allow_variable_horizon=SETTINGS["allow_variable_horizon"],
        log_dir=log_dir,
        custom_logger=imit_logger.configure(log_dir, ["csv"]),
    )

    eval_seed = 10_000 + seed
    eval_env = evaluation_env(domain)

    def evaluate_with(probabilities) -> dict[str, list[float]]:
        return {
            "demonstrated": evaluate_returns(
                probabilities, eval_env, pool, SETTINGS["eval_episodes"], eval_seed
            ),
            "held_out": evaluate_returns(
                probabilities, eval_env, held_out, len(held_out), eval_seed + HELD_OUT_SEEDS
            ),
        }

    by_set: dict = {}
    for e in expert:
        by_set.setdefault(e.ingredients, []).append(e.episode_return)
    eval_sets = [pool[i % len(pool)] for i in range(SETTINGS["eval_episodes"])]
    expert_return = float(np.mean([np.mean(by_set[s]) for s in eval_sets]))
    uniform = evaluate_with(uniform_probabilities(venv.action_space.n))
    meta = {
        "peer": "imitation GAIL",
        "seed": seed,
        "total_steps_asked": total_steps,
        "settings": SETTINGS,
        "demos": str(DEMOS),
        "pool": [list(p) for p in pool],
        "held_out_pool": [list(p) for p in held_out],
        "expert_return": expert_return,
        "expert_return_held_out": float(np.mean(expert_returns(domain, held_out))),
        "random_return": float(np.mean(uniform["demonstrated"])),
        "random_return_held_out": float(np.mean(uniform["held_out"])),
        "threshold_90": 0.9 * expert_return,
    }
    curve_path = OUT / f"curve-s{seed}.json"
    evaluator = Evaluate(lambda: evaluate_with(policy_probabilities(learner)), curve_path, meta)
    gail_trainer.gen_callback = CallbackList([gail_trainer.gen_callback, evaluator])

    rounds = math.ceil(total_steps / gail_trainer.gen_train_timesteps)  # like SB3's learn()
    wall0, cpu0 = time.perf_counter(), time.process_time()
    gail_trainer.train(rounds * gail_trainer.gen_train_timesteps)
    if evaluator.curve[-1]["steps"] < learner.num_timesteps:
        evaluator.record()
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    usage = resource.getrusage(resource.RUSAGE_SELF)
    evaluator.write(
        environment_steps=int(learner.num_timesteps),
        wall_s=round(wall, 1),
        cpu_s=round(cpu, 1),
        cpu_user_sys_s=round(usage.ru_utime + usage.ru_stime, 1),
        finished=True,
    )
    print(f"done: {learner.num_timesteps} steps, wall {wall:.1f} s, cpu {cpu:.1f} s", flush=True)


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    main()
