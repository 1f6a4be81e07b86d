"""What the command line prints of a sequence task's training run (`train-task action-recognition`,
`train-task next-activity`): the λ before the first epoch, one line per epoch, the λ chosen on
validation, and a warning before a finished run's folder is trained over."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import typer

from tleaf_cli import ui

# the options every sequence task's train-task command takes besides its data and rules
EmbedderOption = Annotated[
    Path | None,
    typer.Option("--embedder", help="q: a train-meta directory (needed for --logic-loss tleaf)."),
]
RunOut = Annotated[Path, typer.Option("--out", "-o", help="Run directory to write.")]
Reference = Annotated[
    Path | None,
    typer.Option(
        "--reference",
        help="With --lambdas: a finished λ-0 run of the same settings and data (the "
        "--logic-loss none run of the same seed, or another loss's λ-0 candidate), taken as the "
        "λ-0 candidate instead of training it again.",
    ),
]


def warn_replacing(out: Path, resume: bool, quiet: bool) -> None:
    """Say so before a new run replaces the finished run in `out` (not when resuming it)."""
    from tleaf_cli.training.run_folder import finished_run

    if not resume and finished_run(out):
        ui.summary(f"warning: {out} holds a finished run; this run replaces it", quiet)


@contextmanager
def run_printers(title: str, epochs: int, quiet: bool) -> Iterator[tuple[Callable, Callable]]:
    """A progress bar titled `title` and the run's (on_setup, on_epoch) callbacks."""

    def on_setup(setup) -> None:  # before the first epoch (every candidate's, with --lambdas)
        ui.summary(setup.lam.text(given="given with --lambda"), quiet)
        if setup.coverage is not None and setup.coverage.left_out:
            ui.summary(f"warning: {setup.coverage.left_out_text()}", quiet)

    with ui.progress(title, quiet) as update:

        def on_epoch(r) -> None:
            update(r.epoch, epochs)
            figures = ", ".join(
                f"{name.removesuffix('_loss')} {value:.4f}"
                for name, value in r.figures.items()
                if value or name != "unlabelled_loss"  # self-training's, only where it trains
            )
            score = r.score_name.replace("_", " ").replace("accuracy", "acc")
            ui.summary(
                f"epoch {r.epoch}: {figures}, {score} {r.score:.4f} ({r.seconds:.1f} s)", quiet
            )

        yield on_setup, on_epoch


def train_printing(
    train: Callable[..., dict[str, Any]],
    inputs: tuple,
    out: Path,
    settings: Any,
    title: str,
    *,
    resume: bool,
    reference: Path | None,
    quiet: bool,
) -> dict[str, Any]:
    """`train(*inputs, out, settings, on_epoch, resume=, on_setup=, reference=)` (a task's
    trainer) with its progress printed: a warning before a finished run is replaced, the λ, a
    line per epoch, the λ chosen on validation. Its metrics."""
    warn_replacing(out, resume, quiet)
    with run_printers(title, settings.epochs, quiet) as (on_setup, on_epoch):
        metrics = train(
            *inputs, out, settings, on_epoch, resume=resume, on_setup=on_setup,
            reference=reference,
        )  # fmt: skip
    print_choice(metrics, quiet)
    return metrics


def print_choice(metrics: dict[str, Any], quiet: bool) -> None:
    """The λ chosen on validation, with every candidate's val score (runs with --lambdas)."""
    from tleaf_cli.training.lambdas import LambdaChoice

    if metrics["lambda"]["source"] == "validation":
        ui.summary(LambdaChoice(**metrics["lambda"]).text(), quiet)
