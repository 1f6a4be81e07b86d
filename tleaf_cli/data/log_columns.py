"""Which part of an event log holds what: a CSV's columns for the case, activity and timestamp
(given, or the first known header name), the columns of the attributes kept, a cell as an
attribute's value, and the check that every attribute asked for is one the log has (an
InputError naming it and some that the log does have). Used by data/log_readers.py.
"""

from __future__ import annotations

from pathlib import Path

from tleaf_cli.data.skip_report import EXAMPLES
from tleaf_cli.errors import InputError


def key_column(header: list[str], given: str | None, candidates: tuple[str, ...], what: str) -> str:
    """The column holding `what`: the given name, else the first candidate in the header."""
    if given is not None:
        if given not in header:
            raise InputError(f"no column '{given}' for the {what} (columns: {', '.join(header)})")
        return given
    lowered = {h.lower(): h for h in header}
    for name in candidates:
        if name.lower() in lowered:
            return lowered[name.lower()]
    raise InputError(
        f"no {what} column: none of {', '.join(candidates)} in the header "
        f"({', '.join(header)}); name it with the {what} key setting"
    )


def attribute_column(path: Path, header: list[str], name: str) -> int:
    """The index of the CSV column holding the attribute `name`; InputError naming it and the
    columns the header has otherwise."""
    if name not in header:
        raise InputError(
            f"{path}: no column '{name}' for the attribute (columns: {', '.join(header)})"
        )
    return header.index(name)


def cell(row: list[str], i: int) -> str | None:
    """A CSV cell as an attribute's value: its text, None where it is empty or missing."""
    value = row[i].strip() if i < len(row) else ""
    return value or None


def check_met(path: Path, asked: tuple[str, ...], met: set[str], where: str) -> None:
    """InputError naming the first attribute asked for that no `where` of the log holds, with
    some of those it does hold."""
    for name in asked:
        if name not in met:
            held = sorted(met)
            more = ", ..." if len(held) > 2 * EXAMPLES else ""
            raise InputError(
                f"{path}: no {where} has the attribute '{name}' (the log's {where}s have: "
                f"{', '.join(held[: 2 * EXAMPLES]) or 'none'}{more})"
            )
