"""GAIL on Creative Cooking: reward wrapper, discriminator, logic term, a short run, the report."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pyarrow as pa
import pytest
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import DummyVecEnv

from tests.conftest import make_small, shared_small
from tleaf_cli.data.artifacts import write_artifact
from tleaf_cli.errors import SettingError
from tleaf_cli.settings.gail import GailSettings
from tleaf_cli.tasks.cooking import ENV_ID
from tleaf_cli.tasks.cooking.demo_episodes import read_demo_episodes
from tleaf_cli.tasks.cooking.demos import DEMO_SCHEMA, KIND, SCHEMA
from tleaf_cli.tasks.cooking.discriminator import (
    Discriminator,
    DiscriminatorReward,
    discriminator_step,
)
from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, load_domain
from tleaf_cli.tasks.cooking.environments import IngredientPool
from tleaf_cli.tasks.cooking.expert import plan
from tleaf_cli.tasks.cooking.gail_report import evaluate_cooking_runs
from tleaf_cli.tasks.cooking.logic_term import (
    CookingKnowledge,
    LogicTerm,
    RolloutEpisode,
    rollout_episodes,
)
from tleaf_cli.tasks.cooking.train import train_gail

# Four ingredients already at their required status (liquids, seasonings) and parsley, which
# needs one wash/rinse/chop: the expert's plan is a single step (return 19).
EASY = ("parsley", "water", "vinegar", "salt", "black_pepper")


@pytest.fixture(scope="module")
def domain():
    return load_domain(DEFAULT_DOMAIN)


def write_demos(path: Path, ingredients: tuple[str, ...], episodes: int = 2) -> Path:
    """Expert episodes on fixed ingredients, as gen-demos writes them."""
    env = gym.make(ENV_ID)
    columns: dict[str, list] = {n: [] for n in DEMO_SCHEMA.names}
    for e in range(episodes):
        obs, _ = env.reset(seed=e, options={"ingredients": list(ingredients)})
        for step, action in enumerate(plan(env.unwrapped.rules, rng=np.random.default_rng(e))):
            nxt, reward, terminated, _, info = env.step(action)
            row = (e, step, obs.tolist(), action, info["action_name"], reward, terminated)
            for name, value in zip(DEMO_SCHEMA.names, row, strict=True):
                columns[name].append(value)
            obs = nxt
    table = pa.Table.from_pydict(columns, schema=DEMO_SCHEMA)
    write_artifact(table, path, kind=KIND, schema=SCHEMA, params={}, inputs=[])
    return path


def random_episode(ingredients, steps: int, seed: int) -> RolloutEpisode:
    """A uniformly random episode prefix of `steps` actions on fixed ingredients."""
    env = gym.make(ENV_ID)
    obs, _ = env.reset(seed=seed, options={"ingredients": list(ingredients)})
    rng = np.random.default_rng(seed)
    observations, actions = [], []
    for _ in range(steps):
        action = int(rng.integers(env.action_space.n))
        observations.append(obs)
        actions.append(action)
        obs, *_ = env.step(action)
    names = env.unwrapped.ingredients  # domain order, as in the observation
    return RolloutEpisode(names, np.array(observations), np.array(actions))


def test_reward_wrapper_pays_the_discriminators_reward_not_the_envs() -> None:
    venv = DummyVecEnv([lambda: IngredientPool(gym.make(ENV_ID), [EASY])])
    venv.seed(0)
    torch.manual_seed(0)
    disc = Discriminator(venv.observation_space.nvec, venv.action_space.n, hidden=8)
    wrapped = DiscriminatorReward(venv, disc)
    obs = wrapped.reset()
    for action in (5, 17, 100):
        actions = np.array([action])
        expected = disc.reward(obs, actions)
        obs, rewards, _, infos = wrapped.step(actions)
        assert np.allclose(rewards, expected)
        assert (rewards < 0).all()  # log D
        assert infos[0]["env_reward"] in (-1.0, -2.0, 19.0)
        assert not np.isclose(rewards[0], infos[0]["env_reward"])
    # the other reward form: the logit log D − log(1 − D), so log D = −softplus(−logit)
    logit = disc.reward(obs, np.array([5]), "logit")
    assert np.allclose(-np.logaddexp(0, -logit), disc.reward(obs, np.array([5])), atol=1e-6)
    with pytest.raises(ValueError, match="reward form"):
        disc.reward(obs, np.array([5]), "positive")


def test_discriminator_separates_expert_from_random_pairs(tmp_path: Path, domain) -> None:
    sets = [EASY, ("salmon", "lentils", "cheese", "vinegar", "cilantro")]
    expert = [
        e
        for k, s in enumerate(sets)
        for e in read_demo_episodes(write_demos(tmp_path / f"d{k}.parquet", s, 3), domain)
    ]
    e_obs = torch.as_tensor(np.concatenate([e.observations for e in expert]))
    e_act = torch.as_tensor(np.concatenate([e.actions for e in expert]))
    space = gym.make(ENV_ID).observation_space
    space.seed(1)
    rng = np.random.default_rng(1)

    def random_pairs(n: int):
        obs = torch.as_tensor(np.array([space.sample() for _ in range(n)]))
        return obs, torch.as_tensor(rng.integers(234, size=n))

    torch.manual_seed(0)
    disc = Discriminator(space.nvec, 234, hidden=32)
    optimizer = torch.optim.Adam(disc.parameters(), lr=3e-3)
    for _ in range(150):
        pick = torch.as_tensor(rng.integers(len(e_obs), size=64))
        discriminator_step(disc, optimizer, (e_obs[pick], e_act[pick]), random_pairs(64))
    with torch.no_grad():
        assert (disc(e_obs, e_act) > 0).float().mean() > 0.9
        assert (disc(*random_pairs(500)) < 0).float().mean() > 0.9


def test_rollout_episodes_keep_only_episodes_that_start_in_the_rollout(domain) -> None:
    ep = random_episode(EASY, 6, seed=0)
    observations = np.stack([ep.observations, ep.observations], axis=1)  # [6, 2 envs, 12]
    actions = np.stack([ep.actions, ep.actions], axis=1)[..., None]
    starts = np.zeros((6, 2))
    starts[[0, 4], 0] = 1  # env 0: an episode of 4 steps, then one cut after 2
    starts[3, 1] = 1  # env 1: steps 0-2 belong to an earlier episode
    episodes = rollout_episodes(observations, actions, starts, domain)
    assert [len(e.actions) for e in episodes] == [4, 2, 3]
    assert episodes[2].actions.tolist() == ep.actions[3:].tolist()
    assert episodes[0].ingredients == ep.ingredients and set(ep.ingredients) == set(EASY)


def logic_gradient(kind: str, domain, ingredients, embedder=None) -> tuple[torch.Tensor, float]:
    """ℓ_logic of a fresh policy on two random episodes, and the gradient norm it sends back."""
    venv = DummyVecEnv([lambda: gym.make(ENV_ID)])
    torch.manual_seed(0)
    policy = PPO("MlpPolicy", venv, n_steps=16, batch_size=16, seed=0).policy
    term = LogicTerm(kind, CookingKnowledge(domain, embedder))
    loss = term.loss(policy, [random_episode(ingredients, 8, seed=s) for s in (0, 1)])
    if not loss.requires_grad:
        return loss, 0.0
    loss.backward()
    return loss, float(sum(p.grad.norm() for p in policy.parameters() if p.grad is not None))


def reference_and_batched(
    kind: str, domain, sets: tuple[tuple[str, ...], tuple[str, ...]], embedder=None
) -> list[tuple[float, float]]:
    """The logic term (all rows in one call) against `logic_loss` episode by episode, on
    episodes of `sets` (two, or one twice) and three lengths: (batched, reference) for the value and
    for every parameter's gradient norm."""
    from tleaf_cli.losses import logic_loss

    episodes = [random_episode(sets[0], 7, 0), random_episode(sets[1], 12, 1)]
    episodes.append(random_episode(sets[0], 3, 2))
    venv = DummyVecEnv([lambda: gym.make(ENV_ID)])
    torch.manual_seed(0)
    policy = PPO("MlpPolicy", venv, n_steps=16, batch_size=16, seed=0).policy
    knowledge = CookingKnowledge(domain, embedder)

    def gradients() -> list[float]:
        norms = [float(p.grad.norm()) for p in policy.parameters() if p.grad is not None]
        policy.zero_grad()
        return norms

    batched = LogicTerm(kind, knowledge).loss(policy, episodes)
    batched.backward()
    batched_grads = gradients()
    rows = []
    for e in episodes:
        rules = knowledge.rules(e.ingredients)
        sets = list(rules.trainable)
        obs = torch.as_tensor(e.observations).float()
        logits = policy.get_distribution(obs).distribution.logits[None].repeat(len(sets), 1, 1)
        log_probs = torch.log_softmax(logits, dim=-1)
        rows.append(logic_loss(kind, log_probs, sets, embedder=embedder, reduction="none"))
    reference = torch.cat(rows).mean()
    reference.backward()
    pairs = [(float(batched.detach()), float(reference.detach()))]
    return pairs + list(zip(batched_grads, gradients(), strict=True))


def test_trace_graph_batch_is_the_batch_of_trace_graphs() -> None:
    from torch_geometric.data import Batch

    from tleaf_cli.embed.graphs import trace_graph, trace_graph_batch

    built, edge_nodes = trace_graph_batch([3, 1, 5])
    expected = Batch.from_data_list([trace_graph(n) for n in (3, 1, 5)])
    for key in ("node_kind", "flags", "guard", "edge_index", "initial", "batch", "ptr"):
        assert torch.equal(getattr(built, key), getattr(expected, key)), key
    assert built.num_nodes == expected.num_nodes == 21
    assert edge_nodes.tolist() == [4, 5, 6, 9, 16, 17, 18, 19, 20]


def test_batched_exact_term_equals_the_loss_episode_by_episode(domain) -> None:
    other = ("salmon", "lentils", "cheese", "vinegar", "cilantro")
    pairs = reference_and_batched("exact", domain, (EASY, other))
    assert pairs[0][0] > 0 and len(pairs) > 2
    for batched, reference in pairs:
        assert batched == pytest.approx(reference, rel=1e-4, abs=1e-6)


def test_exact_logic_term_sends_gradient_into_the_policy_and_checker_none(domain) -> None:
    loss, grad = logic_gradient("exact", domain, EASY)
    assert float(loss.detach()) > 0 and grad > 0
    loss, grad = logic_gradient("checker", domain, EASY)
    assert not loss.requires_grad and grad == 0.0
    assert 0.0 <= float(loss) <= 1.0


@pytest.mark.slow
def test_a_short_gail_run_learns_the_easy_episode(tmp_path: Path) -> None:
    """Plain GAIL (the default settings, gradient penalty included, on shorter rollouts) on one
    fixed one-step episode: the return rises well above its start."""
    demos = write_demos(tmp_path / "demos.parquet", EASY)
    settings = GailSettings(
        total_steps=3072, n_envs=2, n_steps=64, eval_every=1024, eval_episodes=4, seed=0,
        lr_schedule="constant",
    )  # fmt: skip
    metrics = train_gail(demos, tmp_path / "run", settings)
    curve = [p["mean_return"] for p in metrics["curve"]]
    assert metrics["expert_return"] == 19.0
    assert curve[-1] > curve[0] + 30
    assert (tmp_path / "run/policy.zip").exists()
    saved = torch.load(tmp_path / "run/discriminator.pt", weights_only=True)
    assert "head.weight" in saved


@pytest.mark.slow
def test_the_ppo_update_keeps_sb3s_target_kl_and_value_clipping(tmp_path: Path) -> None:
    """SB3's PPO settings the update once dropped: target_kl stops an update's epochs early,
    clip_range_vf clips the value; approx_kl and clip_fraction are logged per rollout."""
    demos = write_demos(tmp_path / "demos.parquet", EASY)
    base = {"total_steps": 1024, "n_envs": 2, "batch_size": 64, "eval_every": 512, "seed": 0}
    base["lr_schedule"] = "constant"  # the settings these figures were written with
    plain = train_gail(demos, tmp_path / "plain", GailSettings(**base, eval_episodes=2))
    stopped = train_gail(
        demos, tmp_path / "kl", GailSettings(**base, eval_episodes=2, target_kl=1e-9)
    )
    clipped = train_gail(
        demos, tmp_path / "vf", GailSettings(**base, eval_episodes=2, clip_range_vf=1e-6)
    )
    for run in (plain, stopped, clipped):
        for r in run["rollouts"]:
            assert r["approx_kl"] >= 0.0 and 0.0 <= r["clip_fraction"] <= 1.0
    assert not any(r["stopped_early"] for r in plain["rollouts"])
    assert all(r["stopped_early"] for r in stopped["rollouts"][1:])  # past the first minibatch
    values = [r["value_loss"] for r in plain["rollouts"]]
    assert [r["value_loss"] for r in clipped["rollouts"]] != values  # the clip changed the loss


@pytest.mark.slow
def test_a_linear_learning_rate_schedule_falls_to_zero_and_is_logged(tmp_path: Path) -> None:
    """--lr-schedule linear: each rollout's PPO update uses lr × the share of the run still to
    go (logged per rollout); constant keeps lr; an unknown schedule is a SettingError."""
    demos = write_demos(tmp_path / "demos.parquet", EASY)
    base = {"total_steps": 1024, "n_envs": 2, "n_steps": 64, "eval_every": 512, "seed": 0}
    constant = train_gail(
        demos,
        tmp_path / "c",
        GailSettings(**base, eval_episodes=2, lr=2e-3, lr_schedule="constant"),
    )
    linear = train_gail(
        demos, tmp_path / "l", GailSettings(**base, eval_episodes=2, lr=2e-3, lr_schedule="linear")
    )
    assert {r["learning_rate"] for r in constant["rollouts"]} == {2e-3}
    rates = [r["learning_rate"] for r in linear["rollouts"]]
    assert len(rates) == 8 and rates == sorted(rates, reverse=True)
    # before the k-th update (k = 1..8) of 8, 128 steps each, progress remaining is 1 - k/8
    assert rates == pytest.approx([2e-3 * (1 - k / 8) for k in range(1, 9)])
    config = json.loads((tmp_path / "l/config.json").read_text())
    assert config["settings"]["lr_schedule"] == "linear"
    with pytest.raises(SettingError, match="lr_schedule"):
        GailSettings(lr_schedule="cosine").check()


def fake_run(
    path: Path, variant: str, seed: int, returns: list[float], violations: list | None = None
) -> Path:
    curve = [{"steps": 100 * k, "mean_return": r} for k, r in enumerate(returns)]
    metrics = {"variant": variant, "seed": seed, "curve": curve, "expert_return": 10.0}
    metrics["random_return"] = -90.0
    rates = violations or [None] * 12
    metrics["rollouts"] = [{"violation_rate": v, "entropy": 5.0 - k} for k, v in enumerate(rates)]
    path.mkdir(parents=True)
    (path / "metrics.json").write_text(json.dumps(metrics))
    return path


def test_eval_report_curves_stderr_and_steps_to_90(tmp_path: Path, chain_cli) -> None:
    runs = [
        fake_run(tmp_path / "n0", "none", 0, [-90, -50, 0, 9, 10]),
        fake_run(tmp_path / "n1", "none", 1, [-90, -30, 2, 10, 10]),
        fake_run(tmp_path / "t0", "tleaf", 0, [-90, 9, 10, 10, 10], [1.0] * 10 + [0.0] * 2),
        fake_run(tmp_path / "t1", "tleaf", 1, [-90, 10, 10, 10, 10], [0.5] * 12),
    ]
    report = evaluate_cooking_runs(runs, tmp_path / "report")
    none, tleaf = report["variants"]["none"], report["variants"]["tleaf"]
    assert none["mean_return"] == [-90, -40, 1, 9.5, 10]
    assert none["stderr"][1] == pytest.approx(np.std([-50, -30], ddof=1) / np.sqrt(2))
    assert none["steps_to_90"] == 300 and none["steps_to_90_per_seed"] == [300, 300]
    assert tleaf["steps_to_90"] == 100
    assert report["tleaf_over_none_steps_to_90"] == pytest.approx(1 / 3)
    # normalised: (R + 90) / 100 >= 0.9 -> R >= 0: none's mean reaches it at step 200
    assert none["steps_to_90_normalised"] == 200
    assert (tmp_path / "report/report.png").read_bytes()[:4] == b"\x89PNG"
    md = (tmp_path / "report/report.md").read_text()
    assert "| none | 2 |" in md and "| tleaf | 2 |" in md
    # what can be compared short of 90 %: return at 25/50/100 % of the budget, steps to half-way
    at = none["at_fraction"]
    assert [a["steps"] for a in at] == [100, 200, 400]
    assert [a["mean"] for a in at] == [-40, 1, 10]
    assert at[0]["stderr"] == pytest.approx(10.0)
    assert none["steps_to_half"] == 100 and none["steps_to_half_per_seed"] == [200, 100]
    assert report["tleaf_over_none_steps_to_half"] == pytest.approx(1.0)
    assert none["steps_to_quarter"] == 100 and none["steps_to_quarter_per_seed"] == [100, 100]
    # per-run summaries, mean ± s.e. over seeds: whole curve, best evaluation, training log
    assert none["curve_mean"]["mean"] == pytest.approx(-21.9)
    assert none["curve_mean"]["stderr"] == pytest.approx(np.std([-24.2, -19.6], ddof=1) / 2**0.5)
    assert none["best"] == {"mean": 10.0, "stderr": 0.0, "n": 2}
    assert none["violation_rate_first"] is None  # plain GAIL logs no violation rate
    # first 10 rollouts: 1.0 and 0.5; last 10: (8 · 1.0 + 2 · 0) / 10 and 0.5
    assert tleaf["violation_rate_first"]["mean"] == pytest.approx(0.75)
    assert tleaf["violation_rate_last"]["mean"] == pytest.approx(0.65)
    assert tleaf["entropy_last"]["mean"] == pytest.approx(np.mean([5.0 - k for k in range(2, 12)]))
    assert "| none | -40.00 ± 10.00 (100) | 1.00 ± 1.00 (200) |" in md
    assert "| tleaf | " in md and "| 0.75 ± 0.25 → 0.65 ± 0.15 |" in md
    slow = [
        fake_run(tmp_path / "s0", "none", 0, [-90, -60, -50, -40, -40]),
        fake_run(tmp_path / "s1", "tleaf", 0, [-90, -20, 9, 9, 9]),
    ]
    report = evaluate_cooking_runs(slow, tmp_path / "slow")
    assert report["variants"]["none"]["steps_to_90"] is None
    assert "tleaf_over_none_steps_to_90" not in report
    md = (tmp_path / "slow/report.md").read_text()
    assert "steps to 90 % of the expert: not measurable (none did not reach it" in md
    # a folder without metrics.json is a usage error (exit 2), not a traceback
    (tmp_path / "empty").mkdir()
    result = chain_cli("eval", "cooking", tmp_path / "empty", "-o", tmp_path / "r2")
    assert result.exit_code == 2 and "metrics.json" in result.output


@pytest.fixture(scope="session")
def small_pipeline(tmp_path_factory) -> Path:
    """pipelines/cooking.mk SMALL=1 (2 seeds) with none, tleaf and checker, once a run (its
    three tests may run on different xdist workers)."""
    return shared_small(tmp_path_factory, "cooking.mk", "LOSSES=none tleaf checker", timeout=900)


@pytest.mark.slow
def test_small_pipeline_end_to_end(small_pipeline: Path) -> None:
    report = json.loads((small_pipeline / "report/report.json").read_text())
    assert set(report["variants"]) == {"none", "tleaf", "checker"}
    for v in report["variants"].values():
        assert v["seeds"] == [0, 1] and len(v["steps"]) == len(v["mean_return"]) >= 2
    tleaf = json.loads((small_pipeline / "runs/tleaf-seed0/metrics.json").read_text())
    assert any(r["logic_loss"] and r["logic_loss"] > 0 for r in tleaf["rollouts"])
    config = json.loads((small_pipeline / "runs/tleaf-seed0/config.json").read_text())
    assert config["data"].startswith("synthetic")
    # a seed added to the finished runs is run (make -q exits 1: out of date)
    more = make_small(
        "cooking.mk", small_pipeline, "-q", "LOSSES=none tleaf checker", "SEEDS=0 1 2"
    )
    assert more.returncode == 1, more.stdout[-2000:]


@pytest.mark.slow
def test_checker_trains_exactly_like_plain_gail(small_pipeline: Path) -> None:
    """No gradient, same seed: the checker run's curve equals plain GAIL's."""
    runs = small_pipeline / "runs"
    plain = json.loads((runs / "none-seed0/metrics.json").read_text())
    checker = json.loads((runs / "checker-seed0/metrics.json").read_text())
    assert [p["returns"] for p in plain["curve"]] == [p["returns"] for p in checker["curve"]]
    assert all(r["violation_rate"] is not None for r in checker["rollouts"])


@pytest.mark.slow
def test_tleaf_logic_term_sends_gradient_into_the_policy(small_pipeline: Path, domain) -> None:
    from tleaf_cli.embed.load import load_embedder

    ingredients = read_demo_episodes(small_pipeline / "demos.parquet", domain)[0].ingredients
    embedder = load_embedder(small_pipeline / "meta")
    loss, grad = logic_gradient("tleaf", domain, ingredients, embedder)
    assert float(loss.detach()) > 0 and grad > 0
    other = read_demo_episodes(small_pipeline / "demos.parquet", domain)[-1].ingredients
    pairs = reference_and_batched("tleaf", domain, (ingredients, other), embedder)
    assert pairs[0][0] > 0
    for batched, reference in pairs:
        assert batched == pytest.approx(reference, rel=1e-4, abs=1e-6)
    # the rule sets and q are not pickled into policy.zip (they made it 142 MB)
    assert (small_pipeline / "runs/tleaf-seed0/policy.zip").stat().st_size < 5_000_000


@pytest.mark.slow
def test_shielded_gail_masks_with_the_rules_and_starts_above_the_unshielded(tmp_path) -> None:
    """--shield: MaskablePPO whose masks are the rules' shield (ShieldedActions); its untrained
    policy, restricted to allowed actions, already wastes fewer steps on infeasible actions."""
    from tleaf_cli.errors import SettingError
    from tleaf_cli.tasks.cooking.shield import ShieldedActions, cooking_shield

    env = ShieldedActions(gym.make(ENV_ID))
    env.reset(seed=3)
    game = env.unwrapped
    shield = cooking_shield(game.domain, game.ingredients, game.action_names)
    rng = np.random.default_rng(0)
    for _ in range(10):  # the wrapper's mask follows the actions taken, as a fresh shield does
        assert np.array_equal(env.action_masks(), shield.allowed().numpy())
        action = int(rng.choice(np.flatnonzero(env.action_masks())))
        shield.step(action)
        if any(env.step(action)[2:4]):
            break
    demos = write_demos(tmp_path / "demos.parquet", EASY)
    base = {"total_steps": 512, "n_envs": 2, "batch_size": 64, "eval_every": 512, "seed": 0}
    base["lr_schedule"] = "constant"  # the settings these figures were written with
    plain = train_gail(demos, tmp_path / "plain", GailSettings(**base, eval_episodes=4))
    shielded = train_gail(
        demos, tmp_path / "shield", GailSettings(**base, eval_episodes=4, shield=True)
    )
    assert shielded["curve"][0]["mean_return"] > plain["curve"][0]["mean_return"]
    assert json.loads((tmp_path / "shield/config.json").read_text())["settings"]["shield"]
    with pytest.raises(SettingError, match="shield"):
        GailSettings(shield=True, logic_loss="exact").check()


def test_median_ratio_of_steps_to_90_with_a_bootstrap_interval(tmp_path: Path) -> None:
    from tleaf_cli.tasks.cooking.gail_report import median_ratio

    # tleaf gets there in half of none's steps at every seed: 0.5, and every draw says so
    r = median_ratio([100, 200, 300, 400], [200, 400, 600, 800])
    assert r["ratio"] == pytest.approx(0.5)
    assert r["low"] <= 0.5 <= r["high"] and r["undefined_draws"] == 0
    # a spread of seeds widens the interval around the point
    wide = median_ratio([100, 900, 300, 700, 500], [500, 300, 900, 100, 700])
    assert wide["ratio"] == pytest.approx(1.0) and wide["low"] < 0.7 and wide["high"] > 1.4
    # seeds that never got there count as never: 3 of 4 never -> tleaf's median is infinite
    never = median_ratio([100, None, None, None], [200, 200, 200, 200])
    assert never["ratio"] is None and never["numerator_median"] is None
    assert never["high"] is None  # unbounded above
    # ... and at 1 never of 5 the median is still finite: the never-seed shifts it up
    one = median_ratio([100, 200, 300, 400, None], [300, 300, 300, 300, 300])
    assert one["ratio"] == pytest.approx(1.0)
    # the report carries it and says it in words
    runs = [fake_run(tmp_path / f"n{s}", "none", s, [-90, -50, -50, 9, 10]) for s in range(3)] + [
        fake_run(tmp_path / f"t{s}", "tleaf", s, [-90, -50, 9, 10, 10]) for s in range(3)
    ]
    report = evaluate_cooking_runs(runs, tmp_path / "report")
    assert report["tleaf_over_none_median_steps_to_90"]["ratio"] == pytest.approx(2 / 3)
    md = (tmp_path / "report/report.md").read_text()
    assert "tleaf / none median steps to 90 % of the expert, per seed" in md and ": 0.67;" in md


def _pipeline_value(name: str) -> str:
    """The value pipelines/cooking.mk gives `name` (`NAME ?= value`), the same in every branch."""
    text = (Path(__file__).parent.parent / "pipelines/cooking.mk").read_text()
    values = {line.split("?=")[1].strip() for line in text.splitlines() if line.startswith(name)}
    assert len(values) == 1, (name, values)
    return values.pop()


def test_the_default_is_the_documented_setting_and_paper_a_preset() -> None:
    """Before, the defaults (constant learning rate; λ q's recommendation or 1) were not the
    documented results' settings (pipelines/cooking.mk: --lr-schedule linear, --lambda 0.01)."""
    best = GailSettings()
    assert best.lr_schedule == _pipeline_value("LR_SCHEDULE") == "linear"
    assert best.lam == float(_pipeline_value("LAMBDA")) == 0.01
    assert GailSettings.preset("best") == best and GailSettings.default_preset() == "best"
    paper = GailSettings.preset("paper")
    assert (paper.lam, paper.lr_schedule) == (1.0, "constant")  # the paper's λ = 1.0 (Sec. VII)
    assert set(GailSettings.PRESET_HELP) == set(GailSettings.PRESETS)


def test_the_cli_prints_the_lambda_and_its_source_and_stores_it(chain_cli, tmp_path) -> None:
    """Before, train-task cooking never said which λ it used nor where it came from."""
    demos = write_demos(tmp_path / "demos.parquet", EASY)
    tiny = ["--steps", 128, "--envs", 1, "--rollout", 64, "--eval-every", 128,
            "--eval-episodes", 1, "--held-out", 0, "--cache-dir", tmp_path / "cache"]  # fmt: skip
    exact = ["--logic-loss", "exact"]
    runs = {
        "best": (exact, "λ 0.01 (the best preset's)", "given"),
        "paper": ([*exact, "--preset", "paper"], "λ 1 (the paper preset's)", "given"),
        "given": ([*exact, "--lambda", 0.3], "λ 0.3 (given with --lambda)", "given"),
        "none": ([], "λ unused: no logic loss", "unused"),
    }
    for name, (flags, line, source) in runs.items():
        out = tmp_path / name
        result = chain_cli("train-task", "cooking", demos, *tiny, *flags, "-o", out)
        assert result.exit_code == 0, result.output
        assert line in result.output
        assert json.loads((out / "metrics.json").read_text())["lambda"]["source"] == source
    settings = json.loads((tmp_path / "paper/config.json").read_text())["settings"]
    assert (settings["lam"], settings["lr_schedule"]) == (1.0, "constant")
    settings = json.loads((tmp_path / "best/config.json").read_text())["settings"]
    assert (settings["lam"], settings["lr_schedule"]) == (0.01, "linear")
    quiet = chain_cli("train-task", "cooking", demos, *tiny, "--logic-loss", "exact", "-q",
                      "-o", tmp_path / "q")  # fmt: skip
    assert quiet.exit_code == 0 and "λ" not in quiet.output


def test_a_run_without_lambda_takes_the_papers_and_says_so(tmp_path: Path) -> None:
    """The library's `lam` None: the paper's λ for exact (q's recommendation for tleaf), the
    source in metrics.json and handed to `on_setup` before the first update."""
    demos = write_demos(tmp_path / "demos.parquet", EASY)
    settings = GailSettings(logic_loss="exact", lam=None, total_steps=128, n_envs=1, n_steps=64,
                            eval_every=128, eval_episodes=1, held_out=0)  # fmt: skip
    heard = []
    metrics = train_gail(demos, tmp_path / "run", settings, on_setup=heard.append)
    assert [s.lam.text() for s in heard] == ["λ 1 (the loss's default)"]
    assert metrics["lambda"] == {"value": 1.0, "source": "default", "candidates": []}
