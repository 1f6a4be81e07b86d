"""What every command shares: the options several commands take (--quiet, --jobs, --cluster, ...),
the mapping of tleaf's errors to one stderr line and an exit status, and the checks a command makes
before any work (outputs writable, scheduler reachable, no option given that would be ignored).

Exit status (docs/design.md): 0 all good; 1 some inputs failed (the rest was written, each failure
recorded with its reason); 2 the call itself is unusable.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path
from typing import Annotated, Any, Literal

import typer

from tleaf_cli import ui
from tleaf_cli.cli.options import flag
from tleaf_cli.errors import InputError, MissingSplitError, SettingError, TleafError


def file_path(value: str | Path) -> Path:
    """An output FILE as given: a path that ends in a slash names a folder, and is refused (a
    command would otherwise write a file named like the folder)."""
    text = str(value)
    if text.endswith(("/", os.sep)):
        raise typer.BadParameter(f"'{text}' ends in '/', a folder; give a file name")
    return Path(text)


Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar or summary.")]


def preset_option(cls: type) -> Any:
    """The `--preset` option of a command whose settings class names presets (`cls.PRESETS`):
    its choices and each preset's help from the class; its default is `cls.default_preset()`."""
    return Annotated[
        Literal[tuple(cls.PRESETS)],
        typer.Option(
            help="Settings to start from; options given on the command line override them. "
            + "; ".join(f"{name}: {text}" for name, text in cls.PRESET_HELP.items())
            + "."
        ),
    ]


Jobs = Annotated[int, typer.Option("--jobs", "-j", min=1, help="Parallel worker processes.")]
Cluster = Annotated[
    str | None,
    typer.Option(
        envvar="TLEAF_CLUSTER",
        metavar="ADDRESS",
        help="Run the parallel work on this dask.distributed scheduler (tcp://host:8786; "
        "needs tleaf\\[cluster]) instead of local processes; --jobs is then unused.",
    ),
]
CacheDir = Annotated[
    Path | None,
    typer.Option(help="Compile cache \\[default: $TLEAF_CACHE_DIR or ~/.cache/tleaf]."),
]
NoCache = Annotated[bool, typer.Option("--no-cache", help="Neither read nor fill the cache.")]
Resume = Annotated[
    bool, typer.Option("--resume", help="Continue from the model directory's last epoch.")
]


def cache_folder(cache_dir: Path | None, no_cache: bool) -> Path | None:
    """The compile cache that --cache-dir and --no-cache ask for (None: no cache)."""
    from tleaf_cli.settings.data import default_cache_dir

    return None if no_cache else (cache_dir or default_cache_dir())


# How to draw traces that training and evaluation can read (MissingSplitError).
SPLIT_FIX = "tleaf gen-traces DFAS --split 0.8,0.1,0.1 -o TRACES"


def exits(func):
    """Turn a TleafError into one stderr line and its exit status, never a traceback; a
    SettingError is told by the flag that sets it."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except MissingSplitError as e:
            ui.fatal(f"{e}; draw them with one: {SPLIT_FIX}")
            raise typer.Exit(e.exit_code) from None
        except SettingError as e:
            ui.fatal(f"{flag(e.setting)}: {e.args[0]}")
            raise typer.Exit(e.exit_code) from None
        except TleafError as e:
            ui.fatal(str(e))
            raise typer.Exit(e.exit_code) from None
        except OSError as e:  # the environment, not tleaf: a full disk, a vanished folder
            ui.fatal(f"{e.filename or ''}: {e.strerror or e}".lstrip(": "))
            raise typer.Exit(2) from None
        except KeyboardInterrupt:
            ui.fatal("interrupted; nothing was written")
            raise typer.Exit(130) from None

    return wrapper


def targets(inputs, files=(), folders=()) -> None:
    """Refuse the call (exit 2, nothing written) when an output cannot be written or would
    overwrite an input or another output; called first thing, before any work."""
    from tleaf_cli.data.artifacts import check_targets

    check_targets(inputs, files, folders)


def reachable(cluster: str | None) -> None:
    """Refuse the call (exit 2, nothing written) when --cluster names no scheduler that answers."""
    from tleaf_cli.data.parallel import check_cluster

    check_cluster(cluster)


def given_flags(ctx: typer.Context, *names: str) -> list[str]:
    """The flags among `names` (parameter names) given on the command line, not defaulted."""
    sources = [ctx.get_parameter_source(name) for name in names]
    return [
        flag(name)
        for name, source in zip(names, sources, strict=True)
        if source is not None and source.name in ("COMMANDLINE", "PROMPT")
    ]


def refuse(given: list[str], reason: str) -> None:
    """InputError when options that would be ignored were given: `reason` says why."""
    if given:
        raise InputError(f"{', '.join(given)}: {reason}")


def refuse_unused_lambda(ctx: typer.Context, settings: Any, why: str) -> None:
    """Refuse --lambda and --lambdas where nothing is weighed by λ (`why`: what would be)."""
    if not settings.uses_lambda:
        refuse(given_flags(ctx, "lam", "lambdas"), why)


def finish(failures: list[tuple[str, str]], summary: str, quiet: bool) -> None:
    """One stderr line per failure, the summary line, and exit status 1 if anything failed."""
    ui.failures(failures)
    ui.summary(summary, quiet)
    if failures:
        raise typer.Exit(1)


def epoch_printer(update, epochs: int, scored_on: str, quiet: bool):
    """A training callback: advance the bar and print one line per epoch."""

    def on_epoch(r) -> None:
        update(r.epoch, epochs)
        ui.summary(
            f"epoch {r.epoch}: loss {r.loss:.4f}, train acc {r.train_accuracy:.3f}, "
            f"{scored_on} acc {r.heldout_accuracy:.3f} ({r.seconds:.0f} s)",
            quiet,
        )

    return on_epoch
