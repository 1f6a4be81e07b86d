"""compile-dfa (LTLf formulas to minimal DFAs) and inspect (show any artifact)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import (
    CacheDir,
    Cluster,
    Jobs,
    NoCache,
    Quiet,
    cache_folder,
    exits,
    file_path,
    finish,
    reachable,
    refuse,
    targets,
)
from tleaf_cli.cli.options import COMPILE, with_settings
from tleaf_cli.errors import InputError
from tleaf_cli.settings.data import CompileSettings


@exits
@with_settings(COMPILE)
def compile_dfa(
    formulas: Annotated[
        Path,
        typer.Argument(
            help="A .ltl file, a .decl Declare model, or Parquet with formula_id, formula."
        ),
    ],
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The dfas.parquet to write.")
    ] = Path("dfas.parquet"),
    jobs: Jobs = 1,
    cluster: Cluster = None,
    graphs: Annotated[
        Path | None, typer.Option(help="Also write <id>.graphml and <id>.dot per DFA here.")
    ] = None,
    cases: Annotated[
        Path | None,
        typer.Option(
            help="A cases artifact (tleaf read-log): a .decl's activities read that log's "
            "atoms, matched to its activity names exactly."
        ),
    ] = None,
    cache_dir: CacheDir = None,
    no_cache: NoCache = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """Compile LTLf formulas (or a Declare model's constraints) to minimal DFAs, one row per
    formula.

    A formula that fails (syntax, timeout) gets a row whose `error` says why; the others are still
    compiled, and the exit status is 1. A .decl constraint with an MP-Declare condition is
    refused under --one-hot (the condition holds at an event together with its activity).
    """
    from tleaf_cli.data.compile_dfas import compile_file
    from tleaf_cli.data.event_logs import read_cases
    from tleaf_cli.knowledge.rule_files import read_rule_file

    settings = CompileSettings(
        **values, cache_dir=cache_folder(cache_dir, no_cache), jobs=jobs, cluster=cluster or None
    )
    reachable(cluster)
    inputs = [formulas, *([cases] if cases else [])]
    targets(inputs, [out], [graphs])  # before reading: an output that is an input is refused
    log_atoms = None if cases is None else read_cases(cases).activity_atoms
    sources = read_rule_file(formulas, log_atoms)
    with ui.progress("compiling", quiet) as update:
        report = compile_file(
            formulas,
            out,
            settings,
            graphs,
            update,
            sources,
            inputs,
        )
    finish(
        report.failures,
        f"{out}: {report.compiled} of {len(report.rows)} formulas compiled "
        f"({report.unique} distinct, {report.cache_hits} from cache, "
        f"{len(report.rows) - report.compiled} failed) in {report.seconds:.2f} s",
        quiet,
    )


@exits
def inspect(
    path: Annotated[Path, typer.Argument(help="Any tleaf artifact (.parquet).")],
    formula_id: Annotated[
        str | None, typer.Option("--id", help="Show one DFA of a dfas.parquet.")
    ] = None,
    dot: Annotated[
        bool, typer.Option("--dot", help="With --id: print Graphviz DOT (also with --draw).")
    ] = False,
    draw: Annotated[
        Path | None,
        typer.Option(
            parser=file_path, help="With --id: draw to .png/.svg/.pdf (Graphviz) or .dot."
        ),
    ] = None,
    rows: Annotated[
        int | None, typer.Option(min=0, help="How many first rows to show. \\[default: 10]")
    ] = None,
    stats: Annotated[
        bool,
        typer.Option(
            "--stats",
            help="Distributions: DFA sizes; trace labels and lengths; cases' splits, lengths, "
            "activities.",
        ),
    ] = False,
) -> None:
    """Show an artifact: kind, schema, provenance, row count, first rows; or one DFA with --id."""
    from tleaf_cli import views

    targets([path], [draw])
    if formula_id is None:
        if dot or draw:
            raise InputError("--dot and --draw need --id (which DFA to draw)")
        if stats:
            refuse(["--rows"] if rows is not None else [], "not with --stats")
            views.show_stats(path)
        else:
            views.show_artifact(path, 10 if rows is None else rows)
    else:
        refuse(["--rows"] if rows is not None else [], "not with --id (one DFA is shown)")
        refuse(["--stats"] if stats else [], "not with --id")
        views.show_dfa(path, formula_id, dot, draw)
