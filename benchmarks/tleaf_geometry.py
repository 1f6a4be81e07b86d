"""Does q see a video's own trace as satisfying its rule set? (docs/results/action_recognition.md)

For every training video of a SYNTHETIC activities file: its rule set φ (the knowledge-base
rules whose atoms all occur in its labelled pairs) and the tleaf loss ‖q(A_φ) − q(w)‖² for
  true       the video's labelled trace (satisfies φ: every generated video does)
  shuffled   the same steps in a random order (counted only where it violates φ)
  uniform    the soft trace with every step uniform over all pairs (a model that knows nothing)
The tleaf loss can only steer a model towards the rules if `true` is the smallest.

    python benchmarks/tleaf_geometry.py ACTIVITIES.parquet KB.ltl Q_DIR...
"""

from __future__ import annotations

import sys

import torch

import tleaf_cli as tl
from tleaf_cli.knowledge.base import read_knowledge_base
from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
from tleaf_cli.losses import pair_log_probs, pair_vocabulary, violates
from tleaf_cli.tasks.action_recognition.activities import read_activities
from tleaf_cli.tasks.action_recognition.train import Batch

BIG = 30.0  # logits of a certain prediction


def certain(labels: torch.Tensor, classes: int) -> torch.Tensor:
    """Logits [B, T, classes] that put all the mass on `labels` (padding: class 0)."""
    out = torch.full((*labels.shape, classes), -BIG)
    return out.scatter_(-1, labels.clamp(min=0)[..., None], BIG)


def main(activities: str, kb: str, q_dirs: list[str]) -> None:
    data = read_activities(activities)
    knowledge = read_knowledge_base(kb)
    videos = data.split("train")
    batch = Batch.of(videos, torch.device("cpu"))
    a, i = len(data.actions), len(data.ingredients)
    order = torch.Generator().manual_seed(0)
    shuffled_a, shuffled_i = batch.actions.clone(), batch.ingredients.clone()
    for b, n in enumerate(batch.lengths.tolist()):
        p = torch.randperm(n, generator=order)
        shuffled_a[b, :n], shuffled_i[b, :n] = batch.actions[b, :n][p], batch.ingredients[b, :n][p]
    traces = {
        "true": (certain(batch.actions, a), certain(batch.ingredients, i)),
        "violating shuffle": (certain(shuffled_a, a), certain(shuffled_i, i)),
        "uniform": (torch.zeros(*batch.actions.shape, a), torch.zeros(*batch.ingredients.shape, i)),
    }
    vocabulary = pair_vocabulary(data.actions, data.ingredients)
    for q_dir in q_dirs:
        q = tl.load_embedder(q_dir)
        rules = KnowledgeRuleSets(knowledge, vocabulary, set(q.vectors.index))
        sets = rules.one_each([set(data.atoms(v)) for v in videos])
        kept = [b for b, s in enumerate(sets) if s is not None]
        pairs = (shuffled_a * i + shuffled_i).numpy()
        bad = violates([sets[b] for b in kept], [pairs[b, : batch.lengths[b]] for b in kept])
        with torch.no_grad():
            loss = {
                k: tl.logic_loss(
                    "tleaf", pair_log_probs(*x), sets, batch.lengths, q, reduction="none"
                )[kept]
                for k, x in traces.items()
            }
        loss["violating shuffle"] = loss["violating shuffle"][torch.from_numpy(bad)]
        means = ", ".join(f"{k} {v.mean():.2f}" for k, v in loss.items())
        farther = (loss["violating shuffle"] > loss["true"][torch.from_numpy(bad)]).float().mean()
        print(f"{q_dir}: mean loss {means}; a violating shuffle farther than the true trace "
              f"for {farther:.0%} of {int(bad.sum())} videos")  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3:])
