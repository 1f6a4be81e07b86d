"""Training the next-activity model with a logic loss (`tleaf train-task next-activity`).

Objective per batch of cases: ℓ = ℓ_task + λ · mean_b ℓ_logic(b), with ℓ_task the
cross-entropy of every step's next activity (the end of case at the last step; mean over steps:
the pooled prefixes of Tax et al.), and ℓ_logic one of `tleaf_cli.losses` on the case's soft
trace (objective.py: what it reads, and the independence it assumes) under the conjunction of
the knowledge base's rules. Adam; after every epoch, next-activity accuracy on the val split
(pooled over prefixes, end included); the best epoch's weights are kept and training stops
after `patience` epochs without a better one; test accuracy is then measured the same way.

Same seed, same run: the model's initial weights, batch order and dropout masks depend on the
seed only, so runs that differ only in the logic loss start from the same point.

Run folder: `config.json` (settings, the encoder: vocabulary and time scales, inputs),
`weights.pt` (best epoch), `metrics.json`, `checkpoint.pt` (last epoch, for `resume`).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import torch
from torch.nn import functional as F

from tleaf_cli.data.artifacts import check_writable, describe_inputs, relative_to, write_text_atomic
from tleaf_cli.data.event_logs import Case, read_cases
from tleaf_cli.embed.training import LoopSettings, Step, chunks, device_for, fit
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.settings.next_activity import EXACT_LAMBDA, NextActivitySettings
from tleaf_cli.tasks.action_recognition.lambda_choice import train_choosing_lambda
from tleaf_cli.tasks.lambda_source import RunSetup, resolve_lambda_source
from tleaf_cli.tasks.next_activity.batch import PAD, CaseBatch
from tleaf_cli.tasks.next_activity.encoding import TIME_FEATURES, Encoder
from tleaf_cli.tasks.next_activity.model import NextActivityLSTM
from tleaf_cli.tasks.next_activity.objective import logic_term
from tleaf_cli.tasks.next_activity.rules import Rules, allowed_next, read_rules

SCORE = "val_accuracy"


@dataclass
class EpochRecord:
    epoch: int
    task_loss: float
    logic_loss: float
    seconds: float  # training time of this epoch, without eval
    val_accuracy: float


def train_next_activity(
    cases_path: str | Path,
    kb_path: str | Path | None,
    embedder_dir: str | Path | None,
    out_dir: str | Path,
    settings: NextActivitySettings,
    on_epoch: Callable[[EpochRecord], None] | None = None,
    resume: bool = False,
    on_setup: Callable[[RunSetup], None] | None = None,
    reference: str | Path | None = None,
) -> dict:
    """Train on the train split, keep the best val epoch, score it on test; the metrics.

    `kb_path`: the rules of the logic loss (a `.ltl`, all its rules conjoined); needed unless
    `settings.logic_loss` is none. With `settings.lambdas`, one run per candidate λ and 0, the
    best on val kept; `reference`: a finished λ-0 run of the same settings and cases (another
    loss's) taken as the λ-0 candidate, not trained again. SettingError for settings that do
    not fit, InputError for inputs."""
    settings.check()
    out_dir = Path(out_dir)
    check_writable(out_dir / "metrics.json")
    if settings.logic_loss != "none" and kb_path is None:
        raise SettingError("kb", f"the {settings.logic_loss} loss needs rules (a .ltl file)")
    if settings.logic_loss == "tleaf" and embedder_dir is None:
        raise SettingError("embedder", "the tleaf loss needs an embedder (a train-meta folder)")
    if reference is not None and settings.lambdas is None:
        raise SettingError("reference", "is the λ-0 candidate of a choice: give lambdas too")
    if settings.lambdas is not None:
        return train_choosing_lambda(
            train_next_activity, out_dir, settings, on_setup, score=SCORE, reference=reference,
            cases_path=cases_path, kb_path=kb_path, embedder_dir=embedder_dir,
            on_epoch=on_epoch, resume=resume,
        )  # fmt: skip
    device = device_for(settings.device)
    cases = read_cases(cases_path)
    splits = {s: [c for c in cases.cases if c.split == s] for s in ("train", "val", "test")}
    empty = [s for s, part in splits.items() if not part]
    if empty:
        raise InputError(f"{cases_path}: no cases in split(s) {', '.join(empty)}")
    encoder = Encoder.fit(cases)

    setup_start = time.perf_counter()
    # λ = 0 (the reference candidate of a λ choice) trains without the logic term: the same
    # updates as 0 · ℓ_logic, without computing ℓ_logic (nor reading the rules and q for it)
    logic = "none" if settings.lam == 0 else settings.logic_loss
    rules = None
    if kb_path is not None and logic != "none":
        rules = read_rules(kb_path, encoder.atoms)
    embedder = None
    if logic == "tleaf":
        from tleaf_cli.embed.load import load_embedder

        embedder = load_embedder(embedder_dir)
        missing = sorted(rules.atoms - set(embedder.vectors.index))
        if missing:  # q could not embed the conjunction: the loss would teach nothing
            raise SettingError(
                "embedder",
                f"{embedder_dir} was not trained on the atoms {', '.join(missing[:5])}"
                f"{' and more' if len(missing) > 5 else ''} of the rules: train q on formulas "
                "over this log's activities",
            )
        embedder.model.to(device)
    lam = resolve_lambda_source(
        settings.lam,
        used=settings.logic_loss != "none",
        recommended=embedder.recommended_lambda if embedder is not None else None,
        default=EXACT_LAMBDA,
    )
    settings = replace(settings, lam=lam.value)
    if on_setup is not None:
        on_setup(RunSetup(lam))
    setup_seconds = time.perf_counter() - setup_start

    torch.manual_seed(settings.seed)
    model = new_model(encoder, settings).to(device)

    arrays: dict = {}  # each case's arrays, built once

    def epoch_batches(epoch: int, generator: torch.Generator) -> Iterator[CaseBatch]:
        for part in chunks(splits["train"], settings.batch_size, generator):
            yield CaseBatch.of(part, encoder, device, arrays)

    def step(batch: CaseBatch) -> Step:
        logits = model(batch.activities, batch.times, batch.lengths)
        task = F.cross_entropy(logits.flatten(0, 1), batch.targets.flatten(), ignore_index=PAD)
        term = logic_term(logic, batch, logits, rules, embedder).mean()
        loss = task + settings.lam * term
        return Step(loss, {"task_loss": task.item(), "logic_loss": term.item()})

    run = fit(
        model,
        epoch_batches,
        step,
        lambda: accuracy(model, encoder, splits["val"], 256, device, cache=arrays)["accuracy"],
        LoopSettings.of(settings),
        out_dir,
        score=SCORE,
        resume=resume,
        on_epoch=None if on_epoch is None else lambda record: on_epoch(EpochRecord(**record)),
    )
    history, best = run["history"], run["best"]
    test = accuracy(model, encoder, splits["test"], settings.batch_size, device)
    metrics = {
        "task": "next-activity",
        "logic_loss": settings.logic_loss,
        "seed": settings.seed,
        "cases": {s: len(part) for s, part in splits.items()},
        "history": history,
        "best": best,
        "mean_epoch_seconds": float(np.mean([h["seconds"] for h in history])),
        "setup_seconds": setup_seconds,
        "test": test,
        "lambda": lam.as_dict(),
        "rule_states": None if rules is None else rules.states,
    }
    config = {
        "kind": "next-activity",
        "settings": asdict(settings),
        "encoder": encoder.as_dict(),
        "inputs": describe_inputs([p for p in (cases_path, kb_path) if p is not None]),
        "embedder": None if embedder_dir is None else str(Path(embedder_dir).resolve()),
        "embedder_relative": None if embedder_dir is None else relative_to(out_dir, embedder_dir),
    }
    write_text_atomic(out_dir / "config.json", json.dumps(config, indent=2))
    write_text_atomic(out_dir / "metrics.json", json.dumps(metrics, indent=2))
    return metrics


def new_model(encoder: Encoder, settings: NextActivitySettings) -> NextActivityLSTM:
    """An untrained model of `settings`' shape over the encoder's activities."""
    return NextActivityLSTM(
        len(encoder.atoms), TIME_FEATURES, settings.hidden, settings.layers, settings.dropout
    )


def step_log_probs(
    model: NextActivityLSTM,
    encoder: Encoder,
    cases: Sequence[Case],
    batch_size: int,
    device: torch.device,
    cache: dict | None = None,
) -> list[np.ndarray]:
    """Per case, the log-probabilities of the next token after each of its prefixes
    [n, V + 1] (column V: the end of the case); `cache` as `CaseBatch.of`'s."""
    model.eval()
    out: list[np.ndarray] = []
    with torch.no_grad():
        for i in range(0, len(cases), batch_size):
            batch = CaseBatch.of(cases[i : i + batch_size], encoder, device, cache)
            logits = model(batch.activities, batch.times, batch.lengths)
            log_probs = torch.log_softmax(logits, dim=-1).cpu().numpy()
            out += [log_probs[b, :n] for b, n in enumerate(batch.lengths.tolist())]
    return out


def accuracy(
    model: NextActivityLSTM,
    encoder: Encoder,
    cases: Sequence[Case],
    batch_size: int,
    device: torch.device,
    rules: Rules | None = None,
    cache: dict | None = None,
) -> dict:
    """Next-activity accuracy pooled over every prefix of length ≥ 1 of `cases` (the end of case
    a target), and its parts: on activities and on the end. With `rules`, also
    `accuracy_rules`: each prediction the most probable token that keeps the rules
    satisfiable (`allowed_next`)."""
    log_probs = step_log_probs(model, encoder, cases, batch_size, device, cache)
    targets = [encoder.targets(c) for c in cases]
    hits = np.concatenate([p.argmax(-1) == t for p, t in zip(log_probs, targets, strict=True)])
    ends = np.concatenate([t == encoder.end for t in targets])
    out = {
        "cases": len(cases),
        "prefixes": len(hits),
        "accuracy": float(hits.mean()),
        "accuracy_activities": float(hits[~ends].mean()) if (~ends).any() else None,
        "accuracy_end": float(hits[ends].mean()),
    }
    if rules is not None:
        masked = [
            np.where(allowed_next(rules, encoder.indices(c)), p, -np.inf).argmax(-1) == t
            for c, p, t in zip(cases, log_probs, targets, strict=True)
        ]
        out["accuracy_rules"] = float(np.concatenate(masked).mean())
    return out
