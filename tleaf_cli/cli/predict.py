"""`tleaf predict`: a trained next-activity run on the running cases of a log (the library's
tasks/next_activity/predict.py and predictions.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import Quiet, exits, file_path, targets
from tleaf_cli.cli.options import PREDICT, given, with_settings
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
            help="A live stream: events as JSON lines (stdin, or the file given, read as it "
            "grows), one prediction per event as a JSON line (stdout, or -o FILE.jsonl); "
            "docs/monitoring.md, Live stream."
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
            help="With --follow: each line also holds the predicted rest of the case and the "
            "recommendation (a search per event)."
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
        from tleaf_cli.cli.predict_stream import follow_stream

        return follow_stream(ctx, run, cases, rules, rule, out, until_idle, suffix, quiet, values)
    if cases is None or until_idle is not None or suffix:
        raise InputError(
            "--until-idle and --suffix need --follow"
            if cases is not None
            else "give the cases artifact to predict (or --follow for a stream of events)"
        )
    targets([run, cases, rules], [out])
    if run_kind(run) == RUN_KIND:  # an action-recognition run: its videos decoded
        from tleaf_cli.cli.predict_actions import predict_actions

        return predict_actions(ctx, run, cases, rules, rule, split, out, quiet, values)
    settings = PredictSettings(**given(ctx, values))
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


def show(predictions, risk: float) -> None:
    """The first predictions as a table: case, prefix length, next activity (p), the rules
    broken for good and those at risk (undecided, probability of holding below `risk`), the
    recommendation."""
    rows = []
    for p in predictions:
        if p.reason is not None:
            rows.append([p.case_id, str(p.prefix_length), f"— ({p.reason})", "", "", ""])
            continue
        name, q = p.next_activities[0]
        if p.end_probability > q:
            name, q = "(end)", p.end_probability
        broken = [r.rule for r in p.rules if r.verdict == "permanently violated"]
        at_risk = [
            f"{r.rule} ({r.probability:.2f})"
            for r in p.rules
            if r.method == "sampled" and r.probability < risk
        ]
        advice = ""
        if p.recommendation_status == "found":
            advice = f"{' → '.join(p.recommendation)} (×{p.recommendation_relative:.2g})"
        elif p.recommendation_status == "none":
            advice = "no continuation keeps every rule"
        rows.append(
            [p.case_id, str(p.prefix_length), f"{name} ({q:.2f})", ", ".join(broken) or "—",
             ", ".join(at_risk) or "—", advice or "—"]
        )  # fmt: skip
    ui.table(
        f"first {len(rows)} predictions",
        ["case", "k", "next (p)", "broken", "at risk (p holds)", "recommendation (× p)"],
        rows,
    )
