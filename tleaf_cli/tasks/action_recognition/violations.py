"""`tleaf eval violations`: which rules a trained action recogniser's argmax outputs break, and
how much probability it gives the rules holding.

A run's test metric `violation_fraction` (`train.score`) is the share of videos whose argmax pair
sequence breaks a knowledge-base rule relevant to its predicted pairs. A logic loss on labelled
videos can only lower it where the model breaks rules on the videos it trains on; this report
says, per run and split (the train split being the first `train_videos` videos the run trained
on), where the violations come from:

- the share of videos whose argmax breaks an affordance rule (a pair that never happens), an
  ordering rule (two pairs in the wrong order), any rule (`score`'s figure, computed the same
  way: `KnowledgeRuleSets.one_each` and `violates`);
- the share of steps whose argmax pair is forbidden by an affordance rule, and the mean
  probability per step the model gives the forbidden pairs together;
- P(rules hold), a sequence drawn step by step from the model's outputs (exp of minus the exact
  loss): for the rule set of the video's own argmax pairs (the set the checker and a
  predictions-based loss use; mean over the videos that have rules), and for the whole
  knowledge base (`KnowledgeRuleSets.whole`, one guarded rule set per ingredient, P the product
  over them; mean over all videos). The means of log P are reported too, as the mean of P is
  carried by the easiest videos.

Each run is read from its folder (config.json, weights.pt, metrics.json) and the activities file
and knowledge base its config.json records as inputs, checked against their SHA-256. Writes
violations.json (every figure) and violations.md (one table row per run and split).
"""

from __future__ import annotations

import json
import pickle
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from tleaf_cli.data.artifacts import check_writable, write_text_atomic
from tleaf_cli.embed.model_folder import read_model_config
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.knowledge.base import (
    KnowledgeBase,
    RuleKind,
    forbidden_atom,
    read_knowledge_base,
)
from tleaf_cli.knowledge.rule_sets import KnowledgeRuleSets
from tleaf_cli.losses import logic_loss, pair_log_probs, pair_vocabulary, violates
from tleaf_cli.rule_set import RuleSet
from tleaf_cli.tasks.action_recognition.activities import Activities, Video, read_activities
from tleaf_cli.tasks.action_recognition.learning_curve import read_curve_run
from tleaf_cli.tasks.action_recognition.models import ActionRecognizer
from tleaf_cli.tasks.action_recognition.train import (
    Batch,
    predict,
    predicted_atoms,
    rules_broken,
)
from tleaf_cli.training.run_folder import recorded_input

SPLITS = ("train", "val", "test")
DEFAULT_SPLITS = ("train", "test")
CPU = torch.device("cpu")


@dataclass
class Inputs:
    """What a run was trained on: its activities, knowledge base, and the rule sets of both."""

    data: Activities
    kb: KnowledgeBase
    rules: KnowledgeRuleSets
    forbidden: list[int]  # pair-vocabulary positions of the pairs affordance rules forbid


@dataclass
class Run:
    """A finished train-task run, loaded: its row of `read_curve_run`, model and inputs."""

    path: Path
    row: dict
    model: ActionRecognizer
    inputs: Inputs
    batch_size: int


def forbidden_pairs(kb: KnowledgeBase) -> set[str]:
    """The atoms affordance rules forbid outright (`G !a`, as `base.affordance_rule` writes
    them); an affordance rule of another shape forbids no single pair."""
    return {a for r in kb.of_kind("affordance") if (a := forbidden_atom(r)) is not None}


def _recorded_inputs(run_dir: Path, config: dict) -> tuple[Path, Path]:
    """The activities file and knowledge base config.json records (in that order), checked to
    exist and to be the bytes the run was trained on; InputError naming the run otherwise."""
    data, kb = (recorded_input(run_dir, config, role) for role in ("data", "kb"))
    if data is None or kb is None:
        raise InputError(f"{run_dir}: config.json records no activities file or knowledge base")
    return data, kb


def _read_inputs(activities: Path, kb_path: Path) -> Inputs:
    data = read_activities(activities)
    kb = read_knowledge_base(kb_path)
    vocabulary = pair_vocabulary(data.actions, data.ingredients)
    forbidden = forbidden_pairs(kb)
    return Inputs(
        data,
        kb,
        KnowledgeRuleSets(kb, vocabulary),
        [k for k, a in enumerate(vocabulary) if a in forbidden],
    )


def load_run(run_dir: str | Path, cache: dict[tuple[Path, Path], Inputs] | None = None) -> Run:
    """A finished train-task action-recognition run with its model (best epoch's weights, on the
    CPU) and the inputs it was trained on; `cache` shares inputs between runs of one data set.
    InputError naming the folder when it is not a finished run, its inputs are gone or changed,
    or its weights do not load."""
    run_dir = Path(run_dir)
    row = read_curve_run(run_dir, both_decodings=False)  # a finished run, its train_videos
    config = read_model_config(run_dir, "action-recognizer")
    cache = {} if cache is None else cache
    key = _recorded_inputs(run_dir, config)
    if key not in cache:
        cache[key] = _read_inputs(*key)
    inputs = cache[key]
    data, s = inputs.data, config["settings"]
    if (list(data.actions), list(data.ingredients)) != (config["actions"], config["ingredients"]):
        raise InputError(f"{run_dir}: its actions or ingredients are not its activities file's")
    model = ActionRecognizer.from_config(config)
    try:
        weights = torch.load(run_dir / "weights.pt", map_location=CPU, weights_only=True)
        model.load_state_dict(weights)
    except (OSError, RuntimeError, ValueError, pickle.UnpicklingError) as e:
        first = (str(e).strip().splitlines() or [type(e).__name__])[0]
        raise InputError(f"{run_dir}: weights.pt does not load ({first})") from None
    model.eval()
    return Run(run_dir, row, model, inputs, int(s["batch_size"]))


def split_videos(run: Run, split: str) -> list[Video]:
    """The videos of `split` the report reads: for train, the first `train_videos` of the
    split, those the run trained on; InputError when the split has none (or too few)."""
    videos = run.inputs.data.split(split)
    if split == "train":
        count = run.row["train_videos"]
        if count > len(videos):
            raise InputError(
                f"{run.path}: trained on {count} videos, its activities file's train split has "
                f"{len(videos)}"
            )
        videos = videos[:count]
    if not videos:
        raise InputError(f"{run.path}: no {split} videos in {run.inputs.data.path}")
    return videos


def _broken(rule_sets: Sequence[RuleSet | None], sequences: Sequence[np.ndarray]) -> np.ndarray:
    """bool [n]: sequence i breaks rule_sets[i] (False where it is None: no rule applies)."""
    out = np.zeros(len(sequences), dtype=bool)
    rows = [k for k, r in enumerate(rule_sets) if r is not None]
    out[rows] = violates([rule_sets[k] for k in rows], [sequences[k] for k in rows])
    return out


def _of_kind(rules: KnowledgeRuleSets, present: set[str], kind: RuleKind) -> RuleSet | None:
    """The rule set of the rules of `kind` that apply to atoms `present` (None: none apply)."""
    chosen = [r for r in rules.rules(present) if r.kind == kind]
    return rules.rule_set(chosen) if chosen else None


def _log_p_hold(losses: torch.Tensor, rule_sets: Sequence[RuleSet]) -> np.ndarray:
    """log P(rules hold) [n] from exact losses [n]: −loss, and −inf for an unsatisfiable set
    (whose exact loss is 0 by convention: no signal)."""
    log_p = -losses.double().numpy()
    return np.where([r.satisfiable for r in rule_sets], log_p, -np.inf)


def _probabilities(
    run: Run, videos: Sequence[Video], own: Sequence[RuleSet | None]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per step, the probability the model gives the forbidden pairs [steps]; per video with
    rules, log P(its own rule set holds); per video, log P(the whole knowledge base holds)."""
    whole = run.inputs.rules.whole()
    forbidden = torch.tensor(run.inputs.forbidden, dtype=torch.long)
    mass, log_own, log_whole = [], [], []
    with torch.no_grad():
        for start in range(0, len(videos), run.batch_size):
            chunk = videos[start : start + run.batch_size]
            batch = Batch.of(chunk, CPU)
            log_probs = pair_log_probs(*run.model(batch.features, batch.lengths))
            steps = torch.arange(log_probs.shape[1])[None] < batch.lengths[:, None]
            mass.append(log_probs[..., forbidden].exp().sum(-1)[steps].double().numpy())
            mine = own[start : start + len(chunk)]
            rows = [b for b, r in enumerate(mine) if r is not None]
            if rows:
                sets = [mine[b] for b in rows]
                at = torch.tensor(rows)
                losses = logic_loss(
                    "exact", log_probs[at], sets, batch.lengths[at], reduction="none"
                )
                log_own.append(_log_p_hold(losses, sets))
            if whole:
                losses = logic_loss(
                    "exact",
                    log_probs.repeat_interleave(len(whole), 0),
                    whole * len(chunk),
                    batch.lengths.repeat_interleave(len(whole)),
                    reduction="none",
                )
                per_set = _log_p_hold(losses, whole * len(chunk)).reshape(len(chunk), len(whole))
                log_whole.append(per_set.sum(1))
            else:
                log_whole.append(np.zeros(len(chunk)))
    empty = np.zeros(0)
    return (
        np.concatenate(mass),
        np.concatenate(log_own) if log_own else empty,
        np.concatenate(log_whole),
    )


def _mean(values: np.ndarray) -> float | None:
    return float(values.mean()) if len(values) else None


def split_violations(run: Run, split: str) -> dict:
    """The figures of one run on one split (the module docstring says each)."""
    videos = split_videos(run, split)
    inputs, rules = run.inputs, run.inputs.rules
    predictions, _ = predict(run.model, videos, run.batch_size, CPU)
    width = len(inputs.data.ingredients)
    sequences = [a * width + i for a, i in predictions]
    present = [predicted_atoms(inputs.data, a, i) for a, i in predictions]
    own, broken = rules_broken(rules, inputs.data, predictions)  # score()'s violation metric
    by_kind = {
        kind: _broken([_of_kind(rules, p, kind) for p in present], sequences)
        for kind in ("affordance", "ordering")
    }
    forbidden_steps = np.isin(np.concatenate(sequences), inputs.forbidden)
    mass, log_own, log_whole = _probabilities(run, videos, own)
    return {
        "run": str(run.path),
        "split": split,
        "model": run.row["model"],
        "method": run.row["method"],
        "seed": run.row["seed"],
        "train_videos": run.row["train_videos"],
        "videos": len(videos),
        "steps": len(forbidden_steps),
        "videos_with_rules": sum(r is not None for r in own),
        "affordance_violation_fraction": float(by_kind["affordance"].mean()),
        "ordering_violation_fraction": float(by_kind["ordering"].mean()),
        "violation_fraction": float(broken.mean()),
        "forbidden_step_fraction": float(forbidden_steps.mean()),
        "forbidden_probability_per_step": float(mass.mean()),
        "p_own_rules": _mean(np.exp(log_own)),
        "mean_log_p_own_rules": _mean(log_own),
        "p_whole_kb": float(np.exp(log_whole).mean()),
        "mean_log_p_whole_kb": float(log_whole.mean()),
    }


def _pct(value: float) -> str:
    return f"{100 * value:.1f}%"


def _probability(value: float | None) -> str:
    return "–" if value is None else f"{value:.3g}"


def markdown(rows: Sequence[dict]) -> str:
    """violations.md: what each column means, then one row per run and split."""
    lines = [
        "# Why the argmax outputs break the rules",
        "",
        "Per run and split (train: the first `train_videos` videos of the train split, those the "
        "run trained on), the model's argmax (action, ingredient) pair per step:",
        "",
        "- **affordance / ordering / any rule**: share of videos whose argmax sequence breaks an "
        "affordance rule (a pair that never happens), an ordering rule (two pairs in the wrong "
        "order), or any rule, among the knowledge base's rules whose pairs all occur in the "
        "sequence ('any rule' is the run's `violation_fraction`);",
        "- **forbidden steps**: share of steps whose argmax pair an affordance rule forbids;",
        "- **P(forbidden) / step**: the probability the model gives the forbidden pairs, together, "
        "mean over steps;",
        "- **P(own rules)**: the probability that a sequence drawn step by step from the model's "
        "outputs meets the rules of the video's own argmax pairs (mean over videos with rules);",
        "- **P(whole KB)**: the same for every rule of the knowledge base (mean over videos).",
        "",
        "| run | split | videos | affordance | ordering | any rule | forbidden steps | "
        "P(forbidden) / step | P(own rules) | P(whole KB) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    lines += [_row(r["run"], r) for r in rows]
    groups = mean_over_seeds(rows)
    if any(len(g["seeds"]) > 1 for g in groups):
        lines += [
            "",
            "## Mean over seeds",
            "",
            "The runs that differ only in their seed (same model, method and training videos), "
            "each figure the mean of theirs.",
            "",
            "| model, method, training videos | split | seeds | videos | affordance | ordering | "
            "any rule | forbidden steps | P(forbidden) / step | P(own rules) | P(whole KB) |",
            "|---|---|---|---|---|---|---|---|---|---|---|",
        ]
        lines += [
            _row(f"{g['model']}, {g['method']}, {g['train_videos']}", g, len(g["seeds"]))
            for g in groups
        ]
    return "\n".join(lines) + "\n"


FIGURES = (
    "affordance_violation_fraction",
    "ordering_violation_fraction",
    "violation_fraction",
    "forbidden_step_fraction",
    "forbidden_probability_per_step",
    "p_own_rules",
    "p_whole_kb",
)


def mean_over_seeds(rows: Sequence[dict]) -> list[dict]:
    """Rows of runs that differ only in their seed, merged: each figure the mean over seeds (a
    P(own rules) of None, no video with rules, left out of its mean)."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["model"], r["method"], r["train_videos"], r["split"]), []).append(r)
    out = []
    for (model, method, videos, split), group in groups.items():
        merged = {"model": model, "method": method, "train_videos": videos, "split": split}
        merged["seeds"] = sorted(r["seed"] for r in group)
        merged["videos"] = group[0]["videos"]
        for key in FIGURES:
            values = [r[key] for r in group if r[key] is not None]
            merged[key] = float(np.mean(values)) if values else None
        out.append(merged)
    return out


def _row(name: str, r: dict, seeds: int | None = None) -> str:
    """One table row of `r`'s figures, after the name (and the number of seeds)."""
    return (
        f"| {name} | {r['split']} | {'' if seeds is None else f'{seeds} | '}{r['videos']} | "
        f"{_pct(r['affordance_violation_fraction'])} | "
        f"{_pct(r['ordering_violation_fraction'])} | {_pct(r['violation_fraction'])} | "
        f"{_pct(r['forbidden_step_fraction'])} | "
        f"{r['forbidden_probability_per_step']:.3f} | {_probability(r['p_own_rules'])} | "
        f"{_probability(r['p_whole_kb'])} |"
    )


def check_splits(splits: Sequence[str]) -> tuple[str, ...]:
    """The splits asked for, each once, in the order given; SettingError for another name."""
    wrong = [s for s in splits if s not in SPLITS]
    if wrong:
        raise SettingError("split", f"must be one of {', '.join(SPLITS)}, not '{wrong[0]}'")
    if not splits:
        raise SettingError("split", "give at least one split")
    return tuple(dict.fromkeys(splits))


def violation_report(
    run_dirs: Sequence[str | Path],
    out_dir: str | Path,
    splits: Sequence[str] = DEFAULT_SPLITS,
) -> dict:
    """Every run on every split (`split_violations`); writes violations.json and violations.md
    in `out_dir` and returns the report ({"splits", "rows", "mean_over_seeds"})."""
    splits = check_splits(splits)
    out_dir = Path(out_dir)
    check_writable(out_dir / "violations.json")
    if not run_dirs:
        raise InputError("give at least one train-task run directory")
    cache: dict[tuple[Path, Path], Inputs] = {}
    runs = [load_run(d, cache) for d in run_dirs]  # every folder checked before any work
    rows = [split_violations(run, split) for run in runs for split in splits]
    report = {"splits": list(splits), "rows": rows, "mean_over_seeds": mean_over_seeds(rows)}
    write_text_atomic(out_dir / "violations.json", json.dumps(report, indent=2))
    write_text_atomic(out_dir / "violations.md", markdown(rows))
    return report
