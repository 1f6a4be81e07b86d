"""Knowledge bases and their rule sets: kb-extract (activities), cooking-kb and demos-kb
(Creative Cooking)."""

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
    targets,
)
from tleaf_cli.cli.options import KB, setting_option, with_settings
from tleaf_cli.errors import InputError
from tleaf_cli.settings.data import CompileSettings
from tleaf_cli.settings.generators import DemoSettings
from tleaf_cli.settings.knowledge import ExtractSettings

Domain = setting_option(DemoSettings, "domain")  # the Creative Cooking domain the rules are of


@exits
@with_settings(KB)
def kb_extract(
    inputs: Annotated[
        list[Path],
        typer.Argument(
            metavar="[KB.ltl] ACTIVITIES.parquet",
            help="A knowledge base (optional with --mine), then the labelled activities.",
        ),
    ],
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Folder for samples.parquet and dfas.parquet.")
    ] = Path("kb"),
    jobs: Jobs = 1,
    cluster: Cluster = None,
    cache_dir: CacheDir = None,
    no_cache: NoCache = False,
    quiet: Quiet = False,
    **values,
) -> None:
    """Give every video the rule set of the rules whose atoms all occur in it, compiled once.

    A video's rule set is the conjunction of those rules; each distinct one is compiled once
    (one-hot DFAs).

    Writes OUT/samples.parquet (video -> rule set) and OUT/dfas.parquet (one row per rule set).
    """
    from tleaf_cli.tasks.action_recognition.kb_extract import extract_knowledge

    if not 1 <= len(inputs) <= 2:
        raise InputError("give [KB.ltl] ACTIVITIES.parquet: one or two files")
    kb = inputs[0] if len(inputs) == 2 else None
    extract, compiling = KB.split(values)
    settings = ExtractSettings(**extract)
    written = ["samples.parquet", "dfas.parquet"] + (["kb.ltl"] if settings.mine else [])
    targets(inputs, [out / name for name in written], [out])
    reachable(cluster)
    if kb is None and not settings.mine:
        raise InputError("give a knowledge base file, or --mine to mine one from the train split")
    compile_settings = CompileSettings(
        **compiling,
        alphabet="one-hot",
        cache_dir=cache_folder(cache_dir, no_cache),
        jobs=jobs,
        cluster=cluster or None,
    )
    with ui.progress("compiling rule sets", quiet) as update:
        report = extract_knowledge(kb, inputs[-1], out, compile_settings, settings, update)
    mined = f"; {report.mined} rules mined" if report.mined is not None else ""
    finish(
        report.failures,
        f"{out}: {report.videos} videos, {report.rule_sets} distinct rule sets "
        f"({report.compiled} compiled, {report.cache_hits} from cache); {report.rules_used} of "
        f"{report.rules_total} rules apply to some video{mined} ({report.seconds:.1f} s)",
        quiet,
    )


@exits
def cooking_kb(
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The .ltl file to write.")
    ] = Path("cooking_kb.ltl"),
    ingredients: Annotated[
        str | None,
        typer.Option(help="Comma-separated ingredients (an episode's five) \\[default: all]."),
    ] = None,
    mixture: Annotated[
        bool, typer.Option("--mixture/--no-mixture", help="Include rules on the mixture's actions.")
    ] = True,
    domain: Domain = None,
    quiet: Quiet = False,
) -> None:
    """Write Creative Cooking's rules as LTLf (affordance.* and ordering.* formulas).

    Atoms are the environment's action names (cut_lettuce); compile with `compile-dfa --one-hot`.
    """
    from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN
    from tleaf_cli.tasks.cooking.knowledge import write_cooking_kb

    targets([domain], [out])
    names = [n.strip() for n in ingredients.split(",")] if ingredients else None
    rules = write_cooking_kb(out, domain or DEFAULT_DOMAIN, names, mixture)
    orderings = sum(r.kind == "ordering" for r in rules)
    ui.summary(
        f"{out}: {len(rules)} rules ({len(rules) - orderings} affordance, {orderings} ordering) "
        f"over {len(names) if names else 'all'} ingredients",
        quiet,
    )


@exits
def demos_kb(
    demos: Annotated[Path, typer.Argument(help="A demos.parquet (gen-demos).")],
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The .ltl file to write.")
    ] = Path("demos_kb.ltl"),
    domain: Domain = None,
    quiet: Quiet = False,
) -> None:
    """Write the Creative Cooking rules of the demos' ingredient sets (no mixture rules).

    The training formulas of the embedder q for `train-task cooking --logic-loss tleaf`; compile
    them with `compile-dfa --one-hot`.
    """
    from tleaf_cli.tasks.cooking.demo_episodes import write_demos_knowledge_base
    from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, load_domain

    targets([demos, domain], [out])

    rules = write_demos_knowledge_base(demos, out, load_domain(domain or DEFAULT_DOMAIN))
    orderings = sum(r.kind == "ordering" for r in rules)
    ui.summary(
        f"{out}: {len(rules)} rules ({len(rules) - orderings} affordance, {orderings} ordering)",
        quiet,
    )
