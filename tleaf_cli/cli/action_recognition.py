"""The action-recognition task: train-task action-recognition, and eval action-recognition,
learning-curve, choose-lambda and violations."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import (
    Quiet,
    Resume,
    exits,
    file_path,
    given_flags,
    preset_option,
    refuse,
    refuse_unused_lambda,
    targets,
)
from tleaf_cli.cli.options import TASK, given, setting_option, with_settings
from tleaf_cli.cli.runs import (
    EmbedderOption,
    Reference,
    RunOut,
    train_printing,
)
from tleaf_cli.settings.action_recognition import ReportSettings, TaskSettings

ReportDecoding = setting_option(ReportSettings, "decode")  # whose figures eval's table shows
TaskPreset = preset_option(TaskSettings)
DEFAULT_TASK_PRESET = TaskSettings.default_preset()


@exits
@with_settings(TASK)
def train_task_action_recognition(
    ctx: typer.Context,
    activities: Annotated[Path, typer.Argument(help="An activities.parquet (gen-activities).")],
    kb: Annotated[Path, typer.Option(help="The knowledge base (.ltl) the rule sets come from.")],
    embedder: EmbedderOption = None,
    out: RunOut = Path("run"),
    reference: Reference = None,
    preset: TaskPreset = DEFAULT_TASK_PRESET,
    resume: Resume = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """Train the action recognizer h with ℓ_task + λ·ℓ_logic; best val action accuracy is kept.

    Writes config.json, weights.pt and metrics.json (per epoch: task and logic loss, seconds,
    val action accuracy; test: action / ingredient / pair accuracy, violation fraction, and with
    --decode constrained the same under constrained decoding, with its time per video; the λ
    used and where it came from). Prints the λ and its source before the first epoch.
    """
    from tleaf_cli.tasks.action_recognition.train import train_action_recognition

    targets([activities, kb, embedder, reference], folders=[out])
    settings = TaskSettings.preset(preset, **given(ctx, values))
    if settings.decode != "constrained":
        refuse(given_flags(ctx, "decode_top_k"), "only with --decode constrained")
    why = "only with a logic loss or self-training (--unlabelled-loss), not --logic-loss none"
    refuse_unused_lambda(ctx, settings, why)
    title = f"training h ({settings.model}, {settings.logic_loss})"
    metrics = train_printing(
        train_action_recognition, (activities, kb, embedder), out, settings, title,
        resume=resume, reference=reference, quiet=quiet,
    )  # fmt: skip
    test = metrics["test"]
    ui.summary(
        f"{out}: test action {100 * test['action_accuracy']:.2f}%, ingredient "
        f"{100 * test['ingredient_accuracy']:.2f}%, pair {100 * test['pair_accuracy']:.2f}%, "
        f"violating {100 * test['violation_fraction']:.1f}% of videos (best epoch "
        f"{metrics['best']['epoch']}, {metrics['mean_epoch_seconds']:.2f} s/epoch)",
        quiet,
    )
    if "constrained" in test:
        c = test["constrained"]
        ui.summary(
            f"constrained decoding: test action {100 * c['action_accuracy']:.2f}%, violating "
            f"{100 * c['violation_fraction']:.1f}% of videos, "
            f"{1000 * c['decode_seconds_per_video']:.1f} ms/video",
            quiet,
        )


@exits
def eval_action_recognition(
    runs: Annotated[list[Path], typer.Argument(help="train-task action-recognition run dirs.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path("report"),
    decode: ReportDecoding = ReportSettings.decode,
    quiet: Quiet = False,
) -> None:
    """Accuracy and violations per run; relative change against the same-seed reference run.

    Writes report.json, report.md and report.png (boxplots like the paper's Fig. 4B).
    """
    from tleaf_cli.tasks.action_recognition.evaluate import evaluate_runs

    targets(runs, [out / f"report.{ext}" for ext in ("json", "md", "png")], [out])
    report = evaluate_runs(runs, out, decode)
    ui.summary(
        f"{out}/report.md: {len(report['runs'])} runs, {len(report['pairs'])} compared with "
        "their reference",
        quiet,
    )


@exits
def eval_learning_curve(
    runs: Annotated[
        list[Path],
        typer.Argument(
            help="train-task action-recognition run dirs (--train-videos, --decode "
            "constrained), every size, with the reference (--logic-loss none)."
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path("curve"),
    sweep: Annotated[
        list[Path] | None,
        typer.Option(
            help="A run of the λ sweep (repeat): each model, loss and size's λ choice "
            "on val is shown."
        ),
    ] = None,
    measure: Annotated[
        Literal["action", "pair"],
        typer.Option(
            help="The accuracy of the curve and its data worth: of the action, or of the pair "
            "(action and ingredient: a recording's step and its recipe)."
        ),
    ] = "action",
    quiet: Quiet = False,
) -> None:
    """Accuracy against training videos per variant (loss x decoding): the gain over the
    same-seed reference, and the training videos the reference needs to match each variant.

    Writes curve.md, curve.json and curve.png (accuracy vs videos, log scale, mean ± s.e.).
    """
    from tleaf_cli.tasks.action_recognition.learning_curve import learning_curve

    sweep = sweep or []
    targets([*runs, *sweep], [out / f"curve.{ext}" for ext in ("json", "md", "png")], [out])
    result = learning_curve(runs, out, sweep, measure)
    ui.summary(
        f"{out}/curve.md: {len(result['runs'])} runs, {len(result['curve'])} (model, size, "
        f"variant) cells, {len(result['lambda_choices'])} λ choices",
        quiet,
    )


@exits
def eval_choose_lambda(
    runs: Annotated[
        list[Path],
        typer.Argument(
            help="train-task action-recognition run dirs of one model, loss and "
            "size that differ only in λ and seed."
        ),
    ],
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="Text file for the chosen λ.")
    ] = Path("lambda.txt"),
    quiet: Quiet = False,
) -> None:
    """The λ with the best mean val action accuracy (best epoch) over the runs' seeds; ties go
    to the smaller λ. Writes it to a text file, as %g prints it."""
    from tleaf_cli.tasks.action_recognition.learning_curve import choose_lambda_file

    targets(runs, [out])
    choice = choose_lambda_file(runs, out)
    table = ", ".join(
        f"{v['lambda']:g}: {100 * v['val_action_accuracy']:.2f}%" for v in choice["val"]
    )
    ui.summary(f"{out}: λ {choice['lambda']:g} (mean val action accuracy {table})", quiet)


@exits
def eval_violations(
    runs: Annotated[list[Path], typer.Argument(help="train-task action-recognition run dirs.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path("violations"),
    split: Annotated[
        list[str] | None,
        typer.Option(
            metavar="<train|val|test>",
            help="A split to read (repeat) \\[default: train and test]; train: the first "
            "train_videos videos of the train split, those the run trained on.",
        ),
    ] = None,
    quiet: Quiet = False,
) -> None:
    """Which rules each run's argmax outputs break, per split: the share of videos breaking an
    affordance rule, an ordering rule, any rule; the share of steps on forbidden pairs and the
    probability given them; P(rules hold) for the video's own rules and the whole knowledge base.

    Writes violations.json and violations.md.
    """
    from tleaf_cli.tasks.action_recognition.violations import DEFAULT_SPLITS, violation_report

    targets(runs, [out / "violations.json", out / "violations.md"], [out])
    with ui.progress("reading the runs' outputs", quiet):
        report = violation_report(runs, out, split or DEFAULT_SPLITS)
    ui.summary(
        f"{out}/violations.md: {len(runs)} runs, splits {', '.join(report['splits'])}", quiet
    )
