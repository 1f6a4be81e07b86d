"""The `tleaf` command line: one thin function per stage; the work is in the library.

Exit status (DESIGN.md): 0 all good; 1 some inputs failed (the rest was written, each failure
recorded with its reason); 2 the call itself is unusable.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Annotated

import typer

from tleaf_cli import __version__, ui, views
from tleaf_cli.data.compile_dfas import DEFAULT_TIMEOUT, CompileSettings, compile_file
from tleaf_cli.data.compile_dfas import default_cache_dir as _default_cache_dir
from tleaf_cli.errors import UsageError

app = typer.Typer(
    name="tleaf",
    help="T-LEAF toolchain: LTLf rules -> DFAs -> embeddings -> logic losses.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)

Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar or summary.")]
Jobs = Annotated[int, typer.Option("--jobs", "-j", min=1, help="Parallel worker processes.")]


def _exits(func):
    """Turn a UsageError into one stderr line and exit status 2, never a traceback."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except UsageError as e:
            ui.fatal(str(e))
            raise typer.Exit(e.exit_code) from None
        except KeyboardInterrupt:
            ui.fatal("interrupted; nothing was written")
            raise typer.Exit(130) from None

    return wrapper


def _version(value: bool) -> None:
    if value:
        ui.text(f"tleaf {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print version.")
    ] = False,
) -> None:
    """T-LEAF toolchain: LTLf rules -> DFAs -> embeddings -> logic losses."""


@app.command("compile-dfa")
@_exits
def compile_dfa(
    formulas: Annotated[
        Path, typer.Argument(help="A .ltl file, or Parquet with formula_id, formula.")
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="The dfas.parquet to write.")] = Path(
        "dfas.parquet"
    ),
    one_hot: Annotated[
        bool,
        typer.Option(
            "--one-hot",
            help="One atom of the domain per step: letters are single atoms or none; "
            "DFAs minimal over that alphabet, guards simplified under it.",
        ),
    ] = False,
    jobs: Jobs = 1,
    timeout: Annotated[
        float, typer.Option(min=0.1, help="Seconds MONA may spend on one formula.")
    ] = DEFAULT_TIMEOUT,
    graphs: Annotated[
        Path | None, typer.Option(help="Also write <id>.graphml and <id>.dot per DFA here.")
    ] = None,
    cache_dir: Annotated[
        Path | None,
        typer.Option(help="Compile cache [default: $TLEAF_CACHE_DIR or ~/.cache/tleaf]."),
    ] = None,
    no_cache: Annotated[
        bool, typer.Option("--no-cache", help="Neither read nor fill the cache.")
    ] = False,
    quiet: Quiet = False,
) -> None:
    """Compile LTLf formulas to minimal DFAs (MONA), one row per formula.

    A formula that fails (syntax, timeout) gets a row whose `error` says why; the others are still
    compiled, and the exit status is 1.
    """
    settings = CompileSettings(
        alphabet="one-hot" if one_hot else "powerset",
        timeout=timeout,
        cache_dir=None if no_cache else (cache_dir or _default_cache_dir()),
        jobs=jobs,
    )
    with ui.progress("compiling", quiet) as update:
        report = compile_file(formulas, out, settings, graphs, update)
    ui.failures(report.failures)
    ui.summary(
        f"{out}: {report.compiled} of {len(report.rows)} formulas compiled "
        f"({report.unique} distinct, {report.cache_hits} from cache, "
        f"{len(report.rows) - report.compiled} failed) in {report.seconds:.2f} s",
        quiet,
    )
    if report.failures:
        raise typer.Exit(1)


@app.command("inspect")
@_exits
def inspect(
    path: Annotated[Path, typer.Argument(help="Any tleaf artifact (.parquet).")],
    formula_id: Annotated[
        str | None, typer.Option("--id", help="Show one DFA of a dfas.parquet.")
    ] = None,
    dot: Annotated[bool, typer.Option("--dot", help="With --id: print Graphviz DOT.")] = False,
    draw: Annotated[
        Path | None, typer.Option(help="With --id: draw to .png/.svg/.pdf (Graphviz) or .dot.")
    ] = None,
    rows: Annotated[int, typer.Option(min=0, help="How many first rows to show.")] = 10,
) -> None:
    """Show an artifact: kind, schema, provenance, row count, first rows; or one DFA with --id."""
    if formula_id is None:
        if dot or draw:
            raise UsageError("--dot and --draw need --id (which DFA to draw)")
        views.show_artifact(path, rows)
    else:
        views.show_dfa(path, formula_id, dot, draw)


def main() -> None:
    app()
