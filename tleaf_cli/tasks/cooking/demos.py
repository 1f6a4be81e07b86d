"""Expert demonstrations for Creative Cooking (`tleaf gen-demos`): a `demos` Parquet artifact.

Episodes come from the registered environment (`tleaf/CreativeCooking-v0`, its TimeLimit
included), seeded once with `reset(seed=seed)` and then drawn in sequence, so the first k
episodes of a longer run are the k episodes of a shorter one. The expert plans each episode from
its reset state (`expert.plan`: a shortest plan, ties between equally short ones broken by a
generator seeded with the same seed) and the plan is played in the environment; rows are what the
environment returned, so the rewards and `terminated` are the environment's own.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
import pyarrow as pa

from tleaf_cli.data.artifacts import check_writable, describe_inputs, write_artifact
from tleaf_cli.settings.generators import DemoSettings
from tleaf_cli.tasks.cooking import ENV_ID, MAX_EPISODE_STEPS
from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, load_domain
from tleaf_cli.tasks.cooking.expert import plan

KIND = "demos"
SCHEMA = 1
DEMO_SCHEMA = pa.schema(
    [
        ("episode", pa.int32()),
        ("step", pa.int32()),
        ("observation", pa.list_(pa.int32(), 12)),
        ("action", pa.int32()),
        ("action_name", pa.string()),
        ("reward", pa.float32()),
        ("terminated", pa.bool_()),
    ]
)


@dataclass(frozen=True)
class DemoReport:
    episodes: int
    rows: int
    success_rate: float  # share of episodes that reached the goal within the time limit
    mean_return: float
    mean_length: float
    planning_seconds: float  # the expert's total planning time


def generate_demos(
    out: str | Path,
    settings: DemoSettings,
    update: Callable[[int, int], None] = lambda done, total: None,
) -> DemoReport:
    """Plan and play `settings.episodes` expert episodes; write them to `out` (kind `demos`)."""
    domain_path = settings.domain or DEFAULT_DOMAIN
    domain = load_domain(domain_path)
    check_writable(out)
    env = gym.make(ENV_ID, domain=domain)
    ties = np.random.default_rng(settings.seed)  # which of the equally short plans is shown
    columns: dict[str, list] = {name: [] for name in DEMO_SCHEMA.names}
    returns, lengths, successes, planning = [], [], 0, 0.0
    for episode in range(settings.episodes):
        observation, _ = env.reset(seed=settings.seed if episode == 0 else None)
        started = time.perf_counter()
        actions = plan(env.unwrapped.rules, rng=ties)
        planning += time.perf_counter() - started
        total, steps, terminated = 0.0, 0, False
        for step, action in enumerate(actions):
            nxt, reward, terminated, truncated, info = env.step(action)
            row = (episode, step, observation.tolist(), action, info["action_name"])
            for name, value in zip(DEMO_SCHEMA.names, (*row, reward, terminated), strict=True):
                columns[name].append(value)
            observation, total, steps = nxt, total + reward, step + 1
            if terminated or truncated:
                break
        successes += terminated
        returns.append(total)
        lengths.append(steps)
        update(episode + 1, settings.episodes)
    env.close()
    report = DemoReport(
        episodes=settings.episodes,
        rows=len(columns["episode"]),
        success_rate=successes / max(settings.episodes, 1),
        mean_return=sum(returns) / max(len(returns), 1),
        mean_length=sum(lengths) / max(len(lengths), 1),
        planning_seconds=planning,
    )
    params = {
        "episodes": settings.episodes,
        "seed": settings.seed,
        "domain": str(domain_path),
        "env": ENV_ID,
        "max_episode_steps": MAX_EPISODE_STEPS,
        "expert": "A* shortest plans over the exact rules, ties broken at random (seeded)",
        "success_rate": report.success_rate,
        "mean_return": report.mean_return,
        "mean_length": report.mean_length,
        "data": "synthetic: Creative Cooking environment built from the paper's appendix",
    }
    table = pa.Table.from_pydict(columns, schema=DEMO_SCHEMA)
    write_artifact(
        table,
        out,
        kind=KIND,
        schema=SCHEMA,
        params=params,
        inputs=describe_inputs([domain_path]),
    )
    return report
