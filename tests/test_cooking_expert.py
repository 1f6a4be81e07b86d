"""The Creative Cooking expert (A* shortest plans) and `tleaf gen-demos`."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pyarrow.parquet as pq
import pytest

from tleaf_cli.data.artifacts import read_artifact
from tleaf_cli.tasks.cooking import ENV_ID
from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, load_domain
from tleaf_cli.tasks.cooking.env import GOAL_REWARD, CreativeCookingEnv
from tleaf_cli.tasks.cooking.expert import plan, plan_breadth_first

DOMAIN = load_domain()


@pytest.mark.parametrize("seed", range(6))
def test_expert_solves_sampled_episodes(seed: int):
    env = CreativeCookingEnv(DOMAIN)
    env.reset(seed=seed)
    actions = plan(env.rules)
    assert actions == plan(env.rules)  # deterministic
    total = 0.0
    for i, action in enumerate(actions):
        _, reward, terminated, _, info = env.step(action)
        total += reward
        assert info["feasible"]
        assert terminated == (i == len(actions) - 1)
    assert total == GOAL_REWARD - len(actions)


def test_expert_plans_are_shortest():
    """A* against breadth-first search from reset states and from random mid-episode states."""
    env = CreativeCookingEnv(DOMAIN)
    rng = np.random.default_rng(0)
    cases = []
    for ingredients in [("salmon", "lentils", "cheese", "vinegar", "cilantro")]:
        env.reset(options={"ingredients": list(ingredients)})
        cases.append((env.rules, env.state))
    for seed in range(8):
        env.reset(seed=seed)
        for _ in range(int(rng.integers(3, 7))):  # a few random feasible steps in
            env.step(int(rng.choice(np.flatnonzero(env.action_masks()))))
        if not env.rules.is_goal(env.state):
            cases.append((env.rules, env.state))
    checked = 0
    for rules, state in cases:
        try:
            best = plan(rules, state)
        except RuntimeError:
            continue  # a dead end (over-processed): breadth-first search would roam it all
        assert len(best) == len(plan_breadth_first(rules, state))
        assert len(plan(rules, state, rng=np.random.default_rng(checked))) == len(best)
        checked += 1
    assert checked >= 5


def test_expert_reports_dead_ends():
    from tleaf_cli.tasks.cooking.expert import NoPlan
    from tleaf_cli.tasks.cooking.rules import EpisodeRules

    names = ("beef", "chicken", "pork", "salmon", "shrimp")  # all must end cooked
    rules = EpisodeRules(DOMAIN, [DOMAIN.ingredient(n) for n in names])
    state = rules.initial_state()
    for action in ("cut", "fry", "plate"):  # beef over-processed: plated, never back to cooked
        state = rules.step(state, rules.codec.encode(action, 1))
    state = tuple(s if i in (0, 1, 6) else 0 for i, s in enumerate(state))  # only beef left
    with pytest.raises(NoPlan):
        plan(rules, state)


# -- gen-demos ---------------------------------------------------------------------------------


def test_gen_demos_writes_a_replayable_artifact(chain_cli, tmp_path: Path):
    out = tmp_path / "demos.parquet"
    result = chain_cli("gen-demos", "-o", out, "--episodes", 3, "--seed", 5)
    assert result.exit_code == 0, result.output
    assert "success rate 100.0%" in result.output and "synthetic" in result.output
    table, prov = read_artifact(out, "demos", 1)
    assert table.column_names == [
        "episode",
        "step",
        "observation",
        "action",
        "action_name",
        "reward",
        "terminated",
    ]
    types = [str(t) for t in table.schema.types]
    assert types[:2] == ["int32", "int32"] and types[3:] == ["int32", "string", "float", "bool"]
    assert prov.params["success_rate"] == 1.0 and prov.params["episodes"] == 3
    assert "synthetic" in prov.params["data"]
    assert prov.inputs[0]["path"] == str(DEFAULT_DOMAIN)
    rows = table.to_pylist()
    assert sorted({r["episode"] for r in rows}) == [0, 1, 2]
    returns = [sum(r["reward"] for r in rows if r["episode"] == e) for e in range(3)]
    assert prov.params["mean_return"] == pytest.approx(sum(returns) / 3)
    # Replaying the recorded actions in a freshly seeded environment gives the same rows.
    env = gym.make(ENV_ID)
    for episode in range(3):
        obs, _ = env.reset(seed=5 if episode == 0 else None)
        steps = [r for r in rows if r["episode"] == episode]
        assert [r["step"] for r in steps] == list(range(len(steps)))
        for row in steps:
            assert row["observation"] == obs.tolist() and len(obs) == 12
            obs, reward, terminated, _, info = env.step(row["action"])
            assert (reward, terminated, info["action_name"]) == (
                row["reward"],
                row["terminated"],
                row["action_name"],
            )
        assert steps[-1]["terminated"]


def test_gen_demos_is_deterministic(chain_cli, tmp_path: Path):
    paths = [tmp_path / f"{name}.parquet" for name in ("a", "b", "c")]
    for path, seed in zip(paths, (1, 1, 2), strict=True):
        assert chain_cli("gen-demos", "-o", path, "--episodes", 2, "--seed", seed).exit_code == 0
    a, b, c = (pq.read_table(p) for p in paths)
    assert a.equals(b) and not a.equals(c)
    meta = json.loads(pq.read_schema(paths[0]).metadata[b"tleaf.params"])
    assert meta["seed"] == 1


def test_gen_demos_usage_errors(chain_cli, tmp_path: Path):
    bad = tmp_path / "bad.toml"
    bad.write_text(DEFAULT_DOMAIN.read_text().replace('salt = ["seasoning"]', 'salt = ["salty"]'))
    result = chain_cli("gen-demos", "-o", tmp_path / "d.parquet", "--domain", bad)
    assert result.exit_code == 2
    assert "ingredients.salt: unknown property 'salty'" in result.output
    assert "Traceback" not in result.output
    result = chain_cli("gen-demos", "-o", tmp_path, "--episodes", 1)  # a folder
    assert result.exit_code == 2 and "is a folder" in result.output
