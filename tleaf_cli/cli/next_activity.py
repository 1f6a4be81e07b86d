"""Next-activity prediction on an event log: train-task next-activity and eval next-activity."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import (
    Quiet,
    Resume,
    exits,
    given_flags,
    preset_option,
    refuse,
    refuse_unused_lambda,
    targets,
)
from tleaf_cli.cli.options import NEXT, SUFFIX, given, with_settings
from tleaf_cli.cli.runs import (
    EmbedderOption,
    Reference,
    RunOut,
    train_printing,
)
from tleaf_cli.settings.next_activity import NextActivitySettings, SuffixSettings
from tleaf_cli.settings.training import grid_axes, grid_candidates

NextPreset = preset_option(NextActivitySettings)
DEFAULT_NEXT_PRESET = NextActivitySettings.default_preset()


@exits
@with_settings(NEXT)
def train_task_next_activity(
    ctx: typer.Context,
    cases: Annotated[Path, typer.Argument(help="A cases artifact (read-log, split-cases).")],
    kb: Annotated[
        Path | None,
        typer.Option(
            help="Rules of the logic loss (.ltl from mine-declare or peer-formulas, or a .decl "
            "Declare model, its names matched to the log's), all conjoined; needed for "
            "--logic-loss exact / tleaf."
        ),
    ] = None,
    embedder: EmbedderOption = None,
    out: RunOut = Path("run"),
    reference: Reference = None,
    preset: NextPreset = DEFAULT_NEXT_PRESET,
    resume: Resume = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """Predict each prefix's next activity (or the end of the case): train Tax et al.'s LSTM
    (the default) or a small causal Transformer (--model transformer) with ℓ_task + λ·ℓ_logic,
    the best val accuracy kept, or count the prefix-table baseline (--model prefix-table).

    Writes config.json (settings, vocabulary, time scales), weights.pt and metrics.json (per
    epoch: task and logic loss, seconds, val accuracy; test accuracy pooled over prefixes; the
    λ used and where it came from).
    """
    from tleaf_cli.tasks.next_activity.train import train_next_activity
    from tleaf_cli.training.run_folder import has_checkpoint

    targets([cases, kb, embedder, reference], folders=[out])
    settings = NextActivitySettings.preset(preset, **given(ctx, values))
    refuse_unused_lambda(ctx, settings, "only with a logic loss, not --logic-loss none")
    if settings.logic_loss == "none":
        refuse(["--kb"] if kb is not None else [], "only with a logic loss, not --logic-loss none")
    if settings.logic_loss != "tleaf":
        refuse(["--embedder"] if embedder is not None else [], "only with --logic-loss tleaf")
    refuse_unread(ctx, settings, resume)
    if resume and not has_checkpoint(out):
        ui.summary(f"note: no checkpoint in {out} to resume; training starts afresh", quiet)
    print_grid(settings, out, quiet)
    title = f"training next-activity ({settings.logic_loss})"
    metrics = train_printing(
        train_next_activity, (cases, kb, embedder), out, settings, title,
        resume=resume, reference=reference, quiet=quiet,
    )  # fmt: skip
    print_grid_choice(metrics, quiet)
    unseen = metrics.get("rules_unseen") or {}
    if unseen:
        ui.summary(
            f"warning: {len(unseen)} rule(s) name activities the log never has, read as never "
            f"happening: {', '.join(unseen)}",
            quiet,
        )
    test = metrics["test"]
    scored = (
        f"test next-activity accuracy {100 * test['accuracy']:.2f}% over {test['prefixes']} "
        f"prefixes of {test['cases']} cases"
        if test["cases"]
        else "no test split (score it with tleaf eval next-activity RUN CASES)"
    )
    ui.summary(
        f"{out}: {scored} (best epoch {metrics['best']['epoch']}, "
        f"{metrics['mean_epoch_seconds']:.2f} s/epoch)",
        quiet,
    )


# why a model reads no setting of `NextActivitySettings.unread`: given with it, they are refused
UNREAD_WHY = {
    "lstm": "only with --model transformer (an LSTM has no attention heads)",
    "prefix-table": "the prefix table is counted from the training cases, not trained: it has "
    "no shape, epochs, batches, seed or checkpoint",
}


def refuse_unread(ctx: typer.Context, settings: NextActivitySettings, resume: bool) -> None:
    """Refuse the options the run's model does not read (the prefix table: every training
    option; the LSTM: --heads), unless --grid varies the model; and --resume for the prefix
    table, which keeps no checkpoint."""
    if "model" in grid_axes(settings):
        return  # some candidate may read them
    given = given_flags(ctx, *settings.unread)
    if settings.model == "prefix-table" and resume:
        given.append("--resume")
    if given:
        refuse(given, UNREAD_WHY[settings.model])


def print_grid(settings: NextActivitySettings, out: Path, quiet: bool) -> None:
    """With --grid, the candidates before any is trained, and where they go."""
    if settings.grid is None:
        return
    from tleaf_cli.training.model_choice import CANDIDATES, candidate_name

    axes = grid_axes(settings)
    names = [candidate_name({a: getattr(c, a) for a in axes}) for c in grid_candidates(settings)]
    ui.summary(f"grid: {len(names)} candidates into {out / CANDIDATES}: {', '.join(names)}", quiet)


def print_grid_choice(metrics: dict, quiet: bool) -> None:
    """With --grid, the candidate chosen on validation and every candidate's val score."""
    grid = metrics.get("grid")
    if not grid:
        return
    score = grid["score"]
    chosen = ", ".join(f"{k}={v}" for k, v in grid["chosen"].items())
    best = max(c[score] for c in grid["candidates"])
    scores = ", ".join(f"{c['run'].rpartition('/')[2]} {c[score]:.4f}" for c in grid["candidates"])
    ui.summary(
        f"grid: chose {chosen} on validation ({score.replace('_', ' ')} {best:.4f}; {scores})",
        quiet,
    )


@exits
@with_settings(SUFFIX)
def eval_next_activity(
    ctx: typer.Context,
    run: Annotated[Path, typer.Argument(help="A train-task next-activity run directory.")],
    cases: Annotated[
        Path, typer.Argument(help="The cases artifact whose test split (or --split) to score.")
    ],
    rules: Annotated[
        Path | None,
        typer.Option(
            help="Other rules (.ltl, or a .decl with MP-Declare conditions) for the suffix "
            "search and --scored satisfying than those the run trained with \\[default: the "
            "run's knowledge base, from its config.json]."
        ),
    ] = None,
    rule: Annotated[
        list[str] | None,
        typer.Option(help="Only the rule of this name from the rules (repeat for several)."),
    ] = None,
    scored_by: Annotated[
        Path | None,
        typer.Option(
            help="With --scored satisfying: the rules that choose the cases (.ltl or .decl; "
            "default --rules)."
        ),
    ] = None,
    scored_rule: Annotated[
        list[str] | None,
        typer.Option(help="Only the rule of this name from --scored-by (repeat for several)."),
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder for metrics.json.")] = Path(
        "eval"
    ),
    quiet: Quiet = False,
    **values,
) -> None:
    """Next-activity accuracy on the test split, and suffix prediction from prefixes of
    --prefix-lengths: by argmax, by beam search, by minimum Bayes risk (--mbr-samples), and
    under --rules (the most probable continuation whose completed case satisfies them), each
    with Damerau-Levenshtein similarity per prefix length and pooled over all prefixes, the
    share satisfying the rules and ms per case.
    """
    from tleaf_cli.tasks.next_activity.evaluate import evaluate_next_activity

    targets([run, cases, rules, scored_by], folders=[out])
    if values.get("prefix_lengths") is None:  # they shape the suffixes, predicted only then
        flags = (
            "beam_width", "max_suffix", "temperature", "rule_weight", "min_suffix",
            "mbr_samples",
        )  # fmt: skip
        refuse(given_flags(ctx, *flags), "only with --prefix-lengths")
    if scored_by is None and scored_rule:
        refuse(["--scored-rule"], "only with --scored-by")
    settings = SuffixSettings(**values)
    with ui.progress("suffix prediction", quiet) as update:
        metrics = evaluate_next_activity(
            run, cases, out, settings, rules, tuple(rule or ()), on_length=update,
            scored_by=scored_by, scored_by_names=tuple(scored_rule or ()),
        )  # fmt: skip
    for warning in metrics["warnings"]:
        ui.summary(f"warning: {warning}", quiet)
    acc = metrics["accuracy"]
    under = acc.get("accuracy_rules")
    whose = "the run's rules"
    if metrics["rules"] is not None and metrics["rules"]["source"] == "other":
        whose = f"other rules, {metrics['rules']['path']}"
    ui.summary(
        f"{out}: next-activity accuracy {100 * acc['accuracy']:.2f}%"
        + ("" if under is None else f" ({100 * under:.2f}% under {whose})")
        + f" over {acc['prefixes']} prefixes of {metrics['scored_cases']} "
        f"{metrics['split']} cases",
        quiet,
    )
    pooled = metrics.get("suffix_pooled") or {}
    ways = [w for w, figures in pooled.items() if isinstance(figures, dict)]
    if ways:
        text = ", ".join(
            f"{w} {pooled[w]['dl_similarity']:.3f} ({100 * pooled[w]['at_cap']:.0f}% at the cap)"
            for w in ways
        )
        ui.summary(
            f"all {pooled['prefixes']} prefixes pooled: DL similarity {text}; true suffixes "
            f"at the cap: {100 * pooled['true_at_cap']:.0f}%",
            quiet,
        )
    for k, row in metrics["suffix"].items():
        if not row.get("cases"):
            continue
        ways = [w for w, figures in row.items() if isinstance(figures, dict)]
        text = ", ".join(
            f"{w} {row[w]['dl_similarity']:.3f}"
            + (f" ({100 * row[w]['satisfying']:.0f}% satisfying)" if "satisfying" in row[w] else "")
            for w in ways
        )
        ui.summary(f"prefix length {k} ({row['cases']} cases): DL similarity {text}", quiet)
        capped = ", ".join(f"{w} {100 * row[w]['at_cap']:.0f}%" for w in ways)
        ui.summary(
            f"  suffixes at the length cap: {capped} (true suffixes that long: "
            f"{100 * row['true_at_cap']:.0f}%)",
            quiet,
        )
