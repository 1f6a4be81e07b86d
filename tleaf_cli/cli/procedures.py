"""Real procedures: task-graph (a precedence graph, or a folder of them, into a knowledge base),
read-recordings (CaptainCook4D's annotations into a recordings artifact), check-recordings (each
recording against its recipe's rules), recipe-formulas and recording-traces (the recipes' rules
and recordings as formulas and traces for q). Step recognition is in step_recognition.py."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import Quiet, exits, file_path, targets
from tleaf_cli.cli.options import TASK_GRAPH, with_settings
from tleaf_cli.settings.procedures import TaskGraphSettings


@exits
@with_settings(TASK_GRAPH)
def task_graph(
    graph: Annotated[
        Path,
        typer.Argument(
            help="A task graph (CaptainCook4D's .json, or a .txt edge list: 'a -> b' or 'a,b' a "
            "line), or a folder of them."
        ),
    ],
    out: Annotated[
        Path,
        typer.Option("--out", "-o", parser=file_path, help="The knowledge base (.ltl) to write."),
    ] = Path("task_graph.ltl"),
    quiet: Quiet = False,
    **values,
) -> None:
    """Turn a precedence graph into a knowledge base: an edge a -> b as (!b U a) | G !b.

    A folder gives one .ltl with every graph's rules, named <recipe>.before.<a>.<b> (the recipe
    is the file's stem). An unknown node in an edge, a cycle or a file that does not read exits 2
    naming the file and the edge or line, with nothing written.
    """
    from tleaf_cli.knowledge.task_graphs import write_graph_knowledge

    targets([graph], [out])
    settings = TaskGraphSettings(**values)
    settings.check()
    done = write_graph_knowledge(graph, out, settings.at_most_once, settings.last_step_ends)
    rules = sum(len(r) for _, r in done)
    steps = sum(len(g.step_nodes()) for g, _ in done)
    ui.summary(f"{out}: {rules} rules from {len(done)} graphs ({steps} steps)", quiet)


@exits
def read_recordings(
    annotations: Annotated[
        Path,
        typer.Argument(
            help="CaptainCook4D's annotation_json/ folder (complete_step_annotations.json, "
            "error_annotations.json, activity_idx_step_idx.json)."
        ),
    ],
    out: Annotated[
        Path,
        typer.Option("--out", "-o", parser=file_path, help="The recordings.parquet to write."),
    ] = Path("recordings.parquet"),
    splits: Annotated[
        Path | None,
        typer.Option(
            "--splits",
            help="A split file {split: list of recording ids}, e.g. the dataset's recordings split "
            "(default: every recording's split is 'none').",
        ),
    ] = None,
    quiet: Quiet = False,
) -> None:
    """Read CaptainCook4D's annotations into a recordings artifact, one row per recording.

    Each row: the recording's steps in time order with their times, error flags and categories,
    and its split.

    Steps without times or with an unknown step id, and recordings without steps or of an
    unknown activity id, are skipped and counted; error_annotations.json or
    activity_idx_step_idx.json missing is warned of (and named in the artifact's provenance); a
    file that is not JSON exits 2 naming it, with nothing written.
    """
    from tleaf_cli.data.captaincook import CaptainCookReader

    targets([annotations, splits], [out])
    reader = CaptainCookReader(annotations, splits)
    with ui.progress("reading the recordings", quiet) as tick:
        recordings = reader.read(tick)
    reader.write(recordings, out)
    missing = recordings.params["missing_files"]
    if missing:
        ui.summary(
            f"warning: {len(missing)} annotation file{'s' if len(missing) > 1 else ''} missing: "
            f"{', '.join(missing)} in {annotations} (without error_annotations.json the error "
            "categories are empty and has_errors comes from the steps' flags; without "
            "activity_idx_step_idx.json no step or activity id is checked)",
            quiet,
        )
    errors = sum(r.has_errors for r in recordings)
    per_split = ", ".join(f"{k} {n}" for k, n in recordings.split_counts().items())
    ui.summary(
        f"{out}: {len(recordings)} recordings ({errors} with errors; {per_split}); "
        f"skipped: {recordings.skips.text()}",
        quiet,
    )


@exits
def check_recordings(
    recordings: Annotated[
        Path, typer.Argument(help="A recordings artifact (read-recordings' recordings.parquet).")
    ],
    knowledge: Annotated[
        Path,
        typer.Argument(
            help="The recipes' rules: a .ltl knowledge base from task-graph (rules named "
            "<recipe>.<kind>...), or a folder of .ltl files."
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path(
        "recording_checks"
    ),
    quiet: Quiet = False,
) -> None:
    """Check every recording against its recipe's rules, exactly (one DFA per rule).

    Reports per recipe how many normal and error recordings break a rule, and which; how well
    "breaks a rule" finds the recordings with errors (precision, recall, F1 against has_errors),
    overall, per split and per kind of rule; and each error category's recall. Writes
    metrics.json, report.md and checks.parquet (one row per recording: its broken rules).
    """
    from tleaf_cli.tasks.procedure_checks import (
        CHECKS_FILE,
        METRICS_FILE,
        REPORT_FILE,
        check_recordings_report,
        report_tables,
        score_text,
    )

    files = [out / METRICS_FILE, out / REPORT_FILE, out / CHECKS_FILE]
    targets([recordings, knowledge], files, [out])
    report = check_recordings_report(recordings, knowledge, out)
    if not quiet:
        for title, columns, rows in report_tables(report):
            ui.table(title, columns, rows)
    unseen = report["rules_naming_unseen_steps"]
    if unseen["count"]:
        more = ", ..." if unseen["count"] > len(unseen["examples"]) else ""
        ui.summary(
            f"warning: {unseen['count']} rules name steps no recording of their recipe has, so "
            f"they hold on every recording: {', '.join(unseen['examples'])}{more}",
            quiet,
        )
    d = report["detection"]["all"]
    ui.summary(
        f"{out}/metrics.json: {report['checked']} of {report['recordings']} recordings checked "
        f"against {report['rules']} rules; breaks a rule: precision {score_text(d['precision'])}, "
        f"recall {score_text(d['recall'])}",
        quiet,
    )


@exits
def recipe_formulas(
    knowledge: Annotated[
        Path,
        typer.Argument(
            help="The recipes' rules: a .ltl knowledge base from task-graph (rules named "
            "<recipe>.<kind>...), or a folder of .ltl files."
        ),
    ],
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The .ltl to write.")
    ] = Path("recipes.ltl"),
    quiet: Quiet = False,
) -> None:
    """One formula per recipe: the conjunction of its rules, named by the recipe.

    For compile-dfa and gen-traces, as Table I's one formula per trace label: a recording
    satisfies its recipe's formula when it breaks none of its rules.
    """
    from tleaf_cli.tasks.recording_traces import write_recipe_formulas

    targets([knowledge], [out])
    formulas = write_recipe_formulas(knowledge, out)
    ui.summary(f"{out}: {len(formulas)} recipes", quiet)


@exits
def recording_traces(
    recordings: Annotated[
        Path, typer.Argument(help="A recordings artifact (read-recordings' recordings.parquet).")
    ],
    knowledge: Annotated[Path, typer.Argument(help="The recipes' rules (task-graph's .ltl).")],
    traces: Annotated[
        Path,
        typer.Argument(
            help="gen-traces' traces of the compiled recipe formulas (recipe-formulas), with a "
            "split: its train and val rows are kept, its test recipes' recordings replace its "
            "test rows."
        ),
    ],
    out: Annotated[
        Path,
        typer.Option("--out", "-o", parser=file_path, help="The traces.parquet to write."),
    ] = Path("recording_traces.parquet"),
    quiet: Quiet = False,
) -> None:
    """Real recordings as Table I test traces, for eval model-checking.

    Train and val: the synthetic traces of the train and val recipes. Test: every recording of
    the held-out (test) recipes, one step a letter, labelled by the exact check of its recipe's
    rules (as check-recordings), source 'recorded'. The evaluation's all_accuracy is then the
    accuracy on real recordings against the exact answer.
    """
    from tleaf_cli.tasks.recording_traces import recording_traces as convert

    targets([recordings, knowledge, traces], [out])
    report = convert(recordings, knowledge, traces, out)
    left = ", ".join(f"{n} {why}" for why, n in report.left_out.items()) or "none"
    ui.summary(
        f"{out}: synthetic {report.synthetic}; recordings of {len(report.test_recipes)} held-out "
        f"recipes {report.recorded}; left out: {left}",
        quiet,
    )
