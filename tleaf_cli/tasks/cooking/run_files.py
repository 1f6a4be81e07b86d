"""A GAIL run's folder: config.json (settings, pool, inputs), metrics.json (the curve beside the
expert's and the uniform policy's returns, per-rollout figures), policy.zip, discriminator.pt."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch
from stable_baselines3 import PPO

from tleaf_cli.data.artifacts import atomic_path, describe_inputs, relative_to, write_text_atomic
from tleaf_cli.settings.gail import GailSettings
from tleaf_cli.tasks.cooking import ENV_ID
from tleaf_cli.tasks.cooking.callbacks import GailCallback
from tleaf_cli.tasks.cooking.demo_episodes import DemoEpisode
from tleaf_cli.tasks.cooking.discriminator import Discriminator


def variant_name(settings: GailSettings) -> str:
    """How eval cooking groups a run: its logic loss, or `shield` for a shielded run."""
    return "shield" if settings.shield else settings.logic_loss


def run_metrics(
    expert: list[DemoEpisode],
    pool: list[tuple[str, ...]],
    settings: GailSettings,
    callback: GailCallback,
    model: PPO,
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


def write_run(
    out_dir: Path,
    demos: str | Path,
    embedder_dir: str | Path | None,
    settings: GailSettings,
    pool: list[tuple[str, ...]],
    model: PPO,
    disc: Discriminator,
    metrics: dict,
) -> None:
    """Write the run's four files, each atomically (a crash leaves no half-written file)."""
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
