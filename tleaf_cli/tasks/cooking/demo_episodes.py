"""Expert demonstrations read back as episodes, and the knowledge base of their ingredient sets.

GAIL (train.py) trains on the demos' (observation, action) pairs and plays episodes with the demos'
ingredient sets (the "pool"), so each set's expert return is known. `tleaf demos-kb` writes every
rule of those episodes' knowledge bases into one `.ltl` file, the training formulas of the
embedder q used by the tleaf logic loss; the rule sets GAIL scores (conjunctions per ingredient)
are not among them, so q meets them unseen, as in the paper.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tleaf_cli.data.artifacts import check_writable, read_artifact
from tleaf_cli.errors import InputError
from tleaf_cli.tasks.cooking.demos import KIND, SCHEMA
from tleaf_cli.tasks.cooking.domain import Domain
from tleaf_cli.tasks.cooking.knowledge import Rule, knowledge_base, write_knowledge_base


@dataclass(frozen=True)
class DemoEpisode:
    """One expert episode: its five ingredients (slots 1..5), observations [T, 12], actions [T]."""

    ingredients: tuple[str, ...]
    observations: np.ndarray
    actions: np.ndarray
    episode_return: float


def read_demo_episodes(path: str | Path, domain: Domain) -> list[DemoEpisode]:
    """The episodes of a demos.parquet (gen-demos), in order; InputError on a foreign file."""
    table, _ = read_artifact(path, KIND, SCHEMA)
    if table.num_rows == 0:
        raise InputError(f"{path}: no demonstration steps")
    episode = table.column("episode").to_numpy()
    observations = np.asarray(table.column("observation").to_pylist(), dtype=np.int64)
    actions = table.column("action").to_numpy().astype(np.int64)
    rewards = table.column("reward").to_numpy().astype(np.float64)
    names = [i.name for i in domain.ingredients]
    out = []
    for e in np.unique(episode):
        rows = np.flatnonzero(episode == e)
        first = observations[rows[0]]
        indices = first[2::2]  # ingredient index of slots 1..5 (all present at step 0)
        if not all(1 <= i <= len(names) for i in indices):
            raise InputError(
                f"{path}: row {rows[0]}: episode {e} does not start with five ingredients of "
                f"{domain.source} (indices {indices.tolist()})"
            )
        out.append(
            DemoEpisode(
                ingredients=tuple(names[i - 1] for i in indices),
                observations=observations[rows],
                actions=actions[rows],
                episode_return=float(rewards[rows].sum()),
            )
        )
    return out


def demos_knowledge_base(domain: Domain, pool: Sequence[Sequence[str]]) -> list[Rule]:
    """Every distinct rule of the ingredient sets' knowledge bases (mixture rules left out).

    A rule name can carry different formulas in different sets (an ordering's enablers include
    top-withs of the set's toppings); later variants get a `.v<k>` suffix so names stay unique.
    """
    seen: dict[str, list[str]] = {}
    out = []
    for ingredients in dict.fromkeys(tuple(p) for p in pool):
        for rule in knowledge_base(domain, ingredients, mixture=False):
            variants = seen.setdefault(rule.name, [])
            if rule.formula in variants:
                continue
            name = rule.name if not variants else f"{rule.name}.v{len(variants)}"
            variants.append(rule.formula)
            out.append(Rule(name, rule.kind, rule.formula, rule.atom))
    return out


def write_demos_knowledge_base(demos: str | Path, out: str | Path, domain: Domain) -> list[Rule]:
    """Write the rules of the demos' ingredient sets to `out` (a `.ltl` file)."""
    check_writable(out)
    episodes = read_demo_episodes(demos, domain)
    rules = demos_knowledge_base(domain, [e.ingredients for e in episodes])
    sets = len({e.ingredients for e in episodes})
    header = (
        "Creative Cooking rules of the demonstrations' ingredient sets (synthetic environment)\n"
        f"demos: {demos} ({sets} ingredient sets), domain: {domain.source}"
    )
    write_knowledge_base(out, rules, header)
    return rules
