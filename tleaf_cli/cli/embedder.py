"""The embedders: train-edge (q_e), train-meta (q_m) and embed (vectors from a trained q)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import (
    Quiet,
    Resume,
    epoch_printer,
    exits,
    file_path,
    preset_option,
    refuse,
    targets,
)
from tleaf_cli.cli.options import EDGE, META, flag, given, with_settings
from tleaf_cli.settings.edge import EdgeSettings
from tleaf_cli.settings.meta import MetaSettings

MetaPreset = preset_option(MetaSettings)
DEFAULT_META_PRESET = MetaSettings.default_preset()


@exits
@with_settings(EDGE)
def train_edge(
    dfas: Annotated[Path, typer.Argument(help="A dfas.parquet: its guards are the training data.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Model directory to write.")] = Path(
        "edge_model"
    ),
    resume: Resume = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """Train the edge embedder q_e: guards close to letters that satisfy them (triplet loss).

    Held-out triplet accuracy (d(guard, sat) < d(guard, unsat)) on formulas never trained on is
    reported each epoch; the best epoch's weights are kept.
    """
    from tleaf_cli.embed.train_edge import train_edge as run

    targets([dfas], folders=[out])
    settings = EdgeSettings(**values)
    with ui.progress("training q_e (epochs)", quiet) as update:
        on_epoch = epoch_printer(update, settings.epochs, "held-out", quiet)
        metrics = run(dfas, out, settings, resume=resume, on_epoch=on_epoch)
    best = metrics["best"]
    ui.summary(
        f"{out}: best held-out triplet accuracy {best['heldout_accuracy']:.3f} "
        f"(epoch {best['epoch']} of {len(metrics['history'])})",
        quiet,
    )


@exits
@with_settings(META)
def train_meta(
    ctx: typer.Context,
    dfas: Annotated[Path, typer.Argument(help="The dfas.parquet the traces were drawn from.")],
    traces: Annotated[Path, typer.Argument(help="A traces.parquet with a split column.")],
    edge: Annotated[Path, typer.Option(help="The edge model directory from train-edge.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Model directory to write.")] = Path(
        "meta_model"
    ),
    preset: MetaPreset = DEFAULT_META_PRESET,
    resume: Resume = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """Train the meta embedder q_m (or the syntax-tree baseline) with the triplet loss.

    Triplets (formula, satisfying trace, violating trace) from the train split; the best epoch on
    the val split is kept; the test split (formulas never trained on) gives the final figures.
    The model folder's config.json records every setting and the tleaf loss's λ that fits q.
    """
    from tleaf_cli.embed.train_meta import train_meta as run

    targets([dfas, traces, edge], folders=[out])
    chosen = given(ctx, values)
    settings = MetaSettings.preset(preset, **chosen)
    if settings.readout not in ("accept", "runs"):
        refuse(
            [flag(n) for n in ("bins", "probes") if n in chosen],
            "only with --readout accept or runs",
        )
    if settings.readout not in ("walk", "steps"):
        refuse([flag(n) for n in ("steps",) if n in chosen], "only with --readout walk or steps")
    if settings.monitors == 0:
        refuse(
            [flag(n) for n in ("monitor_ranges", "evidence") if n in chosen and values[n]],
            "only with --monitors",
        )
    if settings.evidence is False:
        refuse([flag(n) for n in ("evidence_scale",) if n in chosen], "only with --evidence")
    with ui.progress(f"training q ({settings.embedder})", quiet) as update:
        on_epoch = epoch_printer(update, settings.epochs, "val", quiet)
        metrics = run(dfas, traces, edge, out, settings, resume=resume, on_epoch=on_epoch)
    test = metrics["test"]
    ui.summary(
        f"{out}: test triplet accuracy {test['triplet_accuracy']:.3f} "
        f"(uniform negatives {test['uniform_negatives']:.3f}, hard {test['hard_negatives']:.3f}; "
        f"best val epoch {metrics['best']['epoch']})",
        quiet,
    )


@exits
def embed(
    model: Annotated[Path, typer.Argument(help="A meta model directory from train-meta.")],
    source: Annotated[Path, typer.Argument(help="A dfas.parquet or a traces.parquet.")],
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The vectors.parquet to write.")
    ] = Path("vectors.parquet"),
    dfas: Annotated[
        Path | None,
        typer.Option(
            help="For traces: their dfas.parquet \\[default: the one their file records]."
        ),
    ] = None,
    quiet: Quiet = False,
) -> None:
    """Vectors for every DFA or trace (deterministic for a model and an input)."""
    from tleaf_cli.embed.vectors import embed_file

    targets([model, source, dfas], [out])
    with ui.progress("embedding", quiet) as update:
        count = embed_file(model, source, out, dfas, update)
    ui.summary(f"{out}: {count} vectors", quiet)
