"""Short GAIL pilot runs on Creative Cooking, and the logic term's cost (docs/results/cooking.md).

Not run by the tests. Two uses, from the repository root (one core: OMP_NUM_THREADS=1):

    # pilots: a name, then GailSettings fields as key=value (demos=PATH picks the demos); configs
    # separated by ":"; one line per run: CPU seconds, best / final return, the curve
    python benchmarks/cooking_gail_pilots.py out/cooking/demos.parquet \\
        A total_steps=80000 : B total_steps=80000 lr=0.003 n_epochs=10

    # profile: cProfile of one run (evaluation off), CPU seconds per 1 000 environment steps
    python benchmarks/cooking_gail_pilots.py out/cooking/demos.parquet --profile exact 4096
    python benchmarks/cooking_gail_pilots.py out/cooking/demos.parquet --profile tleaf 4096 \\
        --embedder out/cooking/meta

    # stuck: replay each run's 8 evaluation episodes with its final policy (same seeds as the
    # run's evaluation) and count episodes whose most frequent action is an infeasible one taken
    # at least 20 times, split by whether a rule forbids it (an affordance) or not
    python benchmarks/cooking_gail_pilots.py out/cooking/demos.parquet --stuck out/cooking/runs/*/

Runs are written under /tmp/cooking-pilots/<name>.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import time
from collections import Counter, defaultdict
from dataclasses import fields, replace
from pathlib import Path

import gymnasium as gym
import numpy as np
from stable_baselines3 import PPO

from tleaf_cli.settings.gail import GailSettings
from tleaf_cli.tasks.cooking import ENV_ID
from tleaf_cli.tasks.cooking.demo_episodes import read_demo_episodes
from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, load_domain
from tleaf_cli.tasks.cooking.evaluate import policy_probabilities
from tleaf_cli.tasks.cooking.knowledge import knowledge_base
from tleaf_cli.tasks.cooking.train import train_gail

OUT = "/tmp/cooking-pilots"


def settings_from(pairs: list[str]) -> tuple[GailSettings, str | None]:
    """GailSettings with `key=value` overrides (typed like the field's default); demos=PATH.
    From preset `paper`: a constant learning rate, as the pilots were run; λ 1 unless given."""
    settings, demos = GailSettings.preset("paper", eval_every=4096, eval_episodes=8), None
    types = {f.name: type(getattr(settings, f.name)) for f in fields(settings)}
    for pair in pairs:
        key, value = pair.split("=", 1)
        if key == "demos":
            demos = value
        else:
            settings = replace(settings, **{key: types[key](value)})
    return settings, demos


def pilot(demos: str, name: str, pairs: list[str], embedder: str | None) -> None:
    settings, own_demos = settings_from(pairs)
    started = time.process_time()
    m = train_gail(own_demos or demos, f"{OUT}/{name}", settings, embedder)
    cpu = time.process_time() - started
    curve = m["curve"]
    points = " ".join(
        f"{p['steps'] // 1000}k:{p['mean_return']:.0f}" for p in curve[:: max(1, len(curve) // 12)]
    )
    best = max(p["mean_return"] for p in curve)
    entropy = m["rollouts"][-1]["entropy"]
    print(
        f"{name}: {cpu:.0f} s CPU, expert {m['expert_return']:.2f}, best {best:.1f}, final "
        f"{curve[-1]['mean_return']:.1f}, last entropy {entropy:.2f} | {points}",
        flush=True,
    )


def profile(demos: str, variant: str, steps: int, embedder: str | None) -> None:
    settings = GailSettings.preset("paper", logic_loss=variant, total_steps=steps, eval_every=10**9)
    profiler = cProfile.Profile()
    started = time.process_time()
    profiler.enable()
    train_gail(demos, f"{OUT}/profile-{variant}", settings, embedder)
    profiler.disable()
    cpu = time.process_time() - started
    print(f"{variant}: {steps} steps, {cpu:.1f} s CPU, {1000 * cpu / steps:.3f} s per 1k steps")
    pstats.Stats(profiler).sort_stats("cumulative").print_stats(30)


def stuck(demos: str, runs: list[str], repeats: int = 20) -> None:
    """Per variant: evaluation episodes of the final policies stuck on one infeasible action."""
    domain = load_domain(DEFAULT_DOMAIN)
    pool = list(dict.fromkeys(e.ingredients for e in read_demo_episodes(demos, domain)))
    forbidden = {
        p: {r.atom for r in knowledge_base(domain, p, mixture=False) if r.kind == "affordance"}
        for p in pool
    }
    counts: dict[str, Counter] = defaultdict(Counter)
    env = gym.make(ENV_ID, domain=domain)
    for run in runs:
        metrics = json.loads((Path(run) / "metrics.json").read_text())
        seed, variant = metrics["seed"], metrics["variant"]
        probabilities = policy_probabilities(PPO.load(Path(run) / "policy.zip", device="cpu"))
        episodes = len(metrics["curve"][-1]["returns"])
        for i in range(episodes):  # as evaluate.evaluate_returns, eval seed 10 000 + seed
            ingredients = pool[i % len(pool)]
            obs, _ = env.reset(seed=10_000 + seed + i, options={"ingredients": list(ingredients)})
            rng = np.random.default_rng([10_000 + seed, i])
            taken, done = [], False
            while not done:
                p = probabilities(obs)
                action = int(rng.choice(len(p), p=p))
                obs, _, terminated, truncated, info = env.step(action)
                taken.append((info["action_name"], info["feasible"]))
                done = terminated or truncated
            (name, feasible), k = Counter(taken).most_common(1)[0]
            counts[variant]["episodes"] += 1
            counts[variant]["reached the goal"] += bool(terminated)
            if not feasible and k >= repeats:
                kind = "affordance" if name in forbidden[ingredients] else "not forbidden"
                counts[variant][f"stuck ({kind})"] += 1
    for variant, c in counts.items():
        print(variant, dict(c))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("demos")
    parser.add_argument("--profile", nargs=2, metavar=("VARIANT", "STEPS"))
    parser.add_argument("--embedder", help="train-meta directory (tleaf)")
    parser.add_argument("--stuck", nargs="+", metavar="RUN", help="train-task cooking runs")
    parser.add_argument("configs", nargs="*", help="NAME key=value ... [: NAME ...]")
    args = parser.parse_args()
    if args.stuck:
        stuck(args.demos, args.stuck)
        return
    if args.profile:
        profile(args.demos, args.profile[0], int(args.profile[1]), args.embedder)
        return
    groups, current = [], []
    for word in args.configs:
        if word == ":":
            groups.append(current)
            current = []
        else:
            current.append(word)
    groups.append(current)
    for group in filter(None, groups):
        pilot(args.demos, group[0], group[1:], args.embedder)


if __name__ == "__main__":
    main()
