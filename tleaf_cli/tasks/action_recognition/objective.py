"""ℓ_logic of a training batch of h: each video's rule sets, and one `losses.logic_loss` call.

A video's rule set φ is the conjunction of the knowledge base's rules whose atoms all occur in
its predicted pairs (argmax per step, re-derived every batch: the paper's choice), in its
labelled pairs (`formula_from="labels"`, fixed for the run), or the whole knowledge base
(`formula_from="kb"`); with `rule_sets="ingredient"` one conjunction per ingredient
(train.py's docstring gives the whole objective).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch

from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
from tleaf_cli.losses import logic_loss, pair_log_probs
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.settings.action_recognition import TaskSettings
from tleaf_cli.tasks.action_recognition.activities import UNLABELLED, Activities
from tleaf_cli.tasks.action_recognition.batch import Batch

if TYPE_CHECKING:  # torch-geometric's 2 s of import only where the tleaf loss loads one
    from tleaf_cli.embed.embedder import Embedder

GRADIENT_LOSSES = ("tleaf", "exact")  # the losses unlabelled videos can teach through


def predicted_atoms(data: Activities, actions: np.ndarray, ingredients: np.ndarray) -> set[str]:
    """The atoms of a predicted sequence (action and ingredient indices per step)."""
    return {data.atom(int(a), int(i)) for a, i in zip(actions, ingredients, strict=True)}


class LogicObjective:
    """ℓ_logic for batches: picks each video's rule sets and calls `losses.logic_loss` [B].

    With one rule set per ingredient, ℓ(φ) = Σ_x ℓ(φ_x): the video's outputs are repeated once
    per set, so every set is one row of a single `logic_loss` call.
    """

    def __init__(
        self,
        settings: TaskSettings,
        data: Activities,
        rules: KnowledgeRuleSets,
        embedder: Embedder | None = None,
    ) -> None:
        self.settings = settings
        self.data = data
        self.rules = rules
        self.embedder = embedder
        kind = settings.logic_loss
        self.per_ingredient = settings.rule_sets == "ingredient" and kind in GRADIENT_LOSSES
        self.fixed: dict[str, list[RuleSet]] = {}  # rule sets from labels, labelled videos only
        self.whole: list[RuleSet] | None = None  # the guarded knowledge base, every video's
        if settings.formula_from == "kb" and kind != "none":
            self.whole = rules.whole()
            if embedder is not None and self.whole:
                embedder.rule_set_vectors(self.whole)
        if settings.formula_from == "labels" and kind != "none":
            videos = [v for v in data.videos if v.split != UNLABELLED]
            groups = self._groups([set(data.atoms(v)) for v in videos])
            self.fixed = {v.video_id: g for v, g in zip(videos, groups, strict=True)}
            fixed = [r for g in groups for r in g]
            if embedder is not None and fixed:  # q(A_φ) of every fixed set now, not in epoch 1
                embedder.rule_set_vectors(fixed)

    def _groups(self, atoms_per_video: list[set[str]]) -> list[list[RuleSet]]:
        return self.rules.for_atoms(atoms_per_video, self.per_ingredient)

    def __call__(self, batch: Batch, actions: torch.Tensor, ingredients: torch.Tensor):
        if self.settings.logic_loss == "none":
            return actions.new_zeros(actions.shape[0])
        if self.whole is not None:
            return self._loss(batch, actions, ingredients, [self.whole] * len(batch.videos))
        a = actions.detach().argmax(-1).cpu().numpy()
        i = ingredients.detach().argmax(-1).cpu().numpy()
        lengths = batch.lengths.tolist()
        predicted = [b for b, v in enumerate(batch.videos) if v.video_id not in self.fixed]
        from_predictions = self._groups(
            [predicted_atoms(self.data, a[b, : lengths[b]], i[b, : lengths[b]]) for b in predicted]
        )
        groups = [self.fixed.get(v.video_id, []) for v in batch.videos]
        for b, g in zip(predicted, from_predictions, strict=True):
            groups[b] = g
        return self._loss(batch, actions, ingredients, groups)

    def _loss(
        self,
        batch: Batch,
        actions: torch.Tensor,
        ingredients: torch.Tensor,
        groups: list[list[RuleSet]],
    ) -> torch.Tensor:
        """Σ over each video's rule sets `groups[b]` of ℓ_logic, one `logic_loss` call [B]."""
        out = actions.new_zeros(actions.shape[0])
        owner = [b for b, sets in enumerate(groups) for _ in sets]
        if not owner:
            return out
        rows = torch.tensor(owner, device=actions.device)
        per_set = logic_loss(
            self.settings.logic_loss,
            pair_log_probs(actions[rows], ingredients[rows]),
            [r for sets in groups for r in sets],
            batch.lengths[rows],
            self.embedder,
            reduction="none",
        )
        return out.index_add(0, rows, per_set)
