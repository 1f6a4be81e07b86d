"""CaptainCook4D as step recognition: recording-activities (recordings and their recipes' task
graphs into an activities artifact that train-task action-recognition reads) and eval
step-recognition (a trained recogniser's steps checked against the recipes)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import Quiet, exits, file_path, targets
from tleaf_cli.cli.options import STEP_FEATURES, with_settings
from tleaf_cli.settings.procedures import StepFeatureSettings, TaskGraphSettings


@exits
@with_settings(STEP_FEATURES)
def recording_activities(
    recordings: Annotated[
        Path, typer.Argument(help="A recordings artifact (read-recordings' recordings.parquet).")
    ],
    graphs: Annotated[
        Path,
        typer.Argument(help="The recipes' task graphs: a folder of them (or one graph file)."),
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            parser=file_path,
            show_default=False,
            help="Where to write the activities artifact.",
        ),
    ] = Path("activities.parquet"),  # not shown: too wide for the help's column
    kb_out: Annotated[
        Path,
        typer.Option(
            "--kb-out", parser=file_path, help="The knowledge base (.ltl) over the steps' atoms."
        ),
    ] = Path("kb.ltl"),
    quiet: Quiet = False,
    **values,
) -> None:
    """Recordings as an activities artifact for train-task action-recognition, real step
    orders, durations and splits with drawn features, and the task graphs as its knowledge base.

    A step is (s<node>, recipe): atom s3_coffee, the rules task-graph gives over those atoms.
    Each step's feature is the mean of its frames, one per frame-seconds of its duration, each
    frame its step's mean (drawn once per step of every graph) plus Gaussian noise.
    """
    from tleaf_cli.tasks.step_recognition.activities import recording_activities as convert

    targets([recordings, graphs], [out, kb_out])
    feature_values, rule_values = STEP_FEATURES.split(values)
    features, rules = StepFeatureSettings(**feature_values), TaskGraphSettings(**rule_values)
    rules.check()
    report = convert(
        recordings, graphs, out, kb_out, features, rules.at_most_once, rules.last_step_ends
    )
    per_split = ", ".join(f"{k} {n}" for k, n in sorted(report.videos.items()))
    extra = sum(len(u) for u in report.not_in_graph.values())
    skipped = ", ".join(f"{n} {k}" for k, n in report.skipped.items()) or "nothing"
    ui.summary(
        f"{out}: {sum(report.videos.values())} recordings ({per_split}), {report.steps} steps "
        f"({extra} step texts not in their graph); {kb_out}: {report.rules} rules; "
        f"skipped: {skipped}",
        quiet,
    )


@exits
def eval_step_recognition(
    runs: Annotated[
        list[Path],
        typer.Argument(help="train-task action-recognition runs on recording-activities data."),
    ],
    checks: Annotated[
        Path,
        typer.Option(
            "--checks",
            help="check-recordings' checks.parquet: which recordings break their recipe's rules.",
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path(
        "step_recognition"
    ),
    quiet: Quiet = False,
) -> None:
    """Test step accuracy of each run decoded by argmax, under the rules, and with the rules as
    a weighted prior (soft; its weight chosen on the val recordings), on all test recordings and
    on those that keep and that break their recipe's rules.

    Writes step_recognition.json and step_recognition.md.
    """
    from tleaf_cli.tasks.step_recognition.evaluate import (
        JSON_FILE,
        MARKDOWN_FILE,
        evaluate_step_recognition,
    )

    targets([*runs, checks], [out / JSON_FILE, out / MARKDOWN_FILE], [out])
    with ui.progress("decoding the runs' outputs", quiet):
        report = evaluate_step_recognition(runs, checks, out)
    ui.summary(f"{out}/{MARKDOWN_FILE}: {len(report['runs'])} runs", quiet)
