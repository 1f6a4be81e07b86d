"""Training the action recognizer h with a logic loss (`tleaf train-task action-recognition`).

Objective per batch (the paper's Sec. III): ℓ = ℓ_task + λ · mean_b ℓ_logic(b), with ℓ_task the
cross-entropy of the action head plus that of the ingredient head (mean over steps), and
ℓ_logic one of `tleaf_cli.losses` (none, tleaf, exact, checker). The rule set φ of a video is
the conjunction of the knowledge base's rules whose atoms all occur in its PREDICTED pairs
(argmax per step, the paper's choice; re-derived every batch) or in its labelled pairs
(`formula_from="labels"`, fixed for the run), or is the whole knowledge base (`formula_from=
"kb"`: every rule guarded by its atoms' presence, `KnowledgeRuleSets.whole`, one conjunction per
ingredient; the same for every video, so no guess of the model's picks the rules). With
`rule_sets="ingredient"` (tleaf, exact) φ is split into one conjunction per ingredient, φ = ∧_x
φ_x over disjoint atoms, and ℓ_logic = Σ_x ℓ_logic(φ_x): far smaller DFAs, which q embeds better
and faster (the cooking experiment's per-ingredient clauses). The checker always checks the
whole φ.

Unlabelled videos (split `unlabelled`, labels never read; the first `unlabelled_videos` of
them): with `unlabelled=True` and a loss with a gradient (tleaf, exact), every training batch is
joined by a batch of them, whose only loss is the logic loss, φ from their predicted pairs (or
the whole knowledge base); ℓ_logic is then the mean over both batches' videos. With
`unlabelled_loss` decoded or argmax they are trained instead on h's own labels for them
(self-training: its constrained decoding under the rules, or its argmax), cross-entropy weighted
by λ. Either way their loss is weighted by epoch/`unlabelled_warmup` over the first epochs. The
knowledge needs no labels, so this is where it could add what a few labelled videos do not
show. The reference (none) and checker (no gradient) do not read them.

Adam (lr 1e-3 by default; the paper's 1e-4 is preset `paper`); after every epoch, action
accuracy on the val split; the best epoch's weights are kept and training stops after
`patience` epochs without a better one. The test split then gives action, ingredient and pair
accuracy and the share of test videos whose predicted sequence violates the rules relevant to
its predicted pairs (the exact checker).

Same seed, same run: h's initial weights, batch order and dropout masks depend on the seed
only, so runs that differ only in the logic loss start from the same point (and the checker
loss, which has no gradient, reproduces the reference run).

`LogicObjective` (objective.py) gives ℓ_logic. The run itself — λ and where it came from, the
epochs, the run folder (`config.json`, `weights.pt` of the best epoch, `metrics.json`,
`checkpoint.pt` of the last for `resume`) — is every task's: `tleaf_cli.training`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.nn import functional as F

from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.knowledge.base import read_knowledge_base
from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
from tleaf_cli.losses import pair_log_probs, pair_vocabulary, violates
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.settings.action_recognition import (  # noqa: F401  (TaskSettings re-exported)
    FORMULA_SOURCES,
    TaskSettings,
)
from tleaf_cli.tasks.action_recognition.activities import (
    UNLABELLED,
    Activities,
    Video,
    read_activities,
)
from tleaf_cli.tasks.action_recognition.batch import Batch
from tleaf_cli.tasks.action_recognition.decoding import decode_pairs, own_labels
from tleaf_cli.tasks.action_recognition.models import ActionRecognizer
from tleaf_cli.tasks.action_recognition.objective import (
    GRADIENT_LOSSES,
    LogicObjective,
    predicted_atoms,
)
from tleaf_cli.training.lambdas import RunSetup
from tleaf_cli.training.loop import Step, chunks
from tleaf_cli.training.q_coverage import check_q_covers
from tleaf_cli.training.task import EpochRecord, LossSetup, RunInputs, TaskTrainer, train_task


class ActionRecognitionTrainer(TaskTrainer[tuple[Batch, Batch | None, float], TaskSettings]):
    """h on an activities artifact's train split (with its unlabelled videos where the loss
    reads them), scored on val by action accuracy; on test by action, ingredient and pair
    accuracy and the share of videos that break their rules, by argmax and under the rules."""

    kind = "action-recognizer"
    task = "action-recognition"
    score = "val_action_accuracy"

    def __init__(self, inputs: RunInputs, settings: TaskSettings, device: torch.device) -> None:
        super().__init__(inputs, settings, device)
        self.data = read_activities(inputs.data)
        self.kb = read_knowledge_base(inputs.kb)
        self.splits = {s: self.data.split(s) for s in ("train", "val", "test")}
        empty = [s for s, videos in self.splits.items() if not videos]
        if empty:
            raise InputError(f"{inputs.data}: no videos in split(s) {', '.join(empty)}")
        self.splits["train"] = first_videos(
            self.splits["train"], settings.train_videos, inputs.data
        )

    def setup(self) -> LossSetup:
        settings, data = self.settings, self.data
        vocabulary = pair_vocabulary(data.actions, data.ingredients)
        # the violation metric, for every loss
        self.checker_rules = KnowledgeRuleSets(self.kb, vocabulary)
        self.embedder, coverage, recommended = None, None, None
        if settings.logic_loss == "tleaf":
            # torch-geometric (3.4 s of import) only where the tleaf loss needs the embedder
            from tleaf_cli.embed.load import load_embedder

            self.embedder = load_embedder(self.inputs.embedder)
            coverage = check_q_covers(self.kb, self.embedder.vectors.index, self.inputs.embedder)
            self.embedder.model.to(self.device)
            known = set(self.embedder.vectors.index)
            self.loss_rules = KnowledgeRuleSets(self.kb, vocabulary, known)
            if settings.lam is None:  # q's λ is read only when used
                recommended = self.embedder.recommended_lambda
        else:
            self.loss_rules = self.checker_rules
        if settings.logic_loss != "none":
            self.loss_rules.prepare()  # every KB rule compiled once: epochs build products only
        self.objective = LogicObjective(settings, data, self.loss_rules, self.embedder)
        self.coverage = coverage
        return LossSetup(recommended, coverage)

    def model(self) -> ActionRecognizer:
        settings, data = self.settings, self.data
        self.net = ActionRecognizer(
            settings.model,
            data.feature_dim,
            len(data.actions),
            len(data.ingredients),
            settings.hidden,
            settings.head_hidden,
            settings.dropout,
        ).to(self.device)
        return self.net

    def batches(
        self, epoch: int, generator: torch.Generator
    ) -> Iterator[tuple[Batch, Batch | None, float]]:
        """The epoch's training batches, each with the batch of unlabelled videos that joins it
        (None when they are not used) and the weight of their loss (`unlabelled_weight`): the
        unlabelled stream is read on from where the epochs before left it, so that the
        batches depend on the seed and the epoch alone."""
        settings = self.settings
        per_epoch = -(-len(self.splits["train"]) // settings.batch_size)  # batches per epoch
        unlabelled = unlabelled_batches(
            self.data, settings, self.device, skip=(epoch - 1) * per_epoch
        )
        weight = unlabelled_weight(epoch, settings.unlabelled_warmup)
        for videos in chunks(self.splits["train"], settings.batch_size, generator):
            extra = None if unlabelled is None else next(unlabelled)
            yield Batch.of(videos, self.device), extra, weight

    def step(self, batches: tuple[Batch, Batch | None, float]) -> Step:
        """ℓ_task + λ·ℓ_logic of a batch, ℓ_logic the mean over its and the unlabelled
        batch's videos (theirs weighted); reported: ℓ_task and ℓ_logic, each the mean over the
        epoch's batches."""
        settings, model = self.settings, self.net
        batch, extra, weight = batches
        actions, ingredients = model(batch.features, batch.lengths)
        task = F.cross_entropy(
            actions.flatten(0, 1), batch.actions.flatten(), ignore_index=-100
        ) + F.cross_entropy(
            ingredients.flatten(0, 1), batch.ingredients.flatten(), ignore_index=-100
        )
        per_video = [self.objective(batch, actions, ingredients)]
        own = task.new_zeros(())
        if extra is not None:
            outputs = model(extra.features, extra.lengths)
            if settings.unlabelled_loss == "logic":
                per_video.append(weight * self.objective(extra, *outputs))
            else:  # self-training: h's own labels, decoded under the rules or not
                rules = self.checker_rules if settings.unlabelled_loss == "decoded" else None
                targets = own_labels(*outputs, extra.lengths, rules, settings.decode_top_k)
                own = weight * sum(
                    F.cross_entropy(out.flatten(0, 1), target.flatten(), ignore_index=-100)
                    for out, target in zip(outputs, targets, strict=True)
                )
        logic = torch.cat(per_video).mean()
        loss = task + settings.lam * (logic + own)
        figures = {"task_loss": task.item(), "logic_loss": logic.item()}
        return Step(loss, {**figures, "unlabelled_loss": own.item()})

    def validate(self) -> float:
        settings = self.settings
        val = score(self.net, self.data, self.splits["val"], settings.batch_size, self.device)
        return val["action_accuracy"]

    def test(self) -> dict[str, Any]:
        settings, videos = self.settings, self.splits["test"]
        test = score(
            self.net, self.data, videos, settings.batch_size, self.device, self.checker_rules
        )
        if settings.decode == "constrained":  # the same model, its test videos under the rules
            test["constrained"] = score(
                self.net, self.data, videos, settings.batch_size, self.device,
                self.checker_rules, top_k=settings.decode_top_k,
            )  # fmt: skip
        return test

    def metrics(self) -> dict[str, Any]:
        return {
            "model": self.settings.model,
            "train_videos": len(self.splits["train"]),
            "unlabelled_videos": unlabelled_count(self.data, self.settings),
            "rule_sets": {
                "compiled": self.loss_rules.compiled,
                "rules_left_out_unknown_to_q": self.loss_rules.skipped_rules,
                **({} if self.coverage is None else self.coverage.as_dict()),
            },
        }

    def config(self) -> dict[str, Any]:
        data = self.data
        return {
            "actions": list(data.actions),
            "ingredients": list(data.ingredients),
            "feature_dim": data.feature_dim,
            "data": data.params.get("data", "synthetic" if data.params else "unknown"),
        }


def train_action_recognition(
    activities_path: str | Path,
    kb_path: str | Path,
    embedder_dir: str | Path | None,
    out_dir: str | Path,
    settings: TaskSettings,
    on_epoch: Callable[[EpochRecord], None] | None = None,
    resume: bool = False,
    on_setup: Callable[[RunSetup], None] | None = None,
    reference: str | Path | None = None,
) -> dict:
    """Train h, keep the best val epoch, score it on test; returns the metrics written.

    The run is every task's (`training.task.train_task`): `resume` continues from out_dir's
    `checkpoint.pt`, only the same run, and ends as the run never interrupted would;
    `on_setup` hears the run's λ and its source, and what of the knowledge base q cannot read,
    before the first epoch. With `settings.lambdas`, one run per candidate λ and the best on
    val kept; `reference`: a finished λ-0 run of the same settings and data (the run without a
    logic loss, or another loss's λ-0 candidate) taken as the λ-0 candidate, not trained
    again. SettingError when the tleaf loss has no q or its q can read none of the knowledge
    base's rules (`q_coverage`)."""
    settings.check()
    if settings.logic_loss == "tleaf" and embedder_dir is None:
        raise SettingError("embedder", "the tleaf loss needs an embedder (a train-meta folder)")
    if settings.logic_loss != "tleaf" and embedder_dir is not None:
        raise SettingError("embedder", "only the tleaf loss reads q")
    inputs = RunInputs(
        Path(activities_path), Path(kb_path), None if embedder_dir is None else Path(embedder_dir)
    )
    return train_task(
        ActionRecognitionTrainer, inputs, out_dir, settings, on_epoch, resume, on_setup, reference
    )


def first_videos(
    videos: list[Video], count: int | None, activities_path: str | Path
) -> list[Video]:
    """The first `count` train videos in file order (all with None): a larger count holds
    every smaller one, so runs at growing sizes form a learning curve on one data set (the
    same val and test videos); SettingError when the split has fewer."""
    if count is None:
        return videos
    if count > len(videos):
        raise SettingError(
            "train_videos",
            f"{count} asked for, but the train split of {activities_path} has {len(videos)} videos",
        )
    return videos[:count]


def unlabelled_weight(epoch: int, warmup: int) -> float:
    """The weight of the unlabelled videos' logic loss in `epoch` (from 1): rising linearly to 1
    over the first `warmup` epochs (epoch/warmup), 1 from then on and without a warm-up. Early
    on, h's guesses on videos it has no labels for are near uniform, and a loss on them alone
    is lowest where h answers every video alike (a sequence of one allowed pair meets every
    rule); the warm-up lets the labels shape h first."""
    return 1.0 if warmup <= 0 else min(1.0, epoch / warmup)


def unlabelled_count(data: Activities, settings: TaskSettings) -> int:
    """How many unlabelled videos the run reads: 0 unless they are on and its loss has a
    gradient; else the first `unlabelled_videos` of the split (all by default)."""
    teaches = settings.logic_loss in GRADIENT_LOSSES or settings.unlabelled_loss != "logic"
    if not (settings.unlabelled and teaches):
        return 0
    return len(data.split(UNLABELLED)[: settings.unlabelled_videos])


def unlabelled_batches(
    data: Activities, settings: TaskSettings, device: torch.device, skip: int = 0
) -> Iterator[Batch] | None:
    """Endless batches of the unlabelled videos, reshuffled each pass (their own seeded order,
    so the labelled batches are the same as without them), from the `skip`-th batch on; None
    when they are not used."""
    if not unlabelled_count(data, settings):
        return None
    videos = data.split(UNLABELLED)[: settings.unlabelled_videos]

    def endless() -> Iterator[Batch]:
        generator = torch.Generator().manual_seed(settings.seed * 100_003 + 99_991)
        drawn = 0
        while True:
            for chunk in chunks(videos, settings.batch_size, generator):
                if drawn >= skip:
                    yield Batch.of(chunk, device)
                drawn += 1

    return endless()


def predict(
    model: ActionRecognizer,
    videos: Sequence[Video],
    batch_size: int,
    device: torch.device,
    rules: KnowledgeRuleSets | None = None,
    top_k: int | None = None,
) -> tuple[list[tuple[np.ndarray, np.ndarray]], dict]:
    """(predicted action indices, predicted ingredient indices) per video — argmax per step,
    or, with `top_k`, the pairs of constrained decoding under `rules` (decoding.py) — and what
    decoding took (`decode_seconds_per_video`, `decode_rounds`: the most rounds of a batch)."""
    model.eval()
    out, seconds, rounds = [], 0.0, 0
    with torch.no_grad():
        for i in range(0, len(videos), batch_size):
            batch = Batch.of(videos[i : i + batch_size], device)
            actions, ingredients = model(batch.features, batch.lengths)
            lengths = batch.lengths.tolist()
            if top_k is None:
                a, g = actions.argmax(-1).cpu().numpy(), ingredients.argmax(-1).cpu().numpy()
            else:
                start = time.perf_counter()
                log_pairs = pair_log_probs(actions, ingredients)
                pairs, used = decode_pairs(log_pairs, batch.lengths, rules, top_k)
                seconds += time.perf_counter() - start
                rounds = max(rounds, used)
                pairs = pairs.clamp(min=0).cpu().numpy()
                a, g = pairs // ingredients.shape[-1], pairs % ingredients.shape[-1]
            out += [(a[b, :n], g[b, :n]) for b, n in enumerate(lengths)]
    stats = {"decode_seconds_per_video": seconds / max(len(videos), 1), "decode_rounds": rounds}
    return out, stats


def rules_broken(
    rules: KnowledgeRuleSets,
    data: Activities,
    predictions: Sequence[tuple[np.ndarray, np.ndarray]],
) -> tuple[list[RuleSet | None], np.ndarray]:
    """Each predicted sequence's rule set — the knowledge base's rules whose pairs all occur in
    it (None where none do) — and bool [n]: the sequence breaks it (the violation metric)."""
    sets = rules.one_each([predicted_atoms(data, a, i) for a, i in predictions])
    n = len(data.ingredients)
    rows = [k for k, r in enumerate(sets) if r is not None]
    bad = np.zeros(len(sets), dtype=bool)
    if rows:
        pairs = [predictions[k][0] * n + predictions[k][1] for k in rows]
        bad[rows] = violates([sets[k] for k in rows], pairs)
    return sets, bad


def score(
    model: ActionRecognizer,
    data: Activities,
    videos: Sequence[Video],
    batch_size: int,
    device: torch.device,
    rules: KnowledgeRuleSets | None = None,
    top_k: int | None = None,
) -> dict:
    """Per-step action / ingredient / pair accuracy; with `rules`, the share of videos whose
    predicted sequence violates the rules relevant to its predicted pairs. With `top_k`, the
    predictions are constrained decoding's under `rules` (and the decoding time is reported)."""
    predictions, stats = predict(model, videos, batch_size, device, rules, top_k)
    hit_a = np.concatenate([p[0] == v.actions for p, v in zip(predictions, videos, strict=True)])
    hit_i = np.concatenate(
        [p[1] == v.ingredients for p, v in zip(predictions, videos, strict=True)]
    )
    out = {
        "videos": len(videos),
        "steps": len(hit_a),
        "action_accuracy": float(hit_a.mean()),
        "ingredient_accuracy": float(hit_i.mean()),
        "pair_accuracy": float((hit_a & hit_i).mean()),
    }
    if rules is not None:
        sets, bad = rules_broken(rules, data, predictions)
        out["violation_fraction"] = float(bad.sum() / len(videos))
        out["videos_with_rules"] = sum(r is not None for r in sets)
    if top_k is not None:
        out.update(stats)
    return out
