"""Creative Cooking: the domain file, the environment's rules, rewards and API, the ANSI render,
and the LTLf knowledge base against the environment's feasibility on random rollouts."""

from __future__ import annotations

import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pyarrow.parquet as pq
import pytest

from tleaf_cli.errors import InputError
from tleaf_cli.logic.formulas import parse
from tleaf_cli.logic.semantics import satisfies
from tleaf_cli.tasks.cooking import ENV_ID, MAX_EPISODE_STEPS, decode_action, encode_action
from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, load_domain
from tleaf_cli.tasks.cooking.env import CreativeCookingEnv
from tleaf_cli.tasks.cooking.knowledge import format_knowledge_base, knowledge_base
from tleaf_cli.tasks.cooking.rules import EpisodeRules

DOMAIN = load_domain()
RAW, PRE, HEATED, SEASONED, COOKED, POST = range(1, 7)  # observation status codes


def make_env(*ingredients: str) -> CreativeCookingEnv:
    env = CreativeCookingEnv(DOMAIN, render_mode="ansi")
    env.reset(seed=0, options={"ingredients": list(ingredients)})
    return env


def act(env: CreativeCookingEnv, action: str, *names: str):
    """Step with `action` on the named ingredients (or 'mixture')."""
    slots = [0 if n == "mixture" else 1 + env.ingredients.index(n) for n in names]
    return env.step(encode_action(DOMAIN, action, *slots))


def status(env: CreativeCookingEnv, name: str) -> int:
    slot = 0 if name == "mixture" else 1 + env.ingredients.index(name)
    return env.state[slot]


# -- the domain file ---------------------------------------------------------------------------


def test_domain_has_the_papers_sizes():
    assert len(DOMAIN.ingredients) == 50
    assert len(DOMAIN.properties) == 15
    assert DOMAIN.statuses == (
        "raw",
        "pre-processed",
        "heated",
        "seasoned",
        "cooked",
        "post-processed",
    )
    assert len(DOMAIN.actions) == 31
    assert len({a.category for a in DOMAIN.actions}) == 10
    assert all(i.properties for i in DOMAIN.ingredients)
    binary = {a.name for a in DOMAIN.actions if a.arity == 2}
    assert binary == {"combine", "top_with"}


def test_required_status_is_the_highest_ranked_goal():
    # tomato: vegetable -> cooked, fruit -> post-processed
    assert DOMAIN.required_status(DOMAIN.ingredient("tomato").properties) == "post-processed"
    assert DOMAIN.required_status(DOMAIN.ingredient("salt").properties) == "raw"
    assert DOMAIN.required_status({"liquid", "dairy"}) == "heated"


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            'only = ["meat", "seafood", "egg"',
            'only = ["meet", "seafood", "egg"',
            "actions.fry.only",
        ),
        ('leafy = "post-processed" ', 'leafy = "served" ', "goals.leafy"),
        ('category = "combine"\narity = 2', 'category = "combine"\narity = 1', "actions.combine"),
        ('lettuce = ["leafy", "vegetable"]', "lettuce = []", "ingredients.lettuce"),
        ('chill]\ncategory = "serve"', 'chill]\ncategory = "chill"', "actions.chill.category"),
        ('herb = "pre-processed"', 'herb = "cooked"', "ingredients.parsley: .* 'cooked'"),
    ],
)
def test_domain_mistakes_name_their_key(tmp_path: Path, old: str, new: str, message: str):
    text = DEFAULT_DOMAIN.read_text(encoding="utf-8")
    assert old in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace(old, new, 1), encoding="utf-8")
    with pytest.raises(InputError, match=message):
        load_domain(bad)


# -- action encoding ---------------------------------------------------------------------------


def test_action_ids_round_trip_and_names_are_the_episodes_atoms():
    env = make_env("lettuce", "beef", "milk", "salt", "almond")
    assert env.action_space.n == 29 * 6 + 2 * 30
    for action_id in range(env.action_space.n):
        name, slots = decode_action(DOMAIN, action_id)
        assert encode_action(DOMAIN, name, *slots) == action_id
    names = env.action_names
    assert len(set(names)) == len(names)
    assert env.ingredients == ("lettuce", "beef", "almond", "milk", "salt")  # domain order
    assert names[encode_action(DOMAIN, "wash", 1)] == "wash_lettuce"
    assert names[encode_action(DOMAIN, "top_with", 2, 5)] == "top_with_beef_salt"
    assert names[encode_action(DOMAIN, "fry", 0)] == "fry_mixture"
    with pytest.raises(KeyError):
        encode_action(DOMAIN, "combine", 2, 2)


# -- rules: affordances, pre-requisites, merging --------------------------------------------------


def test_affordance_infeasible_leaves_state_and_costs_two():
    env = make_env("lettuce", "beef", "milk", "salt", "almond")
    before = env._observation().copy()
    obs, reward, terminated, truncated, info = act(env, "cut", "milk")  # we cannot cut milk
    assert (info["feasible"], info["action_name"], reward) == (False, "cut_milk", -2.0)
    assert np.array_equal(obs, before) and not terminated and not truncated
    _, reward, _, _, info = act(env, "cut", "lettuce")
    assert (info["feasible"], reward, status(env, "lettuce")) == (True, -1.0, PRE)


@pytest.mark.parametrize(
    ("ingredient", "prepare", "action", "result"),
    [
        ("lettuce", [], "fry", None),  # cook needs pre-processing first
        ("lettuce", ["wash"], "fry", COOKED),
        ("carrot", [], "steam", None),  # steam needs pre-processed
        ("carrot", ["peel"], "steam", HEATED),
        ("egg", [], "boil", HEATED),  # boiling works from raw
        ("beef", [], "season", None),
        ("beef", ["cut"], "season", SEASONED),
        ("beef", ["cut", "fry"], "marinate", None),  # marinate only before cooking
        ("lettuce", ["wash"], "plate", None),  # serve needs seasoned or cooked
        ("lettuce", ["wash", "dress"], "plate", POST),
        ("lettuce", ["wash", "dress", "fry"], "plate", POST),  # Fig. 5A: seasoned, then fried
        ("lettuce", ["wash", "fry", "dress"], "plate", POST),  # or fried before seasoned
        ("lettuce", ["wash", "fry", "dress", "plate"], "plate", None),  # served already
    ],
)
def test_prerequisites(ingredient, prepare, action, result):
    others = [n for n in ("salt", "almond", "milk", "rice", "tofu") if n != ingredient][:4]
    env = make_env(ingredient, *others)
    for step in prepare:
        assert act(env, step, ingredient)[4]["feasible"], step
    before = status(env, ingredient)
    _, reward, _, _, info = act(env, action, ingredient)
    assert info["feasible"] == (result is not None)
    assert status(env, ingredient) == (before if result is None else result)
    assert reward == (-2.0 if result is None else -1.0)


def test_add_merges_into_the_mixture():
    env = make_env("lettuce", "beef", "milk", "salt", "almond")
    assert not act(env, "add", "lettuce")[4]["feasible"]  # raw: only prepared ingredients go in
    act(env, "wash", "lettuce")
    obs, *_ = act(env, "add", "lettuce")
    assert list(obs[:4]) == [DOMAIN.mixture_index, PRE, 0, 0]  # lettuce's slot is empty
    assert env.rules.properties(env.state[-1]) == {"leafy", "vegetable"}
    assert not act(env, "wash", "lettuce")[4]["feasible"]  # nothing left in that slot
    act(env, "dress", "mixture")
    assert status(env, "mixture") == SEASONED
    act(env, "add", "salt")  # salt is ready (raw is its goal): it does not lower the mixture
    assert status(env, "mixture") == SEASONED
    act(env, "cut", "beef")
    act(env, "add", "beef")  # beef is not done: the mixture falls to beef's status
    assert status(env, "mixture") == PRE
    assert env.rules.slot_goal(env.state, 0) == POST  # highest goal over the union
    assert not act(env, "add", "mixture")[4]["feasible"]


def test_combine_is_add_then_add():
    rules = EpisodeRules(
        DOMAIN, [DOMAIN.ingredient(n) for n in ("carrot", "beef", "salt", "rice", "egg")]
    )
    state = rules.initial_state()
    for action, slot in [("peel", 1), ("cut", 2), ("boil", 5)]:
        state = rules.step(state, encode_action(DOMAIN, action, slot))
    for first, second in [(1, 2), (2, 5), (3, 1)]:
        combined = rules.step(state, encode_action(DOMAIN, "combine", first, second))
        added = rules.step(
            rules.step(state, encode_action(DOMAIN, "add", first)),
            encode_action(DOMAIN, "add", second),
        )
        assert combined == added and combined is not None
    assert rules.step(state, encode_action(DOMAIN, "combine", 0, 1)) is None


def test_top_with():
    env = make_env("beef", "salt", "almond", "milk", "lettuce")
    assert not act(env, "top_with", "beef", "salt")[4]["feasible"]  # raw beef
    act(env, "cut", "beef")
    assert not act(env, "top_with", "beef", "milk")[4]["feasible"]  # milk is no topping
    assert not act(env, "top_with", "beef", "almond")[4]["feasible"]  # almond not yet toasted
    obs, *_ = act(env, "top_with", "beef", "salt")
    assert status(env, "beef") == SEASONED and status(env, "salt") == 0
    salt_slot = 1 + env.ingredients.index("salt")
    assert list(obs[2 * salt_slot : 2 * salt_slot + 2]) == [0, 0]
    act(env, "toast", "almond")
    act(env, "wash", "lettuce")
    act(env, "add", "lettuce")
    act(env, "top_with", "mixture", "almond")  # the mixture can be topped
    assert status(env, "mixture") == SEASONED and status(env, "almond") == 0
    assert not act(env, "top_with", "beef", "mixture")[4]["feasible"]  # but is never a topping


# -- goal, rewards, time limit -----------------------------------------------------------------


def test_goal_terminates_with_plus_twenty():
    env = make_env("almond", "walnut", "salt", "black_pepper", "parsley")
    rewards = [act(env, "toast", "almond")[1], act(env, "cut", "salt")[1]]  # second infeasible
    rewards.append(act(env, "toast", "walnut")[1])
    assert not env.rules.is_goal(env.state)
    _, reward, terminated, truncated, _ = act(env, "chop", "parsley")
    assert terminated and not truncated
    assert [*rewards, reward] == [-1.0, -2.0, -1.0, 19.0]
    assert env.episode_return == 15.0


def test_reset_never_starts_at_the_goal():
    env = CreativeCookingEnv(DOMAIN)
    for seed in range(30):
        env.reset(seed=seed)
        assert not env.rules.is_goal(env.state)


def test_time_limit_truncates():
    env = gym.make(ENV_ID)
    env.reset(seed=3)
    add_mixture = encode_action(env.unwrapped.domain, "add", 0)  # never feasible
    for t in range(1, MAX_EPISODE_STEPS + 1):
        _, reward, terminated, truncated, info = env.step(add_mixture)
        assert reward == -2.0 and not terminated and not info["feasible"]
        assert truncated == (t == MAX_EPISODE_STEPS)


def test_reset_seed_is_reproducible():
    env = CreativeCookingEnv(DOMAIN)
    first = [env.reset(seed=7)[0]] + [env.reset()[0] for _ in range(4)]
    again = [env.reset(seed=7)[0]] + [env.reset()[0] for _ in range(4)]
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    other = {tuple(env.reset(seed=s)[1]["ingredients"]) for s in range(10)}
    assert len(other) > 5  # different seeds, different ingredients


def test_passes_both_env_checkers():
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any checker warning fails the test
        check_env(gym.make(ENV_ID, render_mode="ansi").unwrapped)
        sb3_check_env(CreativeCookingEnv(DOMAIN))


def test_action_masks_agree_with_steps():
    env = CreativeCookingEnv(DOMAIN)
    rng = np.random.default_rng(0)
    env.reset(seed=1)
    for _ in range(15):
        mask = env.action_masks()
        probe = env.state
        for a in rng.choice(env.action_space.n, 40, replace=False):
            assert (env.rules.step(probe, int(a)) is not None) == mask[a]
        env.step(int(rng.choice(np.flatnonzero(mask))))


def test_ansi_render_shows_ingredients_statuses_and_last_action():
    env = make_env("lettuce", "beef", "milk", "salt", "almond")
    act(env, "cut", "milk")
    text = env.render()
    assert "last action: cut_milk (INFEASIBLE" in text
    assert "milk" in text and "raw" in text and "heated" in text  # status and required status
    act(env, "wash", "lettuce")
    text = env.render()
    assert "wash_lettuce (feasible)" in text
    lettuce = next(line for line in text.splitlines() if " lettuce " in line)
    assert "pre-processed" in lettuce and "post-processed" in lettuce
    assert CreativeCookingEnv(DOMAIN).render() is None  # no render mode, no text


# -- the knowledge base ------------------------------------------------------------------------


def rollouts(env: CreativeCookingEnv, seed: int, count: int, p_feasible: float, length: int):
    """Random rollouts: (action names, feasible flags); a feasible action with p_feasible."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        env.reset(options={"ingredients": list(env.ingredients)})
        names, flags = [], []
        for _ in range(length):
            mask = env.action_masks()
            pool = np.flatnonzero(mask) if rng.random() < p_feasible else np.arange(mask.size)
            _, _, terminated, _, info = env.step(int(rng.choice(pool)))
            names.append(info["action_name"])
            flags.append(info["feasible"])
            if terminated:
                break
        out.append((names, flags))
    return out


@pytest.mark.parametrize(
    "ingredients",
    [("lettuce", "beef", "milk", "salt", "almond"), ("carrot", "tomato", "egg", "cheese", "basil")],
)
def test_knowledge_base_agrees_with_feasibility(ingredients):
    env = make_env(*ingredients)
    rules = knowledge_base(DOMAIN, ingredients)
    parsed = [(r, parse(r.formula)) for r in rules]
    violated = {"affordance": 0, "ordering": 0}
    for names, feasible in rollouts(env, seed=1, count=25, p_feasible=0.8, length=30):
        trace = [{n} for n in names]
        for rule, formula in parsed:
            if satisfies(trace, formula):
                continue
            # The first step with the rule's atom is the offending one: it must be infeasible.
            violated[rule.kind] += 1
            assert not feasible[names.index(rule.atom)], (rule.name, names)
    assert violated["affordance"] > 10 and violated["ordering"] > 10  # the check had teeth
    for names, _ in rollouts(env, seed=2, count=10, p_feasible=1.0, length=30):
        trace = [{n} for n in names]
        assert all(satisfies(trace, f) for _, f in parsed)


def test_knowledge_base_file_format():
    from tleaf_cli.data.formula_files import parse_ltl_text

    ingredients = ("lettuce", "beef", "milk", "salt", "almond")
    rules = knowledge_base(DOMAIN, ingredients)
    text = format_knowledge_base(rules, header="episode: " + ", ".join(ingredients))
    read = parse_ltl_text(text)
    assert [s.formula_id for s in read] == [r.name for r in rules]
    assert all(s.problem is None for s in read)
    assert {s.formula_id.split(".")[0] for s in read} == {"affordance", "ordering"}
    by_name = {r.name: r.formula for r in rules}
    assert by_name["affordance.cut_milk"] == "G !cut_milk"
    fry = by_name["ordering.fry_lettuce"]
    assert fry.startswith("(!fry_lettuce U (wash_lettuce | ") and fry.endswith(") | G !fry_lettuce")
    assert "top_with_lettuce_salt" in fry and "fry_lettuce |" not in fry
    assert "ordering.wash_lettuce" not in by_name  # washing may come first
    assert by_name["affordance.add_mixture"] == "G !add_mixture"


def test_knowledge_base_compiles_one_hot():
    from tleaf_cli.logic.compile import compile_formula

    rules = {
        r.name: r for r in knowledge_base(DOMAIN, ("lettuce", "beef", "milk", "salt", "almond"))
    }
    fry = compile_formula(rules["ordering.fry_lettuce"].formula, alphabet="one-hot")
    assert not fry.accepts([{"fry_lettuce"}, {"wash_lettuce"}])
    assert fry.accepts([{"cut_lettuce"}, {"fry_lettuce"}])
    top = compile_formula(rules["ordering.top_with_beef_almond.almond"].formula, alphabet="one-hot")
    assert top.accepts([{"toast_almond"}, {"top_with_beef_almond"}])
    assert not top.accepts([{"soak_almond"}, {"top_with_beef_almond"}])  # not yet ready


def test_whole_domain_knowledge_base():
    rules = knowledge_base(DOMAIN, mixture=False)
    atoms = {r.atom for r in rules}
    assert "cut_milk" in atoms and not any("mixture" in a for a in atoms)
    with pytest.raises(InputError, match="no ingredient 'unicorn'"):
        knowledge_base(DOMAIN, ["unicorn"])


def test_cooking_kb_cli_writes_rules_compile_dfa_compiles(chain_cli, tmp_path: Path):
    kb, dfas = tmp_path / "kb.ltl", tmp_path / "dfas.parquet"
    result = chain_cli("cooking-kb", "--ingredients", "lettuce,beef,milk,salt,almond", "-o", kb)
    assert result.exit_code == 0, result.output
    expected = knowledge_base(DOMAIN, ("lettuce", "beef", "milk", "salt", "almond"))
    assert f"{len(expected)} rules" in result.output
    result = chain_cli("compile-dfa", kb, "--one-hot", "-o", dfas, "-j", 2, "-q")
    assert result.exit_code == 0, result.output
    table = pq.read_table(dfas).to_pylist()
    assert [r["formula_id"] for r in table] == [r.name for r in expected]
    assert all(r["error"] is None and r["alphabet"] == "one-hot" for r in table)
    result = chain_cli("cooking-kb", "--ingredients", "lettuce,unicorn", "-o", kb)
    assert result.exit_code == 2 and "no ingredient 'unicorn'" in result.output
