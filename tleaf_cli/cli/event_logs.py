"""Real event logs: read-log (an XES or CSV event log into a cases artifact), split-cases (its
cases split anew by a published protocol), mine-declare (Declare rules from its train split) and
peer-formulas (Di Francescomarino et al.'s formulas as a `.ltl`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import Quiet, exits, file_path, given_flags, refuse, targets
from tleaf_cli.cli.options import DECLARE, READ_LOG, SPLIT_CASES, with_settings
from tleaf_cli.settings.declare import DeclareSettings
from tleaf_cli.settings.event_logs import FoldSettings, LogSettings


@exits
@with_settings(READ_LOG)
def read_log(
    ctx: typer.Context,
    log: Annotated[Path, typer.Argument(help="An event log: .xes, .xes.gz, .csv or .csv.gz.")],
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The cases.parquet to write.")
    ] = Path("cases.parquet"),
    quiet: Quiet = False,
    **values,
) -> None:
    """Read an event log into a cases artifact: one row per case, activities in time order.

    Cases without events, events without activity or timestamp, and unreadable timestamps are
    skipped and counted (the first few named); events out of time order are sorted. XES traces
    that repeat a case id are kept apart as <id>#2, ... and counted; CSV rows of one case spread
    over the file are merged and counted. A malformed XML file, a truncated .gz, a NUL in a case
    id or activity, or a CSV row with more fields than its header exits 2 naming the file and
    line, with nothing written. --attributes / --case-attributes keep event / case attributes
    (an attribute the log does not have exits 2 naming it).
    """
    from tleaf_cli.data.activity_names import folded
    from tleaf_cli.data.log_readers import LogReader

    targets([log], [out])
    if values["split_order"] == "file":
        refuse(
            given_flags(ctx, "seed"), "only with --split-order random (file order draws nothing)"
        )
    settings = LogSettings(**values)
    settings.check()
    reader = LogReader(log, settings)
    with ui.progress(f"reading {log.name} (bytes)", quiet) as tick:
        cases = reader.read(tick)
    reader.write(cases, out)
    for names in folded(cases.activity_atoms):
        atoms = ", ".join(f"{n!r} -> {cases.activity_atoms[n]}" for n in names)
        ui.summary(f"note: activity names that read as one word keep apart atoms: {atoms}", quiet)
    keys = ", ".join(f"{k}: {v}" for k, v in cases.params["keys"].items())
    kept = ", ".join([*cases.attribute_names, *(f"case {n}" for n in cases.case_attribute_names)])
    ui.summary(
        f"{out}: {len(cases)} cases, {cases.events} events, {len(cases.activity_atoms)} "
        f"activities ({keys}){'; attributes: ' + kept if kept else ''}; skipped or repaired: "
        f"{cases.skips.text()}",
        quiet,
    )


@exits
@with_settings(SPLIT_CASES)
def split_cases(
    ctx: typer.Context,
    cases: Annotated[Path, typer.Argument(help="A cases artifact (tleaf read-log).")],
    out: Annotated[
        Path,
        typer.Option("--out", "-o", parser=file_path, help="The cases.parquet to write."),
    ],
    quiet: Quiet = False,
    **values,
) -> None:
    """Split a cases artifact anew by a published protocol (k-fold, thirds).

    Only the split changes. kfold (Rama-Maneiro et al.): fold --fold of --folds is the test
    split, the last --val of its training cases validation. thirds (Tax et al.): the first two
    thirds of the cases in file order train. --train-share F keeps a seeded draw of F of the
    training cases (the others split 'unused'), for a learning curve.
    """
    from tleaf_cli.data.case_folds import split_anew
    from tleaf_cli.data.train_share import UNUSED

    if values["protocol"] == "thirds":
        refuse(
            given_flags(ctx, "folds", "fold", "seed", "case_order"),
            "only with --protocol kfold (thirds draws nothing)",
        )
    if values["train_share"] == 1:
        refuse(given_flags(ctx, "share_seed"), "only with --train-share below 1 (1 draws nothing)")
    settings = FoldSettings(**values)
    settings.check()
    counts = split_anew(cases, out, settings)
    what = (
        f"fold {settings.fold} of {settings.folds}"
        if settings.protocol == "kfold"
        else "the first two thirds train"
    )
    shown = ("train", "val", "test", UNUSED) if counts[UNUSED] else ("train", "val", "test")
    share = (
        f" (--train-share {settings.train_share:g} of the training cases)" if counts[UNUSED] else ""
    )
    ui.summary(
        f"{out}: {sum(counts.values())} cases, {what}: "
        + ", ".join(f"{counts[s]} {s}" for s in shown)
        + share,
        quiet,
    )


@exits
@with_settings(DECLARE)
def mine_declare(
    cases: Annotated[Path, typer.Argument(help="A cases artifact (tleaf read-log).")],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            parser=file_path,
            help="The knowledge base to write: .ltl (tleaf's rules), or .decl (a Declare model "
            "in RuM's format).",
        ),
    ] = Path("declare.ltl"),
    quiet: Quiet = False,
    **values,
) -> None:
    """Mine Declare constraints from the cases' train split into a knowledge base (.ltl, .decl).

    A .ltl has one named rule per constraint (template.a[.b]), its support and confidence on the
    train split in a comment; a .decl (OUT ending so) the constraints as RuM writes them, the
    activities by their names in the log. OUT with .tsv (beside it) gives each rule's measures
    and its support on the test split. --templates all mines every template that does not
    repeat another's formula.
    """
    from tleaf_cli.knowledge.log_knowledge import mine_log, support_table_path

    targets([cases], [out, support_table_path(out)])
    settings = DeclareSettings(**values)
    settings.check()
    found = mine_log(cases, out, settings)
    ui.summary(f"{out}: {found.summary()}; per rule: {support_table_path(out)}", quiet)


@exits
def peer_formulas(
    formulas: Annotated[
        Path, typer.Argument(help="Their formulas.tsv: log, kind, formula, prefix lengths.")
    ],
    out: Annotated[
        Path, typer.Option("--out", "-o", parser=file_path, help="The .ltl to write.")
    ] = Path("formulas.ltl"),
    cases: Annotated[
        Path | None,
        typer.Option(
            "--cases",
            help="A cases artifact whose activity -> atom map names the activities "
            "(default: each formula's own activities' atoms).",
        ),
    ] = None,
    log: Annotated[
        str | None, typer.Option("--log", help="Only this log's rows (default: every row).")
    ] = None,
    quiet: Quiet = False,
) -> None:
    """Write Di Francescomarino et al.'s a-priori formulas in tleaf's syntax (.ltl).

    One rule per (log, kind), named <log>.<strong|weak>, their activities as the atoms read-log
    gives them."""
    from tleaf_cli.knowledge.log_knowledge import convert_peer_file

    targets([formulas, cases], [out])
    converted = convert_peer_file(formulas, out, cases, log)
    ui.summary(f"{out}: {len(converted)} formulas", quiet)
