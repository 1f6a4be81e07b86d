"""`tleaf predict`: a trained run on new data. A next-activity run on the running cases of a
log (the library's tasks/next_activity/predict.py and predictions.py), or on a live stream of
events with --follow (tasks/next_activity/stream.py); an action-recognition run on new videos
(tasks/action_recognition/predict.py)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import Quiet, exits, file_path, given_flags, refuse, targets
from tleaf_cli.cli.options import PREDICT, given, with_settings
from tleaf_cli.cli.prediction_tables import show, show_videos
from tleaf_cli.errors import InputError
from tleaf_cli.settings.next_activity import PredictSettings

SHOWN_ROWS = 12  # predictions the terminal's table shows


@exits
@with_settings(PREDICT)
def predict(
    ctx: typer.Context,
    run: Annotated[
        Path,
        typer.Argument(help="A train-task next-activity or action-recognition run directory."),
    ],
    cases: Annotated[
        Path | None,
        typer.Argument(
            help="A cases artifact (read-log) of the run's log: each case taken as running; "
            "for an action-recognition run, an activities artifact (labels optional). With "
            "--follow: the events, JSON lines, a file followed as it grows or - (stdin, the "
            "default)."
        ),
    ] = None,
    rules: Annotated[
        Path | None,
        typer.Option(
            help="The rules to watch (.ltl, or a .decl with MP-Declare conditions, its names "
            "matched to the log's) \\[default: the run's knowledge base, from its config.json]."
        ),
    ] = None,
    rule: Annotated[
        list[str] | None,
        typer.Option(help="Only the rule of this name from the rules (repeat for several)."),
    ] = None,
    split: Annotated[
        str | None,
        typer.Option(help="Only the cases of this split (train, val, test) \\[default: all]."),
    ] = None,
    out: Annotated[
        Path,
        typer.Option("--out", "-o", parser=file_path, help="The predictions.parquet to write."),
    ] = Path("predictions.parquet"),
    follow: Annotated[
        bool,
        typer.Option(
            "--follow",
            help="A live stream: events as JSON lines (stdin, or the file given, read as it "
            "grows), one prediction per event as a JSON line (stdout, or -o FILE.jsonl); "
            "docs/monitoring.md, Live stream.",
        ),
    ] = False,
    until_idle: Annotated[
        float | None,
        typer.Option(
            help="With --follow: stop once no event came for this many seconds "
            "\\[default: until the input ends or Ctrl-C]."
        ),
    ] = None,
    suffix: Annotated[
        bool,
        typer.Option(
            "--suffix",
            help="With --follow: each line also holds the predicted rest of the case and the "
            "recommendation (a search per event).",
        ),
    ] = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """Predict, for every running case: the next activities (top-k, the end of the case, the
    top activity's attribute values), the rest of the case, each rule's verdict now (permanently
    / temporarily satisfied / violated) and its probability of holding when the case ends
    (sampled completions, a 95 % Wilson interval), and where the most probable completion
    breaks a rule, the most probable one that keeps every rule.

    --prefix-lengths replays completed cases as running, the true continuation kept beside the
    prediction. A case with an activity the run never saw gets a row with its reason and no
    prediction. Prints the first cases as a table; the columns: docs/monitoring.md.

    An action-recognition run instead decodes every video of an activities artifact (features;
    labels optional, kept beside): per step the argmax labels and the labels under its rules,
    per video the rules the argmax labels break (--rules, --rule, --split, --top-k apply).
    """
    from tleaf_cli.tasks.action_recognition.predict import RUN_KIND, run_kind
    from tleaf_cli.tasks.next_activity.predictions import predict_cases

    if follow:  # a live stream of events
        return follow_stream(ctx, run, cases, rules, rule, out, until_idle, suffix, quiet, values)
    if cases is None or until_idle is not None or suffix:
        raise InputError(
            "--until-idle and --suffix need --follow"
            if cases is not None
            else "give the cases artifact to predict (or --follow for a stream of events)"
        )
    targets([run, cases, rules], [out])
    if run_kind(run) == RUN_KIND:  # an action-recognition run: its videos decoded
        return predict_actions(ctx, run, cases, rules, rule, split, out, quiet, values)
    settings = PredictSettings(**given(ctx, values))
    for name, way in WAY_ONLY.items():
        if settings.way != way:
            refuse(given_flags(ctx, name), f"only with --way {way}")
    with ui.progress("predicting", quiet) as update:
        summary = predict_cases(
            run, cases, out, settings, rules, tuple(rule or ()), split, on_progress=update
        )
    if summary["unseen"]:
        named = ", ".join(f"{r} ({', '.join(a)})" for r, a in list(summary["unseen"].items())[:5])
        ui.summary(f"warning: rules name atoms no predicted event has: {named}", quiet)
    if not quiet:
        show(summary["predictions"][:SHOWN_ROWS], settings.risk)
    rows, predicted = summary["rows"], summary["predicted"]
    ui.summary(
        f"{out}: {rows} prefixes, {predicted} predicted"
        + (f", {rows - predicted} not (see the reason column)" if rows > predicted else "")
        + f"; {len(summary['rule_names'])} rules watched; "
        f"{1000 * summary['seconds'] / max(rows, 1):.1f} ms per prefix",
        quiet,
    )
    if summary["suffixes_at_cap"]:
        true = summary["true_at_cap"]
        ui.summary(
            f"warning: {summary['suffixes_at_cap']} predicted suffixes reach --max-suffix "
            f"{settings.max_suffix}, most likely a loop"
            + ("" if true is None else f" (true suffixes that long: {true})")
            + "; --way mbr rarely does",
            quiet,
        )


SHOWN_VIDEOS = 8  # videos the terminal's table shows
# PredictSettings' options that only a next-activity run reads (--top-k applies to both)
NEXT_ACTIVITY_ONLY = (
    "way", "beam_width", "temperature", "mbr_samples", "suffix_rules", "rule_weight",
    "max_suffix", "samples", "seed", "prefix_lengths", "risk",
)  # fmt: skip


def predict_actions(
    ctx: typer.Context,
    run: Path,
    activities: Path,
    rules: Path | None,
    rule: list[str] | None,
    split: str | None,
    out: Path,
    quiet: bool,
    values: dict[str, Any],
) -> None:
    """Decode the activities' videos with the action-recognition run `run` and print the first."""
    from tleaf_cli.tasks.action_recognition.predict import predict_activities

    refuse(given_flags(ctx, *NEXT_ACTIVITY_ONLY), "only for a next-activity run")
    with ui.progress("predicting", quiet) as update:
        summary = predict_activities(
            run, activities, out, rules, tuple(rule or ()), split, values["top_k"],
            on_progress=update,
        )  # fmt: skip
    if not quiet:
        show_videos(summary["predictions"][:SHOWN_VIDEOS])
    videos, accuracy = summary["videos"], summary["accuracy"]
    labelled = (
        ""
        if accuracy is None
        else f"; action accuracy against the file's labels {100 * accuracy['argmax']:.2f}% by "
        f"argmax, {100 * accuracy['constrained']:.2f}% under the rules"
    )
    ui.summary(
        f"{out}: {videos} videos, {summary['steps']} steps; the argmax labels break a rule in "
        f"{summary['argmax_breaking']} videos, the labels under the rules in "
        f"{summary['constrained_breaking']} ({summary['rules']} rules){labelled}; "
        f"{1000 * summary['seconds'] / max(videos, 1):.1f} ms per video",
        quiet,
    )


WAY_ONLY = {"temperature": "sample", "mbr_samples": "mbr"}  # an option only one way reads
BATCH_ONLY = ("split", "prefix_lengths", "risk")  # options of the artifact, not of a stream


def follow_stream(
    ctx: typer.Context,
    run: Path,
    source: Path | None,
    rules: Path | None,
    rule: list[str] | None,
    out: Path,
    until_idle: float | None,
    suffix: bool,
    quiet: bool,
    values: dict,
) -> None:
    """Read events from `source` (None or `-`: stdin; a file: followed as it grows), write one
    prediction per event to stdout or `out` (with a summary JSON beside it), report skipped
    lines on stderr; exit 1 where some line was skipped."""
    from tleaf_cli.data.artifacts import write_text_atomic
    from tleaf_cli.tasks.next_activity.predict import Predictor
    from tleaf_cli.tasks.next_activity.stream import StreamMonitor
    from tleaf_cli.tasks.next_activity.stream_events import read_lines, run_stream, summary_path

    chosen = given(ctx, {name: None for name in ("split", *values)})
    refused = [name for name in BATCH_ONLY if name in chosen]
    if refused:
        flag = "--" + refused[0].replace("_", "-")
        raise InputError(f"{flag} applies to a cases artifact, not to --follow's stream")
    source = source if source is not None else Path("-")
    to_stdout = ctx.get_parameter_source("out").name == "DEFAULT" or str(out) == "-"
    if str(source) != "-" and not Path(source).is_file():
        raise InputError(f"{source}: no such file to follow")
    if until_idle is not None and not until_idle >= 0:
        raise InputError(f"--until-idle: a number of seconds, 0 or more, not {until_idle}")
    if not to_stdout:
        targets([run, rules, None if str(source) == "-" else source], [out])
    settings = PredictSettings(**given(ctx, values))
    settings.check()
    import torch

    # one event's model call is too small to share out: more threads only wait on each other
    # (ten times slower per event on a busy 2-core machine, measured)
    torch.set_num_threads(1)
    predictor = Predictor.load(run, settings, rules, tuple(rule or ()))
    monitor = StreamMonitor(predictor, suffix=suffix)
    ui.summary(
        f"following {'stdin' if str(source) == '-' else source}: "
        f"{len(monitor.rule_names)} rules watched, samples {settings.samples}"
        + (", suffix and recommendation" if suffix else ""),
        quiet,
    )
    sink = sys.stdout if to_stdout else open(out, "w", encoding="utf-8")  # noqa: SIM115
    try:

        def write(line: str) -> None:
            sink.write(line + "\n")
            sink.flush()

        def report(line: str) -> None:
            ui.err.print(ui.visible(line), markup=False, soft_wrap=True, highlight=False)

        summary = run_stream(monitor, read_lines(source, True, until_idle), write, report)
    finally:
        if not to_stdout:
            sink.close()
    if not to_stdout:
        record = {"out": str(out), "rule_names": list(monitor.rule_names), **summary.as_dict()}
        write_text_atomic(summary_path(out), json.dumps(record, indent=2) + "\n")
    ui.summary(
        ("" if to_stdout else f"{out}: ")
        + summary.line()
        + f"; {1000 * summary.seconds / max(summary.lines, 1):.2f} ms per line",
        quiet,
    )
    if summary.skipped:
        raise typer.Exit(1)
