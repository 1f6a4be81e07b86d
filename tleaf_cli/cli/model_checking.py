"""How well an embedder model-checks: eval model-checking, eval tsne and eval table."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import (
    Quiet,
    exits,
    file_path,
    targets,
)
from tleaf_cli.cli.options import EVAL, FIGURE, with_settings
from tleaf_cli.settings.evaluation import EvalSettings, FigureSettings


@exits
@with_settings(EVAL)
def eval_model_checking(
    dfas: Annotated[Path, typer.Argument(help="The dfas.parquet of the formulas.")],
    traces: Annotated[Path, typer.Argument(help="A traces.parquet with a split column.")],
    embedder: Annotated[Path, typer.Option(help="A meta model directory (train-meta).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path("report"),
    quiet: Quiet = False,
    **values,
) -> None:
    """Predict from (z_formula, z_trace) alone whether the trace satisfies the formula.

    An MLP (512, 128) and the distance rule d < tau are fitted on the train split, chosen on val,
    and scored on the test split (formulas never trained on). Writes report.json and report.md.
    """
    from tleaf_cli.tasks.model_checking import evaluate_model_checking

    targets([dfas, traces, embedder], [out / "report.json", out / "report.md"], [out])
    settings = EvalSettings(**values)
    with ui.progress("evaluating", quiet):
        report = evaluate_model_checking(embedder, dfas, traces, out, settings)
    # balanced accuracy: the figure Table I and the docs compare (chance 50 %)
    ui.summary(
        f"{out}/report.json: balanced accuracy MLP "
        f"{100 * report['mlp']['balanced_accuracy']:.2f}%, distance rule "
        f"{100 * report['distance']['balanced_accuracy']:.2f}% on {report['test_formulas']} "
        "test formulas",
        quiet,
    )


@exits
@with_settings(FIGURE)
def eval_tsne(
    dfas: Annotated[Path, typer.Argument(help="The dfas.parquet of the formulas.")],
    traces: Annotated[Path, typer.Argument(help="The traces.parquet (its split picks a formula).")],
    embedder: Annotated[
        list[Path], typer.Option(help="A meta model directory; repeat for side-by-side panels.")
    ],
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The PNG to write.")
    ] = Path("tsne.png"),
    quiet: Quiet = False,
    **values,
) -> None:
    """The paper's Fig. 3: a test formula and its traces, embedded, projected with t-SNE."""
    from tleaf_cli.tasks.model_checking_figure import tsne_figure

    targets([dfas, traces, *embedder], [out])
    settings = FigureSettings(**values)
    with ui.progress("t-SNE", quiet):
        shown = tsne_figure(embedder, dfas, traces, out, settings)
    nearer = ", ".join(
        f"{e['kind']} {e['sat_nearer_than_violating']:.2f}" for e in shown["embedders"]
    )
    ui.summary(
        f"{out}: formula {shown['formula_id']}, {sum(shown['points'].values())} traces; "
        f"satisfying nearer than violating: {nearer}",
        quiet,
    )


@exits
def eval_table(
    reports: Annotated[list[Path], typer.Argument(help="report.json files of model-checking.")],
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The markdown table.")
    ] = Path("results.md"),
) -> None:
    """One table: mean ± s.e. over seeds per embedder and tier, beside the paper's Table I."""
    from tleaf_cli.tasks.model_checking_table import results_table

    targets(reports, [out])
    ui.text(results_table(reports, out).rstrip())
