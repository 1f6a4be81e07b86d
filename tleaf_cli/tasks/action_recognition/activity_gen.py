"""`gen-activities`: **synthetic** procedural activity videos drawn from a hidden process.

The hidden process is a knowledge base made on the spot. Every action belongs to a recipe stage
(prepare -> cut -> cook -> season -> finish); every ingredient affords a random subset of the
actions. Affordance rules forbid the pairs no ingredient-action match allows; ordering rules say
that, on one ingredient, an action of an earlier stage comes before one of a later stage. A video
picks 1-4 ingredients, for each a few afforded actions in stage order, and interleaves them, so
every video satisfies the knowledge base (tests check this with the LTLf evaluator).

Features are class-conditional Gaussians: action mean + ingredient_scale * ingredient mean +
noise * N(0, I). Pairs of actions from different stages (and pairs of ingredients) get means
pulled together by `confusable`, so a per-step classifier confuses what the rules can tell
apart. The rules tell actions apart through the ingredient (an affordance names a pair), so
ingredients are made easier to see (scale 1.5): the defaults are a low-data regime (60 training
videos) where a logistic regression reaches about 65% action accuracy and the affordances raise
it to about 71% (docs/activities.md). Nothing here is real data; the artifact's params say so.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np

from tleaf_cli.data.artifacts import check_writable, write_artifact
from tleaf_cli.data.formula_files import check_names
from tleaf_cli.errors import SettingError
from tleaf_cli.knowledge.base import (
    KnowledgeBase,
    affordance_rule,
    ordering_rule,
    write_knowledge_base,
)
from tleaf_cli.settings.generators import (  # the bounds: re-exported for tests and users
    MAX_ACTIONS,  # noqa: F401
    MAX_INGREDIENTS,  # noqa: F401
    ActivitySettings,
)
from tleaf_cli.tasks.action_recognition.activities import KIND, SCHEMA_VERSION, activities_table

# The paper's Tasty Videos vocabulary: 64 actions, 155 ingredients.
MAX_INGREDIENTS_PER_VIDEO = 4
STAGES = ("prepare", "cut", "cook", "season", "finish")
# Built-in names per stage; listed round-robin so a small vocabulary still spans every stage.
# Beyond them names fall back to act07 / ing113 (stage = index mod 5).
VERBS = (
    ("wash", "rinse", "peel", "soak", "thaw", "drain", "trim"),
    ("cut", "chop", "slice", "dice", "mince", "grate", "mash"),
    ("fry", "boil", "bake", "grill", "roast", "steam", "saute", "simmer"),
    ("season", "stir", "mix", "whisk", "pour", "spread", "marinate", "sprinkle"),
    ("serve", "garnish", "plate", "top", "wrap", "cool"),
)
# fmt: off
NOUNS = (
    "onion", "garlic", "carrot", "potato", "tomato", "cabbage", "pepper", "mushroom", "spinach",
    "lettuce", "cucumber", "zucchini", "broccoli", "celery", "chicken", "beef", "pork", "salmon",
    "shrimp", "egg", "tofu", "rice", "pasta", "bread", "cheese", "butter", "milk", "cream",
    "flour", "sugar", "lemon", "apple", "banana", "honey", "oil", "sauce", "beans", "corn",
    "noodles", "avocado", "ginger", "basil", "parsley", "chili", "yogurt",
)
# fmt: on
# Each (action, ingredient) is afforded with this probability; each ingredient affords at least
# MIN_AFFORDED actions.
AFFORD_PROBABILITY = 0.35
MIN_AFFORDED = 3
# Norm scale of the class means relative to the per-dimension noise: chosen so the defaults give
# a per-step logistic regression about 65% action accuracy (docs/activities.md).
MEAN_RADIUS = 4.0


@dataclass(frozen=True)
class Process:
    """The hidden process: vocabulary, each action's stage, and which pairs are afforded."""

    actions: tuple[str, ...]
    ingredients: tuple[str, ...]
    stage: np.ndarray  # int [A]: recipe stage of each action
    affords: np.ndarray  # bool [I, A]

    def knowledge_base(self) -> KnowledgeBase:
        """Affordances for every pair not afforded; orderings for afforded pairs of two stages."""
        rules = [
            affordance_rule(a, i)
            for k, a in enumerate(self.actions)
            for j, i in enumerate(self.ingredients)
            if not self.affords[j, k]
        ]
        for j, i in enumerate(self.ingredients):
            usable = np.flatnonzero(self.affords[j])
            rules += [
                ordering_rule(i, self.actions[x], self.actions[y])
                for x in usable
                for y in usable
                if self.stage[x] < self.stage[y]
            ]
        return KnowledgeBase(tuple(rules))


@dataclass
class ActivityReport:
    videos: int
    rows: int
    affordances: int
    orderings: int
    confusable_actions: list[tuple[str, str]]
    seconds: float


def vocabulary(actions: int, ingredients: int) -> tuple[tuple[str, ...], np.ndarray, tuple]:
    """Action names with their stages, and ingredient names (built-in words, then fallbacks)."""
    longest = max(len(verbs) for verbs in VERBS)
    round_robin = [
        (verbs[k], s) for k in range(longest) for s, verbs in enumerate(VERBS) if k < len(verbs)
    ]
    names = [v for v, _ in round_robin[:actions]]
    stages = [s for _, s in round_robin[:actions]]
    for k in range(len(names), actions):
        names.append(f"act{k:02d}")
        stages.append(k % len(STAGES))
    nouns = list(NOUNS[:ingredients]) + [f"ing{k:03d}" for k in range(len(NOUNS), ingredients)]
    return tuple(names), np.array(stages, dtype=np.int64), tuple(nouns)


def make_process(settings: ActivitySettings, rng: np.random.Generator) -> Process:
    actions, stage, ingredients = vocabulary(settings.actions, settings.ingredients)
    affords = rng.random((len(ingredients), len(actions))) < AFFORD_PROBABILITY
    for row in affords:
        missing = MIN_AFFORDED - int(row.sum())
        if missing > 0:
            row[rng.choice(np.flatnonzero(~row), size=missing, replace=False)] = True
    return Process(actions, ingredients, stage, affords)


def sample_video(
    process: Process, rng: np.random.Generator, min_steps: int, max_steps: int
) -> list[tuple[int, int]]:
    """(action, ingredient) indices per step: per ingredient afforded actions in stage order
    (ties in random order, no action twice on one ingredient), ingredients interleaved."""
    capacity = process.affords.sum(axis=1)
    for _ in range(1000):
        length = int(rng.integers(min_steps, max_steps + 1))
        count = int(rng.integers(1, min(MAX_INGREDIENTS_PER_VIDEO, len(capacity)) + 1))
        chosen = rng.choice(len(capacity), size=count, replace=False)
        if capacity[chosen].sum() >= length:
            break
    else:
        raise SettingError(
            "min_steps",
            f"{min_steps} is more steps than {MAX_INGREDIENTS_PER_VIDEO} ingredients afford; "
            "lower it or raise actions",
        )
    per = np.ones(count, dtype=np.int64)  # steps per chosen ingredient
    for _ in range(length - count):
        room = np.flatnonzero(per < capacity[chosen])
        per[rng.choice(room)] += 1
    queues = []
    for j, n in zip(chosen, per, strict=True):
        picked = rng.choice(np.flatnonzero(process.affords[j]), size=int(n), replace=False)
        order = np.lexsort((rng.random(len(picked)), process.stage[picked]))
        queues.append([(int(a), int(j)) for a in picked[order]])
    slots = np.repeat(np.arange(count), per)
    rng.shuffle(slots)
    return [queues[q].pop(0) for q in slots]


def confusable_pairs(stage: np.ndarray, rng: np.random.Generator) -> list[tuple[int, int]]:
    """Pair classes at random, each pair from two different stages when `stage` allows."""
    order = [int(k) for k in rng.permutation(len(stage))]
    pairs = []
    while len(order) >= 2:
        a = order.pop(0)
        partner = next((b for b in order if stage[b] != stage[a]), order[0])
        order.remove(partner)
        pairs.append((a, partner))
    return pairs


def class_means(
    count: int, dim: int, pairs: list[tuple[int, int]], confusable: float, rng: np.random.Generator
) -> np.ndarray:
    """[count, dim] Gaussian means of norm about MEAN_RADIUS; each pair pulled together so its
    distance shrinks by the factor (1 - confusable)."""
    means = rng.normal(0.0, MEAN_RADIUS / np.sqrt(dim), size=(count, dim))
    for a, b in pairs:
        centre = (means[a] + means[b]) / 2
        means[a] = centre + (1 - confusable) * (means[a] - centre)
        means[b] = centre + (1 - confusable) * (means[b] - centre)
    return means


def generate_activities(
    settings: ActivitySettings,
    out: str | os.PathLike,
    kb_out: str | os.PathLike,
    on_progress: Callable[[int, int], None] | None = None,
) -> ActivityReport:
    """Draw the process, its knowledge base and the videos; write both files."""
    start = time.perf_counter()
    settings.check()
    check_writable(out)
    check_writable(kb_out)
    streams = [np.random.default_rng([settings.seed, k]) for k in range(4)]
    process = make_process(settings, streams[0])
    action_pairs = confusable_pairs(process.stage, streams[1])
    ingredient_pairs = confusable_pairs(np.arange(len(process.ingredients)), streams[1])
    dim = settings.feature_dim
    action_means = class_means(
        len(process.actions), dim, action_pairs, settings.confusable, streams[1]
    )
    # ingredients are objects on screen: --ingredient-scale > 1 makes them easier to see than
    # actions, which is what lets affordances correct actions (docs/activities.md)
    ingredient_means = settings.ingredient_scale * class_means(
        len(process.ingredients), dim, ingredient_pairs, settings.confusable, streams[1]
    )

    # unlabelled videos come last, so adding them leaves the other videos (and their noise) as
    # they were for the same seed
    splits = (
        ["train"] * settings.train
        + ["val"] * settings.val
        + ["test"] * settings.test
        + ["unlabelled"] * settings.unlabelled
    )
    steps: list[list[tuple[int, int]]] = []
    for k in range(len(splits)):
        steps.append(sample_video(process, streams[2], settings.min_steps, settings.max_steps))
        if on_progress:
            on_progress(k + 1, len(splits))
    flat = np.array([s for video in steps for s in video], dtype=np.int64)
    noise = streams[3].normal(0.0, 1.0, size=(len(flat), dim))
    features = action_means[flat[:, 0]] + ingredient_means[flat[:, 1]] + settings.noise * noise

    lengths = [len(v) for v in steps]
    names = [f"synthetic-{k:05d}" for k in range(len(splits))]
    check_names(names, "video id")
    video_ids = np.repeat(names, lengths)
    table = activities_table(
        video_ids=video_ids.tolist(),
        steps=np.concatenate([np.arange(n) for n in lengths]),
        actions=[process.actions[a] for a in flat[:, 0]],
        ingredients=[process.ingredients[i] for i in flat[:, 1]],
        features=features,
        splits=np.repeat(splits, lengths).tolist(),
    )
    kb = process.knowledge_base()
    named_pairs = [(process.actions[a], process.actions[b]) for a, b in action_pairs]
    params = {
        **asdict(settings),
        "data": "synthetic: procedural activities sampled from a generated knowledge base "
        "by tleaf gen-activities (Gaussian class-conditional features, not video)",
        "vocabulary": {"actions": list(process.actions), "ingredients": list(process.ingredients)},
        "stages": {a: STAGES[s] for a, s in zip(process.actions, process.stage, strict=True)},
        "confusable_actions": named_pairs,
    }
    write_knowledge_base(
        kb,
        kb_out,
        [
            f"SYNTHETIC knowledge base: the hidden process of tleaf gen-activities "
            f"--seed {settings.seed} --actions {settings.actions} "
            f"--ingredients {settings.ingredients}",
            f"{len(kb.of_kind('affordance'))} affordances (pairs never afforded), "
            f"{len(kb.of_kind('ordering'))} orderings (recipe stages {' < '.join(STAGES)})",
        ],
    )
    write_artifact(table, out, kind=KIND, schema=SCHEMA_VERSION, params=params, inputs=[])
    return ActivityReport(
        videos=len(splits),
        rows=len(flat),
        affordances=len(kb.of_kind("affordance")),
        orderings=len(kb.of_kind("ordering")),
        confusable_actions=named_pairs,
        seconds=time.perf_counter() - start,
    )
