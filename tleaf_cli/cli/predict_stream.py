"""`tleaf predict RUN --follow [EVENTS]`: a next-activity run on a live stream of events, one
JSON line in, one JSON line out (the library's tasks/next_activity/stream.py)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import targets
from tleaf_cli.cli.options import given
from tleaf_cli.errors import InputError
from tleaf_cli.settings.next_activity import PredictSettings

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
    from tleaf_cli.tasks.next_activity.stream import (
        StreamMonitor,
        read_lines,
        run_stream,
        summary_path,
    )

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
