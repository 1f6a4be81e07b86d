"""`tleaf predict` on an action-recognition run: new videos (features only; labels, where the
file has them, are kept beside the prediction and never read by it) decoded to (action,
ingredient) labels by argmax and under the rules, written as an `action_predictions` artifact.

The decodings are the run's own (`train.predict`, what `train-task`'s test figures and
`eval action-recognition` read): argmax per head and step; and `decoding.decode_pairs`, the
most probable pair sequence under the knowledge-base rules that apply to the model's top
`decode_top_k` candidate pairs (the run's setting), grown until every rule that applies to the
decoded pairs was decoded under. A video's rules, for both sequences, are the rules whose atoms
all occur among its pairs (`KnowledgeRuleSets.rules`, the violation metric's choice: no label
picks them); each is checked alone, so the rules broken are named. The constrained sequence
breaks none by construction.

One row per (video, step), videos in file order; the per-video columns repeat on every step of
a video. The columns are docs/monitoring.md's ("Action-recognition runs").
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import torch

from tleaf_cli.data.artifacts import check_writable, describe_inputs, write_artifact
from tleaf_cli.embed.model_folder import load_weights, read_model_config
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.knowledge.base import KnowledgeBase, read_knowledge_base
from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
from tleaf_cli.losses import pair_log_probs, pair_vocabulary, violates
from tleaf_cli.settings.action_recognition import TaskSettings
from tleaf_cli.tasks.action_recognition.activities import (
    NO_LABEL,
    Activities,
    Video,
    read_activities,
)
from tleaf_cli.tasks.action_recognition.batch import Batch
from tleaf_cli.tasks.action_recognition.decoding import decode_pairs
from tleaf_cli.tasks.action_recognition.models import ActionRecognizer
from tleaf_cli.training.run_folder import CONFIG, finished_run, recorded_input

KIND = "action_predictions"
SCHEMA_VERSION = 1
RUN_KIND = "action-recognizer"  # config.json's kind of a train-task action-recognition run
PREDICTED_KINDS = ("next-activity", RUN_KIND)  # the run kinds `tleaf predict` takes
CPU = torch.device("cpu")

_PAIR = pa.struct(
    [("action", pa.string()), ("ingredient", pa.string()), ("probability", pa.float64())]
)
SCHEMA = pa.schema(
    [
        ("video_id", pa.string()),
        ("split", pa.string()),
        ("step", pa.int32()),
        ("action", pa.string()),
        ("action_probability", pa.float64()),
        ("ingredient", pa.string()),
        ("ingredient_probability", pa.float64()),
        ("top_pairs", pa.list_(_PAIR)),
        ("constrained_action", pa.string()),
        ("constrained_ingredient", pa.string()),
        ("constrained_probability", pa.float64()),
        ("true_action", pa.string()),
        ("true_ingredient", pa.string()),
        ("argmax_log_prob", pa.float64()),
        ("argmax_rules", pa.int32()),
        ("argmax_broken", pa.list_(pa.string())),
        ("constrained_log_prob", pa.float64()),
        ("constrained_rules", pa.int32()),
        ("constrained_broken", pa.list_(pa.string())),
    ]
)


def run_kind(run_dir: str | os.PathLike) -> str | None:
    """The kind a run folder's config.json names (None where there is none to read: the
    next-activity path then says why, as it always did); InputError for a kind `tleaf predict`
    does not take."""
    path = Path(run_dir) / CONFIG
    try:
        config = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    kind = config.get("kind") if isinstance(config, dict) else None
    if kind not in PREDICTED_KINDS:
        raise InputError(
            f"{path}: not a next-activity run nor an action-recognition one (kind {kind}); "
            "tleaf predict takes train-task next-activity and action-recognition runs"
        )
    return kind


@dataclass
class VideoPrediction:
    """One video decoded: per step the argmax labels (each head's) with their probabilities,
    the `top_k` pairs, the constrained labels with their pair's probability; per video each
    sequence's log-probability, how many rules apply to it and which of them it breaks."""

    video_id: str
    split: str
    first_step: int
    actions: list[str]
    action_probabilities: list[float]
    ingredients: list[str]
    ingredient_probabilities: list[float]
    top_pairs: list[list[tuple[str, str, float]]]
    constrained_actions: list[str]
    constrained_ingredients: list[str]
    constrained_probabilities: list[float]
    argmax_log_prob: float
    argmax_rules: int
    argmax_broken: list[str]
    constrained_log_prob: float
    constrained_rules: int
    constrained_broken: list[str]

    def __len__(self) -> int:
        return len(self.actions)


class ActionPredictor:
    """A finished action-recognition run's model (best epoch, on the CPU), its vocabulary and
    the rules it decodes under; `predict(videos)` decodes a batch of videos."""

    def __init__(
        self,
        model: ActionRecognizer,
        actions: Sequence[str],
        ingredients: Sequence[str],
        feature_dim: int,
        kb: KnowledgeBase,
        kb_path: str,
        top_k: int,
        batch_size: int,
    ) -> None:
        self.model = model.eval()
        self.actions, self.ingredients = tuple(actions), tuple(ingredients)
        self.feature_dim = feature_dim
        self.kb, self.kb_path = kb, kb_path
        self.rules = KnowledgeRuleSets(kb, pair_vocabulary(self.actions, self.ingredients))
        self.top_k, self.batch_size = top_k, batch_size

    @classmethod
    def load(
        cls,
        run_dir: str | os.PathLike,
        rules_path: str | os.PathLike | None = None,
        rule_names: Sequence[str] = (),
    ) -> ActionPredictor:
        """The run in `run_dir` and the rules of `rules_path` (a `.ltl` knowledge base; default
        the one the run trained with, from its config.json), only those named `rule_names`
        where given; InputError naming the folder or file otherwise."""
        run_dir = Path(run_dir)
        config = read_model_config(run_dir, RUN_KIND)
        if not finished_run(run_dir):
            raise InputError(f"{run_dir}: not a finished train-task action-recognition run")
        s = config["settings"]
        model = ActionRecognizer.from_config(config)
        load_weights(model, run_dir, RUN_KIND)
        if rules_path is None:
            rules_path = recorded_input(run_dir, config, "kb")
            if rules_path is None:
                raise InputError(
                    f"{run_dir}: config.json records no knowledge base; name a rule file to use"
                )
        if Path(rules_path).suffix != ".ltl":
            raise InputError(
                f"{rules_path}: an action-recognition run decodes under a .ltl knowledge base "
                "(rules over action_ingredient atoms)"
            )
        kb = select_rules(read_knowledge_base(rules_path), rule_names, rules_path)
        return cls(
            model, config["actions"], config["ingredients"], int(config["feature_dim"]), kb,
            os.fspath(Path(rules_path).resolve()),
            int(s.get("decode_top_k", TaskSettings.decode_top_k)), int(s["batch_size"]),
        )  # fmt: skip

    def check(self, videos: Sequence[Video], where: str) -> None:
        """InputError naming `where` for videos this run cannot read: none, a video without
        steps, features of another width than the run's."""
        if not videos:
            raise InputError(f"{where}: no videos to predict")
        for v in videos:
            if len(v) == 0:
                raise InputError(f"{where}: video '{v.video_id}' has no steps")
            if v.features.ndim != 2 or v.features.shape[1] != self.feature_dim:
                width = v.features.shape[-1] if v.features.ndim else 0
                raise InputError(
                    f"{where}: video '{v.video_id}': features have {width} values per step, "
                    f"the run reads {self.feature_dim} (its config.json's feature_dim)"
                )

    def predict(self, videos: Sequence[Video], top_pairs: int = 3) -> list[VideoPrediction]:
        """Each video decoded by argmax and under the rules, batch by batch (the run's batch
        size, as its test figures were computed); `top_pairs` most probable pairs per step."""
        self.check(videos, "videos")
        out: list[VideoPrediction] = []
        with torch.no_grad():
            for first in range(0, len(videos), self.batch_size):
                out += self._batch(videos[first : first + self.batch_size], top_pairs)
        return out

    def _batch(self, videos: Sequence[Video], top_pairs: int) -> list[VideoPrediction]:
        batch = Batch.of(videos, CPU)
        action_logits, ingredient_logits = self.model(batch.features, batch.lengths)
        log_a = torch.log_softmax(action_logits, dim=-1)
        log_i = torch.log_softmax(ingredient_logits, dim=-1)
        log_pairs = pair_log_probs(action_logits, ingredient_logits)
        decoded, _ = decode_pairs(log_pairs, batch.lengths, self.rules, self.top_k)
        n_ing = len(self.ingredients)
        k = min(top_pairs, log_pairs.shape[-1])
        best, best_at = log_pairs.topk(k, dim=-1)
        sequences, parts = [], []
        for b, video in enumerate(videos):
            n = len(video)
            a = log_a[b, :n].argmax(-1)
            i = log_i[b, :n].argmax(-1)
            argmax = (a * n_ing + i).numpy()
            hard = decoded[b, :n].numpy()
            steps, at = np.arange(n), torch.arange(n)
            lp = log_pairs[b, :n].double().numpy()
            sequences += [argmax, hard]
            parts.append(
                {
                    "video_id": video.video_id,
                    "split": video.split,
                    "first_step": video.first_step,
                    "actions": [self.actions[x] for x in a.tolist()],
                    "action_probabilities": log_a[b, at, a].exp().tolist(),
                    "ingredients": [self.ingredients[x] for x in i.tolist()],
                    "ingredient_probabilities": log_i[b, at, i].exp().tolist(),
                    "top_pairs": [self._top(best_at[b, t], best[b, t]) for t in range(n)],
                    "constrained_actions": [self.actions[p // n_ing] for p in hard.tolist()],
                    "constrained_ingredients": [self.ingredients[p % n_ing] for p in hard.tolist()],
                    "constrained_probabilities": np.exp(lp[steps, hard]).tolist(),
                    "argmax_log_prob": float(lp[steps, argmax].sum()),
                    "constrained_log_prob": float(lp[steps, hard].sum()),
                }
            )
        checked = self.broken(sequences)
        out = []
        for b, part in enumerate(parts):
            (na, broken_a), (nc, broken_c) = checked[2 * b], checked[2 * b + 1]
            out.append(
                VideoPrediction(
                    **part, argmax_rules=na, argmax_broken=broken_a, constrained_rules=nc,
                    constrained_broken=broken_c,
                )
            )  # fmt: skip
        return out

    def _top(self, pairs: torch.Tensor, log_probs: torch.Tensor) -> list[tuple[str, str, float]]:
        """(action, ingredient, probability) of pair indices and their log-probabilities."""
        n = len(self.ingredients)
        return [
            (self.actions[p // n], self.ingredients[p % n], q)
            for p, q in zip(pairs.tolist(), log_probs.exp().tolist(), strict=True)
        ]

    def broken(self, sequences: Sequence[np.ndarray]) -> list[tuple[int, list[str]]]:
        """Per sequence of pair indices: how many knowledge-base rules apply to it (their atoms
        all among its pairs) and the names of those it breaks, each rule checked alone."""
        vocabulary = self.rules.vocabulary
        applying = [self.rules.rules({vocabulary[p] for p in s.tolist()}) for s in sequences]
        rows = [(k, r) for k, rules in enumerate(applying) for r in rules]
        bad = np.zeros(len(rows), dtype=bool)
        if rows:
            sets = [self.rules.rule_set([r]) for _, r in rows]
            bad = violates(sets, [sequences[k] for k, _ in rows])
        out: list[tuple[int, list[str]]] = [(len(rules), []) for rules in applying]
        for (k, rule), b in zip(rows, bad, strict=True):
            if b:
                out[k][1].append(rule.name)
        return out


def select_rules(kb: KnowledgeBase, names: Sequence[str], path: str | os.PathLike) -> KnowledgeBase:
    """The rules of `kb` named `names` (all of them where none are named); InputError naming
    the first name `path` does not have."""
    if not names:
        return kb
    have = {r.name for r in kb}
    missing = [n for n in names if n not in have]
    if missing:
        raise InputError(f"{path}: no rule named {missing[0]!r}")
    wanted = set(names)
    return KnowledgeBase(tuple(r for r in kb if r.name in wanted))


def predict_activities(
    run_dir: str | os.PathLike,
    activities_path: str | os.PathLike,
    out: str | os.PathLike,
    rules_path: str | os.PathLike | None = None,
    rule_names: Sequence[str] = (),
    split: str | None = None,
    top_pairs: int = 3,
    on_progress: Callable[[int, int], None] | None = None,
) -> dict:
    """Decode every video of `activities_path` (or of its `split`) with the run in `run_dir`
    and write the `action_predictions` artifact to `out`, atomically. Labels are not needed
    (`read_activities(labels=False)`); where present they are kept as `true_action` and
    `true_ingredient`. A summary: videos, steps, the predictions, how many argmax sequences
    break a rule and how many constrained ones do, the action accuracy of both where every
    step has a label, seconds. InputError, nothing written, for a folder that is not a
    finished action-recognition run, a file that is not activities, features of another
    width, a video without steps, or an empty split."""
    if top_pairs < 1:
        raise SettingError("top_k", f"must be at least 1, not {top_pairs}")
    check_writable(out)
    predictor = ActionPredictor.load(run_dir, rules_path, rule_names)
    data = read_activities(activities_path, labels=False)
    videos = data.videos
    if split is not None:
        videos = data.split(split)
        if not videos:
            have = ", ".join(sorted({v.split for v in data.videos}))
            raise InputError(
                f"{activities_path}: no videos in the split {split!r} (it has: {have})"
            )
    predictor.check(videos, str(activities_path))
    start = time.perf_counter()
    predictions: list[VideoPrediction] = []
    for first in range(0, len(videos), predictor.batch_size):
        predictions += predictor.predict(videos[first : first + predictor.batch_size], top_pairs)
        if on_progress is not None:
            on_progress(min(first + predictor.batch_size, len(videos)), len(videos))
    seconds = time.perf_counter() - start
    table = predictions_table(data, videos, predictions)
    params = {
        "run": os.fspath(Path(run_dir).resolve()),
        "rules": predictor.kb_path,
        "rule_names": list(rule_names),
        "rules_in_force": len(predictor.kb),
        "split": split,
        "top_k": top_pairs,
        "decode_top_k": predictor.top_k,
        "actions": list(predictor.actions),
        "ingredients": list(predictor.ingredients),
        **({"data": data.params["data"]} if "data" in data.params else {}),
    }
    write_artifact(
        table, out, kind=KIND, schema=SCHEMA_VERSION, params=params,
        inputs=describe_inputs([activities_path, predictor.kb_path]),
    )  # fmt: skip
    return {
        "videos": len(predictions),
        "steps": sum(len(p) for p in predictions),
        "argmax_breaking": sum(bool(p.argmax_broken) for p in predictions),
        "constrained_breaking": sum(bool(p.constrained_broken) for p in predictions),
        "rules": len(predictor.kb),
        "accuracy": label_accuracy(data, videos, predictions),
        "predictions": predictions,
        "seconds": seconds,
    }


def true_labels(data: Activities, video: Video) -> tuple[list[str | None], list[str | None]]:
    """A video's labels as names (None where a step has none)."""
    return (
        [None if x == NO_LABEL else data.actions[x] for x in video.actions.tolist()],
        [None if x == NO_LABEL else data.ingredients[x] for x in video.ingredients.tolist()],
    )


def label_accuracy(
    data: Activities, videos: Sequence[Video], predictions: Sequence[VideoPrediction]
) -> dict[str, float] | None:
    """Action accuracy of the argmax and the constrained labels against the file's labels,
    where every step has its action label (None otherwise)."""
    truth = [true_labels(data, v)[0] for v in videos]
    if any(a is None for labels in truth for a in labels):
        return None
    hits = {"argmax": 0, "constrained": 0}
    for labels, p in zip(truth, predictions, strict=True):
        hits["argmax"] += sum(x == y for x, y in zip(labels, p.actions, strict=True))
        hits["constrained"] += sum(
            x == y for x, y in zip(labels, p.constrained_actions, strict=True)
        )
    steps = sum(len(labels) for labels in truth)
    return {k: v / steps for k, v in hits.items()}


def predictions_table(
    data: Activities, videos: Sequence[Video], predictions: Sequence[VideoPrediction]
) -> pa.Table:
    """The artifact's rows (`SCHEMA`), one per (video, step)."""
    rows = []
    for video, p in zip(videos, predictions, strict=True):
        true_a, true_i = true_labels(data, video)
        per_video = {
            "argmax_log_prob": p.argmax_log_prob,
            "argmax_rules": p.argmax_rules,
            "argmax_broken": p.argmax_broken,
            "constrained_log_prob": p.constrained_log_prob,
            "constrained_rules": p.constrained_rules,
            "constrained_broken": p.constrained_broken,
        }
        for t in range(len(p)):
            rows.append(
                {
                    "video_id": p.video_id,
                    "split": p.split,
                    "step": p.first_step + t,
                    "action": p.actions[t],
                    "action_probability": p.action_probabilities[t],
                    "ingredient": p.ingredients[t],
                    "ingredient_probability": p.ingredient_probabilities[t],
                    "top_pairs": [
                        {"action": a, "ingredient": i, "probability": q}
                        for a, i, q in p.top_pairs[t]
                    ],
                    "constrained_action": p.constrained_actions[t],
                    "constrained_ingredient": p.constrained_ingredients[t],
                    "constrained_probability": p.constrained_probabilities[t],
                    "true_action": true_a[t],
                    "true_ingredient": true_i[t],
                    **per_video,
                }
            )
    return pa.Table.from_pylist(rows, schema=SCHEMA)
