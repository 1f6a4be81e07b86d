"""Conformance checking of event logs: check-cases (every case of a cases artifact against every
rule of a knowledge base, exactly; the counterpart of check-recordings for logs)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tleaf_cli import ui
from tleaf_cli.cli.common import Quiet, exits, file_path, targets

MOST_BROKEN_RULES = 10  # the rules broken by most cases the command prints


@exits
def check_cases(
    cases: Annotated[Path, typer.Argument(help="A cases artifact (tleaf read-log).")],
    knowledge: Annotated[
        Path, typer.Argument(help="The rules: a knowledge base (.ltl, .decl, or a formula table).")
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            parser=file_path,
            help="The case_checks.parquet to write (one row per case and rule); its summary "
            "goes beside it as <name>.summary.json.",
        ),
    ] = Path("case_checks.parquet"),
    quiet: Quiet = False,
) -> None:
    """Check every case of a cases artifact against every rule, exactly (one DFA per rule).

    A .decl model's activities are matched to the log's activity names exactly. An event makes
    its activity's atom, its kept attributes' atoms (read-log --attributes) and each MP-Declare
    condition that holds on its values true together. Prints and writes how many rules each
    case breaks and how many cases break each rule; rules naming an activity or attribute value
    the log never has are counted and named, and so are event values outside a .decl's
    declared domains. A rule that does not parse or compile, or a condition on an attribute
    the cases do not keep, exits 2 naming its file and line, nothing written.
    """
    from tleaf_cli.tasks.case_checks import check_case_file, summary_path

    targets([cases, knowledge], [out, summary_path(out)])
    with ui.progress("compiling and checking rules", quiet) as update:
        summary = check_case_file(cases, knowledge, out, on_progress=update)
    n = summary["cases"]
    if not quiet:
        worst = sorted(summary["cases_per_rule"], key=lambda r: -r["broken"])[:MOST_BROKEN_RULES]
        ui.table(
            f"rules broken by most cases ({len(worst)} of {summary['rules']})",
            ["rule", "cases breaking it", "share"],
            [[r["rule"], str(r["broken"]), f"{r['broken'] / max(n, 1):.1%}"] for r in worst],
        )
        histogram = summary["rules_broken_per_case"]["histogram"]
        ui.table(
            "rules broken per case",
            ["rules broken", "cases"],
            [[k, str(v)] for k, v in histogram.items()],
        )
    unseen = summary["rules_naming_unseen_atoms"]
    if unseen["count"]:
        more = ", ..." if unseen["count"] > len(unseen["examples"]) else ""
        ui.summary(
            f"warning: {unseen['count']} rules name an activity or attribute value no event of "
            f"the log has: {', '.join(unseen['examples'])}{more}",
            quiet,
        )
    for attribute, seen in summary["values_outside_declared_domains"].items():
        ui.summary(
            f"warning: {seen['events']} events carry a value of {attribute} outside the model's "
            f"declared domain ({', '.join(map(repr, seen['examples']))}); conditions test them "
            "as they are (Declare4Py's reading: 'is not v' holds for them)",
            quiet,
        )
    ui.summary(
        f"{out}: {n} cases x {summary['rules']} rules ({summary['alphabet']} letters); "
        f"{summary['cases_keeping_every_rule']} cases keep every rule, "
        f"{summary['rules_broken_per_case']['mean']:.2f} rules broken per case on average, "
        f"{summary['rules_kept_by_every_case']} rules kept by every case; per rule: "
        f"{summary_path(out)}",
        quiet,
    )
