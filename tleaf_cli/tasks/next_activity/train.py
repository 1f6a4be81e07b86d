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

import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.nn import functional as F

from tleaf_cli.data.event_logs import Case, Cases, read_cases
from tleaf_cli.errors import InputError, SettingError
from tleaf_cli.settings.next_activity import MODEL_NAMES, NextActivitySettings
from tleaf_cli.tasks.case_checks import read_case_rules
from tleaf_cli.tasks.next_activity.batch import PAD, CaseBatch
from tleaf_cli.tasks.next_activity.encoding import Encoder
from tleaf_cli.tasks.next_activity.model import NextActivityLSTM, NextActivityModel
from tleaf_cli.tasks.next_activity.objective import logic_term
from tleaf_cli.tasks.next_activity.prefix_table import PrefixTable
from tleaf_cli.tasks.next_activity.rules import Rules, allowed_next, read_rules
from tleaf_cli.tasks.next_activity.transformer import NextActivityTransformer
from tleaf_cli.training.loop import Step, chunks
from tleaf_cli.training.task import EpochRecord, LossSetup, RunInputs, TaskTrainer, train_task

__all__ = ["EpochRecord", "NextActivityTrainer", "train_next_activity"]


class NextActivityTrainer(TaskTrainer[CaseBatch, NextActivitySettings]):
    """The next-activity model (Tax et al.'s LSTM, or a small causal Transformer) on a cases
    artifact's train split, scored on val and test by next-activity accuracy pooled over
    prefixes."""

    kind = "next-activity"
    task = "next-activity"
    score = "val_accuracy"

    def __init__(
        self, inputs: RunInputs, settings: NextActivitySettings, device: torch.device
    ) -> None:
        super().__init__(inputs, settings, device)
        cases = read_cases(inputs.data)
        self.splits = {
            s: [c for c in cases.cases if c.split == s] for s in ("train", "val", "test")
        }
        # no test split is allowed: a protocol's test cases may be another file (eval CASES)
        empty = [s for s in ("train", "val") if not self.splits[s]]
        if empty:
            raise InputError(f"{inputs.data}: no cases in split(s) {', '.join(empty)}")
        check_predicted_attributes(cases, settings.attribute_names, self.splits["train"])
        self.encoder = Encoder.fit(
            cases,
            attributes=settings.attribute_names,
            inputs=settings.input_names,
            numeric_inputs=settings.numeric_input_names,
        )
        self.arrays: dict = {}  # each case's arrays, built once
        self.rules: Rules | None = None
        self.embedder = None
        longest = settings.max_events
        self.cut = sum(len(c) > longest for c in self.splits["train"]) if longest else 0
        train = self.splits["train"]
        if settings.logic_loss != "none" and self.cut == len(train):  # it reads whole cases
            raise SettingError(
                "max_events",
                f"cuts every training case (the shortest has {min(len(c) for c in train)} "
                f"events, more than {longest}): the logic loss reads whole cases only, and "
                "would read none",
            )

    def setup(self) -> LossSetup:
        # λ = 0 (the reference candidate of a λ choice) trains without the logic term: the same
        # updates as 0 · ℓ_logic, without computing ℓ_logic (nor reading the rules and q for it)
        settings, kb = self.settings, self.inputs.kb
        self.logic = "none" if settings.lam == 0 else settings.logic_loss
        if kb is not None and self.logic != "none":
            refuse_attribute_rules(kb)
            self.rules = read_rules(kb, self.encoder.atoms, log_atoms=self.encoder.names())
        if self.logic != "tleaf":
            return LossSetup()
        from tleaf_cli.embed.load import load_embedder

        embedder_dir = self.inputs.embedder
        self.embedder = load_embedder(embedder_dir)
        missing = sorted(self.rules.atoms - set(self.embedder.vectors.index))
        if missing:  # q could not embed the conjunction: the loss would teach nothing
            raise SettingError(
                "embedder",
                f"{embedder_dir} was not trained on the atoms {', '.join(missing[:5])}"
                f"{' and more' if len(missing) > 5 else ''} of the rules: train q on formulas "
                "over this log's activities",
            )
        self.embedder.model.to(self.device)
        return LossSetup(recommended_lambda=self.embedder.recommended_lambda)

    def model(self) -> NextActivityModel:
        train = [self.encoder.indices(c) for c in self.splits["train"]]
        try:
            check_model_fits(self.encoder, self.settings, self.device)
            self.net = new_model(self.encoder, self.settings, train).to(self.device)
        except (MemoryError, RuntimeError) as e:  # torch's out of memory is a RuntimeError
            if not isinstance(e, MemoryError | torch.OutOfMemoryError) and "alloc" not in str(e):
                raise
            raise SettingError(
                "hidden", f"{model_size(self.settings)} does not fit in memory"
            ) from None
        return self.net

    def batches(self, epoch: int, generator: torch.Generator) -> Iterator[CaseBatch]:
        longest = self.settings.max_events
        for part in chunks(self.splits["train"], self.settings.batch_size, generator):
            if not longest or all(len(c) <= longest for c in part):
                yield CaseBatch.of(part, self.encoder, self.device, self.arrays)
                continue
            CaseBatch.of(part, self.encoder, self.device, self.arrays)  # fills the cache
            parts = [tuple(a[:longest] for a in self.arrays[c.case_id]) for c in part]
            yield CaseBatch.of_parts(parts, part, self.device)

    def step(self, batch: CaseBatch) -> Step:
        h = self.net.states(batch.activities, batch.times, batch.lengths, batch.attributes)
        logits = self.net.out(h)
        task = F.cross_entropy(logits.flatten(0, 1), batch.targets.flatten(), ignore_index=PAD)
        logged = {}
        if self.encoder.attributes:  # the next event's values, given its activity
            values = attribute_loss(self.net.heads(h, batch.targets), batch.attribute_targets)
            task = task + values
            logged["attribute_loss"] = values.item()
        term = logic_term(self.logic, batch, logits, self.rules, self.embedder).mean()
        loss = task + self.settings.lam * term
        return Step(loss, {"task_loss": task.item(), "logic_loss": term.item(), **logged})

    def validate(self) -> float:
        return accuracy(
            self.net, self.encoder, self.splits["val"], 256, self.device, cache=self.arrays
        )["accuracy"]

    def test(self) -> dict[str, Any]:
        if not self.splits["test"]:  # scored by eval on another file
            return {"cases": 0}
        out = accuracy(
            self.net, self.encoder, self.splits["test"], self.settings.batch_size, self.device
        )
        return out | attribute_accuracy(
            self.net, self.encoder, self.splits["test"], self.settings.batch_size, self.device
        )

    def metrics(self) -> dict[str, Any]:
        return {
            "cases": {s: len(part) for s, part in self.splits.items()},
            "train_cases_cut": self.cut,
            "rule_states": None if self.rules is None else self.rules.states,
            # rules naming activities the log never has (read as never happening)
            "rules_unseen": None if self.rules is None else self.rules.unseen,
        }

    def config(self) -> dict[str, Any]:
        return {"encoder": self.encoder.as_dict()}


def train_next_activity(
    cases_path: str | Path,
    kb_path: str | Path | None,
    embedder_dir: str | Path | None,
    out_dir: str | Path,
    settings: NextActivitySettings,
    on_epoch=None,
    resume: bool = False,
    on_setup=None,
    reference: str | Path | None = None,
) -> dict:
    """Train on the train split, keep the best val epoch, score it on test; the metrics.

    `kb_path`: the rules of the logic loss (a `.ltl`, all its rules conjoined); needed with a
    logic loss, refused without one. `embedder_dir`: q, for the tleaf loss only. With
    `settings.lambdas`, one run per candidate λ and 0, the best on val kept; `reference`: a
    finished λ-0 run of the same settings and cases (another loss's) taken as the λ-0
    candidate, not trained again. The run (`training.task.train_task`) and its folder
    (`training.run_folder`) are every task's. SettingError for settings that do not fit,
    InputError for inputs."""
    settings.check()
    if settings.logic_loss != "none" and kb_path is None:
        raise SettingError("kb", f"the {settings.logic_loss} loss needs rules (a .ltl file)")
    if settings.logic_loss == "none" and kb_path is not None:
        raise SettingError("kb", "rules weigh nothing without a logic loss")
    if settings.logic_loss == "tleaf" and embedder_dir is None:
        raise SettingError("embedder", "the tleaf loss needs an embedder (a train-meta folder)")
    if settings.logic_loss != "tleaf" and embedder_dir is not None:
        raise SettingError("embedder", "only the tleaf loss reads q")
    inputs = RunInputs(
        Path(cases_path),
        None if kb_path is None else Path(kb_path),
        None if embedder_dir is None else Path(embedder_dir),
    )
    return train_task(
        NextActivityTrainer, inputs, out_dir, settings, on_epoch, resume, on_setup, reference
    )


def check_predicted_attributes(
    cases: Cases, attributes: Sequence[str], train: Sequence[Case]
) -> None:
    """SettingError for an attribute the model is to predict (`attributes`) that gives it
    nothing to predict: a case attribute (one value per case, none per event), or an event
    attribute no training event after a case's first has (Sepsis' Diagnose, written on the
    first event only: a value of the case). Either is read, not predicted: as an input."""
    for name in attributes:
        if name not in cases.attribute_names and name in cases.case_attribute_names:
            raise SettingError(
                "attributes",
                f"{name!r} is a case attribute of {cases.path} (one value per case, none per "
                f"event to predict): read it as an input instead (inputs case:{name})",
            )
        if name not in cases.attribute_names:
            continue  # Encoder.fit names those the cases keep
        if not any(v is not None for c in train for v in c.attributes[name][1:]):
            first = sum(c.attributes[name][0] is not None for c in train if len(c))
            raise SettingError(
                "attributes",
                f"{name!r} has no value on any training event after a case's first ({first} "
                "first events have one): nothing to predict, it is a value of the case; read "
                f"it as an input instead (inputs {name})",
            )


def model_size(settings: NextActivitySettings) -> str:
    """The model's shape in words, for a refusal: "an LSTM of 2 layer(s) of 100 units"."""
    return f"{MODEL_NAMES[settings.model]} of {settings.layers} layer(s) of {settings.hidden} units"


def check_model_fits(
    encoder: Encoder, settings: NextActivitySettings, device: torch.device
) -> None:
    """SettingError where training the model would need more memory than the machine (or the
    GPU) has: its parameters, counted on torch's meta device (nothing allocated), at 4 bytes
    each, four times (weights, gradients, Adam's two moments), before any activation. Without
    it, a model of 200,000 units fails deep inside torch's allocator, or starts swapping."""
    if settings.model == "prefix-table":
        return  # counted from the cases, no parameters
    with torch.device("meta"):
        parameters = sum(p.numel() for p in new_model(encoder, settings).parameters())
    needed, available = 4 * 4 * parameters, memory_of(device)
    if available is not None and needed > available:
        raise SettingError(
            "hidden",
            f"{model_size(settings)} has {parameters:,} parameters, {needed / 2**30:,.1f} GiB to "
            "train (weights, gradients and Adam's moments at 4 bytes each), more than the "
            f"{available / 2**30:,.1f} GiB of memory of the {device.type}: make it smaller",
        )


def memory_of(device: torch.device) -> int | None:
    """The memory of `device` in bytes (the machine's RAM for the CPU); None where unknown."""
    if device.type == "cuda":
        return torch.cuda.mem_get_info(device)[1]
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # not a POSIX system
        return None


def refuse_attribute_rules(kb: Path) -> None:
    """SettingError where the knowledge base names attribute values (`attribute_atom`'s double
    _, which no activity atom holds): the logic loss reads a soft trace of activities, so such
    rules apply at decoding only (eval next-activity --rules)."""
    named = sorted({a for rule in read_case_rules(kb) for a in rule.atoms if "__" in a})
    if named:
        raise SettingError(
            "kb",
            f"{kb} names attribute values ({', '.join(named[:3])}"
            f"{', ...' if len(named) > 3 else ''}): the logic loss reads the activities' soft "
            "trace only; rules on attributes apply at decoding (the evaluation's rules)",
        )


def new_model(
    encoder: Encoder,
    settings: NextActivitySettings,
    train: Sequence[Sequence[int]] = (),
) -> NextActivityModel:
    """An untrained model of `settings`' kind and shape over the encoder's activities (the
    prefix table: counted from `train`, the training cases as activity indices)."""
    if settings.model == "prefix-table":
        return PrefixTable(train, len(encoder.atoms))
    values = encoder.value_counts
    if settings.model == "transformer":
        return NextActivityTransformer(
            len(encoder.atoms), encoder.feature_count, settings.hidden, settings.layers,
            settings.heads, settings.dropout, value_counts=values,
        )  # fmt: skip
    return NextActivityLSTM(
        len(encoder.atoms), encoder.feature_count, settings.hidden, settings.layers,
        settings.dropout, values,
    )  # fmt: skip


def attribute_loss(logits: Sequence[torch.Tensor], targets: torch.Tensor) -> torch.Tensor:
    """Cross-entropy of the next event's values: per attribute k, logits[k] [B, T, R_k + 1]
    against targets [B, T, K] (PAD ignored), the mean over the scored steps, summed over the
    attributes; 0 where no step has a value to predict."""
    total = targets.new_zeros((), dtype=torch.float32)
    for k, scores in enumerate(logits):
        target = targets[..., k].flatten()
        scored = (target != PAD).sum()
        if scored:
            ce = F.cross_entropy(scores.flatten(0, 1), target, ignore_index=PAD, reduction="sum")
            total = total + ce / scored
    return total


def attribute_accuracy(
    model: NextActivityModel,
    encoder: Encoder,
    cases: Sequence[Case],
    batch_size: int,
    device: torch.device,
) -> dict:
    """Per event attribute, `accuracy_<attribute>`: how often the most probable value of the
    next event, given its true activity, is its value (over the steps whose next event has a
    value training knows); nothing without attributes."""
    if not encoder.attributes:
        return {}
    hits = [[] for _ in encoder.attributes]
    model.eval()
    with torch.no_grad():
        for i in range(0, len(cases), batch_size):
            batch = CaseBatch.of(cases[i : i + batch_size], encoder, device)
            h = model.states(batch.activities, batch.times, batch.lengths, batch.attributes)
            for k, scores in enumerate(model.heads(h, batch.targets)):
                target = batch.attribute_targets[..., k]
                scored = target != PAD
                hits[k].append((scores.argmax(-1) == target)[scored].cpu().numpy())
    out = {}
    for name, parts in zip(encoder.attributes, hits, strict=True):
        joined = np.concatenate(parts) if parts else np.zeros(0, dtype=bool)
        out[f"accuracy_{name}"] = float(joined.mean()) if len(joined) else None
    return out


def step_log_probs(
    model: NextActivityModel,
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
            log_probs = torch.log_softmax(batch.logits(model), dim=-1).cpu().numpy()
            out += [log_probs[b, :n] for b, n in enumerate(batch.lengths.tolist())]
    return out


def accuracy(
    model: NextActivityModel,
    encoder: Encoder,
    cases: Sequence[Case],
    batch_size: int,
    device: torch.device,
    rules: Rules | None = None,
    cache: dict | None = None,
    seen: np.ndarray | None = None,
) -> dict:
    """Next-activity accuracy pooled over every prefix of length ≥ 1 of `cases` (the end of case
    a target), and its parts: on activities and on the end. With `rules`, also
    `accuracy_rules`: each prediction the most probable token that keeps the rules
    satisfiable (`allowed_next`), and `changed_by_rules`: how many predictions that changed.
    With `seen` (bool per prefix, in order: `prefix_table.seen_in_training`), `leakage`: the
    share of prefixes seen in training with their next token, and `accuracy_unseen`."""
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
    if seen is not None:  # example leakage: prefixes (with their next token) seen in training
        out["leakage"] = float(seen.mean())
        out["accuracy_unseen"] = float(hits[~seen].mean()) if (~seen).any() else None
    if rules is not None:
        under = [
            np.where(allowed_next(rules, encoder.indices(c)), p, -np.inf).argmax(-1)
            for c, p in zip(cases, log_probs, strict=True)
        ]
        out["accuracy_rules"] = float(
            np.concatenate([u == t for u, t in zip(under, targets, strict=True)]).mean()
        )
        # equal accuracies do not show that the rules changed nothing: count the changes
        out["changed_by_rules"] = int(
            sum((u != p.argmax(-1)).sum() for u, p in zip(under, log_probs, strict=True))
        )
    return out
