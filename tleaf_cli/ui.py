"""What tleaf shows people: progress bars, summaries, failure lines, artifact views (rich)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

err = Console(stderr=True, highlight=False)
out = Console(highlight=False)

MAX_FAILURE_LINES = 20


@contextmanager
def progress(description: str, quiet: bool = False) -> Iterator[Callable[[int, int], None]]:
    """A progress bar on stderr; yields `update(done, total)`. Silent when quiet."""
    if quiet:
        yield lambda done, total: None
        return
    bar = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=err,
        transient=True,
    )
    task = bar.add_task(description, total=None)
    with bar:
        yield lambda done, total: bar.update(task, completed=done, total=total)


def visible(text: str) -> str:
    """`text` with every character that does not show escaped as Python's repr writes it:
    controls (`\\x00`, `\\n`), format characters (a byte-order mark `\\ufeff`, a zero-width
    space `\\u200b`), separators other than the space (`\\xa0`), surrogates; letters in any
    script (`γ`, `é`) and symbols stay as they are. So an error line shows what is wrong with a
    name that looks right, and stays one line."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def failures(items: list[tuple[str, str]]) -> None:
    """One stderr line per failure (`path: message`), at most MAX_FAILURE_LINES of them."""
    for path, message in items[:MAX_FAILURE_LINES]:
        err.print(
            f"[red]error[/]: {escape(visible(path))}: {escape(visible(message))}", soft_wrap=True
        )
    if len(items) > MAX_FAILURE_LINES:
        err.print(f"... and {len(items) - MAX_FAILURE_LINES} more (see the error column)")


def summary(line: str, quiet: bool = False) -> None:
    if not quiet:
        err.print(line, soft_wrap=True, markup=False)


def fatal(message: str) -> None:
    """The one stderr line of a refused call; invisible characters shown escaped (`visible`)."""
    err.print(f"[red]error[/]: {escape(visible(message))}", soft_wrap=True)


def table(title: str, columns: list[str], rows: list[list[str]]) -> None:
    t = Table(title=title, title_justify="left", show_lines=False)
    for c in columns:
        t.add_column(c, overflow="fold")
    for r in rows:
        t.add_row(*(escape(c) for c in r))
    out.print(t)


def text(line: str = "") -> None:
    out.print(line, soft_wrap=True, markup=False)
