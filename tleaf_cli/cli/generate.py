"""The SYNTHETIC data generators: gen-formulas, gen-traces, gen-activities, gen-demos."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

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
    given_flags,
    reachable,
    refuse,
    targets,
)
from tleaf_cli.cli.options import ACTIVITIES, DEMOS, FORMULAS, TRACES, given, with_settings
from tleaf_cli.defaults import TIERS
from tleaf_cli.settings.data import FormulaSettings, TraceSettings
from tleaf_cli.settings.generators import ActivitySettings, DemoSettings

Tier = Literal["low", "moderate", "high"]


@exits
@with_settings(FORMULAS)
def gen_formulas(
    ctx: typer.Context,
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The .ltl file to write.")
    ] = Path("formulas.ltl"),
    tier: Annotated[
        Tier | None,
        typer.Option(
            help="The paper's settings: low (3 atoms, size 10), moderate (3, 20), "
            "high (6, 20). Overrides --atoms and --size."
        ),
    ] = None,
    jobs: Jobs = 1,
    cluster: Cluster = None,
    cache_dir: CacheDir = None,
    no_cache: NoCache = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """Draw SYNTHETIC random LTLf formulas worth learning from.

    Rejects unsatisfiable and valid formulas, formulas with fewer than --pairs distinct
    (satisfying, violating) pairs of equal length in [--min-len, --max-len], repeats of a
    language already kept, and candidates MONA cannot finish within --timeout. With
    --protocol paper, the authors' Table I formulas and filters instead (docs/embedder.md).
    """
    from tleaf_cli.data.formula_gen import generate_formulas, write_formula_file

    targets([], [out])
    reachable(cluster)
    if values["protocol"] == "paper":
        ignored = given_flags(ctx, "min_len", "max_len", "pairs", "one_hot")
        refuse(ignored, "not with --protocol paper (its own filters decide)")
    else:
        refuse(given_flags(ctx, "paper_arcs"), "only with --protocol paper")
    if tier is not None:
        refuse(given_flags(ctx, "atoms", "size"), "set by --tier; give --tier or these, not both")
        values["atoms"], values["size"] = TIERS[tier]
        if "prefix" not in given(ctx, values):
            values["prefix"] = f"{tier}-"
    settings = FormulaSettings(
        **values, cache_dir=cache_folder(cache_dir, no_cache), jobs=jobs, cluster=cluster or None
    )
    with ui.progress("generating", quiet) as update:
        report = generate_formulas(settings, update)
    write_formula_file(report, settings, out)
    reasons = ", ".join(f"{k}: {v}" for k, v in report.rejected.most_common()) or "none"
    ui.summary(
        f"{out}: kept {len(report.kept)} of {report.drawn} drawn "
        f"({settings.atoms} atoms, size {settings.size}); rejected "
        f"{sum(report.rejected.values())} ({reasons})",
        quiet,
    )
    if len(report.kept) < settings.n:
        ui.fatal(f"only {len(report.kept)} of {settings.n} formulas found before the draw limit")
        raise typer.Exit(1)


@exits
@with_settings(TRACES)
def gen_traces(
    ctx: typer.Context,
    dfas: Annotated[Path, typer.Argument(help="A dfas.parquet from compile-dfa.")],
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The traces.parquet to write.")
    ] = Path("traces.parquet"),
    jobs: Jobs = 1,
    cluster: Cluster = None,
    quiet: Quiet = False,
    **values,
) -> None:
    """Sample SYNTHETIC satisfying and violating traces for every DFA, paired by length.

    Satisfying traces are uniform among accepted words of a length; violating ones are uniform
    rejected words or hard negatives (a satisfying trace with the fewest steps changed). Every
    label is checked with the exact checker. Exit 1 if some DFA cannot give K of each.
    """
    from tleaf_cli.data.traces import generate_traces

    targets([dfas], [out])
    reachable(cluster)
    if values["protocol"] == "paper":
        ignored = given_flags(
            ctx, "per_formula", "min_len", "max_len", "hard_fraction", "one_hot", "once_each"
        )
        refuse(ignored, "not with --protocol paper (its paths decide the traces)")
    else:
        refuse(given_flags(ctx, "paper_arcs", "paper_hard"), "only with --protocol paper")
    if values["once_each"]:
        ignored = given_flags(ctx, "min_len", "max_len", "hard_fraction")
        refuse(ignored, "ignored with --once-each (a video's length is set by its atoms)")
        values["one_hot"] = True
    else:
        refuse(given_flags(ctx, "max_none"), "only with --once-each")
    settings = TraceSettings(**values, jobs=jobs, cluster=cluster or None)
    with ui.progress("sampling", quiet) as update:
        report = generate_traces(dfas, out, settings, update)
    skipped = f", {report.skipped} rows without a DFA skipped" if report.skipped else ""
    if report.always_true:
        skipped += (
            f", {len(report.always_true)} always true skipped (every trace satisfies them, "
            f"so none violates them: {', '.join(report.always_true[:3])}"
            f"{', ...' if len(report.always_true) > 3 else ''})"
        )
    finish(
        [(str(dfas), f"formula {fid}: {why}") for fid, why in report.short],
        f"{out}: {report.rows} traces for {report.formulas} formulas "
        f"({report.hard} hard negatives; {len(report.short)} formulas short of "
        f"{settings.per_formula} pairs{skipped})",
        quiet,
    )


@exits
@with_settings(ACTIVITIES)
def gen_activities(
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The activities.parquet to write.")
    ] = Path("activities.parquet"),
    kb_out: Annotated[
        Path,
        typer.Option(
            parser=file_path, help="Where to write the knowledge base that generated the data."
        ),
    ] = Path("kb.ltl"),
    quiet: Quiet = False,
    **values,
) -> None:
    """Generate SYNTHETIC procedural activity videos and the knowledge base they satisfy.

    A hidden process (affordances, recipe-stage orderings) yields labelled (action, ingredient)
    steps; features are class-conditional Gaussians with confusable class pairs.
    """
    from tleaf_cli.tasks.action_recognition.activity_gen import generate_activities

    targets([], [out, kb_out])
    s = ActivitySettings(**values)
    with ui.progress("generating videos", quiet) as update:
        report = generate_activities(s, out, kb_out, update)
    ui.summary(
        f"{out}: {report.videos} synthetic videos ({s.train} train, {s.val} val, {s.test} test, "
        f"{s.unlabelled} unlabelled), {report.rows} steps; {kb_out}: {report.affordances} "
        f"affordances, {report.orderings} orderings ({report.seconds:.1f} s)",
        quiet,
    )


@exits
@with_settings(DEMOS)
def gen_demos(
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The demos.parquet to write.")
    ] = Path("demos.parquet"),
    quiet: Quiet = False,
    **values,
) -> None:
    """Record expert demonstrations in the SYNTHETIC Creative Cooking environment.

    The expert plans each episode optimally (A* over the environment's exact rules) and its plan
    is played in tleaf/CreativeCooking-v0; one row per step. Success rate and mean return go to
    the artifact's params and the summary line.
    """
    from tleaf_cli.tasks.cooking.demos import generate_demos

    settings = DemoSettings(**values)
    targets([settings.domain], [out])
    with ui.progress("planning and playing", quiet) as update:
        report = generate_demos(out, settings, update)
    ui.summary(
        f"{out}: {report.episodes} synthetic expert episodes, {report.rows} steps; success rate "
        f"{100 * report.success_rate:.1f}%, mean return {report.mean_return:.2f}, mean length "
        f"{report.mean_length:.2f} (planning {report.planning_seconds:.2f} s)",
        quiet,
    )
