"""How well an embedder model-checks: eval model-checking, eval tsne and eval table."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import (
    Quiet,
    Seed,
    exits,
    targets,
)
from tleaf_cli.settings import DEVICES, PRECISIONS

PairFeatures = Literal["concat", "rich"]
EvalDevice = Literal[DEVICES]
Precision = Literal[PRECISIONS]


@exits
def eval_model_checking(
    dfas: Annotated[Path, typer.Argument(help="The dfas.parquet of the formulas.")],
    traces: Annotated[Path, typer.Argument(help="A traces.parquet with a split column.")],
    embedder: Annotated[Path, typer.Option(help="A meta model directory (train-meta).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path("report"),
    pair_features: Annotated[
        PairFeatures, typer.Option(help="concat (the paper's) or rich (adds |a-b| and a*b).")
    ] = "concat",
    label: Annotated[str, typer.Option(help="A name for the report (e.g. the tier).")] = "",
    all_negatives: Annotated[
        bool,
        typer.Option(
            help="Also fit a second MLP on all negatives, hard ones too (doubles the time)."
        ),
    ] = False,
    device: Annotated[
        EvalDevice, typer.Option(help="Where q embeds and the MLPs train: cpu or cuda.")
    ] = "cpu",
    precision: Annotated[
        Precision,
        typer.Option(
            help="float32; bfloat16: the MLPs' products under autocast, 3-4x faster on CPUs "
            "with AMX / AVX-512 BF16 (slower on others); auto: bfloat16 where the hardware "
            "computes it natively, else float32."
        ),
    ] = "float32",
    seed: Seed = 0,
    quiet: Quiet = False,
) -> None:
    """Predict from (z_formula, z_trace) alone whether the trace satisfies the formula.

    An MLP (512, 128) and the distance rule d < tau are fitted on the train split, chosen on val,
    and scored on the test split (formulas never trained on). Writes report.json and report.md.
    """
    from tleaf_cli.tasks.model_checking import EvalSettings, evaluate_model_checking

    targets([dfas, traces, embedder], [out / "report.json", out / "report.md"], [out])
    settings = EvalSettings(
        pair_features=pair_features,
        seed=seed,
        label=label,
        all_negatives=all_negatives,
        device=device,
        precision=precision,
    )
    with ui.progress("evaluating", quiet):
        report = evaluate_model_checking(embedder, dfas, traces, out, settings)
    ui.summary(
        f"{out}/report.json: MLP {100 * report['mlp']['accuracy']:.2f}%, distance rule "
        f"{100 * report['distance']['accuracy']:.2f}% on {report['test_formulas']} test formulas",
        quiet,
    )


@exits
def eval_tsne(
    dfas: Annotated[Path, typer.Argument(help="The dfas.parquet of the formulas.")],
    traces: Annotated[Path, typer.Argument(help="The traces.parquet (its split picks a formula).")],
    embedder: Annotated[
        list[Path], typer.Option(help="A meta model directory; repeat for side-by-side panels.")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="The PNG to write.")] = Path("tsne.png"),
    formula: Annotated[
        str | None, typer.Option(help="Formula id \\[default: the test formula with most traces].")
    ] = None,
    pairs: Annotated[int, typer.Option(min=2, help="Satisfying/violating pairs to draw.")] = 150,
    seed: Seed = 0,
    quiet: Quiet = False,
) -> None:
    """The paper's Fig. 3: a test formula and its traces, embedded, projected with t-SNE."""
    from tleaf_cli.tasks.model_checking_figure import FigureSettings, tsne_figure

    targets([dfas, traces, *embedder], [out])
    settings = FigureSettings(formula_id=formula, pairs=pairs, seed=seed)
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
    out: Annotated[Path, typer.Option("--out", "-o", help="The markdown table.")] = Path(
        "results.md"
    ),
) -> None:
    """One table: mean ± s.e. over seeds per embedder and tier, beside the paper's Table I."""
    from tleaf_cli.tasks.model_checking_table import results_table

    targets(reports, [out])
    ui.text(results_table(reports, out).rstrip())
