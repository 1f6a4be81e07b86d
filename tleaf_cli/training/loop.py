"""The one training loop of tleaf's models (the edge and meta embedders, every sequence task
through `training.task`), and the helpers every trainer shares (`chunks`, `device_for`).

A trainer gives `fit` what is its own: `batches(epoch, generator)`, the epoch's training batches
(shuffled by `generator`); `step(batch)`, the batch's loss and the figures to report (a `Step`;
the triplet loss of the embedders, ℓ_task + λ·ℓ_logic of the action recognizer); `evaluate()`,
the validation score that chooses the best epoch. The loop does the rest, the same for all:

* Adam on the trainable parameters, the learning rate constant or on a cosine schedule;
* per epoch a record: the epoch, each step figure's mean over the epoch, `seconds` (training time
  of the epoch, without evaluation) and the score under its name (e.g. `val_action_accuracy`);
* the best epoch's weights kept; stop after `epochs`, after `patience` epochs without a better
  score, or after the epoch that passes `max_minutes`; the model ends with the best weights,
  written to `weights.pt`;
* after every epoch `checkpoint.pt`: model, optimiser, schedule, history, best weights, epochs
  since the best, torch's RNG, and the run's `identity` (its settings and inputs, when the
  trainer gives one). `resume=True` continues from it, only the same run
  (`run_folder.check_same_run`), and ends with the weights and records (but `seconds`) of a run
  never interrupted: an epoch's batches depend only on the seed and the epoch (epoch e shuffles
  with seed · 100003 + e), everything else is in the checkpoint;
* a loss that is not finite (a learning rate too large) stops the run with `TrainingDiverged`,
  an interrupt (Ctrl-C) with `TrainingInterrupted`: each names the last epoch kept.

Both files are written atomically (a temporary file renamed over the target), so a crash
never leaves half a checkpoint; `on_epoch(record)` is called once the epoch's checkpoint is
written (the CLI's progress lines).
"""

from __future__ import annotations

import math
import os
import time
import zipfile
from collections.abc import Callable, Iterable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, NamedTuple, TypeVar

import torch

from tleaf_cli.data.artifacts import atomic_path
from tleaf_cli.errors import InputError, SettingError, TleafError
from tleaf_cli.settings import SCHEDULES
from tleaf_cli.training.run_folder import CHECKPOINT, check_same_run

B = TypeVar("B")  # a trainer's batch

WEIGHTS = "weights.pt"


class Step(NamedTuple):
    """What `step(batch)` gives the loop for one training batch."""

    loss: torch.Tensor  # minimised
    figures: dict[str, float]  # reported per epoch: the mean over its batches, weighted by:
    weight: int = 1  # the batch's weight in those means (the embedders: triplets in the batch)


class TrainingDiverged(TleafError):
    """The loss stopped being a finite number: the run cannot go on (a learning rate too large,
    a loss weight too large). The checkpoint holds the last finished epoch."""


class TrainingInterrupted(TleafError):
    """The run was interrupted (Ctrl-C) between two checkpoints."""

    exit_code = 130


@dataclass(frozen=True)
class LoopSettings:
    """Every setting of the loop."""

    epochs: int  # most epochs (a resumed run counts the epochs before it)
    patience: int | None  # epochs without a better score before stopping (None: never)
    lr: float  # Adam's learning rate
    seed: int  # the batches' order (and nothing else: the trainer seeds torch itself)
    max_minutes: float | None = None  # stop after the epoch that passes this budget
    schedule: str = "constant"  # or "cosine": the learning rate falls to 0 over `epochs`
    weight_decay: float = 0.0  # Adam's L2 penalty on the weights

    def __post_init__(self) -> None:
        for name in ("epochs", "patience"):
            if getattr(self, name) is not None and getattr(self, name) < 1:
                raise SettingError(name, f"must be at least 1, not {getattr(self, name)}")
        if self.schedule not in SCHEDULES:
            choices = ", ".join(SCHEDULES)
            raise SettingError("schedule", f"must be one of {choices}, not '{self.schedule}'")

    @classmethod
    def of(cls, settings: object) -> LoopSettings:
        """The loop's fields, taken from a trainer's settings object (defaults where it has
        none)."""
        return cls(
            **{f.name: getattr(settings, f.name) for f in fields(cls) if hasattr(settings, f.name)}
        )


def adam(
    parameters: list[torch.nn.Parameter], lr: float, weight_decay: float = 0.0
) -> torch.optim.Adam:
    """Adam as every trainer here uses it: torch's fused kernel, one pass over each tensor
    instead of a loop of small operations (on one CPU thread: 1.4 against 7.5 ms a step on a
    model of q_m's size, 5.6 against 24 ms on the model-checking MLP's 4 M parameters), the
    same updates as the loop to float rounding (2.4e-7 apart after 50 random steps)."""
    return torch.optim.Adam(parameters, lr=lr, weight_decay=weight_decay, fused=True)


class FlatParameters:
    """A model's trainable parameters as views of one tensor, and their gradients as views of
    another, so that Adam steps one tensor: torch's fused Adam on the CPU launches a handful of
    operators per parameter tensor (its step counters alone, five each), and q_m has 21.

    Backward adds each parameter's gradient into its view in place (a parameter whose `.grad`
    is set accumulates into it), `zero_grad` zeroes the one gradient tensor. The same updates
    as Adam over the separate tensors, element by element, provided every parameter gets a
    gradient in every step (Adam skips a parameter without one, and would not skip its view):
    `check` raises if one did not.
    """

    def __init__(self, parameters: list[torch.nn.Parameter]) -> None:
        first = parameters[0]
        total = sum(p.numel() for p in parameters)
        self.tensor = torch.empty(total, dtype=first.dtype, device=first.device)
        self.tensor.grad = torch.zeros_like(self.tensor)
        self.parameters = parameters
        self.reached: set[int] = set()
        offset = 0
        for p in parameters:
            view = self.tensor[offset : offset + p.numel()].view_as(p)
            view.copy_(p.detach())
            p.data = view
            p.grad = self.tensor.grad[offset : offset + p.numel()].view_as(p)
            p.register_post_accumulate_grad_hook(lambda q: self.reached.add(id(q)))
            offset += p.numel()

    def zero_grad(self) -> None:
        self.tensor.grad.zero_()
        self.reached.clear()

    def check(self) -> None:
        """Raise if some parameter got no gradient in this step."""
        if len(self.reached) < len(self.parameters):
            raise RuntimeError("a parameter got no gradient: train with flat=False")


def fit(
    model: torch.nn.Module,
    batches: Callable[[int, torch.Generator], Iterable[B]],
    step: Callable[[B], Step],
    evaluate: Callable[[], float],
    settings: LoopSettings,
    out_dir: Path,
    *,
    score: str,
    resume: bool = False,
    on_epoch: Callable[[dict[str, Any]], None] | None = None,
    flat: bool = False,
    identity: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Train `model` as `settings` say; returns {"best": {"epoch", score}, "history": records}.

    `batches(epoch, generator)`: the epoch's training batches; `step(batch)`: its `Step`;
    `evaluate()`: the validation score, higher better, named `score` in the records. The
    model's state_dict is what `weights.pt` and the checkpoint hold. `resume`: continue from
    out_dir's checkpoint when there is one. `on_epoch(record)`: after each epoch's checkpoint.
    `flat`: Adam over the parameters laid out as one tensor (`FlatParameters`), for a model
    whose every parameter gets a gradient in every step. `identity`: what makes this run this
    run (`run_folder.run_identity`), kept in the checkpoint; with it, `resume` refuses another
    run's checkpoint (InputError naming what differs).
    """
    start = time.perf_counter()
    out_dir.mkdir(parents=True, exist_ok=True)
    trainable = [p for p in model.parameters() if p.requires_grad]
    flat_parameters = FlatParameters(trainable) if flat and trainable else None
    optimiser = adam(
        trainable if flat_parameters is None else [flat_parameters.tensor],
        settings.lr,
        settings.weight_decay,
    )
    # cosine: stepped once per epoch, so a resumed run continues on the same curve
    scheduler = (
        torch.optim.lr_scheduler.CosineAnnealingLR(optimiser, T_max=settings.epochs)
        if settings.schedule == "cosine"
        else None
    )
    history: list[dict[str, Any]] = []
    best: dict[str, Any] = {"epoch": 0, score: float("-inf")}  # any epoch beats none
    best_weights = _snapshot(model)
    stale = 0  # epochs since the best one
    done = 0  # epochs trained
    checkpoint = out_dir / CHECKPOINT
    if resume and checkpoint.exists():
        history, best, best_weights, stale, done = _restore(
            checkpoint, model, optimiser, scheduler, identity
        )
    try:
        for epoch in range(done + 1, settings.epochs + 1):
            over_budget = settings.max_minutes is not None and (
                time.perf_counter() - start > 60 * settings.max_minutes
            )
            if (settings.patience is not None and stale >= settings.patience) or over_budget:
                break
            generator = torch.Generator().manual_seed(settings.seed * 100_003 + epoch)
            model.train()
            began = time.perf_counter()
            means = _train_epoch(
                batches(epoch, generator), step, optimiser, flat_parameters, epoch, checkpoint
            )
            if scheduler is not None:
                scheduler.step()
            seconds = time.perf_counter() - began
            model.eval()
            with torch.no_grad():
                value = evaluate()
            record = {"epoch": epoch, **means, "seconds": seconds, score: value}
            history.append(record)
            if value > best[score]:
                best = {"epoch": epoch, score: value}
                best_weights = _snapshot(model)
                stale = 0
            else:
                stale += 1
            save_atomic(
                {
                    "model": model.state_dict(),
                    "optimiser": optimiser.state_dict(),
                    "scheduler": scheduler.state_dict() if scheduler is not None else None,
                    "epoch": epoch,
                    "history": history,
                    "best": best,
                    "best_model": best_weights,
                    "stale": stale,
                    "torch_rng": torch.get_rng_state(),
                    "cuda_rng": torch.cuda.get_rng_state_all()
                    if torch.cuda.is_initialized()
                    else None,
                    "identity": identity,
                },
                checkpoint,
            )
            if on_epoch is not None:
                on_epoch(record)
    except KeyboardInterrupt:
        raise TrainingInterrupted(f"interrupted; {_kept(checkpoint)}") from None

    model.load_state_dict(best_weights)
    save_atomic(_on_cpu(best_weights), out_dir / WEIGHTS)
    return {"best": best, "history": history}


def _train_epoch(
    batches: Iterable[B],
    step: Callable[[B], Step],
    optimiser: torch.optim.Optimizer,
    flat_parameters: FlatParameters | None,
    epoch: int,
    checkpoint: Path,
) -> dict[str, float]:
    """One epoch's updates; each step figure's mean over the epoch (weighted by the batches'
    weights). TrainingDiverged when a batch's loss is not a finite number."""
    sums: dict[str, float] = {}
    seen = 0
    for batch in batches:
        loss, figures, weight = step(batch)
        if not math.isfinite(loss.item()):
            raise TrainingDiverged(
                f"the loss is {loss.item()} in epoch {epoch}: training diverged (lower the "
                f"learning rate or the loss's weight); {_kept(checkpoint)}"
            )
        if flat_parameters is None:
            optimiser.zero_grad()
            loss.backward()
        else:
            flat_parameters.zero_grad()
            loss.backward()
            flat_parameters.check()
        optimiser.step()
        for name, value in figures.items():
            sums[name] = sums.get(name, 0.0) + value * weight
        seen += weight
    return {name: total / max(seen, 1) for name, total in sums.items()}


def _kept(checkpoint: Path) -> str:
    """What an unfinished run leaves: the checkpoint of its last finished epoch, or nothing."""
    if checkpoint.exists():
        return f"the last finished epoch is in {checkpoint} (resuming continues from it)"
    return "no epoch finished, nothing was written"


def save_atomic(obj: object, path: Path) -> None:
    """`torch.save` to a temporary file beside `path`, then renamed over it: `path` is either
    the old file or the whole new one, never half of one."""
    tmp = atomic_path(path)
    try:
        torch.save(obj, tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _snapshot(model: torch.nn.Module) -> dict[str, torch.Tensor]:
    """A copy of the model's state_dict as it is now. Entries that share memory (q_m's one
    encoder under two names) share their copy too, so that `weights.pt` stores it once."""
    copies: dict[tuple, torch.Tensor] = {}
    out = {}
    for name, tensor in model.state_dict().items():
        key = (tensor.data_ptr(), tensor.dtype, tuple(tensor.shape), tensor.stride())
        if key not in copies:
            copies[key] = tensor.detach().clone()
        out[name] = copies[key]
    return out


def _on_cpu(weights: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
    """`weights` on the CPU, whatever device they were trained on, so that a model trained on a
    GPU loads on any machine; entries that share a tensor still share its copy."""
    copies: dict[int, torch.Tensor] = {}
    return {name: copies.setdefault(id(t), t.cpu()) for name, t in weights.items()}


def read_checkpoint(checkpoint: Path) -> dict[str, Any]:
    """The state `fit` saved in `checkpoint`; InputError naming the file when it is damaged
    (truncated, bytes changed, emptied) or not a checkpoint at all.

    torch.save writes a zip archive with a CRC-32 per member, which torch.load does not verify:
    a changed byte of a tensor loads as another weight, one of the pickle fails in any of a dozen
    ways (IndexError, AssertionError, torch's advice to load with weights_only=False). So the
    archive is verified first (`_damage`), and any failure to load what passes is damage too."""
    why = _damage(checkpoint)
    if why is None:
        try:
            state = torch.load(checkpoint, map_location="cpu", weights_only=True)
        except Exception:  # a damaged pickle fails in any type torch meets
            state = None
        why = None if isinstance(state, dict) else "its contents do not load"
    if why is not None:
        raise InputError(
            f"{checkpoint}: not a checkpoint, or a damaged one ({why}); delete it and train "
            "afresh without resuming"
        )
    return state


def _damage(checkpoint: Path) -> str | None:
    """What is wrong with `checkpoint` as a zip archive (the form torch.save writes), in
    words; None for a whole one, every member's bytes matching its CRC-32."""
    with checkpoint.open("rb") as file:  # a file that cannot be read: the OSError says why
        if file.seek(0, os.SEEK_END) == 0:
            return "an empty file"
        try:
            with zipfile.ZipFile(file) as archive:
                bad = archive.testzip()
        except Exception as e:  # a damaged archive fails in many types: a truncated one
            # BadZipFile or EOFError, a changed offset OSError (EINVAL), a changed name ...
            return f"not a whole archive: {type(e).__name__}"
    # a member's name starts with the name torch.save wrote the archive under (a temporary one)
    return None if bad is None else f"bytes changed in its {bad.partition('/')[2] or bad}"


def _restore(
    checkpoint: Path,
    model: torch.nn.Module,
    optimiser: torch.optim.Optimizer,
    scheduler: torch.optim.lr_scheduler.LRScheduler | None,
    identity: dict[str, Any] | None,
) -> tuple[list[dict[str, Any]], dict[str, Any], dict[str, torch.Tensor], int, int]:
    """Load a checkpoint into the model, optimiser, schedule and torch's RNG; returns the
    run's (history, best, best weights, epochs since the best, epochs trained). InputError
    for a file that is not a checkpoint of this model, or (with `identity`) of another run."""
    state = read_checkpoint(checkpoint)
    if identity is not None:
        check_same_run(checkpoint, state.get("identity"), identity)
    try:
        model.load_state_dict(state["model"])
        optimiser.load_state_dict(state["optimiser"])
        if scheduler is not None and state["scheduler"] is not None:
            scheduler.load_state_dict(state["scheduler"])
        torch.set_rng_state(state["torch_rng"])
        if state["cuda_rng"] is not None and torch.cuda.is_available():
            torch.cuda.set_rng_state_all(state["cuda_rng"])
        return (
            state["history"],
            state["best"],
            state["best_model"],
            state["stale"],
            state["epoch"],
        )
    except (KeyError, IndexError, AttributeError, TypeError, ValueError, RuntimeError) as e:
        first = (str(e).strip().splitlines() or [type(e).__name__])[0]
        raise InputError(
            f"{checkpoint}: not a checkpoint of this model and settings ({first}); "
            "train afresh without resuming"
        ) from None


def chunks(items: list, size: int, generator: torch.Generator) -> Iterable[list]:
    """`items` shuffled by `generator`, in lists of `size`."""
    order = torch.randperm(len(items), generator=generator).tolist()
    for i in range(0, len(order), size):
        yield [items[j] for j in order[i : i + size]]


def device_for(name: str) -> torch.device:
    """cpu or cuda (SettingError when cuda is asked for and absent)."""
    if name not in ("cpu", "cuda"):
        raise SettingError("device", f"must be cpu or cuda, not '{name}'")
    if name == "cuda" and not torch.cuda.is_available():
        raise SettingError("device", "cuda asked for, and no CUDA device is available here")
    return torch.device(name)
