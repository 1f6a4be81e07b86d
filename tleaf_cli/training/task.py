"""One training run of a sequence task, the same for every task: `train_task` reads nothing of a
task's own and a `TaskTrainer` holds only what is the task's — its data, model, batches, step
and scoring.

A run, top to bottom:

1. the settings checked (`settings.check()`), the folder writable, `--reference` checked
   against this run before anything trains; with `lambdas`, one run per candidate λ and the
   best on val kept (`lambdas.train_choosing_lambda`), each run this same function;
2. the task reads its data (`TaskTrainer.__init__`) and sets up its loss (`setup`: rules, q);
3. the λ (`lambdas.resolve_lambda`: given, q's recommended, the task's
   `DEFAULT_LAMBDA`, or unused), told to the caller (`on_setup`) before the first update;
4. torch seeded with the run's seed, then the model built: runs that differ only in their loss
   start from the same weights;
5. the epochs (`loop.fit`): the run's identity (settings, inputs' sha256s, embedder) is kept in
   the checkpoint, and `resume` continues only the same run (`run_folder.check_same_run`);
6. the best epoch scored on test, and config.json and metrics.json written (each whole or not
   at all), config.json naming the data and the knowledge base by path and sha256, so that
   evaluation reads the rules the run trained with.
"""

from __future__ import annotations

import json
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any, ClassVar, Generic, TypeVar

import numpy as np
import torch

from tleaf_cli.data.artifacts import check_writable, describe_inputs, relative_to, write_text_atomic
from tleaf_cli.errors import SettingError
from tleaf_cli.settings.training import TrainingSettings
from tleaf_cli.training.lambdas import RunSetup, resolve_lambda, train_choosing_lambda
from tleaf_cli.training.loop import WEIGHTS, LoopSettings, Step, device_for, fit, save_atomic
from tleaf_cli.training.model_choice import train_choosing_settings
from tleaf_cli.training.q_coverage import QCoverage
from tleaf_cli.training.run_folder import CONFIG, METRICS, run_identity

B = TypeVar("B")  # a task's training batch
S = TypeVar("S", bound=TrainingSettings)


@dataclass(frozen=True)
class EpochRecord:
    """One finished epoch as a run's caller hears it: each step figure's mean over the epoch
    (`figures`: task_loss, logic_loss, ...), its training seconds (without evaluation), and
    the val score that chooses the best epoch, `score` by name."""

    epoch: int
    seconds: float
    score_name: str
    score: float
    figures: dict[str, float]


@dataclass(frozen=True)
class RunInputs:
    """The files a run reads: its data (cases, videos), the knowledge base of its logic loss
    (None without one), the q of the tleaf loss (None without it)."""

    data: Path
    kb: Path | None = None
    embedder: Path | None = None


@dataclass(frozen=True)
class LossSetup:
    """What a task's loss set-up tells the run: the λ q recommends (the tleaf loss), and how
    much of the knowledge base q can read."""

    recommended_lambda: float | None = None
    coverage: QCoverage | None = None


class TaskTrainer(ABC, Generic[B, S]):
    """A task's part of a run. Built on the run's settings and inputs, it reads its data (and
    raises InputError for data it cannot train on); then `setup` prepares its loss, and
    `model`, `batches`, `step`, `validate`, `test` are called in that order."""

    kind: ClassVar[str]  # config.json's "kind": what `eval` reads the folder as
    task: ClassVar[str]  # metrics.json's "task"
    score: ClassVar[str]  # the val score's name in the records (higher is better)

    def __init__(self, inputs: RunInputs, settings: S, device: torch.device) -> None:
        self.inputs, self.settings, self.device = inputs, settings, device

    @abstractmethod
    def setup(self) -> LossSetup:
        """Read the rules and q the loss needs (`self.settings.lam` as given: 0 needs none)."""

    @abstractmethod
    def model(self) -> torch.nn.Module:
        """The untrained model on the run's device, kept for `validate` and `test` (torch is
        seeded just before: the same model for every loss)."""

    @abstractmethod
    def batches(self, epoch: int, generator: torch.Generator) -> Iterable[B]:
        """The epoch's training batches, shuffled by `generator`."""

    @abstractmethod
    def step(self, batch: B) -> Step:
        """The batch's loss, ℓ_task + λ·ℓ_logic at `self.settings.lam`, and its figures."""

    @abstractmethod
    def validate(self) -> float:
        """The val score of the model as it is now."""

    @abstractmethod
    def test(self) -> dict[str, Any]:
        """The best epoch's test figures."""

    def metrics(self) -> dict[str, Any]:
        """The task's own entries of metrics.json."""
        return {}

    def config(self) -> dict[str, Any]:
        """The task's own entries of config.json (what `eval` needs to rebuild the model)."""
        return {}


def train_task(
    trainer: type[TaskTrainer],
    inputs: RunInputs,
    out_dir: str | Path,
    settings: TrainingSettings,
    on_epoch: Callable[[EpochRecord], None] | None = None,
    resume: bool = False,
    on_setup: Callable[[RunSetup], None] | None = None,
    reference: str | Path | None = None,
) -> dict[str, Any]:
    """Train a `trainer` run on `inputs` into `out_dir`; returns the metrics written.

    With `settings.grid`, one run per combination of its values, the best on val kept
    (`model_choice`); with `settings.lambdas`, one run per candidate λ and 0, the best on val kept;
    `reference`: a finished λ-0 run of the same settings and data taken as the λ-0 candidate,
    not trained again (checked before any training). SettingError for settings that do not
    fit, InputError for inputs."""
    settings.check()
    out_dir = Path(out_dir)
    check_writable(out_dir / METRICS)
    if reference is not None and settings.lambdas is None:
        raise SettingError("reference", "is the λ-0 candidate of a choice: give lambdas too")
    if settings.grid is not None:

        def grid_candidate(folder: Path, one: TrainingSettings) -> dict[str, Any]:
            return train_task(trainer, inputs, folder, one, on_epoch, resume, on_setup)

        return train_choosing_settings(grid_candidate, out_dir, settings, trainer.score, resume)
    if settings.lambdas is not None:

        def candidate(folder: Path, one: TrainingSettings, hear) -> dict[str, Any]:
            return train_task(trainer, inputs, folder, one, on_epoch, resume, hear)

        metrics = train_choosing_lambda(
            candidate, out_dir, settings, on_setup, trainer.score, reference, inputs.data
        )
        # the chosen candidate may be a reference trained without rules: this run names its own
        config = json.loads((out_dir / CONFIG).read_text())
        config.update(_named_inputs(inputs, _described(inputs)))
        write_text_atomic(out_dir / CONFIG, json.dumps(config, indent=2))
        return metrics
    device = device_for(settings.device)
    task = trainer(inputs, settings, device)
    setup_start = time.perf_counter()
    loss = task.setup()
    lam = resolve_lambda(settings, loss.recommended_lambda)
    settings = task.settings = replace(settings, lam=lam.value)
    if on_setup is not None:
        on_setup(RunSetup(lam, loss.coverage))
    setup_seconds = time.perf_counter() - setup_start

    torch.manual_seed(settings.seed)  # after q is loaded: the model starts the same for every loss
    model = task.model()
    described = _described(inputs)  # each input hashed once: identity and config.json

    def record(values: dict[str, Any]) -> None:
        figures = {k: v for k, v in values.items() if k not in ("epoch", "seconds", trainer.score)}
        on_epoch(
            EpochRecord(values["epoch"], values["seconds"], trainer.score, values[trainer.score],
                        figures)
        )  # fmt: skip

    if any(p.requires_grad for p in model.parameters()):
        run = fit(
            model,
            task.batches,
            task.step,
            task.validate,
            LoopSettings.of(settings),
            out_dir,
            score=trainer.score,
            resume=resume,
            on_epoch=None if on_epoch is None else record,
            identity=run_identity(settings, described, inputs.embedder),
        )
    else:  # nothing to train (a count, e.g. next activity's prefix table): scored as it is
        model.eval()
        with torch.no_grad():
            run = {"best": {"epoch": 0, trainer.score: task.validate()}, "history": []}
        out_dir.mkdir(parents=True, exist_ok=True)
        save_atomic(model.state_dict(), out_dir / WEIGHTS)
    history = run["history"]
    metrics = {
        "task": trainer.task,
        "logic_loss": getattr(settings, "logic_loss", "none"),
        "seed": settings.seed,
        **task.metrics(),
        "history": history,
        "best": run["best"],
        "mean_epoch_seconds": float(np.mean([h["seconds"] for h in history])) if history else 0.0,
        "setup_seconds": setup_seconds,
        "test": task.test(),
        "lambda": lam.as_dict(),
    }
    config = {
        "kind": trainer.kind,
        "settings": asdict(settings),
        **task.config(),
        **_named_inputs(inputs, described),
        # absolute, and relative to this folder (docs/artifacts.md: portable run folders)
        "embedder": None if inputs.embedder is None else str(Path(inputs.embedder).resolve()),
        "embedder_relative": None
        if inputs.embedder is None
        else relative_to(out_dir, inputs.embedder),
    }
    write_text_atomic(out_dir / CONFIG, json.dumps(config, indent=2))
    write_text_atomic(out_dir / METRICS, json.dumps(metrics, indent=2))
    return metrics


def _described(inputs: RunInputs) -> list[dict[str, str]]:
    """The run's input files (the data, then the knowledge base) with their sha256s."""
    return describe_inputs([p for p in (inputs.data, inputs.kb) if p is not None])


def _named_inputs(inputs: RunInputs, described: list[dict[str, str]]) -> dict[str, Any]:
    """config.json's record of a run's inputs (`_described`): as a list (data, knowledge
    base), and by role (`run_folder.recorded_input` reads them back)."""
    return {
        "inputs": described,
        "trained_on": {"data": described[0], "kb": described[1] if inputs.kb else None},
    }
